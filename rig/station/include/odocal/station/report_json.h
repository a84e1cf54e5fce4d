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
// measured), flags, status, message, driver, plan (the default plan's
// sizes), findings, robot_params_recommended (a set the driver could not
// apply); per round also cvra (as batch's), turn_slip, corrected.
nlohmann::json StationReportJson(const StationResult& result);

// An iteration's "turn_slip": by_rate [{turn_rate_deg_s, runs, track_factor,
// sigma}], slip_at_1rad_s and its sigma, track_factor_at_rest, significant, advice.
nlohmann::json TurnSlipJson(const TurnSlipResult& turn_slip);

// {left_wheel_diameter_mm, right_wheel_diameter_mm, track_mm, ticks_per_rev}
nlohmann::json ParamSetJson(const robot_link::ParamSet& params);

}  // namespace odocal::station

#endif  // ODOCAL_STATION_REPORT_JSON_H_
