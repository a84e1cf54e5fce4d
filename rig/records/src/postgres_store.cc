// The PostgreSQL record store (libpq): one server shared by the stations of a line or the
// machines of a batch. Each record is one INSERT ... ON CONFLICT DO NOTHING (atomic on its own);
// migrations run in one transaction under an advisory lock, so shards opening a new database
// at once apply them once.
#include <libpq-fe.h>

#include <memory>

#include "backends.h"
#include "odocal/base/format.h"
#include "schema.h"

namespace odocal::records::internal {
namespace {

// Any fixed number: the lock that serialises odocal's migrations on a server.
constexpr long long kMigrationLock = 0x0d0ca1;

struct ResultDeleter {
  void operator()(PGresult* r) const { PQclear(r); }
};
using PgResult = std::unique_ptr<PGresult, ResultDeleter>;

// "postgresql://user:secret@host:5432/db?x=y" -> "postgresql host:5432/db" (no credentials).
// The query goes first: a '@' in it (application_name=a@b) is not the credentials' end.
std::string Redacted(const std::string& url) {
  std::string rest = url.substr(url.find("://") + 3);
  if (const size_t q = rest.find('?'); q != std::string::npos) rest = rest.substr(0, q);
  if (const size_t at = rest.rfind('@', rest.find('/')); at != std::string::npos) rest = rest.substr(at + 1);
  return "postgresql " + rest;
}

// libpq's message about a URL it cannot parse quotes the URL, password and all ("... in URI:
// \"postgresql://u:secret@[::1/x\""): the URL becomes its redacted name, and any password left
// stars (store.h's PasswordsIn).
std::string Scrubbed(std::string message, const std::string& url) {
  auto replace_all = [&message](const std::string& what, const std::string& with) {
    if (what.empty()) return;
    for (size_t at = message.find(what); at != std::string::npos; at = message.find(what, at + with.size()))
      message.replace(at, what.size(), with);
  };
  replace_all(url, Redacted(url));
  for (const std::string& secret : PasswordsIn(url)) replace_all(secret, "***");
  return message;
}

// Text is ordered COLLATE "C" (by bytes, as SQLite does): a database's own collation (en_US:
// "r-0001" before "R-0002") would order robots, and fleet tables, by the server's locale.
class PostgresStore final : public RecordStore {
 public:
  PostgresStore(PGconn* conn, std::string name) : conn_(conn), name_(std::move(name)) {}
  ~PostgresStore() override { PQfinish(conn_); }
  std::string Describe() const override { return name_; }
  int SchemaVersion() const override { return version_; }

  Status Open() {
    PQsetNoticeProcessor(conn_, [](void*, const char*) {}, nullptr);  // "relation exists, skipping"
    Result<int> version = ReadVersion();
    if (!version) return Status::From(version);
    if (*version > kSchemaVersion) return NewerSchema(*version);
    if (*version < kSchemaVersion) {
      if (Status s = Migrate(); !s) return s;
    }
    version_ = kSchemaVersion;
    return Status::Ok();
  }

  Result<bool> Put(const Record& record) override {
    if (Status s = Storable(record); !s) return Result<bool>::From(s);
    const RecordRow row = RowOf(record);
    std::vector<std::string> numbers;
    std::vector<const char*> values;
    for (const std::string* text : {&row.robot, &row.digest, &row.kind, &row.time_utc, &row.host, &row.odocal_version,
                                    &row.folder, &row.verdict, &row.kept_utc, &row.document})
      values.push_back(text->c_str());
    numbers.reserve(6);
    for (const std::optional<double>* v : {&row.ed, &row.eb, &row.emax_syst_before_mm, &row.emax_syst_after_mm,
                                           &row.mean_wheel_diameter_mm, &row.track_mm}) {
      if (*v) {
        numbers.push_back(Format("%.17g", **v));
        values.push_back(numbers.back().c_str());
      } else {
        values.push_back(nullptr);
      }
    }
    const std::string sql = std::string("INSERT INTO records (") + kInsertColumns +
                            ") VALUES ($1,$2,$3,$4,$5,$6,$7,$8,$9,$10,$11,$12,$13,$14,$15,$16) "
                            "ON CONFLICT (robot, digest) DO NOTHING";
    PgResult r(PQexecParams(conn_, sql.c_str(), static_cast<int>(values.size()), nullptr, values.data(), nullptr,
                            nullptr, 0));
    if (PQresultStatus(r.get()) != PGRES_COMMAND_OK) return Result<bool>::From(Error(StatusCode::kIoError, "cannot insert the record"));
    return Result<bool>::Ok(std::string(PQcmdTuples(r.get())) == "1");
  }

