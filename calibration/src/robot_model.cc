#include "odocal/calibration/robot_model.h"

#include <cmath>
#include <ostream>
#include <sstream>

#include "odocal/base/units.h"

namespace odocal::calibration {

double WheelParams::LeftMetresPerTick() const {
  return M_PI * left_wheel_diameter_m / ticks_per_rev;
}

double WheelParams::RightMetresPerTick() const {
  return M_PI * right_wheel_diameter_m / ticks_per_rev;
}

bool WheelParams::IsValid(std::string* why) const {
  auto fail = [why](const std::string& message) {
    if (why) *why = message;
    return false;
  };
  if (!std::isfinite(left_wheel_diameter_m) || left_wheel_diameter_m <= 0.0)
    return fail("left_wheel_diameter_mm must be a positive number");
  if (!std::isfinite(right_wheel_diameter_m) || right_wheel_diameter_m <= 0.0)
    return fail("right_wheel_diameter_mm must be a positive number");
  if (!std::isfinite(track_m) || track_m <= 0.0) return fail("track_mm must be a positive number");
  if (!std::isfinite(ticks_per_rev) || ticks_per_rev <= 0.0)
    return fail("ticks_per_rev must be a positive number");
  return true;
}

std::ostream& operator<<(std::ostream& os, const WheelParams& p) {
  return os << "WheelParams(D_L=" << p.left_wheel_diameter_m * kMToMm
            << " mm, D_R=" << p.right_wheel_diameter_m * kMToMm << " mm, b=" << p.track_m * kMToMm
            << " mm, ticks/rev=" << p.ticks_per_rev << ")";
}

std::ostream& operator<<(std::ostream& os, const ErrorFactors& f) {
  return os << "ErrorFactors(Ed=" << f.Ed << ", Eb=" << f.Eb << ", Es=" << f.Es << ")";
}

ErrorFactors ErrorFactorsFrom(const WheelParams& nominal, const WheelParams& truth) {
  ErrorFactors f;
  f.Ed = (truth.right_wheel_diameter_m / truth.left_wheel_diameter_m) /
         (nominal.right_wheel_diameter_m / nominal.left_wheel_diameter_m);
  f.Eb = truth.track_m / nominal.track_m;
  f.Es = (truth.left_wheel_diameter_m + truth.right_wheel_diameter_m) /
         (nominal.left_wheel_diameter_m + nominal.right_wheel_diameter_m);
  return f;
}

WheelScales WheelScalesFrom(const WheelParams& nominal, const WheelParams& truth) {
  WheelScales s;
  s.r_left = truth.left_wheel_diameter_m / nominal.left_wheel_diameter_m;
  s.r_right = truth.right_wheel_diameter_m / nominal.right_wheel_diameter_m;
  s.Eb = truth.track_m / nominal.track_m;
  return s;
}

WheelScales WheelScalesFromFactors(double Ed, double Eb, double mean_scale) {
  WheelScales s;
  s.r_left = 2.0 * mean_scale / (1.0 + Ed);
  s.r_right = 2.0 * mean_scale * Ed / (1.0 + Ed);
  s.Eb = Eb;
  return s;
}

}  // namespace odocal::calibration
