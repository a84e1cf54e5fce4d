// Corrections applied to a firmware parameter set, and exports.
//
// UMBMark's Ed moves wheel travel per tick between the wheels, keeping their
// mean: D_L' = D_L * c_L, D_R' = D_R * c_R with c_L = 2 / (Ed + 1),
// c_R = 2 / (1/Ed + 1) (Borenstein & Feng 1996 eq. 17-18). These multiply the
// *measured* travel per tick; a controller that multiplies *requested* counts
// needs the reciprocals (the seed says otherwise: erratum E3).
// Eb scales the track: b' = b * Eb.
#ifndef ODOCAL_CALIBRATION_CORRECTIONS_H_
#define ODOCAL_CALIBRATION_CORRECTIONS_H_

#include <iosfwd>

#include "odocal/calibration/robot_model.h"

namespace odocal::calibration {

WheelParams ApplyUmbmarkCorrection(const WheelParams& params, double Ed, double Eb);

// The parameters of a robot whose true wheel travel per tick is r_left and
// r_right times what `params` believe and whose track is Eb times: a
// trajectory fit's scales (trajectory_fit.h), which, unlike UMBMark, include
// the distance scale Es when the pose source measures true lengths.
WheelParams ApplyWheelScales(const WheelParams& params, const WheelScales& scales);

// ROS 2 diff_drive_controller multipliers that turn `nominal` into `corrected`.
struct Ros2Multipliers {
  double wheel_separation_multiplier = 1.0;
  double left_wheel_radius_multiplier = 1.0;
  double right_wheel_radius_multiplier = 1.0;
};

Ros2Multipliers Ros2MultipliersFrom(const WheelParams& nominal, const WheelParams& corrected);
std::ostream& operator<<(std::ostream& os, const Ros2Multipliers& m);

}  // namespace odocal::calibration

#endif  // ODOCAL_CALIBRATION_CORRECTIONS_H_
