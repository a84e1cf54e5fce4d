// carpet_drift: while not turning in place, lateral drift to the left of rate cos(heading - grain)
// per metre forward, fitted as the linear pair (a, b) = rate (cos grain, sin grain);
// the grain angle reported beside them is no evidence across runs (it is any angle
// when the rate vanishes).
// The model's term: trajectory_fit.cc (DeadReckon, PredictFrame); the simulator's:
// sim/effects.h ({name: carpet_drift, ...}).
#include "effects.h"

namespace odocal::calibration::internal {

EffectDescriptor CarpetDriftEffect() {
  EffectDescriptor d;
  d.effect = Effect::kCarpetDrift;
  d.name = "carpet_drift";
  d.params = {EffectParams::kDriftA, EffectParams::kDriftB};
  d.param_names = {"rate_cos_grain", "rate_sin_grain"};
  d.tested = d.params;
  d.not_compared_across_runs = {"grain_rad"};
  d.distinguishing_runs =
      "straights in several headings seen by the camera (e.g. cw and ccw squares, or "
      "straights at 0, 90, 180 deg): drift along one heading is a wheel-ratio error";
  d.advice = "the floor pushes the robot sideways (carpet grain): calibrate on the floor it works on";
  return d;
}

}  // namespace odocal::calibration::internal
