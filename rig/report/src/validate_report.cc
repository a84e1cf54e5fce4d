#include "odocal/report/validate_report.h"

#include <cmath>
#include <sstream>

#include "odocal/base/format.h"
#include "odocal/report/measurement_json.h"

namespace odocal::report {
namespace {

nlohmann::json IntervalJson(const calibration::Interval& i) { return {i.lower, i.upper}; }

}  // namespace

std::string AxisSentence(const std::string& axis, const std::string& unit, const calibration::BlandAltmanResult& r,
                         double confidence) {
  std::ostringstream os;
  const int pct = static_cast<int>(std::lround(confidence * 100));
  os << axis << ": ";
  if (r.bias_ci.Contains(0.0)) {
    os << "no significant bias (" << (r.bias >= 0 ? "+" : "") << Fixed(r.bias, 2) << " " << unit << ", " << pct
       << " % CI " << Fixed(r.bias_ci.lower, 2) << " to " << Fixed(r.bias_ci.upper, 2) << ")";
  } else {
    os << "tape reads " << Fixed(std::abs(r.bias), 2) << " " << unit << (r.bias > 0 ? " high" : " low") << " (" << pct
       << " % CI " << Fixed(r.bias_ci.lower, 2) << " to " << Fixed(r.bias_ci.upper, 2) << ")";
  }
  os << ", a single reading within ±" << Fixed(r.z * r.sd, 2) << " " << unit << " of that (" << pct
     << " % limits of agreement " << Fixed(r.lower_limit, 2) << " to " << Fixed(r.upper_limit, 2) << " " << unit << ")";
  if (!r.outliers.empty()) os << "; " << r.outliers.size() << " outlier(s)";
  return os.str();
}

ValidateReport MakeValidateReport(const std::string& session_path, const std::string& manual_path, double confidence,
                                  const std::vector<measure::TapePair>& pairs,
                                  const measure::TapeValidation& validation, const std::vector<std::string>& notes,
                                  const measure::SessionMeasurement& session) {
  ValidateReport out;
  nlohmann::json& report = out.json;
  report = {{"command", "validate"},          {"session", session_path},          {"manual", manual_path},
            {"confidence", confidence},       {"differences", "manual - camera"}, {"pairs", nlohmann::json::array()},
            {"axes", nlohmann::json::array()}};
  for (const measure::TapePair& p : pairs) {
    nlohmann::json manual = {{"x_mm", p.reading->x_mm}, {"y_mm", p.reading->y_mm}};
    if (p.reading->theta_deg) manual["theta_deg"] = *p.reading->theta_deg;
    report["pairs"].push_back(
        {{"run", p.reading->run},
         {"line", p.reading->line},
         {"manual", manual},
         {"camera", {{"x_mm", p.camera_x_mm()}, {"y_mm", p.camera_y_mm()}, {"theta_deg", p.camera_theta_deg()}}},
         {"camera_sigma", {{"x_mm", p.sigma_x_mm()}, {"y_mm", p.sigma_y_mm()}, {"theta_deg", p.sigma_theta_deg()}}}});
  }

  for (const measure::AxisAgreement& a : validation.axes) {
    const calibration::BlandAltmanResult& r = a.agreement;
    nlohmann::json outliers = nlohmann::json::array(), outside = nlohmann::json::array();
    for (int i : r.outliers)
      outliers.push_back(
          {{"run", a.readings[i]->run}, {"line", a.readings[i]->line}, {"difference", r.differences[i]}});
    for (int i : r.outside_limits)
      outside.push_back({{"run", a.readings[i]->run}, {"line", a.readings[i]->line}, {"difference", r.differences[i]}});
    std::vector<std::string> runs;
    for (const config::ManualReading* m : a.readings) runs.push_back(m->run);
    report["axes"].push_back({{"axis", a.key},
                              {"unit", a.unit},
                              {"n", r.n},
                              {"bias", r.bias},
                              {"bias_ci", IntervalJson(r.bias_ci)},
                              {"sd", r.sd},
                              {"lower_limit", r.lower_limit},
                              {"lower_limit_ci", IntervalJson(r.lower_limit_ci)},
                              {"upper_limit", r.upper_limit},
                              {"upper_limit_ci", IntervalJson(r.upper_limit_ci)},
                              {"z", r.z},
                              {"t", r.t},
                              {"error_bound", r.error_bound()},
                              {"camera_sigma_max", a.camera_sigma_max},
                              {"outliers", outliers},
                              {"outside_limits", outside},
                              {"runs", runs},
                              {"means", r.means},
                              {"differences", r.differences}});
    out.sentences.push_back(AxisSentence(a.key, a.unit, r, confidence));
  }
  std::ostringstream verdict;
  verdict << "A tape reading is within " << Fixed(validation.error_bound_mm, 1) << " mm of the camera ("
          << static_cast<int>(std::lround(confidence * 100))
          << " %, bias included): good for UMBMark when E_max,syst is above ~"
          << Fixed(validation.usable_above_emax_mm, 0) << " mm, not for fine calibration below that (use the camera).";
  if (validation.few_readings())
    verdict << " With " << validation.position_n << " readings the limits themselves are uncertain: up to "
            << Fixed(validation.limits_worst_case_mm, 1) << " mm at the far end of their confidence intervals"
            << " (more readings narrow them).";
  report["verdict"] = {{"text", verdict.str()},
                       {"axes", out.sentences},
                       {"error_bound_mm", validation.error_bound_mm},
                       {"limits_worst_case_mm", validation.limits_worst_case_mm},
                       {"usable_above_emax_mm", validation.usable_above_emax_mm}};
  out.verdict = verdict.str();
  report["notes"] = notes;
  report["runs"] = nlohmann::json::array();
  report["trajectories"] = nlohmann::json::array();
  for (const measure::RunMeasurement& rm : session.runs) {
    report["runs"].push_back(report::RunJson(rm));
    report["trajectories"].push_back(report::TrajectoryJson(rm));
  }

  return out;
}

}  // namespace odocal::report
