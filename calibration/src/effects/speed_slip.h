// speed_slip: each wheel's ground travel = tick travel (1 - k |v_wheel|).
// The simulator's term: sim/effects.h ({name: speed_slip, ...}).
//
// Its descriptor (what it is, what it needs, what to do about it: effect_registry.h)
// and its term in the model, one file (docs/architecture.md, "Add an effect").
#ifndef ODOCAL_CALIBRATION_SRC_EFFECTS_SPEED_SLIP_H_
#define ODOCAL_CALIBRATION_SRC_EFFECTS_SPEED_SLIP_H_

#include <cmath>

#include "odocal/calibration/effect_registry.h"
#include "odocal/calibration/trajectory_fit.h"

namespace odocal::calibration::internal {

inline EffectDescriptor SpeedSlipEffect() {
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

// The model's term (DeadReckon): each wheel loses k |v| of its travel over a
// step of `dt_s`, v its speed over the step.
template <typename T>
void SpeedSlip(const T* effect_values, double dt_s, T* left_m, T* right_m) {
  using std::abs;
  *left_m *= 1.0 - effect_values[EffectParams::kSpeedSlip] * abs(*left_m) / dt_s;
  *right_m *= 1.0 - effect_values[EffectParams::kSpeedSlip] * abs(*right_m) / dt_s;
}

}  // namespace odocal::calibration::internal

#endif  // ODOCAL_CALIBRATION_SRC_EFFECTS_SPEED_SLIP_H_
