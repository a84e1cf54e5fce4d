// encoder_backlash: after a wheel's ticks reverse, `ticks` counts pass without motion.
// The simulator's term: sim/effects.h ({name: encoder_backlash, ...}).
//
// Its descriptor (what it is, what it needs, what to do about it: effect_registry.h)
// and its term in the model, one file (docs/architecture.md, "Add an effect").
#ifndef ODOCAL_CALIBRATION_SRC_EFFECTS_ENCODER_BACKLASH_H_
#define ODOCAL_CALIBRATION_SRC_EFFECTS_ENCODER_BACKLASH_H_

#include <cstdint>

#include "odocal/calibration/effect_registry.h"
#include "odocal/calibration/trajectory_fit.h"
#include "scalar.h"

namespace odocal::calibration::internal {

inline EffectDescriptor EncoderBacklashEffect() {
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

// The model's term (DeadReckon): of a step of `step_ticks` on one wheel, the
// ticks that moved it. `direction` is the wheel's last direction (+1, -1) and
// `dead_ticks` what is left of the backlash since it last reversed.
template <typename T>
T MovingTicks(std::int64_t step_ticks, int* direction, T* dead_ticks, const T& backlash_ticks) {
  if (step_ticks == 0) return T(0.0);
  const int s = step_ticks > 0 ? 1 : -1;
  if (s != *direction) {
    *direction = s;
    *dead_ticks = backlash_ticks;
  }
  const double magnitude = static_cast<double>(step_ticks > 0 ? step_ticks : -step_ticks);
  const T consumed = Scalar(*dead_ticks) < magnitude ? *dead_ticks : T(magnitude);
  *dead_ticks -= consumed;
  return T(static_cast<double>(step_ticks)) - double(s) * consumed;
}

}  // namespace odocal::calibration::internal

#endif  // ODOCAL_CALIBRATION_SRC_EFFECTS_ENCODER_BACKLASH_H_
