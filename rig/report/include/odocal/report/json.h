// JSON documents for the estimators: the keys other tools rely on.
//
// Units at this edge: millimetres and degrees, the unit in every key.
#ifndef ODOCAL_REPORT_JSON_H_
#define ODOCAL_REPORT_JSON_H_

#include <string>

#include <nlohmann/json.hpp>

#include "odocal/calibration/corrections.h"
#include "odocal/calibration/pose2.h"
#include "odocal/calibration/robot_model.h"
#include "odocal/calibration/umbmark.h"

namespace odocal::report {

// A number, or null where it is not finite (not computed, not determined).
nlohmann::json FiniteOrNull(double value);

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

}  // namespace odocal::report

#endif  // ODOCAL_REPORT_JSON_H_
