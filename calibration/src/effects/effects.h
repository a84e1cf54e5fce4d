// Internal: one function per candidate effect, each in its own file
// (calibration/src/effects/<name>.cc), returning its descriptor
// (odocal/calibration/effect_registry.h). effect_registry.cc lists them.
#ifndef ODOCAL_CALIBRATION_SRC_EFFECTS_EFFECTS_H_
#define ODOCAL_CALIBRATION_SRC_EFFECTS_EFFECTS_H_

#include "odocal/calibration/effect_registry.h"

namespace odocal::calibration::internal {

EffectDescriptor TagOffsetEffect();
EffectDescriptor CameraLatencyEffect();
EffectDescriptor TurnSlipEffect();
EffectDescriptor LensDistortionEffect();
EffectDescriptor EncoderBacklashEffect();
EffectDescriptor CarpetDriftEffect();
EffectDescriptor TrackerYawEffect();
EffectDescriptor SpeedSlipEffect();
EffectDescriptor ArcScaleEffect();
EffectDescriptor RollingShutterEffect();

}  // namespace odocal::calibration::internal

#endif  // ODOCAL_CALIBRATION_SRC_EFFECTS_EFFECTS_H_
