// The candidate effects of the trajectory fit and explain, each in one place:
// calibration/src/effects/<name>.h, its descriptor and its term of the model,
// registered once in calibration/src/effect_registry.cc (docs/architecture.md,
// "Add an effect").
//
// A descriptor says what an effect is called, which parameters of the effect
// block (trajectory_fit.h's EffectParams) are its own and how reports spell
// them, which of them name it (the others are nuisances its tests leave out),
// which runs tell it from the base model, what a session must hold for it to
// be formed and the words when it does not, what the user should do when
// explain finds it, and the simulator's hidden effect of the same name
// (sim/effects.h). The trajectory fit, explain, the station's findings and
// the reports read these; nothing else switches on an effect. Its term of the
// model (and so its Jacobian, by automatic differentiation) is a template in
// the same file, which trajectory_fit.cc's DeadReckon / PredictFrame call in
// the order the effects act.
#ifndef ODOCAL_CALIBRATION_EFFECT_REGISTRY_H_
#define ODOCAL_CALIBRATION_EFFECT_REGISTRY_H_

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "odocal/calibration/trajectory_fit.h"

namespace odocal::calibration {

struct MeasuredSession;

struct EffectDescriptor {
  Effect effect{};
  // As scenario files, explain and the reports name it; the simulator's
  // hidden effect of the same name is its counterpart (sim/effects.h).
  std::string_view name;
  // Its parameters: indices into EffectParams::values and their names in
  // reports (one per index), and those that name it (tested against zero,
  // checked for aliasing): all of them unless some are nuisances.
  std::vector<int> params;
  std::vector<std::string_view> param_names;
  std::vector<int> tested;
  // Reported parameters (own or derived, e.g. carpet_drift's grain_rad) that
  // are no evidence that the effect holds from run to run (a nuisance, an
  // angle of a vanishing rate): left out of explain's between_runs_z.
  std::vector<std::string_view> not_compared_across_runs;
  // Which runs separate it from the base model, in words.
  std::string_view distinguishing_runs;
  // What to do about it when explain finds it (the station's findings).
  std::string_view advice;
  // What the session lacks for the candidate to be formed, in words; empty
  // when it holds what the effect needs. nullptr: the effect needs nothing
  // beyond runs seen by a camera or a pose source.
  std::string (*missing_input)(const MeasuredSession& session) = nullptr;
};

// Every registered effect, in kAllEffects' order.
const std::vector<EffectDescriptor>& Effects();
const EffectDescriptor& Describe(Effect effect);
// The effect of a name (EffectDescriptor::name); nullopt when none.
std::optional<Effect> EffectNamed(std::string_view name);
// What `session` lacks for `effect` (EffectDescriptor::missing_input), else "".
std::string MissingInput(const MeasuredSession& session, Effect effect);

}  // namespace odocal::calibration

#endif  // ODOCAL_CALIBRATION_EFFECT_REGISTRY_H_
