// One calibration kept: what a station, batch, check or explain run found for one robot, in
// the form the record store keeps it (docs/formats.md, "Records"). A record is made from the
// run's own report (report.json, check.json, explain.json: the documents other tools already
// read), written beside it as record.json, and then stored: the store can be down, the folder
// still holds what it would have kept (`odocal history import DIR`).
//
//   Result<Record> r = records::RecordFromReport(records::RunKind::kBatch, report_json, context);
//   records::WriteRecordFile(*r, out_dir);                  // record.json beside report.json
//   store->Put(*r);                                         // once per (robot, digest)
#ifndef ODOCAL_RECORDS_RECORD_H_
#define ODOCAL_RECORDS_RECORD_H_

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "odocal/base/status.h"
#include "odocal/base/utc_time.h"

namespace odocal::records {

enum class RunKind { kStation, kBatch, kCheck, kExplain };
std::string_view ToString(RunKind kind);
std::optional<RunKind> RunKindFromString(std::string_view text);

// A value with its 1-sigma when the run stated one.
struct Estimate {
  double value = 0.0;
  std::optional<double> sigma;
};

// A robot's wheel set in the units of its exports (mm, counts per revolution).
struct WheelSet {
  Estimate left_wheel_diameter_mm;
  Estimate right_wheel_diameter_mm;
  Estimate track_mm;
  double ticks_per_rev = 0.0;
  // The mean wheel diameter (the travel scale), with the sigma of the mean when both wheels
  // have one (treated as independent: an upper bound when they are positively correlated).
  Estimate MeanWheelDiameterMm() const;
};

// The verdict against the line's limits (limits.h): kNone when no limits were given.
enum class Verdict { kNone, kPass, kFail };
std::string_view ToString(Verdict verdict);

struct Record {
  std::string robot;          // the link's serial, --robot, or the session's robot.id
  RunKind kind = RunKind::kBatch;
  std::string time_utc;       // when the robot was measured (ISO 8601, UTC, seconds)
  std::string host;           // the station (host name) that measured it
  std::string odocal_version;
  std::string digest;         // sha256 hex of the run's content (digest.h): the record's key with `robot`
  std::string folder;         // the run folder (absolute path) holding the reports

  std::optional<WheelSet> before;  // the parameters the robot drove with
  std::optional<WheelSet> after;   // the calibrated set (with sigmas where the estimator gave them)
  std::optional<Estimate> ed;      // the wheel-diameter ratio Ed = D_R / D_L the calibration found
  std::optional<Estimate> eb;      // the track scale Eb (true / believed)
  std::optional<Estimate> emax_syst_before_mm;  // UMBMark's E_max,syst with `before`
  std::optional<Estimate> emax_syst_after_mm;   // measured again with `after` (station only)
  std::optional<double> distance_km;            // the robot's odometer when known (wear per 1000 km)
  std::vector<std::string> findings;            // significant effects, in words
  Verdict verdict = Verdict::kNone;
  std::vector<std::string> failed_limits;       // each limit that failed, in words
  std::string status;                           // the run's own outcome (converged, measured, ...)
};

nlohmann::json ToJson(const Record& record);
// An estimate as record.json and history.json write it: {"value", "sigma"}, null when absent.
nlohmann::json ToJson(const std::optional<Estimate>& estimate);
// A record.json read back; a missing or mistyped key is an error naming it.
Result<Record> RecordFromJson(const nlohmann::json& j);

// Where the run was, who it was: what the report itself does not say.
struct RecordContext {
  std::string robot;           // empty: the report's robot_id or robot_name (the link's); may stay empty
  std::string time_utc;        // empty: now
  std::string host;            // empty: this machine's host name
  std::string folder;          // the run folder
  std::string digest;          // the run's content digest (digest.h)
};

// The record of a run from its report document: report.json (station, batch), check.json
// (check) or explain.json (explain). The keys read are in docs/formats.md, "Records". The
// robot may be left unnamed (a store refuses such a record; `history import --robot` names it).
Result<Record> RecordFromReport(RunKind kind, const nlohmann::json& report, const RecordContext& context);

// record.json in `folder`, written atomically; the file `history import` reads.
Status WriteRecordFile(const Record& record, const std::string& folder);
Result<Record> ReadRecordFile(const std::string& folder_or_file);

// odocal's version as it writes it into records.
std::string_view OdocalVersion();
// Time in records: ISO 8601 UTC (base/utc_time.h).
using odocal::FormatUtc;
using odocal::NowUtc;
using odocal::ParseUtc;

}  // namespace odocal::records

#endif  // ODOCAL_RECORDS_RECORD_H_
