// The station file (`odocal station --config station.yaml`): the robot's driver (link port,
// command templates, or operator), the camera and
// its calibration file, the tag, optionally a floor length reference, and the plan. Paths are resolved against the file's folder.
// docs/formats.md lists every key.
#ifndef ODOCAL_CONFIG_STATION_FILE_H_
#define ODOCAL_CONFIG_STATION_FILE_H_

#include <optional>
#include <string>
#include <vector>

#include "odocal/base/status.h"
#include "odocal/calibration/procedures.h"
#include "odocal/calibration/robot_model.h"
#include "odocal/vision/camera_model.h"
#include "odocal/records/limits.h"
#include "odocal/vision/floor_reference.h"
#include "odocal/vision/tag.h"

namespace odocal::config {

// How the station makes the robot move (station/driver.h).
enum class StationDriver { kLink, kCommand, kOperator };

struct StationConfig {
  StationDriver driver = StationDriver::kLink;
  // link
  std::string port;
  int baud = 115200;
  int timeout_ms = 200;
  // command and operator: templates (station/driver.h lists the placeholders)
  std::string run_command, stop_command, apply_command;
  double apply_timeout_s = 60.0;
  // The set the robot runs with (command and operator cannot read it).
  std::optional<calibration::WheelParams> params;
  double run_timeout_s = 120.0;
  std::string camera_device;
  std::string camera_file;
  vision::CameraMount mount_guess;
  int flush_frames = 5;
  double settle_s = 0.5;
  vision::TagSpec tag;
  std::optional<double> tag_size_sigma_mm;  // tag.size_sigma_mm: the print as measured
  // `floor_reference:` (the session file's keys; vision/floor_reference.h).
  std::optional<vision::FloorReference> floor_reference;
  // plan: {side_mm, runs_per_direction} (squares), a list of runs, or
  // `default` / {default: {...}} (the built-in plan sized to the view).
  double side_mm = 2000.0;
  int runs_per_direction = 3;
  std::vector<calibration::RunSpec> runs;  // a list: these runs
  bool default_plan = false;
  std::optional<double> slow_turn_rate_deg_s, fast_turn_rate_deg_s;
  int max_rounds = 3;
  // `limits:` {emax_syst_after_mm, emax_syst_before_mm, ed, eb, recalibrate_days}: the line's
  // acceptance limits (records/limits.h; ed and eb fractions or percentages "0.5%").
  records::Limits limits;
};

// kNotFound or kBadFile with one line naming the file and the key otherwise.
Result<StationConfig> LoadStationConfig(const std::string& path);

}  // namespace odocal::config

#endif  // ODOCAL_CONFIG_STATION_FILE_H_
