// camera_latency: a frame stamped s shows the robot at telemetry time s + latency.
// The simulator's term: sim/effects.h ({name: camera_latency, ...}).
//
// Its descriptor (what it is, what it needs, what to do about it: effect_registry.h)
// and its term in the model, one file (docs/architecture.md, "Add an effect").
#ifndef ODOCAL_CALIBRATION_SRC_EFFECTS_CAMERA_LATENCY_H_
#define ODOCAL_CALIBRATION_SRC_EFFECTS_CAMERA_LATENCY_H_

#include "odocal/calibration/effect_registry.h"
#include "odocal/calibration/trajectory_fit.h"

namespace odocal::calibration::internal {

inline EffectDescriptor CameraLatencyEffect() {
  EffectDescriptor d;
  d.effect = Effect::kCameraLatency;
  d.name = "camera_latency";
  d.params = {EffectParams::kLatency};
  d.param_names = {"latency_s"};
  d.tested = d.params;
  d.distinguishing_runs =
      "motion seen by the camera at two speeds (e.g. straights at 100 and 400 mm/s) or a "
      "spin seen by the camera";
  d.advice =
      "the camera's frames lag the robot's clock: harmless to return errors; "
      "state it as the clock offset where poses and telemetry are combined";
  return d;
}

// The model's term (PredictFrame, and the frames' telemetry times): the
// telemetry time a frame stamped `stamp_s` shows.
template <typename T>
T CameraLatency(const T* effect_values, double stamp_s) {
  return stamp_s + effect_values[EffectParams::kLatency];
}

}  // namespace odocal::calibration::internal

#endif  // ODOCAL_CALIBRATION_SRC_EFFECTS_CAMERA_LATENCY_H_