  Result<std::vector<Record>> ForRobot(const std::string& robot) override {
    return Select("SELECT document FROM records WHERE robot = $1 ORDER BY time_utc COLLATE \"C\", id", &robot);
  }
  Result<std::vector<Record>> All() override {
    return Select("SELECT document FROM records ORDER BY robot COLLATE \"C\", time_utc COLLATE \"C\", id", nullptr);
  }
  Result<std::vector<std::string>> Robots() override {
    using R = Result<std::vector<std::string>>;
    PgResult r(PQexec(conn_, "SELECT DISTINCT robot COLLATE \"C\" FROM records ORDER BY 1"));
    if (PQresultStatus(r.get()) != PGRES_TUPLES_OK) return R::From(Error(StatusCode::kIoError, "cannot list the robots"));
    std::vector<std::string> out;
    for (int i = 0; i < PQntuples(r.get()); ++i) out.emplace_back(PQgetvalue(r.get(), i, 0));
    return R::Ok(std::move(out));
  }

 private:
  Status Error(StatusCode code, const std::string& what) const {
    std::string m = PQerrorMessage(conn_);
    while (!m.empty() && (m.back() == '\n' || m.back() == ' ')) m.pop_back();
    return Status::Error(code, name_ + ": " + what + (m.empty() ? "" : " (" + m + ")"));
  }
  Status NewerSchema(int version) const { return NewerSchemaError(name_, version); }

  Status Exec(const std::string& sql) {
    PgResult r(PQexec(conn_, sql.c_str()));
    const ExecStatusType st = PQresultStatus(r.get());
    if (st != PGRES_COMMAND_OK && st != PGRES_TUPLES_OK) {
      std::string what(sql, 0, std::min<size_t>(sql.size(), 40));  // (appending to a literal trips GCC 12's -Wrestrict)
      what.append("... failed");
      return Error(StatusCode::kIoError, what);
    }
    return Status::Ok();
  }
  // -1: no odocal_schema table.
  Result<int> ReadVersion() {
    PgResult has(PQexec(conn_, "SELECT to_regclass('odocal_schema') IS NOT NULL"));
    if (PQresultStatus(has.get()) != PGRES_TUPLES_OK)
      return Result<int>::From(Error(StatusCode::kIoError, "cannot read the schema version"));
    if (std::string(PQgetvalue(has.get(), 0, 0)) != "t") return Result<int>::Ok(-1);
    PgResult r(PQexec(conn_, "SELECT coalesce(max(version), 0) FROM odocal_schema"));
    if (PQresultStatus(r.get()) != PGRES_TUPLES_OK)
      return Result<int>::From(Error(StatusCode::kIoError, "cannot read the schema version"));
    return Result<int>::Ok(std::atoi(PQgetvalue(r.get(), 0, 0)));
  }
  Status Migrate() {
    if (Status s = Exec("BEGIN"); !s) return s;
    // Shards opening a new database at once: one migrates, the others wait here and find it done.
    Status migrated = Exec("SELECT pg_advisory_xact_lock(" + std::to_string(kMigrationLock) + ")");
    if (migrated)
      migrated = ApplyMigrations(
          Dialect::kPostgres, [this](const std::string& sql) { return Exec(sql); }, [this] { return ReadVersion(); },
          [this](int version) { return NewerSchema(version); });
    if (!migrated) {
      Exec("ROLLBACK");
      return migrated;
    }
    return Exec("COMMIT");
  }
  Result<std::vector<Record>> Select(const std::string& sql, const std::string* robot) {
    using R = Result<std::vector<Record>>;
    const char* values[1] = {robot ? robot->c_str() : nullptr};
    PgResult r(PQexecParams(conn_, sql.c_str(), robot ? 1 : 0, nullptr, values, nullptr, nullptr, 0));
    if (PQresultStatus(r.get()) != PGRES_TUPLES_OK) return R::From(Error(StatusCode::kIoError, "cannot read the records"));
    std::vector<Record> out;
    out.reserve(PQntuples(r.get()));
    for (int i = 0; i < PQntuples(r.get()); ++i) {
      Result<Record> rec = RecordFromDocument(PQgetvalue(r.get(), i, 0), name_);
      if (!rec) return R::From(rec);
      out.push_back(std::move(*rec));
    }
    return R::Ok(std::move(out));
  }

  PGconn* conn_;
  std::string name_;
  int version_ = 0;
};

}  // namespace

Result<std::unique_ptr<RecordStore>> OpenPostgresStore(const std::string& url) {
  using R = Result<std::unique_ptr<RecordStore>>;
  // connect_timeout unless the URL sets one: an unreachable server is an answer in seconds.
  // libpq takes the last value of a repeated key, the URL's expanded where dbname stands: the
  // default goes first, or it would override the URL's.
  const char* keys[] = {"connect_timeout", "dbname", nullptr};
  const char* values[] = {"5", url.c_str(), nullptr};
  PGconn* conn = PQconnectdbParams(keys, values, /*expand_dbname=*/1);
  const std::string name = Redacted(url);
  if (!conn || PQstatus(conn) != CONNECTION_OK) {
    std::string m = conn ? Scrubbed(PQerrorMessage(conn), url) : "out of memory";
    while (!m.empty() && (m.back() == '\n' || m.back() == ' ')) m.pop_back();
    PQfinish(conn);
    return R::Error(StatusCode::kOpenFailed, name + ": cannot connect (" + m + ")");
  }
  auto store = std::make_unique<PostgresStore>(conn, name);
  if (Status s = store->Open(); !s) return R::From(s);
  return R::Ok(std::move(store));
}

}  // namespace odocal::records::internal
