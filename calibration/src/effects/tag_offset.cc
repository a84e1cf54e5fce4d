// tag_offset: the tag is not over the wheel axle: measured position = p + R(heading) (x, y)_tag.
// The model's term: trajectory_fit.cc (DeadReckon, PredictFrame); the simulator's:
// sim/effects.h ({name: tag_offset, ...}).
#include "effects.h"

namespace odocal::calibration::internal {

EffectDescriptor TagOffsetEffect() {
  EffectDescriptor d;
  d.effect = Effect::kTagOffset;
  d.name = "tag_offset";
  d.params = {EffectParams::kTagX, EffectParams::kTagY};
  d.param_names = {"x_m", "y_m"};
  d.tested = d.params;
  d.distinguishing_runs =
      "a spin in place seen by the camera (the tag circles the axle; a centred tag does "
      "not move)";
  d.advice = "measure the tag's offset from the axle and set tag.offset_mm";
  return d;
}

}  // namespace odocal::calibration::internal
