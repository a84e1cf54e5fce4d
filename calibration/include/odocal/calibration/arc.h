// The exact arc of a differential-drive robot, templated so that Ceres can
// differentiate through it (T = double or ceres::Jet).
//
// When both wheels roll with proportional profiles the curvature is constant,
// and the motion is an arc of length ds = (l + r) / 2 turning by
// dtheta = (r - l) / b. Its chord has length ds * sinc(dtheta / 2) and points
// along heading + dtheta / 2. This is exact, not a first-order step.
#ifndef ODOCAL_CALIBRATION_ARC_H_
#define ODOCAL_CALIBRATION_ARC_H_

#include <cmath>

namespace odocal::calibration {

template <typename T>
void AdvanceArc(const T& left_m, const T& right_m, const T& track_m, T* x_m, T* y_m,
                T* heading_rad) {
  using std::abs;
  using std::cos;
  using std::sin;
  const T ds = (left_m + right_m) / 2.0;
  const T dtheta = (right_m - left_m) / track_m;
  const T half = dtheta / 2.0;
  // sin(h)/h, with its Taylor series where the division would lose digits.
  const T sinc = abs(half) < 1e-4 ? T(1.0) - half * half / 6.0 : sin(half) / half;
  const T chord = ds * sinc;
  const T direction = *heading_rad + half;
  *x_m += chord * cos(direction);
  *y_m += chord * sin(direction);
  *heading_rad += dtheta;
}

}  // namespace odocal::calibration

#endif  // ODOCAL_CALIBRATION_ARC_H_
