#include "record_util.h"

#include <cstdio>

#include <CLI/CLI.hpp>

#include "cli_util.h"
#include "odocal/records/store.h"

namespace odocal::app {

void AddRecordOptions(CLI::App* cmd, RecordArgs* args, bool with_limits) {
  cmd->add_option("--db", args->db,
                  "Record store: a file (SQLite) or postgresql://user@host/db (default: $ODOCAL_DB, else "
                  "~/.local/share/odocal/records.sqlite)");
  cmd->add_option("--robot", args->robot, "The robot's id in the record store (default: the session's robot.id, or "
                                          "the name the robot gives on the link)");
  cmd->add_flag("--no-record", args->no_record, "Keep no record (record.json is still written)");
  if (with_limits)
    cmd->add_option("--limits", args->limits,
                    "Acceptance limits, e.g. emax_syst_after_mm=2,ed=0.5%,eb=2% (also emax_syst_before_mm, "
                    "recalibrate_days): PASS or FAIL, exit 6 on FAIL");
}

records::Limits LimitsOrFail(const std::string& command, const RecordArgs& args, const records::Limits& from_file) {
  if (args.limits.empty()) return from_file;
  const Result<records::Limits> limits = records::ParseLimits(args.limits);
  if (!limits) Fail(command, kExitBadInput, "--limits " + args.limits + ": " + limits.message);
  return *limits;
}

std::string VerdictLine(const records::Record& record, const records::Limits& limits) {
  switch (record.verdict) {
    case records::Verdict::kNone: return "";
    case records::Verdict::kPass: return "limits: PASS (" + records::Describe(limits) + ")";
    case records::Verdict::kFail: {
      std::string failed;
      for (const std::string& f : record.failed_limits) failed += (failed.empty() ? "" : "; ") + f;
      return "limits: FAIL: " + failed;
    }
  }
  return "";
}

records::Record KeepRecord(const std::string& command, const nlohmann::json& report, const RunIdentity& run,
                           const RecordArgs& args, const records::Limits& limits) {
  records::RecordContext context;
  context.robot = args.robot.empty() ? run.robot : args.robot;
  context.time_utc = run.time_utc;
  context.folder = run.folder;
  context.digest = run.digest;
  Result<records::Record> made = records::RecordFromReport(run.kind, report, context);
  if (!made) {
    std::fprintf(stderr, "odocal %s: record not made: %s\n", command.c_str(), made.message.c_str());
    return records::Record{};
  }
  records::Record record = *made;
  if (run.odometer_km) record.distance_km = run.odometer_km;
  records::Judge(limits, &record);
  if (Status s = records::WriteRecordFile(record, run.folder); !s) {
    std::fprintf(stderr, "odocal %s: record.json not written: %s\n", command.c_str(), s.message.c_str());
    return record;
  }
  if (args.no_record) return record;
  const std::string db = args.db.empty() ? records::DefaultDatabase() : args.db;
  const std::string later = "add it later: odocal history import " + run.folder +
                            (args.db.empty() ? std::string() : " --db " + records::WithoutPassword(args.db)) +
                            (record.robot.empty() ? std::string(" --robot ID") : std::string());
  Result<bool> added = Result<bool>::Error(StatusCode::kFailed, "");
  Result<std::unique_ptr<records::RecordStore>> store = records::OpenStore(db);
  if (!store) {
    added = Result<bool>::From(store);
  } else {
    added = (*store)->Put(record);
    if (!added) added.message = (*store)->Describe() + ": " + added.message;
  }
  if (!added) {
    std::fprintf(stderr, "odocal %s: record not kept: %s; the run folder has it (record.json): %s\n", command.c_str(),
                 added.message.c_str(), later.c_str());
  } else {
    std::printf("record: %s for robot %s in %s\n", *added ? "kept" : "already kept (same robot and content)",
                record.robot.c_str(), (*store)->Describe().c_str());
  }
  return record;
}

}  // namespace odocal::app
