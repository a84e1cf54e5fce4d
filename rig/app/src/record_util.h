// Every station, batch, check and explain run leaves a record (records/record.h): made from the
// report it wrote, saved as record.json beside it, kept in the record store (--db, $ODOCAL_DB,
// or the user's data directory), and judged against the line's limits. A store that cannot be
// reached never costs the run: the folder is written, the message says how to add it later.
#ifndef ODOCAL_APP_RECORD_UTIL_H_
#define ODOCAL_APP_RECORD_UTIL_H_

#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "odocal/records/limits.h"
#include "odocal/records/record.h"

namespace CLI {
class App;
}

namespace odocal::app {

// Calibrated, but outside the line's limits (--limits, station.yaml's limits:).
inline constexpr int kExitOutsideLimits = 6;

struct RecordArgs {
  std::string db;      // empty: records::DefaultDatabase()
  std::string robot;   // empty: the session's robot.id or the link's name
  std::string limits;  // KEY=VALUE,... (records/limits.h); empty: none (or the station file's)
  bool no_record = false;
};

// --db, --robot, --no-record and, with `with_limits`, --limits.
void AddRecordOptions(CLI::App* cmd, RecordArgs* args, bool with_limits);

// --limits parsed (it replaces `from_file`'s when given); fails `command` with exit 2 otherwise.
records::Limits LimitsOrFail(const std::string& command, const RecordArgs& args, const records::Limits& from_file = {});

// What the report does not say about the run.
struct RunIdentity {
  records::RunKind kind = records::RunKind::kBatch;
  std::string folder;        // the run folder (record.json goes here)
  std::string digest;        // records/digest.h
  std::string robot;         // the session's robot.id; --robot overrides
  std::string time_utc;      // the session's recorded_utc; empty: now
  std::optional<double> odometer_km;
};

// Makes the record from `report`, judges it, writes record.json, keeps it (unless --no-record)
// and prints one line saying where it went or why not. Returns the record (its verdict).
records::Record KeepRecord(const std::string& command, const nlohmann::json& report, const RunIdentity& run,
                           const RecordArgs& args, const records::Limits& limits);

// The verdict line ("limits: PASS (...)" / "limits: FAIL: ..."), empty without limits.
std::string VerdictLine(const records::Record& record, const records::Limits& limits);

}  // namespace odocal::app

#endif  // ODOCAL_APP_RECORD_UTIL_H_
