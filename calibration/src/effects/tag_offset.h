// tag_offset: the tag is not over the wheel axle: measured position = p + R(heading) (x, y)_tag.
// The simulator's term: sim/effects.h ({name: tag_offset, ...}).
//
// Its descriptor (what it is, what it needs, what to do about it: effect_registry.h)
// and its term in the model, one file (docs/architecture.md, "Add an effect").
#ifndef ODOCAL_CALIBRATION_SRC_EFFECTS_TAG_OFFSET_H_
#define ODOCAL_CALIBRATION_SRC_EFFECTS_TAG_OFFSET_H_

#include <cmath>

#include "odocal/calibration/effect_registry.h"
#include "odocal/calibration/trajectory_fit.h"

namespace odocal::calibration::internal {

inline EffectDescriptor TagOffsetEffect() {
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

// The model's term (PredictFrame): the camera measures the tag, (x, y) from
// the axle midpoint in the robot's frame, at `heading_rad`.
template <typename T>
void TagOffset(const T* effect_values, const T& heading_rad, T* x_m, T* y_m) {
  using std::cos;
  using std::sin;
  const T tag_x_m = effect_values[EffectParams::kTagX], tag_y_m = effect_values[EffectParams::kTagY];
  const T ch = cos(heading_rad), sh = sin(heading_rad);
  *x_m += ch * tag_x_m - sh * tag_y_m;
  *y_m += sh * tag_x_m + ch * tag_y_m;
}

}  // namespace odocal::calibration::internal

#endif  // ODOCAL_CALIBRATION_SRC_EFFECTS_TAG_OFFSET_H_
