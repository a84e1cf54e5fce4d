// lens_distortion: the tag seen through a lens whose k1 is off by dk1, in the camera's geometry over
// the plane (floor_camera.h), with the camera tilt the plane estimate absorbed as
// a nuisance (tilt_x, tilt_y): only k1 names it.
// The model's term: trajectory_fit.cc (DeadReckon, PredictFrame); the simulator's:
// sim/effects.h ({name: lens_distortion, ...}).
#include "effects.h"

#include "odocal/calibration/measured_session.h"

namespace odocal::calibration::internal {
namespace {

// The lens is seen through the camera's geometry over the tag plane.
std::string LensMissingInput(const MeasuredSession& session) {
  return session.camera ? "" : "the camera's floor geometry (centre, height)";
}

}  // namespace

EffectDescriptor LensDistortionEffect() {
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

}  // namespace odocal::calibration::internal
