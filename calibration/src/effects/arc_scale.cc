// arc_scale: on arcs, each wheel's ground travel = tick travel (1 - c |kappa|).
// The model's term: trajectory_fit.cc (DeadReckon, PredictFrame); the simulator's:
// sim/effects.h ({name: arc_scale, ...}).
#include "effects.h"

namespace odocal::calibration::internal {

EffectDescriptor ArcScaleEffect() {
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

}  // namespace odocal::calibration::internal
