// turn_slip: in-place turns achieve (1 - f |omega|) of the wheel rotation.
// The model's term: trajectory_fit.cc (DeadReckon, PredictFrame); the simulator's:
// sim/effects.h ({name: turn_slip, ...}).
#include "effects.h"

namespace odocal::calibration::internal {

EffectDescriptor TurnSlipEffect() {
  EffectDescriptor d;
  d.effect = Effect::kTurnSlip;
  d.name = "turn_slip";
  d.params = {EffectParams::kSlip};
  d.param_names = {"fraction_at_1rad_s"};
  d.tested = d.params;
  d.distinguishing_runs =
      "in-place turns at two different turn rates (e.g. spins at 30 and 120 deg/s): slip "
      "at one rate is a track error";
  d.advice = "turns in place slip: calibrate the track at your operating turn rate";
  return d;
}

}  // namespace odocal::calibration::internal
