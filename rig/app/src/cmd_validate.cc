// odocal validate --manual manual.csv SESSION.yaml --out DIR
//
// How far can the tape be trusted? Each hand-measured return error (the CSV
// format is in config/manual_csv.h) against the camera's measurement of the
// same run: Bland-Altman per axis, outliers, and a plain verdict
// (measure/tape_validation.h). Writes DIR/report.json and DIR/report.html.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <sstream>

#include <nlohmann/json.hpp>

#include "cli_util.h"
#include "commands.h"
#include "odocal/base/format.h"
#include "odocal/base/units.h"
#include "odocal/calibration/bland_altman.h"
#include "odocal/config/files.h"
#include "odocal/config/manual_csv.h"
#include "odocal/config/session.h"
#include "odocal/measure/measure.h"
#include "odocal/measure/tape_validation.h"
#include "odocal/report/html_report.h"
#include "odocal/report/json.h"
#include "odocal/report/measurement_json.h"

namespace odocal::app {
namespace {

nlohmann::json IntervalJson(const calibration::Interval& i) { return {i.lower, i.upper}; }

std::string AxisSentence(const std::string& axis, const std::string& unit,
                         const calibration::BlandAltmanResult& r, double confidence) {
  std::ostringstream os;
  const int pct = static_cast<int>(std::lround(confidence * 100));
  os << axis << ": ";
  if (r.bias_ci.Contains(0.0)) {
    os << "no significant bias (" << (r.bias >= 0 ? "+" : "") << Fixed(r.bias, 2) << " " << unit
       << ", " << pct << " % CI " << Fixed(r.bias_ci.lower, 2) << " to " << Fixed(r.bias_ci.upper, 2) << ")";
  } else {
    os << "tape reads " << Fixed(std::abs(r.bias), 2) << " " << unit << (r.bias > 0 ? " high" : " low")
       << " (" << pct << " % CI " << Fixed(r.bias_ci.lower, 2) << " to " << Fixed(r.bias_ci.upper, 2) << ")";
  }
  os << ", a single reading within ±" << Fixed(r.z * r.sd, 2) << " " << unit << " of that ("
     << pct << " % limits of agreement " << Fixed(r.lower_limit, 2) << " to " << Fixed(r.upper_limit, 2)
     << " " << unit << ")";
  if (!r.outliers.empty()) os << "; " << r.outliers.size() << " outlier(s)";
  return os.str();
}

}  // namespace

void RegisterValidateCommand(CLI::App& app) {
  struct Args {
    std::string manual;
    std::string session;
    std::string out;
    double confidence = 0.95;
    int threads = 0;
  };
  auto args = std::make_shared<Args>();
  CLI::App* cmd = app.add_subcommand(
      "validate",
      "Tape-measured return errors against the camera's: Bland-Altman bias, limits of agreement,\n"
      "outliers and a verdict; writes DIR/report.json and DIR/report.html.\n"
      "manual.csv: header run,x_mm,y_mm[,theta_deg], one reading a line, run = the session's\n"
      "run name; x, y, theta = true - odometry in the run's start frame (mm, degrees)");
  cmd->add_option("--manual", args->manual, "Manual measurements (CSV)")->required();
  cmd->add_option("session", args->session, "Session file (session.yaml)")->required();
  cmd->add_option("--out", args->out, "Output directory (created)")->required();
  cmd->add_option("--confidence", args->confidence, "Of the limits and intervals")->capture_default_str();
  cmd->add_option("--threads", args->threads, "Worker threads (default: one per core)");
  cmd->callback([args]() {
    const std::string name = "validate";
    std::string error;
    calibration::BlandAltmanOptions ba_options;
    ba_options.confidence = args->confidence;
    if (!ba_options.IsValid(&error)) Fail(name, kExitBadInput, "--confidence: " + error);
    const auto readings = config::ReadManualCsv(args->manual);
    if (!readings) Fail(name, kExitBadInput, readings.message);
    const auto session = config::LoadSession(args->session);
    if (!session) Fail(name, kExitBadInput, session.message);
    std::map<std::string, int> run_index;
    std::string run_names;
    for (size_t i = 0; i < session->runs.size(); ++i) {
      run_index[session->runs[i].name] = static_cast<int>(i);
      run_names += (run_names.empty() ? "" : ", ") + session->runs[i].name;
    }
    for (const config::ManualReading& r : *readings)
      if (!run_index.count(r.run))
        Fail(name, kExitBadInput,
             args->manual + ":" + std::to_string(r.line) + ": run '" + r.run + "' is not in " +
                 args->session + " (its runs: " + run_names + ")");

    // Too few readings for any statistics: said before the videos are
    // measured (most of validate's time).
    if (readings->size() < 3)
      Fail(name, kExitFailure,
           "fewer than 3 readings in " + args->manual + ": no agreement statistics (" +
               std::to_string(readings->size()) + " given)");

    measure::MeasureOptions options;
    options.threads = args->threads;
    const auto measured =
        measure::MeasureSessions({*session}, options, TerminalProgressBar("measuring"));
    // A malformed pose log (or its telemetry) is the one way measuring fails.
    if (!measured) Fail(name, kExitBadInput, measured.message);
    const measure::SessionMeasurement& sm = measured->front();

    std::vector<measure::TapePair> pairs;
    std::vector<std::string> notes;
    for (const config::ManualReading& r : *readings) {
      const measure::RunMeasurement& rm = sm.runs[run_index[r.run]];
      const calibration::RelativePose* camera = measure::UsableReturnError(rm.measured);
      if (!camera) {
        notes.push_back(args->manual + ":" + std::to_string(r.line) + ": run " + r.run +
                        " has no camera measurement (" +
                        nlohmann::json(calibration::ToStrings(rm.measured.flags)).dump() + "); left out");
        continue;
      }
      pairs.push_back({&r, *camera});
    }

    nlohmann::json report = {{"command", "validate"},
                             {"session", args->session},
                             {"manual", args->manual},
                             {"confidence", args->confidence},
                             {"differences", "manual - camera"},
                             {"pairs", nlohmann::json::array()},
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

    const measure::TapeValidation validation = measure::ValidateTape(pairs, ba_options);
    notes.insert(notes.end(), validation.notes.begin(), validation.notes.end());
    std::vector<std::string> sentences;
    for (const measure::AxisAgreement& a : validation.axes) {
      const calibration::BlandAltmanResult& r = a.agreement;
      nlohmann::json outliers = nlohmann::json::array(), outside = nlohmann::json::array();
      for (int i : r.outliers)
        outliers.push_back({{"run", a.readings[i]->run}, {"line", a.readings[i]->line},
                            {"difference", r.differences[i]}});
      for (int i : r.outside_limits)
        outside.push_back({{"run", a.readings[i]->run}, {"line", a.readings[i]->line},
                           {"difference", r.differences[i]}});
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
      sentences.push_back(AxisSentence(a.key, a.unit, r, args->confidence));
    }
    if (!validation.ok)
      Fail(name, kExitFailure,
           "fewer than 3 readings with a camera measurement: no agreement statistics (" +
               std::to_string(pairs.size()) + " usable)");

    std::ostringstream verdict;
    verdict << "A tape reading is within " << Fixed(validation.error_bound_mm, 1) << " mm of the camera ("
            << static_cast<int>(std::lround(args->confidence * 100))
            << " %, bias included): good for UMBMark when E_max,syst is above ~"
            << Fixed(validation.usable_above_emax_mm, 0)
            << " mm, not for fine calibration below that (use the camera).";
    if (validation.few_readings())
      verdict << " With " << validation.position_n << " readings the limits themselves are uncertain: up to "
              << Fixed(validation.limits_worst_case_mm, 1) << " mm at the far end of their confidence intervals"
              << " (more readings narrow them).";
    report["verdict"] = {{"text", verdict.str()},
                         {"axes", sentences},
                         {"error_bound_mm", validation.error_bound_mm},
                         {"limits_worst_case_mm", validation.limits_worst_case_mm},
                         {"usable_above_emax_mm", validation.usable_above_emax_mm}};
    report["notes"] = notes;
    report["runs"] = nlohmann::json::array();
    report["trajectories"] = nlohmann::json::array();
    for (const measure::RunMeasurement& rm : sm.runs) {
      report["runs"].push_back(report::RunJson(rm));
      report["trajectories"].push_back(report::TrajectoryJson(rm));
    }

    if (auto e = config::EnsureDirectory(args->out)) Fail(name, kExitFailure, *e);
    if (auto e = config::WriteFileAtomically(args->out + "/report.json", report.dump(2) + "\n"))
      Fail(name, kExitFailure, *e);
    if (auto e = report::WriteReportHtml(report, "odocal validate", args->out + "/report.html"))
      Fail(name, kExitFailure, *e);

    std::printf("odocal validate: %zu readings, %zu with a camera measurement\n", readings->size(),
                pairs.size());
    std::printf("  %-6s %4s %22s %10s %26s\n", "axis", "n", "bias [CI]", "sd", "limits of agreement");
    for (const auto& a : report["axes"]) {
      char bias[64], lim[64];
      std::snprintf(bias, sizeof(bias), "%+.2f [%+.2f,%+.2f]", a["bias"].get<double>(),
                    a["bias_ci"][0].get<double>(), a["bias_ci"][1].get<double>());
      std::snprintf(lim, sizeof(lim), "%+.2f to %+.2f %s", a["lower_limit"].get<double>(),
                    a["upper_limit"].get<double>(), a["unit"].get<std::string>().c_str());
      std::printf("  %-6s %4d %22s %10.2f %26s\n", a["axis"].get<std::string>().c_str(),
                  a["n"].get<int>(), bias, a["sd"].get<double>(), lim);
    }
    for (const std::string& s : sentences) std::printf("  %s\n", s.c_str());
    for (const std::string& n : notes) std::printf("note: %s\n", n.c_str());
    std::printf("\n%s\n", verdict.str().c_str());
    std::printf("report: %s/report.json, %s/report.html\n", args->out.c_str(), args->out.c_str());
  });
}

}  // namespace odocal::app
