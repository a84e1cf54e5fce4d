// Parameter sets to replay (`odocal check`): a file, whatever tool wrote it,
// turned into a named calibration::ReplayModel relative to the parameters the
// session's robot believed (its nominal set): per wheel
//   r = true metres-per-tick / believed metres-per-tick,   Eb = track / believed track.
//
// The kind is read from the content, not the file name:
//   firmware  YAML {left_wheel_diameter_mm, right_wheel_diameter_mm, track_mm,
//             ticks_per_rev} (`--export firmware`, rig/exports.h); every key
//             required, no other key (a typo would otherwise replay the nominal).
//   ros2      YAML diff_drive_controller.ros__parameters.{wheel_separation_multiplier,
//             left_wheel_radius_multiplier, right_wheel_radius_multiplier}
//             (`--export ros2`): already relative to the nominal set. Other
//             controller parameters may sit beside them (a real controller file
//             has dozens); the three multipliers are required.
//   explain   explain.json (`odocal explain`, rig/explain_report.h): the final
//             fit's Ed, Es and Eb (final.parameters.*.value) and the
//             parameters of each effect in effects_added
//             ("<effect>.<name>", SI). The top-level final fit, not
//             camera_refit's: it models the camera as calibrated, which is how
//             check measures the videos. The wheel scales are rebuilt from
//             Ed, Es with the check session's nominal diameters (explain.json
//             does not record its own); they must be the same robot's.
//
// Units at this edge: millimetres; inside: SI.
#ifndef ODOCAL_CONFIG_PARAM_FILES_H_
#define ODOCAL_CONFIG_PARAM_FILES_H_

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "odocal/base/status.h"
#include "odocal/calibration/replay.h"
#include "odocal/calibration/robot_model.h"
#include "odocal/calibration/trajectory_fit.h"

namespace odocal::config {

enum class ParamFileKind { kNominal, kFirmware, kRos2, kExplain };
std::string_view ToString(ParamFileKind kind);

struct ReplaySet {
  std::string name;
  std::string path;  // empty for the nominal set
  ParamFileKind kind = ParamFileKind::kNominal;
  calibration::ReplayModel model;
  std::vector<calibration::Effect> effects;  // the effects the set names (explain)

  // The wheel parameters model.scales stand for, at the believed ticks per
  // revolution (what a firmware export of this set would hold).
  calibration::WheelParams Equivalent(const calibration::WheelParams& believed) const;
};

// `--params` as given: "NAME=FILE" or "FILE" (named by the file's stem).
struct ParamSpec {
  std::string name;
  std::string path;
};

// kInvalidArgument naming `--params TEXT` for an empty name or path. A NAME is
// letters, digits, '_', '-' and '.'; text whose part before the first '=' is
// not one is a path.
Result<ParamSpec> ParseParamSpec(const std::string& text);

// The session's own parameters: scales 1, no effect.
ReplaySet NominalReplaySet();

// Reads `spec.path`, detects its kind and returns the set relative to
// `believed`. An error with one line naming the file (and the key, the
// line where YAML knows it) otherwise: unreadable, of no known kind, a key
// missing or not a positive number.
Result<ReplaySet> ReadReplaySet(const ParamSpec& spec, const calibration::WheelParams& believed);

}  // namespace odocal::config

#endif  // ODOCAL_CONFIG_PARAM_FILES_H_
