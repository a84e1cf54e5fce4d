#include "odocal/report/session_estimate_json.h"

#include <cmath>

#include "odocal/base/units.h"
#include "odocal/calibration/corrections.h"
#include "odocal/report/json.h"

namespace odocal::report {
namespace {

// One pooled CVRA quantity as {key, sigma_key, n, runs}.
nlohmann::json PooledCvraJson(const std::string& key, const measure::PooledCvra& c) {
  return {{key, c.mean},
          {"sigma_" + key, c.standard_error ? nlohmann::json(*c.standard_error) : nlohmann::json(nullptr)},
          {"n", c.values.size()},
          {"runs", c.runs}};
}

}  // namespace

nlohmann::json SessionUmbmarkJson(const measure::SessionEstimate& e) {
  if (!e.umbmark || !e.umbmark_input) return nullptr;
  return UmbmarkJson(*e.umbmark_input, *e.umbmark);
}

nlohmann::json CvraJson(const measure::SessionEstimate& e) {
  nlohmann::json cvra = nlohmann::json::object();
  if (e.ratio) cvra["ratio"] = PooledCvraJson("Ed", *e.ratio);
  if (e.scale) {
    nlohmann::json scale = PooledCvraJson("scale", *e.scale);
    // The camera's length scale is common to the runs: it adds to their spread.
    const double camera = e.scale->camera_scale_sigma * e.scale->mean;
    scale["sigma_camera_scale"] = camera;
    scale["sigma_total"] = std::hypot(e.scale->standard_error.value_or(0.0), camera);
    cvra["scale"] = scale;
  }
  if (e.track) cvra["track"] = PooledCvraJson("track_factor", *e.track);
  return cvra;
}

nlohmann::json TrajectoryFitJson(const calibration::WheelParams& nominal,
                                 const calibration::TrajectoryFitResult& fit) {
  nlohmann::json j = {{"method", "full-trajectory least squares (base model)"},
                      {"frames", fit.n_frames},
                      {"gap_mm", fit.gap_m * kMToMm},
                      {"noise_floor_mm", fit.noise_floor_m * kMToMm},
                      {"lag1_autocorrelation", fit.lag1_autocorrelation},
                      {"unidentifiable", fit.unidentifiable}};
  int runs_used = 0;
  for (bool used : fit.run_used) runs_used += used ? 1 : 0;
  j["runs_used"] = runs_used;
  // camera_latency: a frame stamped s shows the robot at telemetry time s + latency.
  if (const calibration::ParameterEstimate* p = fit.Find("camera_latency.latency_s")) {
    j["clock_offset_ms"] = {{"value", p->value * kSToMs},
                            {"sigma", p->identifiable ? nlohmann::json(p->sigma * kSToMs) : nlohmann::json(nullptr)},
                            {"sigma_between_runs", FiniteOrNull(p->sigma_between_runs * kSToMs)},
                            {"meaning", "a pose stamped s shows the robot at telemetry time s + offset"}};
  }
  bool all_identifiable = true;
  for (const char* key : {"Ed", "Es", "Eb", "turn_gain"}) {
    const calibration::ParameterEstimate* p = fit.Find(key);
    if (!p) continue;
    if (!p->identifiable) all_identifiable = false;
    j[key] = {{"value", p->value},
              {"sigma", p->identifiable ? nlohmann::json(p->sigma) : nlohmann::json(nullptr)},
              {"sigma_between_runs", FiniteOrNull(p->sigma_between_runs)},
              {"identifiable", p->identifiable}};
  }
  j["jackknife_runs"] = fit.jackknife_runs;
  j["jackknife_groups"] = fit.jackknife_groups;
  if (all_identifiable) {
    const calibration::WheelParams corrected = calibration::ApplyWheelScales(nominal, fit.scales);
    j["corrected"] = WheelParamsJson(corrected);
    j["ros2"] = Ros2Json(calibration::Ros2MultipliersFrom(nominal, corrected));
  }
  return j;
}

nlohmann::json EstimatorChoiceJson(const std::string& requested, const measure::EstimatorChoice& choice) {
  nlohmann::json candidates = nlohmann::json::array();
  for (const measure::CandidateScore& c : choice.candidates) {
    nlohmann::json j = {{"name", measure::ToString(c.estimator)},
                        {"defined", c.params.has_value()},
                        {"corrected", c.params ? WheelParamsJson(*c.params) : nlohmann::json(nullptr)}};
    if (choice.cross_validated) {
      j["heldout_final_error_mm"] = {{"mean", c.mean_m * kMToMm}, {"sigma", c.sigma_m * kMToMm}, {"max", c.max_m * kMToMm}};
      nlohmann::json per_run = nlohmann::json::array();
      for (double e : c.final_error_m) per_run.push_back(e * kMToMm);
      j["per_run_mm"] = per_run;
      j["heldout_rms_error_mm"] = {{"mean", c.rms_mean_m * kMToMm}, {"sigma", c.rms_sigma_m * kMToMm}};
      j["versus_lowest_mm"] = {{"mean", c.versus_lowest_m * kMToMm}, {"sigma", c.versus_lowest_sigma_m * kMToMm}};
      j["travel_scale"] = {{"value", c.scale}, {"sigma_between_runs", c.scale_sigma}};
    } else {
      j["heldout_final_error_mm"] = nullptr;
    }
    candidates.push_back(j);
  }
  nlohmann::json rule = nullptr;
  if (choice.cross_validated)
    rule = {{"paired_difference_mm",
             {{"mean", choice.paired_difference_m * kMToMm},
              {"sigma", choice.paired_sigma_m * kMToMm},
              {"told_apart", choice.told_apart}}},
            {"scale_difference",
             {{"value", choice.scale.difference}, {"sigma", choice.scale.sigma}, {"z", choice.scale.z()}}},
            {"tell_apart_z", choice.tell_apart_z},
            {"scale_z", choice.scale_z}};
  return {{"requested", requested},
          {"chosen", measure::ToString(choice.chosen)},
          {"cross_validated", choice.cross_validated},
          {"why", choice.why},
          {"basis", measure::ToString(choice.basis)},
          {"rule", rule},
          {"runs", choice.runs},
          {"candidates", candidates},
          {"notes", choice.notes}};
}

}  // namespace odocal::report
