#include "odocal/test_util/robots.h"

namespace odocal::test_util {

calibration::WheelParams NominalParams(int ticks_per_rev) {
  calibration::WheelParams p;
  p.left_wheel_diameter_m = 0.070;
  p.right_wheel_diameter_m = 0.070;
  p.track_m = 0.300;
  p.ticks_per_rev = ticks_per_rev;
  return p;
}

calibration::WheelParams TrueParamsFor(const calibration::WheelParams& nominal, double Ed,
                                       double Eb, double Es) {
  // Ed = (DR/DL)_t / (DR/DL)_n and DL_t + DR_t = Es (DL_n + DR_n).
  const double ratio = Ed * nominal.right_wheel_diameter_m / nominal.left_wheel_diameter_m;
  const double sum = Es * (nominal.left_wheel_diameter_m + nominal.right_wheel_diameter_m);
  calibration::WheelParams t = nominal;
  t.left_wheel_diameter_m = sum / (1.0 + ratio);
  t.right_wheel_diameter_m = sum * ratio / (1.0 + ratio);
  t.track_m = Eb * nominal.track_m;
  return t;
}

sim::RobotConfig ExactRobot(double Ed, double Eb, int ticks_per_rev) {
  sim::RobotConfig c;
  c.nominal = NominalParams(ticks_per_rev);
  c.truth = TrueParamsFor(c.nominal, Ed, Eb);
  c.rest_s = 0.1;
  c.pause_s = 0.05;
  c.limits.speed_m_s = 0.5;
  c.limits.accel_m_s2 = 1.0;
  c.limits.turn_rate_rad_s = 2.0;
  c.limits.turn_accel_rad_s2 = 4.0;
  c.control_rate_hz = 500.0;
  c.telemetry_rate_hz = 50.0;
  c.seed = 1;
  return c;
}

}  // namespace odocal::test_util
