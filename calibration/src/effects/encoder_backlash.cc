// encoder_backlash: after a wheel's ticks reverse, `ticks` counts pass without motion.
// The model's term: trajectory_fit.cc (DeadReckon, PredictFrame); the simulator's:
// sim/effects.h ({name: encoder_backlash, ...}).
#include "effects.h"

namespace odocal::calibration::internal {

EffectDescriptor EncoderBacklashEffect() {
  EffectDescriptor d;
  d.effect = Effect::kEncoderBacklash;
  d.name = "encoder_backlash";
  d.params = {EffectParams::kBacklash};
  d.param_names = {"ticks"};
  d.tested = d.params;
  d.distinguishing_runs =
      "runs that reverse each wheel a different number of times per metre (e.g. "
      "out_and_back beside long straights, spins in both directions)";
  d.advice = "the encoders lose counts when a wheel reverses: check the couplings";
  return d;
}

}  // namespace odocal::calibration::internal
