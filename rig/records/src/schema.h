// The record store's schema, one migration per version, in the SQL both SQLite and PostgreSQL
// read (the key column's type is the one difference). Version N's migration takes a store at
// N - 1 to N; a store records its version in odocal_schema.
#ifndef ODOCAL_RECORDS_SRC_SCHEMA_H_
#define ODOCAL_RECORDS_SRC_SCHEMA_H_

#include <functional>
#include <string>
#include <vector>

#include "odocal/records/record.h"

namespace odocal::records::internal {

enum class Dialect { kSqlite, kPostgres };

// The statements of migration `version` (1 .. kSchemaVersion).
std::vector<std::string> Migration(int version, Dialect dialect);

// Inside a write transaction the caller opened (and rolls back on an error): creates
// odocal_schema when missing, reads its version (`read_version`), refuses a newer one (`newer`'s
// error) and applies each later migration with `exec`, recording it. Both stores migrate so.
Status ApplyMigrations(Dialect dialect, const std::function<Status(const std::string&)>& exec,
                       const std::function<Result<int>()>& read_version, const std::function<Status(int)>& newer);

// The columns a record is stored in, besides its document: what fleet and history select on.
struct RecordRow {
  std::string robot, digest, kind, time_utc, host, odocal_version, folder, verdict, kept_utc, document;
  std::optional<double> ed, eb, emax_syst_before_mm, emax_syst_after_mm, mean_wheel_diameter_mm, track_mm;
};
RecordRow RowOf(const Record& record);
// A record is kept only with its key: a robot and a digest.
Status Storable(const Record& record);
// The error for a store whose schema `version` is newer than this odocal's, naming `store`,
// both versions and this odocal's release (both stores word it so).
Status NewerSchemaError(const std::string& store, int version);
// A stored document read back; a damaged one is an error naming the store (`store`), never skipped.
Result<Record> RecordFromDocument(const char* document, const std::string& store);

inline constexpr const char* kInsertColumns =
    "robot, digest, kind, time_utc, host, odocal_version, folder, verdict, kept_utc, document, ed, eb, "
    "emax_syst_before_mm, emax_syst_after_mm, mean_wheel_diameter_mm, track_mm";

}  // namespace odocal::records::internal

#endif  // ODOCAL_RECORDS_SRC_SCHEMA_H_
