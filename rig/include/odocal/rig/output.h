// Writing results: JSON documents for the estimators (the keys other tools
// rely on) and files written so that a failure never leaves half of one.
//
// Units at this edge: millimetres and degrees, the unit in every key.
#ifndef ODOCAL_RIG_OUTPUT_H_
#define ODOCAL_RIG_OUTPUT_H_

#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "odocal/calibration/corrections.h"
#include "odocal/calibration/pose2.h"
#include "odocal/calibration/robot_model.h"
#include "odocal/calibration/umbmark.h"

namespace odocal::rig {

// {x_mm, y_mm, heading_deg}
nlohmann::json PoseJson(const calibration::Pose2& pose);
// {x_mm, y_mm, theta_deg}: a return error, true - odometry.
nlohmann::json ReturnErrorJson(const calibration::Pose2& error);
// {left_wheel_diameter_mm, right_wheel_diameter_mm, track_mm, ticks_per_rev}
nlohmann::json WheelParamsJson(const calibration::WheelParams& params);
// Ticks per revolution as JSON: an integer when whole (as the robot link
// carries it), a number otherwise.
nlohmann::json TicksPerRevJson(double ticks_per_rev);
nlohmann::json Ros2Json(const calibration::Ros2Multipliers& m);

// The document of `odocal umbmark --json` (and of report.json's `umbmark`),
// with the runs it used in `return_errors: {cw: [...], ccw: [...]}`.
nlohmann::json UmbmarkJson(const calibration::UmbmarkInput& input,
                           const calibration::UmbmarkSummary& summary);
// The same as a table people read.
std::string UmbmarkTable(const calibration::UmbmarkInput& input,
                         const calibration::UmbmarkSummary& summary);

// Creates `dir` (and parents); nullopt on success, else the error line.
std::optional<std::string> EnsureDirectory(const std::string& dir);
// Writes `contents` to a temporary file beside `path` and renames it into
// place: readers see the old file or the new one, never a partial one.
std::optional<std::string> WriteFileAtomically(const std::string& path,
                                               const std::string& contents);

}  // namespace odocal::rig

#endif  // ODOCAL_RIG_OUTPUT_H_
