// Replaying a run's ticks through the model with a given parameter set and
// comparing with what the pose source measured: the referee of every
// calibration on data it did not see (`odocal check`, explain's
// cross-validation by run).
//
// The run's start pose is not fitted to the whole run (that would let the
// model hide its errors in it): it is anchored on the frames measured while
// the wheels were still before the first motion (the start rest), or, when
// there are none, on the first `anchor_frames` valid frames, by least squares
// of those frames alone. From there the model dead-reckons the ticks
// (trajectory_fit.h: exact arcs and the enabled effects) and is compared with
// every later valid frame. The final pose is the mean of the frames after
// the last wheel motion (the end rest) or, without them, the last valid
// frame.
//
// Frames: the measurement frame (REP-103). Units: SI.
#ifndef ODOCAL_CALIBRATION_REPLAY_H_
#define ODOCAL_CALIBRATION_REPLAY_H_

#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include "odocal/base/status.h"
#include "odocal/base/units.h"
#include "odocal/calibration/floor_camera.h"
#include "odocal/calibration/measured_session.h"
#include "odocal/calibration/pose2.h"
#include "odocal/calibration/robot_model.h"
#include "odocal/calibration/trajectory_fit.h"

namespace odocal::calibration {

// A parameter set to replay: the robot's believed parameters corrected by
// `scales`, with `effects` (zero: none).
struct ReplayModel {
  WheelScales scales;
  EffectParams effects;
};

struct ReplayOptions {
  // Frames used to anchor the start pose when the run has no frames before
  // its first wheel motion.
  int anchor_frames = 5;
  // At most this many still frames before the first motion anchor the start
  // (the last ones, closest to the motion).
  int max_anchor_frames = 200;
  // Stand-ins for a frame whose stated sigma is zero (as in the fit).
  double default_position_sigma_m = 1e-3;
  double default_heading_sigma_rad = DegToRad(0.2);
  // Each wheel's last direction of motion before the run (+1, -1), for
  // encoder_backlash; a session's earlier runs set it (LastShaftDirections).
  int left_direction0 = 1;
  int right_direction0 = 1;

  bool IsValid(std::string* why) const;
};

struct RunReplay {
  StatusCode status = StatusCode::kFailed;
  bool ok() const { return status == StatusCode::kOk; }
  std::string message;  // why not, naming the run

  Pose2 start;  // anchored robot start pose at the first telemetry sample
  // Every valid frame after the anchor: time, measured, predicted.
  std::vector<double> t_s;
  std::vector<Pose2> measured;
  std::vector<Pose2> predicted;

  double final_position_error_m = 0.0;   // |predicted - measured| at the final pose
  double final_heading_error_rad = 0.0;  // predicted - measured, wrapped to (-pi, pi]
  double rms_position_error_m = 0.0;     // over every compared frame
  double distance_m = 0.0;               // travelled, from the ticks (believed parameters)
  // final position error / distance travelled (0 when the robot did not move).
  double final_error_fraction() const {
    return distance_m > 0.0 ? final_position_error_m / distance_m : 0.0;
  }
};

RunReplay ReplayRun(const MeasuredRun& run, const WheelParams& believed, const ReplayModel& model,
                    const std::optional<FloorCamera>& camera = std::nullopt,
                    const ReplayOptions& options = {});

}  // namespace odocal::calibration

#endif  // ODOCAL_CALIBRATION_REPLAY_H_
