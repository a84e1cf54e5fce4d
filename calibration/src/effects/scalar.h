// The value of a number or of a Ceres Jet (its real part): the model's terms
// branch on it where the model is not smooth (encoder_backlash's dead ticks,
// PredictFrame's sample). IsExactlyZero: a value and every derivative exactly
// 0, where a term can be skipped as the identity it then is (an effect held at
// zero), to the bit.
#ifndef ODOCAL_CALIBRATION_SRC_EFFECTS_SCALAR_H_
#define ODOCAL_CALIBRATION_SRC_EFFECTS_SCALAR_H_

#include <ceres/jet.h>

namespace odocal::calibration::internal {

inline double Scalar(double v) { return v; }
template <typename T, int N>
double Scalar(const ceres::Jet<T, N>& j) {
  return Scalar(j.a);
}

inline bool IsExactlyZero(double v) { return v == 0.0; }
template <typename T, int N>
bool IsExactlyZero(const ceres::Jet<T, N>& j) {
  if (!IsExactlyZero(j.a)) return false;
  for (int i = 0; i < N; ++i)
    if (!IsExactlyZero(j.v[i])) return false;
  return true;
}

}  // namespace odocal::calibration::internal

#endif  // ODOCAL_CALIBRATION_SRC_EFFECTS_SCALAR_H_
