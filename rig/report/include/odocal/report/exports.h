// Parameter exports shared by the commands that correct a robot (batch, demo,
// umbmark with diameters, the station): `--export ros2 FILE` and
// `--export firmware FILE`, repeatable.
//
//  ros2:     YAML for ROS 2 diff_drive_controller,
//              diff_drive_controller:
//                ros__parameters:
//                  wheel_separation_multiplier: ...
//                  left_wheel_radius_multiplier: ...
//                  right_wheel_radius_multiplier: ...
//            (multipliers that turn the nominal set into the corrected one).
//  firmware: YAML with the corrected set in the robot link's names
//            (left_wheel_diameter_mm, right_wheel_diameter_mm, track_mm,
//            ticks_per_rev), mm; the `odocal robot push` line in a comment.
#ifndef ODOCAL_REPORT_EXPORTS_H_
#define ODOCAL_REPORT_EXPORTS_H_

#include <optional>
#include <string>
#include <vector>

#include "odocal/base/status.h"
#include "odocal/calibration/robot_model.h"

namespace odocal::report {

struct ExportRequests {
  std::vector<std::string> raw;  // KIND FILE KIND FILE ...
};

std::string Ros2ExportYaml(const calibration::WheelParams& nominal,
                           const calibration::WheelParams& corrected);
std::string FirmwareExportYaml(const calibration::WheelParams& corrected);

// kInvalidArgument naming the option unless every kind is known; call before the
// work so a typo fails fast.
Status CheckExports(const ExportRequests& requests);

// Writes every requested export (atomically); the first error. An export without a
// corrected set is an error naming the option (kFailed).
Status WriteExports(const ExportRequests& requests, const calibration::WheelParams& nominal,
                    const std::optional<calibration::WheelParams>& corrected);

}  // namespace odocal::report

#endif  // ODOCAL_REPORT_EXPORTS_H_
