#include "odocal/station/report_json.h"

#include "odocal/base/units.h"
#include "odocal/report/json.h"
#include "odocal/report/measurement_json.h"

namespace odocal::station {

nlohmann::json ParamSetJson(const robot_link::ParamSet& p) {
  return {{"left_wheel_diameter_mm", p.left_wheel_diameter_mm},
          {"right_wheel_diameter_mm", p.right_wheel_diameter_mm},
          {"track_mm", p.track_mm},
          {"ticks_per_rev", p.ticks_per_rev}};
}

nlohmann::json StationReportJson(const StationResult& result) {
  nlohmann::json iterations = nlohmann::json::array();
  for (const StationIteration& it : result.iterations) {
    nlohmann::json runs = nlohmann::json::array();
    for (const StationRun& run : it.runs) {
      nlohmann::json r = {{"procedure", calibration::ToString(run.spec.procedure)},
                          {"direction", calibration::ToString(run.spec.direction)},
                          {"side_mm", run.spec.side_m * 1e3},
                          {"run_id", run.run_id},
                          {"moving_frames", run.moving_frames},
                          {"moving_frames_tag_found", run.moving_found},
                          {"rest_frames", {{"start", run.start_rest.n}, {"end", run.end_rest.n}}}};
      if (run.start_rest.n > 0 && run.end_rest.n > 0) {
        r["return_error"] = report::ReturnErrorJson(run.return_error.pose);
        r["sigma"] = {{"x_mm", run.return_error.sigma_x_m() * 1e3},
                      {"y_mm", run.return_error.sigma_y_m() * 1e3},
                      {"theta_deg", run.return_error.sigma_heading_rad() * 180.0 / M_PI}};
      }
      runs.push_back(r);
    }
    nlohmann::json j = {{"params_used", ParamSetJson(it.params_used)}, {"runs", runs}};
    if (it.estimate.ok()) {
      const calibration::CoupledEstimate& c = it.estimate.coupled;
      j["emax_syst_mm"] = it.estimate.emax_syst_m * 1e3;
      j["emax_syst_sigma_mm"] = it.emax_sigma_m ? nlohmann::json(*it.emax_sigma_m * 1e3) : nlohmann::json();
      j["estimate"] = {{"Ed", c.Ed},
                       {"Eb", c.Eb},
                       {"sigma_Ed", c.sigma_Ed ? nlohmann::json(*c.sigma_Ed) : nlohmann::json()},
                       {"sigma_Eb", c.sigma_Eb ? nlohmann::json(*c.sigma_Eb) : nlohmann::json()},
                       {"Eb_is", "turn gain Eb/Es (UMBMark does not see the distance scale)"}};
      j["umbmark"] = report::UmbmarkJson(it.input, it.estimate);
    } else {
      j["emax_syst_mm"] = nullptr;
      j["estimate"] = nullptr;
    }
    j["pushed"] = it.pushed ? ParamSetJson(*it.pushed) : nlohmann::json();
    j["converged"] = it.converged;
    if (!it.note.empty()) j["note"] = it.note;
    iterations.push_back(j);
  }
  nlohmann::json report = {
      {"status", ToString(result.status)},
      {"message", result.message},
      {"iterations", iterations},
      {"robot_params_initial", result.params_initial ? ParamSetJson(*result.params_initial) : nlohmann::json()},
      {"robot_params_final", result.params_final ? ParamSetJson(*result.params_final) : nlohmann::json()},
      {"improvement", result.improvement ? nlohmann::json(*result.improvement) : nlohmann::json()},
      {"camera_plane",
       {{"estimated", result.plane_estimated},
        {"roll_deg", result.plane.mount.roll_deg},
        {"pitch_deg", result.plane.mount.pitch_deg},
        {"height_mm", result.plane.mount.height_mm},
        {"views", result.plane.views_used}}},
      {"camera_scale", result.camera_scale ? report::CameraScaleJson(*result.camera_scale) : nlohmann::json()},
      {"flags", result.flags},
      {"wall_s", result.wall_s},
  };
  if (!result.ok()) {
    report["cleanup"] = result.cleanup;
    report["restored"] = result.restored;
  }
  if (result.robot) report["robot_name"] = result.robot->robot_name;
  return report;
}

}  // namespace odocal::station
