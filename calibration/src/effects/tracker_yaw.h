// tracker_yaw: the tracked body's (tag's) heading is off the robot's by a constant.
// The simulator's term: sim/effects.h ({name: tracker_yaw, ...}).
//
// Its descriptor (what it is, what it needs, what to do about it: effect_registry.h)
// and its term in the model, one file (docs/architecture.md, "Add an effect").
#ifndef ODOCAL_CALIBRATION_SRC_EFFECTS_TRACKER_YAW_H_
#define ODOCAL_CALIBRATION_SRC_EFFECTS_TRACKER_YAW_H_

#include "odocal/calibration/effect_registry.h"
#include "odocal/calibration/trajectory_fit.h"

namespace odocal::calibration::internal {

inline EffectDescriptor TrackerYawEffect() {
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

// The model's term (PredictFrame): the heading measured is the robot's plus a constant.
template <typename T>
void TrackerYaw(const T* effect_values, T* heading_rad) {
  *heading_rad += effect_values[EffectParams::kTrackerYaw];
}

}  // namespace odocal::calibration::internal

#endif  // ODOCAL_CALIBRATION_SRC_EFFECTS_TRACKER_YAW_H_
