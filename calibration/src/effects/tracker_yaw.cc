// tracker_yaw: the tracked body's (tag's) heading is off the robot's by a constant.
// The model's term: trajectory_fit.cc (DeadReckon, PredictFrame); the simulator's:
// sim/effects.h ({name: tracker_yaw, ...}).
#include "effects.h"

namespace odocal::calibration::internal {

EffectDescriptor TrackerYawEffect() {
  EffectDescriptor d;
  d.effect = Effect::kTrackerYaw;
  d.name = "tracker_yaw";
  d.params = {EffectParams::kTrackerYaw};
  d.param_names = {"yaw_rad"};
  d.tested = d.params;
  d.distinguishing_runs =
      "straights seen by the pose source with their measured headings (the direction of "
      "travel against the heading the tracker reports)";
  d.advice = "the tag is turned on the robot: set tag.yaw_deg";
  return d;
}

}  // namespace odocal::calibration::internal
