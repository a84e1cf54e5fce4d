// The SQLite record store: one file, WAL journal (several stations may write one file at the
// same moment: each write is one IMMEDIATE transaction, a busy writer waits up to 30 s).
#include "backends.h"

#include <sqlite3.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <memory>
#include <thread>

#include "schema.h"

namespace odocal::records::internal {
namespace {

constexpr int kBusyTimeoutMs = 30000;

struct StatementDeleter {
  void operator()(sqlite3_stmt* s) const { sqlite3_finalize(s); }
};
using Statement = std::unique_ptr<sqlite3_stmt, StatementDeleter>;

class SqliteStore final : public RecordStore {
 public:
  SqliteStore(sqlite3* db, std::string path) : db_(db), path_(std::move(path)) {}
  ~SqliteStore() override { sqlite3_close_v2(db_); }

  std::string Describe() const override { return "sqlite " + path_; }
  int SchemaVersion() const override { return version_; }

  // Reads the schema version and applies the migrations the file lacks.
  Status Open() {
    sqlite3_busy_timeout(db_, kBusyTimeoutMs);
    // Anything read first tells a file that is not a database ("file is not a database").
    Result<int> tables = CountTables();
    if (!tables) return Status::From(tables);
    Result<int> version = ReadVersion();
    if (!version) return Status::From(version);
    if (*version < 0 && *tables > 0)
      return Error(StatusCode::kBadFile, "holds tables but no odocal_schema: not an odocal record store");
    if (*version > kSchemaVersion) return NewerSchema(*version);
    if (*version < kSchemaVersion) {
      if (Status s = UseWal(); !s) return s;
      if (Status s = Migrate(); !s) return s;
    }
    version_ = kSchemaVersion;
    return Status::Ok();
  }

  Result<bool> Put(const Record& record) override {
    if (Status s = Storable(record); !s) return Result<bool>::From(s);
    const RecordRow row = RowOf(record);
    if (Status s = Exec("BEGIN IMMEDIATE"); !s) return Result<bool>::From(s);
    Statement st = Prepare(std::string("INSERT INTO records (") + kInsertColumns +
                           ") VALUES (?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?) ON CONFLICT (robot, digest) DO NOTHING");
    if (!st) return Rollback<bool>("cannot prepare the insert");
    int i = 1;
    for (const std::string* text : {&row.robot, &row.digest, &row.kind, &row.time_utc, &row.host, &row.odocal_version,
                                    &row.folder, &row.verdict, &row.kept_utc, &row.document})
      sqlite3_bind_text(st.get(), i++, text->c_str(), static_cast<int>(text->size()), SQLITE_TRANSIENT);
    for (const std::optional<double>* v : {&row.ed, &row.eb, &row.emax_syst_before_mm, &row.emax_syst_after_mm,
                                           &row.mean_wheel_diameter_mm, &row.track_mm}) {
      if (*v) sqlite3_bind_double(st.get(), i, **v);
      else sqlite3_bind_null(st.get(), i);
      ++i;
    }
    if (sqlite3_step(st.get()) != SQLITE_DONE) return Rollback<bool>("cannot insert the record");
    const bool added = sqlite3_changes(db_) > 0;
    st.reset();
    if (Status s = Exec("COMMIT"); !s) return Rollback<bool>("cannot commit the record");
    return Result<bool>::Ok(added);
  }

  Result<std::vector<Record>> ForRobot(const std::string& robot) override {
    return Select("SELECT document FROM records WHERE robot = ? ORDER BY time_utc, id", &robot);
  }
  Result<std::vector<Record>> All() override {
    return Select("SELECT document FROM records ORDER BY robot, time_utc, id", nullptr);
  }
  Result<std::vector<std::string>> Robots() override {
    using R = Result<std::vector<std::string>>;
    Statement st = Prepare("SELECT DISTINCT robot FROM records ORDER BY robot");
    if (!st) return R::From(Error(StatusCode::kIoError, "cannot list the robots"));
    std::vector<std::string> out;
    int rc;
    while ((rc = sqlite3_step(st.get())) == SQLITE_ROW)
      out.emplace_back(reinterpret_cast<const char*>(sqlite3_column_text(st.get(), 0)));
    if (rc != SQLITE_DONE) return R::From(Error(StatusCode::kIoError, "cannot list the robots"));
    return R::Ok(std::move(out));
  }

 private:
  Status Error(StatusCode code, const std::string& what) const {
    return Status::Error(code, path_ + ": " + what + " (" + sqlite3_errmsg(db_) + ")");
  }
  Status NewerSchema(int version) const { return NewerSchemaError(path_, version); }

