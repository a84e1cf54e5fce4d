// carpet_drift: while not turning in place, lateral drift to the left of rate cos(heading - grain)
// per metre forward, fitted as the linear pair (a, b) = rate (cos grain, sin grain);
// the grain angle reported beside them is no evidence across runs (it is any angle
// when the rate vanishes).
// The simulator's term: sim/effects.h ({name: carpet_drift, ...}).
//
// Its descriptor (what it is, what it needs, what to do about it: effect_registry.h)
// and its term in the model, one file (docs/architecture.md, "Add an effect").
#ifndef ODOCAL_CALIBRATION_SRC_EFFECTS_CARPET_DRIFT_H_
#define ODOCAL_CALIBRATION_SRC_EFFECTS_CARPET_DRIFT_H_

#include <cmath>

#include "odocal/calibration/effect_registry.h"
#include "odocal/calibration/trajectory_fit.h"

namespace odocal::calibration::internal {

inline EffectDescriptor CarpetDriftEffect() {
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

// The model's term (DeadReckon): after a straight step of `ds_m` from heading
// `h0_rad` to `*heading_rad`, the robot is pushed to its left by (a cos h +
// b sin h) ds, h the step's mid heading.
template <typename T>
void CarpetDrift(const T* effect_values, const T& h0_rad, const T& ds_m, T* x_m, T* y_m, const T* heading_rad) {
  using std::cos;
  using std::sin;
  const T mid_rad = (h0_rad + *heading_rad) / 2.0;
  const T lateral_m =
      (effect_values[EffectParams::kDriftA] * cos(mid_rad) + effect_values[EffectParams::kDriftB] * sin(mid_rad)) *
      ds_m;
  *x_m -= lateral_m * sin(mid_rad);
  *y_m += lateral_m * cos(mid_rad);
}

}  // namespace odocal::calibration::internal

#endif  // ODOCAL_CALIBRATION_SRC_EFFECTS_CARPET_DRIFT_H_
