// The differential-drive odometry model and its error factors.
//
// A robot's firmware converts encoder ticks to wheel travel with the wheel
// diameters it believes (nominal) and turns wheel travel into heading with the
// track it believes. The floor answers to the true ones. Everything odocal
// calibrates is the ratio between the two, in the factors of Borenstein &
// Feng (1996):
//
//   Ed = (D_R / D_L)_true / (D_R / D_L)_nominal   wheel-diameter ratio error
//   Eb = b_true / b_nominal                        track (wheelbase) error
//   Es = (D_L + D_R)_true / (D_L + D_R)_nominal    scale (distance) error
//
// Per wheel, the true travel for a believed travel d is d * r with
// r_left = D_L,true / D_L,nominal and r_right = D_R,true / D_R,nominal, so that
// Ed = r_right / r_left. Units: SI (metres).
#ifndef ODOCAL_CALIBRATION_ROBOT_MODEL_H_
#define ODOCAL_CALIBRATION_ROBOT_MODEL_H_

#include <iosfwd>
#include <string>

namespace odocal::calibration {

// The parameter set a robot's firmware holds.
struct WheelParams {
  double left_wheel_diameter_m = 0.0;
  double right_wheel_diameter_m = 0.0;
  double track_m = 0.0;
  // Encoder counts per wheel revolution; not always whole (64 counts per motor
  // turn through a 43.7:1 gear is 2796.8).
  double ticks_per_rev = 0.0;

  // Wheel travel per encoder tick.
  double LeftMetresPerTick() const;
  double RightMetresPerTick() const;
  bool IsValid(std::string* why) const;
};

std::ostream& operator<<(std::ostream& os, const WheelParams& params);

struct ErrorFactors {
  double Ed = 1.0;
  double Eb = 1.0;
  double Es = 1.0;
};

std::ostream& operator<<(std::ostream& os, const ErrorFactors& factors);

// How the true robot differs from what its firmware believes, in the form the
// kinematics uses: true wheel travel = believed travel * r, true track = believed * Eb.
struct WheelScales {
  double r_left = 1.0;
  double r_right = 1.0;
  double Eb = 1.0;

  double Ed() const { return r_right / r_left; }
  // Mean travel scale: what a straight run measures.
  double mean() const { return 0.5 * (r_left + r_right); }
};

ErrorFactors ErrorFactorsFrom(const WheelParams& nominal, const WheelParams& truth);
WheelScales WheelScalesFrom(const WheelParams& nominal, const WheelParams& truth);

// The scales implied by Ed and Eb for a robot whose mean travel scale
// (r_left + r_right) / 2 is `mean_scale` (1 once distance is calibrated).
WheelScales WheelScalesFromFactors(double Ed, double Eb, double mean_scale = 1.0);

}  // namespace odocal::calibration

#endif  // ODOCAL_CALIBRATION_ROBOT_MODEL_H_
