// eccentric_wheel: a wheel turning about a point off its centre rolls with a
// radius that changes once a turn, r (1 + a sin(phi + phase)), phi its angle:
// its travel ripples about what its ticks say, with no drift over whole turns.
// It needs each wheel's angle: encoder counts that run on from run to run.
// The simulator's term: sim/effects.h ({name: eccentric_wheel, ...}).
//
// Its descriptor (what it is, what it needs, what to do about it: effect_registry.h)
// and its term in the model, one file (docs/architecture.md, "Add an effect").
#ifndef ODOCAL_CALIBRATION_SRC_EFFECTS_ECCENTRIC_WHEEL_H_
#define ODOCAL_CALIBRATION_SRC_EFFECTS_ECCENTRIC_WHEEL_H_

#include <cmath>
#include <cstdint>
#include <string>

#include "odocal/calibration/effect_registry.h"
#include "odocal/calibration/measured_session.h"
#include "odocal/calibration/trajectory_fit.h"
#include "scalar.h"

namespace odocal::calibration::internal {

// A wheel's angle is its encoder count over its counts per turn, up to one
// phase for the session, which the fit absorbs. Firmware that restarts its
// counts at every run (odocal's link does) gives every run its own phase.
inline std::string WheelAngleMissingInput(const MeasuredSession& session) {
  int with_telemetry = 0, from_zero = 0;
  for (const MeasuredRun& run : session.runs) {
    if (run.telemetry.empty()) continue;
    ++with_telemetry;
    if (run.telemetry.front().left_ticks == 0 && run.telemetry.front().right_ticks == 0) ++from_zero;
  }
  if (with_telemetry == 0) return "the wheels' encoder counts (telemetry)";
  if (with_telemetry >= 2 && from_zero == with_telemetry)
    return "each wheel's angle (here every run's encoder counts start at 0; counts that run on from "
           "run to run, as a robot's own since power-on, give it)";
  return "";
}

inline EffectDescriptor EccentricWheelEffect() {
  EffectDescriptor d;
  d.effect = Effect::kEccentricWheel;
  d.name = "eccentric_wheel";
  // Each wheel's a sin(phase) and a cos(phase): the model is linear in them.
  d.params = {EffectParams::kEccLeftSin, EffectParams::kEccLeftCos, EffectParams::kEccRightSin,
              EffectParams::kEccRightCos};
  d.param_names = {"left_sin", "left_cos", "right_sin", "right_cos"};
  d.tested = d.params;
  d.distinguishing_runs =
      "frames along straights and spins several wheel turns long: the travel ripples once a "
      "wheel turn (a circumference, ~0.2 m); whole turns leave no drift, so the return errors "
      "alone barely show it";
  d.advice = "a wheel turns off its centre (an eccentric hub or a worn tyre): re-seat or replace it";
  d.missing_input = WheelAngleMissingInput;
  return d;
}

// The model's term (DeadReckon): a wheel whose count was `count` before a step
// of `step_ticks` travels (1 + s sin(phi) + c cos(phi)) times what its ticks
// say, phi its angle mid-step, 2 pi count / ticks_per_rev.
template <typename T>
void EccentricWheel(const T* effect_values, double ticks_per_rev, std::int64_t left_count, std::int64_t left_step_ticks,
                    std::int64_t right_count, std::int64_t right_step_ticks, T* left_m, T* right_m) {
  if (!(ticks_per_rev > 0.0)) return;  // no angle: a model built without the counts per turn
  // A wheel whose two values are held at zero rolls true: skipped (to the
  // bit; most fits hold them so, and two sines a step were 10 % of explain).
  const auto ripple = [&](std::int64_t count, std::int64_t step, int sin_index, int cos_index, T* travel_m) {
    if (IsExactlyZero(effect_values[sin_index]) && IsExactlyZero(effect_values[cos_index])) return;
    const double phi = 2.0 * M_PI * (static_cast<double>(count) + 0.5 * static_cast<double>(step)) / ticks_per_rev;
    *travel_m *= 1.0 + effect_values[sin_index] * std::sin(phi) + effect_values[cos_index] * std::cos(phi);
  };
  ripple(left_count, left_step_ticks, EffectParams::kEccLeftSin, EffectParams::kEccLeftCos, left_m);
  ripple(right_count, right_step_ticks, EffectParams::kEccRightSin, EffectParams::kEccRightCos, right_m);
}

}  // namespace odocal::calibration::internal

#endif  // ODOCAL_CALIBRATION_SRC_EFFECTS_ECCENTRIC_WHEEL_H_
