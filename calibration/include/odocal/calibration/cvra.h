// The CVRA odometry calibration procedures (shared/seeds/cvra-odometry-calibration.md),
// with update rules derived in docs/calibration.md rather than copied.
//
// Units: metres and radians; headings counter-clockwise positive.
//
//  1. Wheel-diameter ratio from the out-and-back path (forward d, +180 deg,
//     forward d, -180 deg, repeated). The two turns cancel whatever the track
//     error, so the only heading the path accumulates is the veer of the
//     straights, D (r_R - r_L) / b_true for a believed travel D.
//       wall-referenced:   the wall restores the true heading. Over the whole
//         path the true rotation is zero, so r_R * T_R = r_L * T_L for the
//         total believed travel T of each wheel, i.e. Ed = T_L / T_R exactly.
//         With D = (T_L + T_R) / 2 and the odometry heading at the wall
//         delta = (T_R - T_L) / b:  Ed = (D - delta b / 2) / (D + delta b / 2).
//       camera-referenced: the camera measures the heading error
//         epsilon = true - odometry; epsilon = D (r_R - r_L) / b_true, so with
//         r_L + r_R = 2:  Ed = (2D + epsilon b) / (2D - epsilon b).
//  2. Travel scale from a straight run: the robot drives until its odometry
//     says `asked`; the camera sees the true arc length `real`. Diameters
//     scale by real / asked; ticks per mm scale by asked / real (the seed has
//     the ratio upside down: erratum E2).
//  3. Track from N in-place turns: the robot turns until odometry says
//     a = 2 pi N. True rotation = a / g with g = Eb / mean_scale.
//       wall-referenced: the odometry heading at the wall is delta = a (g - 1),
//         so g = 1 + delta / a (the seed's rule, exact for in-place turns).
//       camera-referenced: epsilon = true - odometry = a / g - a, so
//         g = a / (a + epsilon).
#ifndef ODOCAL_CALIBRATION_CVRA_H_
#define ODOCAL_CALIBRATION_CVRA_H_

#include <optional>
#include <string>

#include "odocal/base/status.h"
#include "odocal/calibration/robot_model.h"

namespace odocal::calibration {

struct CvraResult {
  StatusCode status = StatusCode::kInvalidArgument;
  std::string message;
  double value = 1.0;                 // the estimated factor (Ed, scale or g)
  std::optional<double> sigma;        // when repeated measurements were given
  bool ok() const { return status == StatusCode::kOk; }
};

// 1a. Wall-referenced: `mean_travel_m` is D, the mean of the two wheels'
// total believed travel from reset to the wall (signed); `wall_heading_rad` is
// the odometry heading at the wall; `track_m` the firmware's track.
CvraResult WheelRatioFromWall(double mean_travel_m, double wall_heading_rad, double track_m);

// 1b. Camera-referenced: `mean_travel_m` as above (the straights' total),
// `heading_error_rad` the camera's true - odometry heading at the end.
CvraResult WheelRatioFromCamera(double mean_travel_m, double heading_error_rad, double track_m);

// The seed's gain update, written with the derivation's terms:
// new_left = (1 + f) old_left, new_right = (1 - f) old_right with
// f = (Ed^-1 - 1) / (Ed^-1 + 1) = (T_R - T_L) / (T_R + T_L). Exact, not first order.
double WheelGainFactor(double Ed);

// 2. `asked_m` is the odometry distance, `true_dx_m`, `true_dy_m` and
// `true_heading_rad` the true end pose in the start frame (camera). The arc
// length is recovered from the chord and the heading change. A negative
// `asked_m` is a run backwards: the same scale.
CvraResult ScaleFromStraight(double asked_m, double true_dx_m, double true_dy_m,
                             double true_heading_rad);

// 3a. `believed_rotation_rad` is a = +-2 pi N (what odometry turned, signed),
// `wall_heading_rad` the odometry heading at the wall after the turns,
// relative to the start (wrapped).
CvraResult TrackFromWall(double believed_rotation_rad, double wall_heading_rad);
// 3b. `heading_error_rad` is the camera's true - odometry heading (wrapped).
CvraResult TrackFromCamera(double believed_rotation_rad, double heading_error_rad);

// Applies the three CVRA results to a parameter set: wheels get the ratio
// (mean kept) and then the scale; the track gets g * scale (g was measured in
// the old distance units).
WheelParams ApplyCvra(const WheelParams& params, std::optional<double> Ed,
                      std::optional<double> scale, std::optional<double> g);

}  // namespace odocal::calibration

#endif  // ODOCAL_CALIBRATION_CVRA_H_
