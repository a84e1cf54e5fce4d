// lens_distortion: the tag seen through a lens whose k1 is off by dk1, in the camera's geometry over
// the plane (floor_camera.h), with the camera tilt the plane estimate absorbed as
// a nuisance (tilt_x, tilt_y): only k1 names it.
// The simulator's term: sim/effects.h ({name: lens_distortion, ...}).
//
// Its descriptor (what it is, what it needs, what to do about it: effect_registry.h)
// and its term in the model, one file (docs/architecture.md, "Add an effect").
#ifndef ODOCAL_CALIBRATION_SRC_EFFECTS_LENS_DISTORTION_H_
#define ODOCAL_CALIBRATION_SRC_EFFECTS_LENS_DISTORTION_H_

#include <optional>

#include "odocal/calibration/effect_registry.h"
#include "odocal/calibration/floor_camera.h"
#include "odocal/calibration/measured_session.h"
#include "odocal/calibration/trajectory_fit.h"

namespace odocal::calibration::internal {
// The lens is seen through the camera's geometry over the tag plane.
inline std::string LensMissingInput(const MeasuredSession& session) {
  return session.camera ? "" : "the camera's floor geometry (centre, height)";
}

inline EffectDescriptor LensDistortionEffect() {
  EffectDescriptor d;
  d.effect = Effect::kLensDistortion;
  d.name = "lens_distortion";
  d.params = {EffectParams::kK1, EffectParams::kTiltX, EffectParams::kTiltY};
  d.param_names = {"k1", "camera_tilt_x_rad", "camera_tilt_y_rad"};
  d.tested = {EffectParams::kK1};
  d.not_compared_across_runs = {"camera_tilt_x_rad", "camera_tilt_y_rad"};
  d.distinguishing_runs =
      "runs seen both near the image centre and near its edge (e.g. a square that "
      "crosses the field of view)";
  d.advice = "the lens calibration is off: calibrate the camera again (calibrate-camera)";
  d.missing_input = LensMissingInput;
  return d;
}

// The model's term (PredictFrame): where the pipeline, through a lens whose k1
// is off, measures the tag truly at (x, y); nothing without the camera's
// geometry over the plane.
template <typename T>
void LensDistortion(const T* effect_values, const std::optional<FloorCamera>& camera, T* x_m, T* y_m) {
  if (!camera) return;
  const T x = *x_m, y = *y_m;
  SeenThroughLens(*camera, x, y, effect_values[EffectParams::kK1], effect_values[EffectParams::kTiltX],
                  effect_values[EffectParams::kTiltY], x_m, y_m);
}

}  // namespace odocal::calibration::internal

#endif  // ODOCAL_CALIBRATION_SRC_EFFECTS_LENS_DISTORTION_H_
