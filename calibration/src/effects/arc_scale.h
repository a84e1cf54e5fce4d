// arc_scale: on arcs, each wheel's ground travel = tick travel (1 - c |kappa|).
// The simulator's term: sim/effects.h ({name: arc_scale, ...}).
//
// Its descriptor (what it is, what it needs, what to do about it: effect_registry.h)
// and its term in the model, one file (docs/architecture.md, "Add an effect").
#ifndef ODOCAL_CALIBRATION_SRC_EFFECTS_ARC_SCALE_H_
#define ODOCAL_CALIBRATION_SRC_EFFECTS_ARC_SCALE_H_

#include <cmath>

#include "odocal/calibration/effect_registry.h"
#include "odocal/calibration/trajectory_fit.h"

namespace odocal::calibration::internal {

inline EffectDescriptor ArcScaleEffect() {
  EffectDescriptor d;
  d.effect = Effect::kArcScale;
  d.name = "arc_scale";
  d.params = {EffectParams::kArcScale};
  d.param_names = {"fraction_at_1_per_m"};
  d.tested = d.params;
  d.distinguishing_runs =
      "arcs (e.g. circles of radius 0.3-1 m) beside straights and turns in place: on arcs of "
      "one curvature it is a scale of both wheels there, which only straights tell from Es "
      "(and spins from Eb)";
  d.advice = "arcs travel a different scale than straights: calibrate on the paths you drive";
  return d;
}

// The model's term (DeadReckon): on a step of curvature `curvature_per_m`
// (0: not an arc) both wheels lose c |kappa| of their travel.
template <typename T>
void ArcScale(const T* effect_values, double curvature_per_m, T* left_m, T* right_m) {
  if (curvature_per_m == 0.0) return;
  const T scale = 1.0 - effect_values[EffectParams::kArcScale] * std::abs(curvature_per_m);
  *left_m *= scale;
  *right_m *= scale;
}

}  // namespace odocal::calibration::internal

#endif  // ODOCAL_CALIBRATION_SRC_EFFECTS_ARC_SCALE_H_
