// odocal history ROBOT [--db] [--json] [--out DIR]    a robot's calibrations over time
// odocal history import DIR... [--db] [--robot ID]    keep the records that run folders hold
// odocal fleet [--db] [--json] [--out DIR]            every robot's last calibration; the line's charts
#include <chrono>
#include <cstdio>
#include <iostream>
#include <memory>

#include <CLI/CLI.hpp>

#include "cli_util.h"
#include "commands.h"
#include "odocal/base/utc_time.h"
#include "odocal/config/files.h"
#include "odocal/records/history.h"
#include "odocal/records/store.h"
#include "record_util.h"

namespace odocal::app {
namespace {

struct ViewArgs {
  std::string db;
  std::string limits;
  std::string now;
  std::string out;
  bool json = false;
};

void AddViewOptions(CLI::App* cmd, ViewArgs* args) {
  cmd->add_option("--db", args->db, "Record store (default: $ODOCAL_DB, else ~/.local/share/odocal/records.sqlite)");
  cmd->add_option("--limits", args->limits,
                  "Limits for the forecast, e.g. emax_syst_after_mm=2,recalibrate_days=30 (when E_max,syst "
                  "crosses its limit; who is due)");
  cmd->add_option("--now", args->now, "The date 'due' is measured from (ISO 8601; default: now)");
  cmd->add_option("--out", args->out, "Also write DIR/report.html and DIR/<command>.json");
  cmd->add_flag("--json", args->json, "Print the JSON document instead of the table");
}

// `create`: import keeps records (a new store is made); history and fleet only read.
std::unique_ptr<records::RecordStore> OpenOrFail(const std::string& command, const std::string& db_option,
                                                 bool create) {
  const std::string db = db_option.empty() ? records::DefaultDatabase() : db_option;
  Result<std::unique_ptr<records::RecordStore>> store = records::OpenStore(db, create);
  if (!store) Fail(command, store.status == StatusCode::kOpenFailed ? kExitFailure : kExitBadInput, store.message);
  return std::move(*store.value);
}

records::HistoryOptions OptionsOrFail(const std::string& command, const ViewArgs& args) {
  records::HistoryOptions options;
  if (!args.limits.empty()) {
    const Result<records::Limits> limits = records::ParseLimits(args.limits);
    if (!limits) Fail(command, kExitBadInput, "--limits " + args.limits + ": " + limits.message);
    options.limits = *limits;
  }
  if (args.now.empty()) {
    options.now_s = std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
  } else {
    const std::optional<double> now = ParseUtc(args.now);
    if (!now) Fail(command, kExitBadInput, "--now " + args.now + ": not ISO 8601 (2026-11-27 or 2026-11-27T14:05:00Z)");
    options.now_s = *now;
  }
  return options;
}

void Emit(const std::string& command, const ViewArgs& args, const nlohmann::json& j, const std::string& table,
          const std::string& html) {
  if (!args.out.empty()) {
    if (const Status e = config::EnsureDirectory(args.out); !e) Fail(command, kExitFailure, e.message);
    if (const Status e = config::WriteFileAtomically(args.out + "/" + command + ".json", j.dump(2) + "\n"); !e)
      Fail(command, kExitFailure, e.message);
    if (const Status e = config::WriteFileAtomically(args.out + "/report.html", html); !e)
      Fail(command, kExitFailure, e.message);
  }
  if (args.json) std::cout << j.dump(2) << std::endl;
  else std::fputs(table.c_str(), stdout);
}

void RunHistory(const std::string& robot, const ViewArgs& args) {
  const std::string name = "history";
  const records::HistoryOptions options = OptionsOrFail(name, args);
  std::unique_ptr<records::RecordStore> store = OpenOrFail(name, args.db, /*create=*/false);
  Result<std::vector<records::Record>> list = store->ForRobot(robot);
  if (!list) Fail(name, kExitFailure, list.message);
  if (list->empty()) {
    Result<std::vector<std::string>> robots = store->Robots();
    if (!robots) Fail(name, kExitFailure, robots.message);
    std::string close;
    for (const std::string& c : records::CloseNames(robot, *robots)) close += (close.empty() ? "" : ", ") + c;
    Fail(name, kExitBadInput,
         "no robot '" + robot + "' in " + store->Describe() +
             (robots->empty() ? std::string(" (it holds no records yet)")
                              : close.empty() ? " (" + std::to_string(robots->size()) + " robots; odocal fleet lists them)"
                                              : "; close names: " + close));
  }
  const records::HistoryAnalysis analysis = records::AnalyseHistory(robot, std::move(*list), options);
  Emit(name, args, records::HistoryJson(analysis), records::HistoryTable(analysis), records::HistoryHtml(analysis));
}

void RunImport(const std::vector<std::string>& folders, const std::string& db_option, const std::string& robot) {
  const std::string name = "history import";
  std::vector<records::Record> found;
  for (const std::string& folder : folders) {
    Result<records::Record> r = records::ReadRecordFile(folder);
    if (!r) Fail(name, kExitBadInput, r.message);
    if (!robot.empty()) r->robot = robot;
    found.push_back(*r);
  }
  std::unique_ptr<records::RecordStore> store = OpenOrFail(name, db_option, /*create=*/true);
  int added = 0;
  for (const records::Record& r : found) {
    Result<bool> put = store->Put(r);
    if (!put) Fail(name, kExitFailure, r.folder + ": " + put.message + " (" + std::to_string(added) + " added before it)");
    added += *put ? 1 : 0;
  }
  std::printf("imported %d record(s) into %s (%zu already kept)\n", added, store->Describe().c_str(), found.size() - added);
}

}  // namespace

void RegisterHistoryCommand(CLI::App& app) {
  struct Args {
    std::string robot;
    ViewArgs view;
    std::vector<std::string> folders;
    std::string import_db, import_robot;
  };
  auto args = std::make_shared<Args>();
  CLI::App* cmd = app.add_subcommand("history", "A robot's calibrations over time: wear, repairs, when it is due");
  cmd->add_option("robot", args->robot, "The robot's id (as its records name it)");
  AddViewOptions(cmd, &args->view);
  CLI::App* import = cmd->add_subcommand(
      "import", "Keep the records run folders hold (record.json), e.g. of runs whose store was unreachable");
  import->add_option("folders", args->folders, "Run folders (or record.json files)")->required();
  import->add_option("--db", args->import_db, "Record store (default: $ODOCAL_DB, else ~/.local/share/odocal/records.sqlite)");
  import->add_option("--robot", args->import_robot, "Name the robot (for records made without one)");
  import->callback([args]() { RunImport(args->folders, args->import_db, args->import_robot); });
  cmd->callback([args, cmd]() {
    if (cmd->got_subcommand("import")) return;
    if (args->robot.empty()) Fail("history", kExitBadInput, "give a ROBOT (odocal fleet lists them) or `import DIR`");
    RunHistory(args->robot, args->view);
  });
}

void RegisterFleetCommand(CLI::App& app) {
  auto args = std::make_shared<ViewArgs>();
  CLI::App* cmd = app.add_subcommand(
      "fleet", "Every robot's last calibration, its verdict and drift, who is due; the line's pass rate and charts");
  AddViewOptions(cmd, args.get());
  cmd->callback([args]() {
    const std::string name = "fleet";
    const records::HistoryOptions options = OptionsOrFail(name, *args);
    std::unique_ptr<records::RecordStore> store = OpenOrFail(name, args->db, /*create=*/false);
    Result<std::vector<records::Record>> all = store->All();
    if (!all) Fail(name, kExitFailure, all.message);
    const records::FleetSummary fleet = records::SummariseFleet(*all, options);
    Emit(name, *args, records::FleetJson(fleet), records::FleetTable(fleet), records::FleetHtml(fleet));
  });
}

}  // namespace odocal::app
