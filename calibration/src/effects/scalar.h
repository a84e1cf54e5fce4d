// The value of a number or of a Ceres Jet (its real part): the model's terms
// branch on it where the model is not smooth (encoder_backlash's dead ticks,
// PredictFrame's sample).
#ifndef ODOCAL_CALIBRATION_SRC_EFFECTS_SCALAR_H_
#define ODOCAL_CALIBRATION_SRC_EFFECTS_SCALAR_H_

#include <ceres/jet.h>

namespace odocal::calibration::internal {

inline double Scalar(double v) { return v; }
template <typename T, int N>
double Scalar(const ceres::Jet<T, N>& j) {
  return Scalar(j.a);
}

}  // namespace odocal::calibration::internal

#endif  // ODOCAL_CALIBRATION_SRC_EFFECTS_SCALAR_H_
