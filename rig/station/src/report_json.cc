#include "odocal/station/report_json.h"

#include "odocal/base/units.h"
#include "odocal/report/explain_report.h"
#include "odocal/report/json.h"
#include "odocal/report/measurement_json.h"
#include "odocal/report/session_estimate_json.h"

namespace odocal::station {

nlohmann::json ParamSetJson(const robot_link::ParamSet& p) {
  return {{"left_wheel_diameter_mm", p.left_wheel_diameter_mm},
          {"right_wheel_diameter_mm", p.right_wheel_diameter_mm},
          {"track_mm", p.track_mm},
          {"ticks_per_rev", p.ticks_per_rev}};
}

nlohmann::json TurnSlipJson(const TurnSlipResult& t) {
  nlohmann::json groups = nlohmann::json::array();
  for (const TurnRateGroup& g : t.groups)
    groups.push_back({{"turn_rate_deg_s", RadToDeg(g.turn_rate_rad_s)},
                      {"runs", g.runs},
                      {"track_factor", g.mean},
                      {"sigma", g.standard_error ? nlohmann::json(*g.standard_error) : nlohmann::json()}});
  auto opt = [](const std::optional<double>& v) { return v ? nlohmann::json(*v) : nlohmann::json(); };
  return {{"by_rate", groups},
          {"slip_at_1rad_s", opt(t.slip_per_rad_s)},
          {"sigma_slip_at_1rad_s", opt(t.slip_sigma)},
          {"track_factor_at_rest", opt(t.track_factor_at_rest)},
          {"sigma_track_factor_at_rest", opt(t.track_factor_at_rest_sigma)},
          {"significant", t.significant},
          {"advice", t.advice},
          {"model", "an in-place turn at omega achieves (1 - f omega) of the wheels' rotation; "
                    "track_factor(omega) = track_factor_at_rest / (1 - f omega)"}};
}

namespace {

// One run of an iteration: what was driven, what the camera saw, its return error.
nlohmann::json StationRunJson(const StationRun& run) {
  nlohmann::json r = {{"name", run.name},
                      {"procedure", calibration::ToString(run.spec.procedure)},
                      {"direction", calibration::ToString(run.spec.direction)},
                      {"side_mm", run.spec.side_m * kMToMm},
                      {"run_id", run.run_id},
                      {"moving_frames", run.moving_frames},
                      {"moving_frames_tag_found", run.moving_found},
                      {"max_motion_px", run.max_motion_px},
                      {"turned_deg", run.turned_rad ? nlohmann::json(RadToDeg(*run.turned_rad)) : nlohmann::json()},
                      {"unseen_s", run.unseen_s},
                      {"frames_dropped", run.frames_dropped},
                      {"rest_frames", {{"start", run.start_rest.n}, {"end", run.end_rest.n}}}};
  if (run.spec.procedure == calibration::Procedure::kStraight ||
      run.spec.procedure == calibration::Procedure::kOutAndBack)
    r["distance_mm"] = run.spec.distance_m * kMToMm;
  if (run.spec.procedure == calibration::Procedure::kSpin) r["turns"] = run.spec.turns;
  if (run.spec.turn_rate_rad_s) r["turn_rate_deg_s"] = RadToDeg(*run.spec.turn_rate_rad_s);
  if (!run.log_path.empty()) r["log"] = run.log_path;
  if (run.start_rest.n > 0 && run.end_rest.n > 0) {
    r["return_error"] = report::ReturnErrorJson(run.return_error.pose);
    r["sigma"] = {{"x_mm", run.return_error.sigma_x_m() * kMToMm},
                  {"y_mm", run.return_error.sigma_y_m() * kMToMm},
                  {"theta_deg", RadToDeg(run.return_error.sigma_heading_rad())}};
  }
  return r;
}

// One iteration: the runs driven with a set, what they estimate and what was pushed.
nlohmann::json IterationJson(const StationIteration& it) {
  nlohmann::json runs = nlohmann::json::array();
  for (const StationRun& run : it.runs) runs.push_back(StationRunJson(run));
  nlohmann::json j = {{"params_used", ParamSetJson(it.params_used)}, {"runs", runs}};
  if (it.estimate.ok()) {
    const calibration::CoupledEstimate& c = it.estimate.coupled;
    j["emax_syst_mm"] = it.estimate.emax_syst_m * kMToMm;
    j["emax_syst_sigma_mm"] = it.emax_sigma_m ? nlohmann::json(*it.emax_sigma_m * kMToMm) : nlohmann::json();
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
  j["cvra"] = report::CvraJson(it.session_estimate);
  if (!it.session_estimate.notes.empty()) j["notes"] = it.session_estimate.notes;
  if (!it.turn_slip.groups.empty()) j["turn_slip"] = TurnSlipJson(it.turn_slip);
  j["corrected"] = it.corrected ? ParamSetJson(*it.corrected) : nlohmann::json();
  j["pushed"] = it.pushed ? ParamSetJson(*it.pushed) : nlohmann::json();
  j["converged"] = it.converged;
  if (!it.note.empty()) j["note"] = it.note;
  return j;
}

}  // namespace

nlohmann::json StationReportJson(const StationResult& result) {
  nlohmann::json iterations = nlohmann::json::array();
  for (const StationIteration& it : result.iterations) iterations.push_back(IterationJson(it));
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
      {"flags", measure::ToStrings(result.flags)},
      {"driver", result.driver},
      {"findings", result.findings},
      {"robot_params_recommended",
       result.params_recommended ? ParamSetJson(*result.params_recommended) : nlohmann::json()},
      {"wall_s", result.wall_s},
  };
  if (!result.ok()) {
    report["cleanup"] = result.cleanup;
    report["restored"] = result.restored;
  }
  if (result.robot) report["robot_name"] = result.robot->robot_name;
  if (!result.plan_summary.empty()) report["plan"] = result.plan_summary;
  if (result.explain && result.recorded && result.explain->ok())
    report["explain"] = report::ExplainJson(*result.recorded, *result.explain);
  else if (result.explain)
    report["explain"] = {{"error", result.explain->message}};
  return report;
}

}  // namespace odocal::station