  template <typename T>
  Result<T> Rollback(const std::string& what) {
    const Status error = Error(StatusCode::kIoError, what);
    sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
    return Result<T>::From(error);
  }
  Status Exec(const std::string& sql) {
    char* message = nullptr;
    if (sqlite3_exec(db_, sql.c_str(), nullptr, nullptr, &message) != SQLITE_OK) {
      const std::string m = message ? message : sqlite3_errmsg(db_);
      sqlite3_free(message);
      return Status::Error(StatusCode::kIoError, path_ + ": " + m);
    }
    return Status::Ok();
  }
  // Switching to WAL takes the file's exclusive lock from within a read, so SQLite answers
  // SQLITE_BUSY at once, without the busy handler, while another connection reads (two
  // stations opening a new file together): retried here for as long as the busy timeout.
  Status UseWal() {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(kBusyTimeoutMs);
    for (int attempt = 1;; ++attempt) {
      Status s = Exec("PRAGMA journal_mode=WAL");
      if (s || (sqlite3_errcode(db_) & 0xff) != SQLITE_BUSY || std::chrono::steady_clock::now() > deadline) return s;
      std::this_thread::sleep_for(std::chrono::milliseconds(std::min(attempt, 20)));
    }
  }
  Statement Prepare(const std::string& sql) {
    sqlite3_stmt* st = nullptr;
    if (sqlite3_prepare_v2(db_, sql.c_str(), -1, &st, nullptr) != SQLITE_OK) return Statement();
    return Statement(st);
  }
  // A file that is no database is a bad file; one SQLite cannot read for another reason is not
  // (a WAL store in a read-only directory cannot make its -shm file: "readonly database").
  Result<int> CountTables() {
    Statement st = Prepare("SELECT count(*) FROM sqlite_master WHERE type = 'table'");
    if (!st || sqlite3_step(st.get()) != SQLITE_ROW) {
      const int code = sqlite3_errcode(db_) & 0xff;
      if (code == SQLITE_NOTADB || code == SQLITE_CORRUPT)
        return Result<int>::From(Error(StatusCode::kBadFile, "cannot be read as an odocal record store"));
      return Result<int>::From(Error(StatusCode::kOpenFailed,
                                     code == SQLITE_READONLY ? "cannot read the record store: SQLite must write its -shm file beside it"
                                                             : "cannot read the record store"));
    }
    return Result<int>::Ok(sqlite3_column_int(st.get(), 0));
  }
  // -1: no odocal_schema table.
  Result<int> ReadVersion() {
    Statement has = Prepare("SELECT count(*) FROM sqlite_master WHERE type = 'table' AND name = 'odocal_schema'");
    if (!has || sqlite3_step(has.get()) != SQLITE_ROW)
      return Result<int>::From(Error(StatusCode::kBadFile, "cannot read the schema version"));
    if (sqlite3_column_int(has.get(), 0) == 0) return Result<int>::Ok(-1);
    Statement st = Prepare("SELECT max(version) FROM odocal_schema");
    if (!st || sqlite3_step(st.get()) != SQLITE_ROW)
      return Result<int>::From(Error(StatusCode::kBadFile, "cannot read the schema version"));
    return Result<int>::Ok(sqlite3_column_type(st.get(), 0) == SQLITE_NULL ? 0 : sqlite3_column_int(st.get(), 0));
  }
  Status Migrate() {
    // Two stations opening a new file at once: the second waits here, then finds it done.
    if (Status s = Exec("BEGIN IMMEDIATE"); !s) return s;
    const Status migrated = ApplyMigrations(
        Dialect::kSqlite, [this](const std::string& sql) { return Exec(sql); }, [this] { return ReadVersion(); },
        [this](int version) { return NewerSchema(version); });
    if (!migrated) {
      Exec("ROLLBACK");
      return migrated;
    }
    return Exec("COMMIT");
  }
  Result<std::vector<Record>> Select(const std::string& sql, const std::string* robot) {
    using R = Result<std::vector<Record>>;
    Statement st = Prepare(sql);
    if (!st) return R::From(Error(StatusCode::kIoError, "cannot read the records"));
    if (robot) sqlite3_bind_text(st.get(), 1, robot->c_str(), static_cast<int>(robot->size()), SQLITE_TRANSIENT);
    std::vector<Record> out;
    int rc;
    while ((rc = sqlite3_step(st.get())) == SQLITE_ROW) {
      const char* text = reinterpret_cast<const char*>(sqlite3_column_text(st.get(), 0));
      Result<Record> r = RecordFromDocument(text, path_);
      if (!r) return R::From(r);
      out.push_back(std::move(*r));
    }
    if (rc != SQLITE_DONE) return R::From(Error(StatusCode::kIoError, "cannot read the records"));
    return R::Ok(std::move(out));
  }

  sqlite3* db_;
  std::string path_;
  int version_ = 0;
};

}  // namespace

Result<std::unique_ptr<RecordStore>> OpenSqliteStore(const std::string& path) {
  using R = Result<std::unique_ptr<RecordStore>>;
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::path parent = fs::path(path).parent_path();
  if (!parent.empty() && !fs::exists(parent)) fs::create_directories(parent, ec);
  if (ec) return R::Error(StatusCode::kOpenFailed, path + ": cannot create its directory: " + ec.message());
  if (fs::is_directory(path)) return R::Error(StatusCode::kOpenFailed, path + ": is a directory, not a record store file");
  sqlite3* db = nullptr;
  const int rc = sqlite3_open_v2(path.c_str(), &db, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_FULLMUTEX, nullptr);
  if (rc != SQLITE_OK) {
    const std::string m = db ? sqlite3_errmsg(db) : sqlite3_errstr(rc);
    sqlite3_close_v2(db);
    return R::Error(StatusCode::kOpenFailed, path + ": cannot open the record store (" + m + ")");
  }
  auto store = std::make_unique<SqliteStore>(db, path);
  if (Status s = store->Open(); !s) return R::From(s);
  return R::Ok(std::move(store));
}

}  // namespace odocal::records::internal
