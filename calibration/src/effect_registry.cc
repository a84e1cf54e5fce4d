// The registry of candidate effects (odocal/calibration/effect_registry.h):
// one line per effect, in kAllEffects' order.
#include "odocal/calibration/effect_registry.h"

#include <cstdlib>

#include "effects/effects.h"

namespace odocal::calibration {

const std::vector<EffectDescriptor>& Effects() {
  static const std::vector<EffectDescriptor> registry = {
      internal::TagOffsetEffect(),      internal::CameraLatencyEffect(),   internal::TurnSlipEffect(),
      internal::LensDistortionEffect(), internal::EncoderBacklashEffect(), internal::CarpetDriftEffect(),
      internal::TrackerYawEffect(),     internal::SpeedSlipEffect(),       internal::ArcScaleEffect(),
      internal::RollingShutterEffect(), internal::EccentricWheelEffect(),
  };
  return registry;
}

const EffectDescriptor& Describe(Effect effect) {
  for (const EffectDescriptor& d : Effects())
    if (d.effect == effect) return d;
  std::abort();  // every Effect is registered (effect_registry_test)
}

std::optional<Effect> EffectNamed(std::string_view name) {
  for (const EffectDescriptor& d : Effects())
    if (d.name == name) return d.effect;
  return std::nullopt;
}

std::string MissingInput(const MeasuredSession& session, Effect effect) {
  const EffectDescriptor& d = Describe(effect);
  return d.missing_input ? d.missing_input(session) : std::string();
}

}  // namespace odocal::calibration
