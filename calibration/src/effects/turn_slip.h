// turn_slip: in-place turns achieve (1 - f |omega|) of the wheel rotation.
// The simulator's term: sim/effects.h ({name: turn_slip, ...}).
//
// Its descriptor (what it is, what it needs, what to do about it: effect_registry.h)
// and its term in the model, one file (docs/architecture.md, "Add an effect").
#ifndef ODOCAL_CALIBRATION_SRC_EFFECTS_TURN_SLIP_H_
#define ODOCAL_CALIBRATION_SRC_EFFECTS_TURN_SLIP_H_

#include <cmath>

#include "odocal/calibration/effect_registry.h"
#include "odocal/calibration/trajectory_fit.h"

namespace odocal::calibration::internal {

inline EffectDescriptor TurnSlipEffect() {
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

// The model's term (DeadReckon): a step of a turn in place over `dt_s`
// achieves (1 - f |omega|) of the turn its wheels' travel makes; the distance
// travelled stays.
template <typename T>
void TurnSlip(const T* effect_values, double dt_s, const T& track_m, T* left_m, T* right_m) {
  using std::abs;
  const T ds_m = (*left_m + *right_m) / 2.0;
  const T dtheta_rad = (*right_m - *left_m) / track_m;
  const T achieved_rad = dtheta_rad * (1.0 - effect_values[EffectParams::kSlip] * abs(dtheta_rad) / dt_s);
  *left_m = ds_m - achieved_rad * track_m / 2.0;
  *right_m = ds_m + achieved_rad * track_m / 2.0;
}

}  // namespace odocal::calibration::internal

#endif  // ODOCAL_CALIBRATION_SRC_EFFECTS_TURN_SLIP_H_
