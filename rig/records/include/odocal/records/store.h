// The record store: one table of calibrations keyed by (robot, digest), in SQLite (one file,
// the default) or PostgreSQL (a server several stations share). The schema is versioned:
// opening a store applies the migrations it lacks in one transaction; a store written by a
// newer odocal is refused, naming both versions (docs/formats.md, "Records").
//
//   Result<std::unique_ptr<RecordStore>> store = records::OpenStore(records::DefaultDatabase());
//   Result<bool> added = (*store)->Put(record);    // false: already kept (same robot and digest)
//   Result<std::vector<Record>> all = (*store)->ForRobot("R-0042");
#ifndef ODOCAL_RECORDS_STORE_H_
#define ODOCAL_RECORDS_STORE_H_

#include <memory>
#include <string>
#include <vector>

#include "odocal/base/status.h"
#include "odocal/records/record.h"

namespace odocal::records {

// The schema version this odocal writes (and the newest it reads).
inline constexpr int kSchemaVersion = 1;

class RecordStore {
 public:
  virtual ~RecordStore() = default;
  // Keeps `record` in one transaction. Ok(true): added; Ok(false): a record with the same robot
  // and digest is already kept (nothing changes). An error leaves the store as it was.
  virtual Result<bool> Put(const Record& record) = 0;
  // The robot's records, oldest first (by time_utc, then by when they were kept).
  virtual Result<std::vector<Record>> ForRobot(const std::string& robot) = 0;
  // Every robot's records, grouped by robot (sorted by name), each oldest first.
  virtual Result<std::vector<Record>> All() = 0;
  // Every robot with at least one record, sorted.
  virtual Result<std::vector<std::string>> Robots() = 0;
  // "sqlite /path/file" or "postgresql host:port/db" (no password), for messages.
  virtual std::string Describe() const = 0;
  virtual int SchemaVersion() const = 0;
};

// `db` is a file path (SQLite; created with its directory when missing) or a
// postgresql:// (or postgres://) URL. Errors name the database: unreachable, not an odocal
// record store (a corrupt file is never read as an empty one), a newer schema.
// `create` false (history, fleet: they only read): a SQLite file that is not there is an error
// naming it (a mistyped --db is not an empty fleet), and nothing is created.
Result<std::unique_ptr<RecordStore>> OpenStore(const std::string& db, bool create = true);

// The passwords a postgresql:// URL carries (the user info's, a password= parameter's); none
// for a path. WithoutPassword: `db` with each replaced by ***, for messages.
std::vector<std::string> PasswordsIn(const std::string& db);
std::string WithoutPassword(const std::string& db);

// $ODOCAL_DB when set, else $XDG_DATA_HOME/odocal/records.sqlite, else
// ~/.local/share/odocal/records.sqlite.
std::string DefaultDatabase();

// The names in `known` closest to `name` (edit distance, at most `count`): for "no robot X,
// did you mean ...".
std::vector<std::string> CloseNames(const std::string& name, const std::vector<std::string>& known, int count = 3);

}  // namespace odocal::records

#endif  // ODOCAL_RECORDS_STORE_H_
