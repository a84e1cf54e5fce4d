#include "schema.h"

#include <algorithm>

#include "odocal/records/store.h"

namespace odocal::records::internal {

std::vector<std::string> Migration(int version, Dialect dialect) {
  const std::string key =
      dialect == Dialect::kSqlite ? "id INTEGER PRIMARY KEY AUTOINCREMENT" : "id BIGSERIAL PRIMARY KEY";
  switch (version) {
    case 1:
      return {"CREATE TABLE records (" + key +
                  ", robot TEXT NOT NULL, digest TEXT NOT NULL, kind TEXT NOT NULL, time_utc TEXT NOT NULL, "
                  "host TEXT NOT NULL, odocal_version TEXT NOT NULL, folder TEXT NOT NULL, verdict TEXT NOT NULL, "
                  "kept_utc TEXT NOT NULL, document TEXT NOT NULL, ed DOUBLE PRECISION, eb DOUBLE PRECISION, "
                  "emax_syst_before_mm DOUBLE PRECISION, emax_syst_after_mm DOUBLE PRECISION, "
                  "mean_wheel_diameter_mm DOUBLE PRECISION, track_mm DOUBLE PRECISION, "
                  "UNIQUE (robot, digest))",
              "CREATE INDEX records_by_robot_time ON records (robot, time_utc)"};
    default:
      return {};
  }
}

Status ApplyMigrations(Dialect dialect, const std::function<Status(const std::string&)>& exec,
                       const std::function<Result<int>()>& read_version, const std::function<Status(int)>& newer) {
  if (Status s = exec("CREATE TABLE IF NOT EXISTS odocal_schema (version INTEGER NOT NULL, applied_utc TEXT NOT NULL)"); !s)
    return s;
  // Read inside the transaction: a store another process migrated meanwhile is found done.
  const Result<int> version = read_version();
  if (!version) return Status::From(version);
  if (*version > kSchemaVersion) return newer(*version);
  for (int v = std::max(*version, 0) + 1; v <= kSchemaVersion; ++v) {
    for (const std::string& sql : Migration(v, dialect))
      if (Status s = exec(sql); !s) return s;
    if (Status s = exec("INSERT INTO odocal_schema (version, applied_utc) VALUES (" + std::to_string(v) + ", '" +
                        NowUtc() + "')");
        !s)
      return s;
  }
  return Status::Ok();
}

RecordRow RowOf(const Record& r) {
  RecordRow row;
  row.robot = r.robot;
  row.digest = r.digest;
  row.kind = std::string(ToString(r.kind));
  row.time_utc = r.time_utc;
  row.host = r.host;
  row.odocal_version = r.odocal_version;
  row.folder = r.folder;
  row.verdict = std::string(ToString(r.verdict));
  row.kept_utc = NowUtc();
  row.document = ToJson(r).dump();
  if (r.ed) row.ed = r.ed->value;
  if (r.eb) row.eb = r.eb->value;
  if (r.emax_syst_before_mm) row.emax_syst_before_mm = r.emax_syst_before_mm->value;
  if (r.emax_syst_after_mm) row.emax_syst_after_mm = r.emax_syst_after_mm->value;
  if (r.after) {
    row.mean_wheel_diameter_mm = r.after->MeanWheelDiameterMm().value;
    row.track_mm = r.after->track_mm.value;
  }
  return row;
}

Status Storable(const Record& r) {
  if (r.robot.empty())
    return Status::Error(StatusCode::kInvalidArgument,
                         "the robot is not named: give --robot ID (or robot.id in session.yaml; a robot on the link "
                         "names itself)");
  if (r.digest.empty()) return Status::Error(StatusCode::kInvalidArgument, "the record has no digest (its key)");
  if (!ParseUtc(r.time_utc)) return Status::Error(StatusCode::kInvalidArgument, "time_utc `" + r.time_utc + "` is not ISO 8601");
  return Status::Ok();
}

Status NewerSchemaError(const std::string& store, int version) {
  return Status::Error(StatusCode::kVersionMismatch,
                       store + ": record store schema version " + std::to_string(version) + " is newer than this odocal's (" +
                           std::to_string(kSchemaVersion) + "): use a newer odocal (odocal " + std::string(OdocalVersion()) +
                           " reads versions up to " + std::to_string(kSchemaVersion) + ")");
}

Result<Record> RecordFromDocument(const char* document, const std::string& store) {
  Result<Record> r = RecordFromJson(nlohmann::json::parse(document ? document : "", nullptr, false));
  if (!r) return Result<Record>::Error(StatusCode::kBadFile, store + ": a stored record is damaged: " + r.message);
  return r;
}

}  // namespace odocal::records::internal
