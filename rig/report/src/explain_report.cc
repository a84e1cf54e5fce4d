#include "odocal/report/explain_report.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

#include "odocal/base/units.h"
#include "odocal/calibration/corrections.h"
#include "odocal/report/json.h"
#include "svg_plot.h"

namespace odocal::report {
namespace {

using calibration::ParameterEstimate;


// An effect parameter at the edge: the scenario's key and its unit scale.
std::pair<std::string, double> EdgeName(const std::string& name) {
  if (name == "x_m") return {"x_mm", 1e3};
  if (name == "y_m") return {"y_mm", 1e3};
  if (name == "latency_s") return {"ms", 1e3};
  if (name == "readout_s") return {"ms", 1e3};
  if (name == "grain_rad") return {"grain_deg", kRadToDeg};
  if (name == "rate_m_per_m") return {"rate_mm_per_m", 1e3};
  if (name == "camera_tilt_x_rad") return {"camera_tilt_x_deg", kRadToDeg};
  if (name == "camera_tilt_y_rad") return {"camera_tilt_y_deg", kRadToDeg};
  if (name == "yaw_rad") return {"deg", kRadToDeg};
  return {name, 1.0};
}

nlohmann::json ParamsJson(const std::vector<ParameterEstimate>& params, bool intervals) {
  nlohmann::json j = nlohmann::json::object();
  for (const ParameterEstimate& p : params) {
    const auto [key, scale] = EdgeName(p.name);
    if (!intervals) {
      j[key] = p.value * scale;
    } else if (p.identifiable) {
      j[key] = {p.lower95() * scale, p.upper95() * scale};
    } else {
      j[key] = nullptr;
    }
  }
  return j;
}

nlohmann::json SummaryJson(const calibration::ResidualSummary& s) {
  nlohmann::json by_motion = nlohmann::json::object(), by_run = nlohmann::json::object(),
                 worst = nlohmann::json::array();
  for (const auto& g : s.by_motion) by_motion[g.label] = {{"rms_mm", g.rms_m * kMToMm}, {"frames", g.n}};
  for (const auto& g : s.by_run) by_run[g.label] = {{"rms_mm", g.rms_m * kMToMm}, {"frames", g.n}};
  for (const auto& w : s.worst)
    worst.push_back({{"run", w.run},
                     {"t_s", w.t_s},
                     {"motion", calibration::ToString(w.motion)},
                     {"error_mm", w.error_m * kMToMm}});
  return {{"by_motion", by_motion}, {"by_run", by_run}, {"largest", worst}};
}

nlohmann::json FitJson(const calibration::TrajectoryFitResult& fit) {
  nlohmann::json params = nlohmann::json::object();
  for (const ParameterEstimate& p : fit.parameters) {
    const auto [key, scale] = EdgeName(p.name);
    params[key] = {{"value", p.value * scale},
                   {"sigma", p.identifiable ? nlohmann::json(p.sigma * scale) : nlohmann::json(nullptr)},
                   {"sigma_between_runs", FiniteOrNull(p.sigma_between_runs * scale)},
                   {"interval95", p.identifiable ? nlohmann::json({p.lower95() * scale, p.upper95() * scale})
                                                 : nlohmann::json(nullptr)},
                   {"identifiable", p.identifiable}};
  }
  return {{"parameters", params},
          {"gap_mm", fit.gap_m * kMToMm},
          {"noise_floor_mm", fit.noise_floor_m * kMToMm},
          {"frames", fit.n_frames},
          {"condition_number", std::isfinite(fit.condition_number)
                                   ? nlohmann::json(fit.condition_number)
                                   : nlohmann::json(nullptr)},
          {"lag1_autocorrelation", fit.lag1_autocorrelation},
          {"variance_factor", fit.variance_factor},
          {"jackknife_runs", fit.jackknife_runs},
          {"jackknife_groups", fit.jackknife_groups},
          {"not_identifiable", fit.unidentifiable}};
}

nlohmann::json AliasJson(const calibration::AliasReport& a) {
  return {{"effect", calibration::ToString(a.effect)},
          {"separation", a.separation},
          {"no_signal", a.no_signal},
          {"looks_like", a.looks_like},
          {"distinguishing_runs", a.distinguishing_runs}};
}

nlohmann::json CrossValidationJson(const calibration::CrossValidation& cv) {
  nlohmann::json j = {{"method", cv.method}, {"folds", cv.folds}, {"heldout_runs", cv.heldout_runs}};
  if (cv.possible()) {
    j["heldout_rms_before_mm"] = cv.heldout_rms_before_m * kMToMm;
    j["heldout_rms_after_mm"] = cv.heldout_rms_after_m * kMToMm;
    j["improved"] = cv.improved;
  } else {
    j["heldout_rms_before_mm"] = nullptr;
    j["heldout_rms_after_mm"] = nullptr;
  }
  if (!cv.note.empty()) j["note"] = cv.note;
  return j;
}

nlohmann::json TrialJson(const calibration::CandidateTrial& t) {
  nlohmann::json j = {{"effect", calibration::ToString(t.effect)},
                      {"fitted", t.fitted},
                      {"score", t.score},
                      {"wald", t.wald},
                      {"wald_threshold", t.wald_threshold},
                      {"explained_mm", t.explained_m * kMToMm},
                      {"separation", t.alias.separation},
                      {"gap_mm", t.gap_m * kMToMm}};
  if (t.cross_validation) j["cross_validation"] = CrossValidationJson(*t.cross_validation);
  return j;
}

nlohmann::json UnexplainedJson(const calibration::UnexplainedReport& u) {
  nlohmann::json where = nlohmann::json::array();
  for (const calibration::UnexplainedSegment& w : u.where)
    where.push_back({{"where", w.run},
                     {"when", {{"t_from_s", w.t_from_s}, {"t_to_s", w.t_to_s}}},
                     {"motion", w.motion},
                     {"size_mm", w.size_m * kMToMm},
                     {"frames", w.frames}});
  return where;
}

nlohmann::json RemainderJson(const calibration::UnexplainedReport& u) {
  return {{"gap_mm", u.gap_m * kMToMm},
          {"expected_gap_mm", u.expected_gap_m * kMToMm},
          {"wheel_noise_gap_mm", u.wheel_noise_gap_m * kMToMm},
          {"excess_mm", u.excess_m * kMToMm},
          {"F", u.ratio},
          {"F_threshold", u.threshold},
          {"n_eff", u.n_eff},
          {"significant", u.significant},
          {"statistic",
           "F = gap^2 / expected_gap^2 (camera noise and wheel noise after the fit) against "
           "chi2_{2 N_eff}(0.999) / (2 N_eff); significant if above it and the excess "
           "sqrt(gap^2 - expected^2) >= 0.1 mm; then segments with RMS >= 2x the expected gap "
           "are listed; a lone segment with RMS >= 3x, chi-square significant at 0.001 / "
           "segments, is listed in any case"}};
}

// One SVG plot of |position error| per frame over the session's frames, runs
// side by side, coloured by motion.
std::string ResidualSvg(const calibration::MeasuredSession& session,
                        const calibration::TrajectoryFitResult& fit, double y_max_mm,
                        const std::string& title) {
  const size_t n = fit.residuals.size();
  svg::Plot plot(900, 240, {0.0, std::max<double>(1.0, double(n) - 1.0)}, {0.0, y_max_mm});
  plot.Title(title);
  plot.Axes("frame (runs side by side)", "|model − camera| [mm]");
  int last_run = -1;
  for (size_t i = 0; i < n; ++i) {
    const calibration::FrameResidual& r = fit.residuals[i];
    if (r.run != last_run) {
      plot.Line(double(i), 0.0, double(i), y_max_mm, "#999", 1.0, "3,3");
      // Alternate heights so that the names of short runs do not overlap.
      plot.Text(double(i), y_max_mm, session.runs[r.run].name, "#333", 9, "start", 2,
                r.run % 2 == 0 ? 10 : 21);
      last_run = r.run;
    }
    const char* colour = r.motion == calibration::MotionKind::kTurn       ? "#d62728"
                         : r.motion == calibration::MotionKind::kStraight ? "#1f77b4"
                                                                          : "#7f7f7f";
    plot.Circle(double(i), std::min(r.error_m.norm() * kMToMm, y_max_mm), 1.0, colour);
  }
  return plot.Svg("residuals");
}

}  // namespace

nlohmann::json ExplainJson(const calibration::MeasuredSession& session,
                           const calibration::ExplainResult& result) {
  (void)session;
  nlohmann::json steps = nlohmann::json::array();
  for (const calibration::ExplainStep& s : result.steps) {
    nlohmann::json trials = nlohmann::json::array();
    for (const calibration::CandidateTrial& t : s.trials) trials.push_back(TrialJson(t));
    steps.push_back({{"effect", calibration::ToString(s.effect)},
                     {"params", ParamsJson(s.params, false)},
                     {"interval95", ParamsJson(s.params, true)},
                     {"gap_after_mm", s.gap_after_m * kMToMm},
                     {"score", s.score},
                     {"cross_validation", CrossValidationJson(s.cross_validation)},
                     {"between_runs_z", FiniteOrNull(s.between_runs_z)},
                     {"holds_across_runs", std::isfinite(s.between_runs_z)
                                               ? nlohmann::json(s.holds_across_runs())
                                               : nlohmann::json(nullptr)},
                     {"candidates", trials}});
  }
  nlohmann::json rejected = nlohmann::json::array();
  for (const calibration::CandidateTrial& t : result.rejected)
    if (t.fitted) {
      nlohmann::json j = TrialJson(t);
      j.erase("fitted");
      j.erase("separation");
      rejected.push_back(j);
    }
  nlohmann::json aliased = nlohmann::json::array();
  for (const calibration::AliasReport& a : result.aliased) aliased.push_back(AliasJson(a));
  return {
      {"gap_before_mm", result.gap_before_m() * kMToMm},
      {"steps", steps},
      {"gap_after_mm", result.gap_after_m() * kMToMm},
      {"effects_added", result.EffectsAdded()},
      {"noise_floor_mm", result.final_fit.noise_floor_m * kMToMm},
      {"criterion",
       "BIC drop N_eff ln(SSE_before/SSE_after) - k ln(N_eff) above 10, and a Wald test of the "
       "effect's parameters against zero (wheel noise included) above its chi-square 0.999 "
       "quantile, and it explains at least 0.05 mm RMS of the gap, and (when the session has "
       "more than one run) it predicts held-out runs better: the RMS over held-out runs of "
       "their replays' RMS position error falls by more than 5 % and 0.01 mm (leave one run "
       "out up to 8 runs, else 5 folds by run)"},
      {"not_kept", rejected},
      {"cannot_tell", aliased},
      {"unexplained", UnexplainedJson(result.unexplained)},
      {"remainder", RemainderJson(result.unexplained)},
      {"base", FitJson(result.base)},
      {"final", FitJson(result.final_fit)},
      // The physical parameters the final fit stands for, and the beliefs they
      // are relative to: another session of the same robot, recorded with
      // other beliefs, can replay them (odocal check).
      {"believed", WheelParamsJson(session.believed)},
      {"corrected", WheelParamsJson(calibration::ApplyWheelScales(session.believed,
                                                                  result.final_fit.scales))},
      {"residuals_before", SummaryJson(result.base_residuals)},
      {"residuals_after", SummaryJson(result.final_residuals)},
  };
}

nlohmann::json CameraRefitJson(double k1_correction, const calibration::MeasuredSession& session,
                               const calibration::ExplainResult& result) {
  const nlohmann::json again = ExplainJson(session, result);
  return {{"k1_correction", k1_correction},
          {"why",
           "a lens error is a camera-model error: the videos were measured again with the "
           "calibrated k1 corrected (the camera plane, estimated from the same views, had "
           "absorbed part of it, chiefly its height: every distance) and explained again"},
          {"gap_before_mm", again["gap_before_mm"]},
          {"steps", again["steps"]},
          {"gap_after_mm", again["gap_after_mm"]},
          {"effects_added", again["effects_added"]},
          {"final", again["final"]}};
}

std::string ExplainHtml(const calibration::MeasuredSession& session,
                        const calibration::ExplainResult& result) {
  double y_max = 0.0;
  for (const auto& r : result.base.residuals) y_max = std::max(y_max, r.error_m.norm() * kMToMm);
  y_max = std::max(1.0, std::ceil(y_max));
  std::ostringstream os;
  os << std::fixed << std::setprecision(3);
  os << "<!DOCTYPE html>\n<html><head><meta charset='utf-8'><title>odocal explain</title>"
        "<style>body{font-family:sans-serif;margin:2em}td,th{padding:2px 8px;text-align:left}"
        "pre{background:#f6f6f6;padding:1em}</style></head><body>\n";
  os << "<h1>Where model and measurement disagree</h1>\n";
  os << "<p>Gap (RMS position residual): <b>" << result.gap_before_m() * kMToMm
     << " mm</b> with the base model, <b>" << result.gap_after_m() * kMToMm
     << " mm</b> after; noise floor " << result.final_fit.noise_floor_m * kMToMm << " mm.</p>\n";
  os << "<h2>Steps</h2><table><tr><th>effect</th><th>parameters</th><th>gap after [mm]</th>"
        "<th>score (BIC drop)</th><th>held-out RMS before &rarr; after [mm]</th></tr>\n";
  for (const auto& s : result.steps) {
    os << "<tr><td>" << calibration::ToString(s.effect) << "</td><td>";
    for (const auto& p : s.params) os << p.name << " " << p.value << " &plusmn; " << 1.96 * p.sigma << "; ";
    os << "</td><td>" << s.gap_after_m * kMToMm << "</td><td>" << s.score << "</td><td>";
    if (s.cross_validation.possible())
      os << s.cross_validation.heldout_rms_before_m * kMToMm << " &rarr; "
         << s.cross_validation.heldout_rms_after_m * kMToMm << " (" << s.cross_validation.method
         << ", " << s.cross_validation.folds << " folds)";
    else
      os << s.cross_validation.note;
    os << "</td></tr>\n";
  }
  if (result.steps.empty()) os << "<tr><td colspan='5'>nothing significant</td></tr>\n";
  os << "</table>\n";
  const calibration::UnexplainedReport& u = result.unexplained;
  os << "<h2>Unexplained</h2><p>Remainder: gap " << u.gap_m * kMToMm << " mm against "
     << u.expected_gap_m * kMToMm << " mm that camera and wheel noise leave (F " << u.ratio
     << ", threshold " << u.threshold << ": " << (u.significant ? "significant" : "not significant")
     << ").</p>\n";
  if (u.any()) {
    os << "<p>No candidate explains these; look there:</p><table><tr><th>run</th><th>from [s]"
          "</th><th>to [s]</th><th>motion</th><th>RMS [mm]</th><th>frames</th></tr>\n";
    for (const auto& w : u.where)
      os << "<tr><td>" << w.run << "</td><td>" << w.t_from_s << "</td><td>" << w.t_to_s
         << "</td><td>" << w.motion << "</td><td>" << w.size_m * kMToMm << "</td><td>" << w.frames
         << "</td></tr>\n";
    os << "</table>\n";
  } else {
    os << "<p>Nothing structured remains.</p>\n";
  }
  os << "<p>Colours: <span style='color:#1f77b4'>straight</span>, "
        "<span style='color:#d62728'>turn</span>, <span style='color:#7f7f7f'>rest</span>. "
        "Same vertical scale in both plots.</p>\n";
  os << ResidualSvg(session, result.base, y_max, "|model - camera| per frame, base model");
  os << "<br/>\n";
  os << ResidualSvg(session, result.final_fit, y_max, "|model - camera| per frame, after");
  os << "<h2>Report</h2><pre>" << result.BriefReport() << "</pre>\n";
  os << "</body></html>\n";
  return os.str();
}

}  // namespace odocal::report
