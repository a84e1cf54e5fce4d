// The station file (`odocal station --config station.yaml`): the robot's port, the camera and
// its calibration file, the tag, optionally a floor length reference, and the plan. Paths are resolved against the file's folder.
// docs/formats.md lists every key.
#ifndef ODOCAL_CONFIG_STATION_FILE_H_
#define ODOCAL_CONFIG_STATION_FILE_H_

#include <optional>
#include <string>

#include "odocal/base/status.h"
#include "odocal/vision/camera_model.h"
#include "odocal/vision/floor_reference.h"
#include "odocal/vision/tag.h"

namespace odocal::config {

struct StationConfig {
  std::string port;
  int baud = 115200;
  int timeout_ms = 200;
  std::string camera_device;
  std::string camera_file;
  vision::CameraMount mount_guess;
  int flush_frames = 5;
  double settle_s = 0.5;
  vision::TagSpec tag;
  std::optional<double> tag_size_sigma_mm;  // tag.size_sigma_mm: the print as measured
  // `floor_reference:` (the session file's keys; vision/floor_reference.h).
  std::optional<vision::FloorReference> floor_reference;
  double side_mm = 2000.0;
  int runs_per_direction = 3;
  int max_rounds = 3;
};

// kNotFound or kBadFile with one line naming the file and the key otherwise.
Result<StationConfig> LoadStationConfig(const std::string& path);

}  // namespace odocal::config

#endif  // ODOCAL_CONFIG_STATION_FILE_H_
