// camera_latency: a frame stamped s shows the robot at telemetry time s + latency.
// The model's term: trajectory_fit.cc (DeadReckon, PredictFrame); the simulator's:
// sim/effects.h ({name: camera_latency, ...}).
#include "effects.h"

namespace odocal::calibration::internal {

EffectDescriptor CameraLatencyEffect() {
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

}  // namespace odocal::calibration::internal
