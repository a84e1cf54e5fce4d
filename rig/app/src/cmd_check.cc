// odocal check SESSION.yaml --params FILE [--params [NAME=]FILE ...] --out DIR
//
// Does a calibration hold on runs it never saw? Measures the session's videos
// (as batch and explain do), replays every run's ticks with the session's
// nominal set and each given set (check_report.h) and compares with the
// camera: DIR/check.json, DIR/report.html and a table on stdout. The sets are
// firmware exports, ROS 2 multiplier files or explain.json files
// (param_files.h), told apart by their content.
#include <memory>
#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "cli_util.h"
#include "commands.h"
#include "record_util.h"
#include "odocal/records/digest.h"
#include "odocal/config/files.h"
#include "odocal/config/param_files.h"
#include "odocal/config/session.h"
#include "odocal/measure/measure.h"
#include "odocal/report/check_report.h"
#include "odocal/report/json.h"

namespace odocal::app {

struct CheckArgs {
  std::string session;
  std::vector<std::string> params;
  std::string out;
  RecordArgs record;
};

void RunCheck(const CheckArgs& args) {
  // Everything the user typed is checked before the videos are measured.
  std::string error;
  std::vector<config::ParamSpec> specs;
  std::set<std::string> names = {"nominal"};
  for (const std::string& text : args.params) {
    const Result<config::ParamSpec> spec = config::ParseParamSpec(text);
    if (!spec) Fail("check", kExitBadInput, spec.message);
    if (!names.insert(spec->name).second)
      Fail("check", kExitBadInput,
           "--params " + text + ": a set named '" + spec->name +
               "' is already given (nominal is the session's own); name it with NAME=FILE");
    specs.push_back(*spec);
  }
  const auto session = config::LoadSession(args.session);
  if (!session) Fail("check", kExitBadInput, session.message);
  std::vector<config::ReplaySet> sets = {config::NominalReplaySet()};
  for (const config::ParamSpec& spec : specs) {
    const auto set = config::ReadReplaySet(spec, session->nominal);
    if (!set) Fail("check", kExitBadInput, set.message);
    sets.push_back(*set);
  }
  if (const Status e = config::EnsureDirectory(args.out); !e) Fail("check", kExitFailure, e.message);

  const auto measured =
      measure::MeasureSessions({*session}, measure::MeasureOptions{}, TerminalProgressBar("measuring"));
  if (!measured) Fail("check", kExitFailure, measured.message);
  const measure::SessionMeasurement& sm = measured->front();
  calibration::MeasuredSession ms = sm.ToMeasuredSession();
  ms.camera = measure::FloorCameraOf(sm);

  const report::CheckResult result = report::RunCheck(ms, sets);
  const nlohmann::json j = report::CheckJson(args.session, ms, result);
  std::fputs(report::CheckTable(j).c_str(), stdout);
  if (const Status e = config::WriteFileAtomically(args.out + "/check.json", j.dump(2) + "\n"); !e)
    Fail("check", kExitFailure, e.message);
  if (const Status e = config::WriteFileAtomically(args.out + "/report.html", report::CheckHtml(j)); !e)
    Fail("check", kExitFailure, e.message);
  std::printf("wrote %s/check.json and report.html\n", args.out.c_str());
  if (result.Replayed() > 0) {
    RunIdentity run;
    run.kind = records::RunKind::kCheck;
    run.folder = args.out;
    run.robot = session->robot_id;
    run.time_utc = session->recorded_utc;
    run.odometer_km = session->odometer_km;
    std::vector<std::string> inputs = config::SessionFiles(*session);
    for (const config::ParamSpec& spec : specs) inputs.push_back(spec.path);
    const Result<std::string> digest = records::DigestFiles("check", inputs);
    if (!digest) Fail("check", kExitBadInput, digest.message);
    run.digest = *digest;
    KeepRecord("check", j, run, args.record, {});
  }
  if (result.Replayed() == 0)
    Fail("check", kExitFailure,
         "no run could be replayed (" +
             (j["not_replayed"].empty() ? std::string("the session has no runs")
                                        : j["not_replayed"][0]["reason"].get<std::string>()) +
             ")");
}

void RegisterCheckCommand(CLI::App& app) {
  auto args = std::make_shared<CheckArgs>();
  CLI::App* cmd = app.add_subcommand(
      "check", "Replay every run with parameter sets and compare with the camera: does a "
               "calibration hold on runs it never saw?");
  cmd->add_option("session", args->session, "Session file (session.yaml)")->required();
  cmd->add_option("--params", args->params,
                  "[NAME=]FILE: a firmware export, a ROS 2 multipliers file or an explain.json "
                  "(named by the file's stem unless NAME= is given); repeatable. The session's "
                  "nominal set is always replayed too, as `nominal`")
      ->required()
      ->allow_extra_args(false);
  cmd->add_option("--out", args->out, "Output directory (created): check.json, report.html")
      ->required();
  AddRecordOptions(cmd, &args->record, /*with_limits=*/false);
  cmd->callback([args]() { RunCheck(*args); });
}

}  // namespace odocal::app
