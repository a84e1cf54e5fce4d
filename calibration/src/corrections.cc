#include "odocal/calibration/corrections.h"

#include <ostream>

#include "odocal/calibration/umbmark.h"

namespace odocal::calibration {

WheelParams ApplyUmbmarkCorrection(const WheelParams& params, double Ed, double Eb) {
  WheelParams corrected = params;
  corrected.left_wheel_diameter_m *= CorrectionLeft(Ed);
  corrected.right_wheel_diameter_m *= CorrectionRight(Ed);
  corrected.track_m *= Eb;
  return corrected;
}

WheelParams ApplyWheelScales(const WheelParams& params, const WheelScales& scales) {
  WheelParams corrected = params;
  corrected.left_wheel_diameter_m *= scales.r_left;
  corrected.right_wheel_diameter_m *= scales.r_right;
  corrected.track_m *= scales.Eb;
  return corrected;
}

Ros2Multipliers Ros2MultipliersFrom(const WheelParams& nominal, const WheelParams& corrected) {
  Ros2Multipliers m;
  m.wheel_separation_multiplier = corrected.track_m / nominal.track_m;
  m.left_wheel_radius_multiplier = corrected.left_wheel_diameter_m / nominal.left_wheel_diameter_m;
  m.right_wheel_radius_multiplier =
      corrected.right_wheel_diameter_m / nominal.right_wheel_diameter_m;
  return m;
}

std::ostream& operator<<(std::ostream& os, const Ros2Multipliers& m) {
  return os << "Ros2Multipliers(separation=" << m.wheel_separation_multiplier
            << ", left_radius=" << m.left_wheel_radius_multiplier
            << ", right_radius=" << m.right_wheel_radius_multiplier << ")";
}

}  // namespace odocal::calibration
