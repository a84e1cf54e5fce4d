// The measurement's entries in report.json: one run (its return error with
// sigma and flags, its frames), the image quality at its rests, its
// trajectory. Units at this edge: millimetres and degrees, the unit in every key.
#ifndef ODOCAL_REPORT_MEASUREMENT_JSON_H_
#define ODOCAL_REPORT_MEASUREMENT_JSON_H_

#include <nlohmann/json.hpp>

#include "odocal/measure/measure.h"

namespace odocal::report {

// One run's JSON entry of report.json: procedure, direction, source
// ("video" or "poses") and its file, return_error {x_mm, y_mm, theta_deg}
// (null when fatal), sigma, flags, frames; pose runs add clock_offset_s.
nlohmann::json RunJson(const measure::RunMeasurement& run);

// The quality entry of report.json for one rest.
nlohmann::json RestQualityJson(const measure::RestQuality& quality);

// One run's trajectory for report.json's `trajectories[]`: {name, procedure,
// direction, points_mm: [[x, y], ...]} of the camera's valid poses in its
// measurement frame, thinned to at most `max_points`.
nlohmann::json TrajectoryJson(const measure::RunMeasurement& run, int max_points = 300);

// The camera plane of a session: {estimated, roll_deg, pitch_deg, height_mm,
// sigma {...}, views, rms_reprojection_px}; {estimated: false, message} when
// the operator's guess was used; null for a session of pose logs.
nlohmann::json PlaneJson(const measure::SessionMeasurement& session);

// Where the session's length scale comes from (report.json sessions[].camera_scale):
// {source: tag_size | floor_reference, relative_sigma, camera_height_mm,
// sigma_camera_height_mm, explanation}; with a floor reference also
// floor_tags[] (id, frames, centre_px, sigma_centre_px, quality, flags),
// distances[] (tape vs seen), variance shares, and tag_print_scale
// {value, sigma}. Null for a session of pose logs.
nlohmann::json CameraScaleJson(const measure::SessionMeasurement& session);
// The same for any camera scale (the station's report.json `camera_scale`).
nlohmann::json CameraScaleJson(const measure::CameraScale& scale);

}  // namespace odocal::report

#endif  // ODOCAL_REPORT_MEASUREMENT_JSON_H_
