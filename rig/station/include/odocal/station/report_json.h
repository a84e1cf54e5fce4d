// The station's report.json: every round's runs, estimate and pushed set.
#ifndef ODOCAL_STATION_REPORT_JSON_H_
#define ODOCAL_STATION_REPORT_JSON_H_

#include <nlohmann/json.hpp>

#include "odocal/robot_link/params.h"
#include "odocal/station/station.h"

namespace odocal::station {

// report.json: iterations [{emax_syst_mm, estimate {Ed, Eb, ...}, pushed
// {left_wheel_diameter_mm, right_wheel_diameter_mm, track_mm, ticks_per_rev}
// or null}], robot_params_final, improvement, camera_plane, camera_scale
// (report::CameraScaleJson: source tag_size | floor_reference, the camera
// height, the robot tag's print scale; null before the first round was
// measured), flags, status, message and more.
nlohmann::json StationReportJson(const StationResult& result);

// {left_wheel_diameter_mm, right_wheel_diameter_mm, track_mm, ticks_per_rev}
nlohmann::json ParamSetJson(const robot_link::ParamSet& params);

}  // namespace odocal::station

#endif  // ODOCAL_STATION_REPORT_JSON_H_
