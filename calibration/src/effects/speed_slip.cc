// speed_slip: each wheel's ground travel = tick travel (1 - k |v_wheel|).
// The model's term: trajectory_fit.cc (DeadReckon, PredictFrame); the simulator's:
// sim/effects.h ({name: speed_slip, ...}).
#include "effects.h"

namespace odocal::calibration::internal {

EffectDescriptor SpeedSlipEffect() {
  EffectDescriptor d;
  d.effect = Effect::kSpeedSlip;
  d.name = "speed_slip";
  d.params = {EffectParams::kSpeedSlip};
  d.param_names = {"fraction_at_1m_s"};
  d.tested = d.params;
  d.distinguishing_runs =
      "straights at two different speeds (e.g. out-and-backs at 100 and 400 mm/s): slip at "
      "one speed is a scale error, and in spins a turn slip";
  d.advice = "the wheels slip more at speed: calibrate at your operating speed";
  return d;
}

}  // namespace odocal::calibration::internal
