// rolling_shutter: a frame whose tag centre is at image row fraction f shows the robot at telemetry
// time s + latency + (f - 1/2) T, T the rows' readout time; it needs each frame's
// image row, which only video measured by odocal has.
// The model's term: trajectory_fit.cc (DeadReckon, PredictFrame); the simulator's:
// sim/effects.h ({name: rolling_shutter, ...}).
#include "effects.h"

#include "odocal/calibration/measured_session.h"

namespace odocal::calibration::internal {
namespace {

// A readout shows only where frames carry their tag's image row.
std::string RowsMissingInput(const MeasuredSession& session) {
  for (const MeasuredRun& run : session.runs)
    for (const CameraRecord& f : run.camera)
      if (f.valid && f.has_image_row()) return "";
  return "each frame's image row (video measured by odocal; a pose log has none)";
}

}  // namespace

EffectDescriptor RollingShutterEffect() {
  EffectDescriptor d;
  d.effect = Effect::kRollingShutter;
  d.name = "rolling_shutter";
  d.params = {EffectParams::kReadout};
  d.param_names = {"readout_s"};
  d.tested = d.params;
  d.distinguishing_runs =
      "motion seen by a video camera at different image rows (e.g. squares or straights "
      "that cross the image top to bottom, spins away from the middle row): at one row "
      "it is a camera latency, at the middle row nothing";
  d.advice = "the camera's rolling shutter skews moving frames: measure at rest, or use a global shutter";
  d.missing_input = RowsMissingInput;
  return d;
}

}  // namespace odocal::calibration::internal
