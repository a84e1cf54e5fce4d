// rolling_shutter: a frame whose tag centre is at image row fraction f shows the robot at telemetry
// time s + latency + (f - 1/2) T, T the rows' readout time; it needs each frame's
// image row, which only video measured by odocal has.
// The simulator's term: sim/effects.h ({name: rolling_shutter, ...}).
//
// Its descriptor (what it is, what it needs, what to do about it: effect_registry.h)
// and its term in the model, one file (docs/architecture.md, "Add an effect").
#ifndef ODOCAL_CALIBRATION_SRC_EFFECTS_ROLLING_SHUTTER_H_
#define ODOCAL_CALIBRATION_SRC_EFFECTS_ROLLING_SHUTTER_H_

#include "odocal/calibration/effect_registry.h"
#include "odocal/calibration/measured_session.h"
#include "odocal/calibration/trajectory_fit.h"

namespace odocal::calibration::internal {
// A readout shows only where frames carry their tag's image row.
inline std::string RowsMissingInput(const MeasuredSession& session) {
  for (const MeasuredRun& run : session.runs)
    for (const CameraRecord& f : run.camera)
      if (f.valid && f.has_image_row()) return "";
  return "each frame's image row (video measured by odocal; a pose log has none)";
}

inline EffectDescriptor RollingShutterEffect() {
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

// The model's term (PredictFrame, and the frames' telemetry times): the tag's
// row, `row_offset` (image row fraction - 1/2) from the middle row whose time
// `t` is, was exposed that many readouts later.
template <typename T>
T RollingShutter(const T* effect_values, double row_offset, const T& t) {
  return t + row_offset * effect_values[EffectParams::kReadout];
}

}  // namespace odocal::calibration::internal

#endif  // ODOCAL_CALIBRATION_SRC_EFFECTS_ROLLING_SHUTTER_H_
