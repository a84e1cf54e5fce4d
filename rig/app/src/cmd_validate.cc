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
#include "odocal/report/validate_report.h"

namespace odocal::app {
namespace {

struct ValidateArgs {
  std::string manual;
  std::string session;
  std::string out;
  double confidence = 0.95;
  int threads = 0;
};

// The table, the sentences, the notes and the verdict on stdout.
void PrintValidateSummary(const nlohmann::json& report, const report::ValidateReport& written, size_t readings,
                          size_t pairs, const std::string& out) {
  std::printf("odocal validate: %zu readings, %zu with a camera measurement\n", readings, pairs);
  std::printf("  %-6s %4s %22s %10s %26s\n", "axis", "n", "bias [CI]", "sd", "limits of agreement");
  for (const auto& a : report["axes"]) {
    char bias[64], lim[64];
    std::snprintf(bias, sizeof(bias), "%+.2f [%+.2f,%+.2f]", a["bias"].get<double>(), a["bias_ci"][0].get<double>(),
                  a["bias_ci"][1].get<double>());
    std::snprintf(lim, sizeof(lim), "%+.2f to %+.2f %s", a["lower_limit"].get<double>(), a["upper_limit"].get<double>(),
                  a["unit"].get<std::string>().c_str());
    std::printf("  %-6s %4d %22s %10.2f %26s\n", a["axis"].get<std::string>().c_str(), a["n"].get<int>(), bias,
                a["sd"].get<double>(), lim);
  }
  for (const std::string& s : written.sentences) std::printf("  %s\n", s.c_str());
  for (const auto& n : report["notes"]) std::printf("note: %s\n", n.get<std::string>().c_str());
  std::printf("\n%s\n", written.verdict.c_str());
  std::printf("report: %s/report.json, %s/report.html\n", out.c_str(), out.c_str());
}

void RunValidate(const ValidateArgs& args) {
  const std::string name = "validate";
  std::string error;
  calibration::BlandAltmanOptions ba_options;
  ba_options.confidence = args.confidence;
  if (!ba_options.IsValid(&error)) Fail(name, kExitBadInput, "--confidence: " + error);
  const auto readings = config::ReadManualCsv(args.manual);
  if (!readings) Fail(name, kExitBadInput, readings.message);
  const auto session = config::LoadSession(args.session);
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
           args.manual + ":" + std::to_string(r.line) + ": run '" + r.run + "' is not in " + args.session +
               " (its runs: " + run_names + ")");

  // Too few readings for any statistics: said before the videos are
  // measured (most of validate's time).
  if (readings->size() < 3)
    Fail(name, kExitFailure,
         "fewer than 3 readings in " + args.manual + ": no agreement statistics (" + std::to_string(readings->size()) +
             " given)");

  measure::MeasureOptions options;
  options.threads = args.threads;
  const auto measured = measure::MeasureSessions({*session}, options, TerminalProgressBar("measuring"));
  // A malformed pose log (or its telemetry) is the one way measuring fails.
  if (!measured) Fail(name, kExitBadInput, measured.message);
  const measure::SessionMeasurement& sm = measured->front();

  std::vector<measure::TapePair> pairs;
  std::vector<std::string> notes;
  for (const config::ManualReading& r : *readings) {
    const measure::RunMeasurement& rm = sm.runs[run_index[r.run]];
    const calibration::RelativePose* camera = measure::UsableReturnError(rm.measured);
    if (!camera) {
      notes.push_back(args.manual + ":" + std::to_string(r.line) + ": run " + r.run + " has no camera measurement (" +
                      nlohmann::json(calibration::ToStrings(rm.measured.flags)).dump() + "); left out");
      continue;
    }
    pairs.push_back({&r, *camera});
  }

  const measure::TapeValidation validation = measure::ValidateTape(pairs, ba_options);
  if (!validation.ok())
    Fail(name, kExitFailure,
         "fewer than 3 readings with a camera measurement: no agreement statistics (" + std::to_string(pairs.size()) +
             " usable)");
  notes.insert(notes.end(), validation.notes.begin(), validation.notes.end());
  const report::ValidateReport written =
      report::MakeValidateReport(args.session, args.manual, args.confidence, pairs, validation, notes, sm);
  const nlohmann::json& report = written.json;

  if (const Status e = config::EnsureDirectory(args.out); !e) Fail(name, kExitFailure, e.message);
  if (const Status e = config::WriteFileAtomically(args.out + "/report.json", report.dump(2) + "\n"); !e)
    Fail(name, kExitFailure, e.message);
  if (const Status e = report::WriteReportHtml(report, "odocal validate", args.out + "/report.html"); !e)
    Fail(name, kExitFailure, e.message);

  PrintValidateSummary(report, written, readings->size(), pairs.size(), args.out);
}

}  // namespace

void RegisterValidateCommand(CLI::App& app) {
  auto args = std::make_shared<ValidateArgs>();
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
  cmd->callback([args]() { RunValidate(*args); });
}

}  // namespace odocal::app
