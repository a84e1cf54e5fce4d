// The record store against real databases: SQLite files (new, reopened, damaged, foreign,
// newer, read-only, written by two processes at once, a writer killed mid-write) and a real
// PostgreSQL server the test starts (postgres_server.h): the same round trip, shards migrating a
// new database at once, a newer schema, an unreachable server, a shard killed mid-write.
// Processes are fork()ed: that is how stations and shards meet a store.
#include "odocal/records/store.h"

#include <fcntl.h>
#include <grp.h>
#include <libpq-fe.h>
#include <netinet/in.h>
#include <pwd.h>
#include <signal.h>
#include <sqlite3.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "odocal/records/digest.h"
#include "odocal/records/record.h"
#include "postgres_server.h"

namespace odocal::records {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using ::testing::Not;
using Clock = std::chrono::steady_clock;
using nlohmann::json;

constexpr uint32_t kSeed = 20261127;

// A fresh directory under the system's temporary directory, removed with everything in it.
class TempDir {
 public:
  TempDir() {
    std::string tmpl = (fs::temp_directory_path() / "odocal-store-test-XXXXXX").string();
    if (mkdtemp(tmpl.data())) path_ = tmpl;
  }
  ~TempDir() {
    std::error_code ec;
    if (path_.empty()) return;
    // A test may have left a directory read-only.
    for (const auto& e : fs::recursive_directory_iterator(path_, ec))
      if (e.is_directory(ec)) fs::permissions(e.path(), fs::perms::owner_all, fs::perm_options::add, ec);
    fs::remove_all(path_, ec);
  }
  const fs::path& path() const { return path_; }
  std::string operator/(const std::string& name) const { return (path_ / name).string(); }

 private:
  fs::path path_;
};

// Record `index` of `robot`: every field filled from a generator seeded by (kSeed, robot, index),
// so a writer and the checker make the same one. Optional parts (sets, sigmas, estimates) are
// present or absent at random: the round trip must keep "absent" absent.
Record MakeRecord(const std::string& robot, int index) {
  std::vector<uint32_t> seeds = {kSeed, static_cast<uint32_t>(index)};
  for (char c : robot) seeds.push_back(static_cast<unsigned char>(c));
  std::seed_seq seq(seeds.begin(), seeds.end());
  std::mt19937 rng(seq);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  auto maybe = [&](double p) { return unit(rng) < p; };
  auto estimate = [&](double centre, double spread, bool with_sigma) {
    Estimate e{centre + spread * (unit(rng) - 0.5), std::nullopt};
    if (with_sigma) e.sigma = spread * 0.01 * (0.1 + unit(rng));
    return e;
  };
  auto wheel_set = [&](bool sigmas) {
    WheelSet w;
    w.left_wheel_diameter_mm = estimate(72.0, 0.6, sigmas && maybe(0.8));
    w.right_wheel_diameter_mm = estimate(72.0, 0.6, sigmas && maybe(0.8));
    w.track_mm = estimate(354.0, 3.0, sigmas && maybe(0.8));
    w.ticks_per_rev = maybe(0.5) ? 4096.0 : 1440.0 * 4;
    return w;
  };
  Record r;
  r.robot = robot;
  r.kind = std::array{RunKind::kStation, RunKind::kBatch, RunKind::kCheck, RunKind::kExplain}[rng() % 4];
  // A day per index, at a random hour: ForRobot's order is the index's.
  r.time_utc = FormatUtc(1.79e9 + index * 86400.0 + std::floor(unit(rng) * 80000.0));
  r.host = "station-" + std::to_string(rng() % 5);
  r.odocal_version = std::string(OdocalVersion());
  r.digest = DigestText(robot + "/" + std::to_string(index));
  r.folder = "/srv/runs/" + robot + "/" + std::to_string(index);
  if (maybe(0.7)) r.before = wheel_set(false);
  if (maybe(0.8)) r.after = wheel_set(true);
  if (maybe(0.8)) r.ed = estimate(1.0, 0.01, maybe(0.7));
  if (maybe(0.8)) r.eb = estimate(1.0, 0.03, maybe(0.7));
  if (maybe(0.6)) r.emax_syst_before_mm = estimate(8.0, 6.0, maybe(0.5));
  if (maybe(0.4)) r.emax_syst_after_mm = estimate(1.5, 1.0, maybe(0.5));
  if (maybe(0.5)) r.distance_km = 1000.0 * unit(rng);
  // Text a store must not bend: quotes, a backslash, non-ASCII.
  for (int i = 0, n = static_cast<int>(rng() % 3); i < n; ++i)
    r.findings.push_back("wheel \"L\" Ø " + std::to_string(rng() % 100) + " \\ slip");
  r.verdict = std::array{Verdict::kNone, Verdict::kPass, Verdict::kFail}[rng() % 3];
  if (r.verdict == Verdict::kFail) r.failed_limits = {"E_max,syst after 2.61 mm > 2 mm"};
  r.status = maybe(0.9) ? "converged" : "measured";
  return r;
}

// Doubles within a relative 1e-12 (they pass through text); "absent" must stay absent.
void ExpectSameEstimate(const std::optional<Estimate>& got, const std::optional<Estimate>& want, const std::string& what) {
  ASSERT_EQ(got.has_value(), want.has_value()) << what;
  if (!want) return;
  EXPECT_NEAR(got->value, want->value, 1e-12 * std::abs(want->value)) << what;
  ASSERT_EQ(got->sigma.has_value(), want->sigma.has_value()) << what << ".sigma";
  if (want->sigma) {
    EXPECT_NEAR(*got->sigma, *want->sigma, 1e-12 * std::abs(*want->sigma)) << what << ".sigma";
  }
}

void ExpectSameWheelSet(const std::optional<WheelSet>& got, const std::optional<WheelSet>& want, const std::string& what) {
  ASSERT_EQ(got.has_value(), want.has_value()) << what;
  if (!want) return;
  ExpectSameEstimate(got->left_wheel_diameter_mm, want->left_wheel_diameter_mm, what + ".left");
  ExpectSameEstimate(got->right_wheel_diameter_mm, want->right_wheel_diameter_mm, what + ".right");
  ExpectSameEstimate(got->track_mm, want->track_mm, what + ".track");
  EXPECT_NEAR(got->ticks_per_rev, want->ticks_per_rev, 1e-9) << what;
}

void ExpectSameRecord(const Record& got, const Record& want) {
  SCOPED_TRACE(want.robot + " " + want.digest.substr(0, 12));
  EXPECT_EQ(got.robot, want.robot);
  EXPECT_EQ(got.kind, want.kind);
  EXPECT_EQ(got.time_utc, want.time_utc);
  EXPECT_EQ(got.host, want.host);
  EXPECT_EQ(got.odocal_version, want.odocal_version);
  EXPECT_EQ(got.digest, want.digest);
  EXPECT_EQ(got.folder, want.folder);
  ExpectSameWheelSet(got.before, want.before, "before");
  ExpectSameWheelSet(got.after, want.after, "after");
  ExpectSameEstimate(got.ed, want.ed, "ed");
  ExpectSameEstimate(got.eb, want.eb, "eb");
  ExpectSameEstimate(got.emax_syst_before_mm, want.emax_syst_before_mm, "emax_syst_before_mm");
  ExpectSameEstimate(got.emax_syst_after_mm, want.emax_syst_after_mm, "emax_syst_after_mm");
  ASSERT_EQ(got.distance_km.has_value(), want.distance_km.has_value());
  if (want.distance_km) {
    EXPECT_NEAR(*got.distance_km, *want.distance_km, 1e-12 * *want.distance_km);
  }
  EXPECT_EQ(got.findings, want.findings);
  EXPECT_EQ(got.verdict, want.verdict);
  EXPECT_EQ(got.failed_limits, want.failed_limits);
  EXPECT_EQ(got.status, want.status);
}

std::unique_ptr<RecordStore> MustOpen(const std::string& db) {
  Result<std::unique_ptr<RecordStore>> store = OpenStore(db);
  EXPECT_TRUE(store) << store;
  return store ? std::move(*store) : nullptr;
}

// ---- Processes -------------------------------------------------------------------------------

// A forked child running `work` (whose JSON it reports through a pipe) once the parent says go:
// children forked one after another then start at the same moment.
class Children {
 public:
  Children() {
    if (pipe(go_) != 0) go_[0] = go_[1] = -1;
  }
  ~Children() {
    for (Child& c : children_)
      if (c.pid > 0) kill(c.pid, SIGKILL), waitpid(c.pid, nullptr, 0);
    CloseGo();
  }
  // The child's index (-1: no fork). It leaves by _exit: nothing of the test's (GoogleTest, the server
  // harness) runs in it.
  int Fork(const std::function<json()>& work) {
    int report[2];
    if (pipe(report) != 0) return -1;
    const pid_t pid = fork();
    if (pid < 0) {
      close(report[0]), close(report[1]);
      return -1;
    }
    if (pid == 0) {
      close(report[0]);
      close(go_[1]);
      char c;
      while (read(go_[0], &c, 1) < 0 && errno == EINTR) {
      }
      const std::string text = work().dump();
      size_t done = 0;
      while (done < text.size()) {
        const ssize_t n = write(report[1], text.data() + done, text.size() - done);
        if (n <= 0) break;
        done += static_cast<size_t>(n);
      }
      _exit(0);
    }
    close(report[1]);
    children_.push_back({pid, report[0]});
    return static_cast<int>(children_.size()) - 1;
  }
  // Every child starts (closing the write end wakes every reader).
  void Go() { CloseGo(); }
  // The child's report ({} when it reported nothing: it died).
  json Wait(int i) {
    Child& c = children_[i];
    std::string text;
    char buf[4096];
    ssize_t n;
    while ((n = read(c.report_fd, buf, sizeof(buf))) != 0) {
      if (n < 0 && errno == EINTR) continue;
      if (n < 0) break;
      text.append(buf, static_cast<size_t>(n));
    }
    close(c.report_fd);
    waitpid(c.pid, nullptr, 0);
    c.pid = -1;
    return text.empty() ? json::object() : json::parse(text, nullptr, false);
  }

 private:
  struct Child {
    pid_t pid;
    int report_fd;
  };
  void CloseGo() {
    for (int& fd : go_)
      if (fd >= 0) close(fd), fd = -1;
  }
  int go_[2] = {-1, -1};
  std::vector<Child> children_;
};

// What a writer did: {"added": n, "kept": n, "errors": [...]}; an open error counts as one.
json PutAll(const std::string& db, const std::vector<Record>& records) {
  json out = {{"added", 0}, {"kept", 0}, {"errors", json::array()}};
  Result<std::unique_ptr<RecordStore>> store = OpenStore(db);
  if (!store) {
    out["errors"].push_back("open: " + store.message);
    return out;
  }
  for (const Record& r : records) {
    Result<bool> added = (*store)->Put(r);
    if (!added) out["errors"].push_back(added.message);
    else out[*added ? "added" : "kept"] = out[*added ? "added" : "kept"].get<int>() + 1;
  }
  return out;
}

std::vector<Record> Records(const std::string& robot, int first, int end) {
  std::vector<Record> out;
  for (int i = first; i < end; ++i) out.push_back(MakeRecord(robot, i));
  return out;
}

// Each record of `all` is one of `expected` (and whole), and each of `expected` is there once.
void ExpectExactlyOnce(const std::vector<Record>& all, const std::vector<Record>& expected) {
  std::map<std::pair<std::string, std::string>, const Record*> want;
  for (const Record& r : expected) want[{r.robot, r.digest}] = &r;
  std::map<std::pair<std::string, std::string>, int> seen;
  for (const Record& r : all) {
    const auto key = std::make_pair(r.robot, r.digest);
    const auto it = want.find(key);
    if (it == want.end()) {
      ADD_FAILURE() << "a record nobody wrote: " << r.robot << " " << r.digest;
      continue;
    }
    if (++seen[key] == 1) ExpectSameRecord(r, *it->second);
  }
  for (const auto& [key, n] : seen) EXPECT_EQ(n, 1) << key.first << " " << key.second << " kept " << n << " times";
  EXPECT_EQ(seen.size(), want.size()) << "records missing";
}

// ---- The behaviour both stores share ---------------------------------------------------------

void ExpectOncePerRobotAndDigest(const std::string& db) {
  std::unique_ptr<RecordStore> store = MustOpen(db);
  ASSERT_TRUE(store);
  EXPECT_EQ(store->SchemaVersion(), kSchemaVersion);
  const Record r = MakeRecord("R-0042", 1);
  Result<bool> first = store->Put(r);
  ASSERT_TRUE(first) << first;
  EXPECT_TRUE(*first);
  Result<bool> again = store->Put(r);
  ASSERT_TRUE(again) << again;
  EXPECT_FALSE(*again);
  // The key is (robot, digest): another content under the same key changes nothing ...
  Record changed = r;
  changed.host = "another-station";
  changed.time_utc = FormatUtc(1.0e9);
  Result<bool> third = store->Put(changed);
  ASSERT_TRUE(third) << third;
  EXPECT_FALSE(*third);
  // ... and the same digest for another robot is another record.
  Record other = r;
  other.robot = "R-0043";
  Result<bool> fourth = store->Put(other);
  ASSERT_TRUE(fourth) << fourth;
  EXPECT_TRUE(*fourth);

  Result<std::vector<Record>> kept = store->ForRobot("R-0042");
  ASSERT_TRUE(kept) << kept;
  ASSERT_EQ(kept->size(), 1u);
  ExpectSameRecord(kept->front(), r);
  Result<std::vector<Record>> none = store->ForRobot("R-9999");
  ASSERT_TRUE(none) << none;
  EXPECT_TRUE(none->empty());
}

void ExpectOrderAndGrouping(const std::string& db) {
  std::unique_ptr<RecordStore> store = MustOpen(db);
  ASSERT_TRUE(store);
  // Kept in a shuffled order: the store orders by time, not by arrival.
  const std::vector<std::string> robots = {"R-0002", "R-0010", "R-0001"};
  std::vector<Record> records;
  for (const std::string& robot : robots)
    for (int i = 0; i < 6; ++i) records.push_back(MakeRecord(robot, i));
  std::mt19937 rng(kSeed);
  std::shuffle(records.begin(), records.end(), rng);
  // Two records of one robot at the same second: then the order they were kept in.
  Record twin_a = MakeRecord("R-0001", 100), twin_b = MakeRecord("R-0001", 101);
  twin_b.time_utc = twin_a.time_utc;
  for (const Record* r : {&twin_b, &twin_a}) records.push_back(*r);
  for (const Record& r : records) {
    Result<bool> added = store->Put(r);
    ASSERT_TRUE(added) << added;
    ASSERT_TRUE(*added);
  }

  Result<std::vector<std::string>> names = store->Robots();
  ASSERT_TRUE(names) << names;
  EXPECT_EQ(*names, (std::vector<std::string>{"R-0001", "R-0002", "R-0010"}));

  Result<std::vector<Record>> r1 = store->ForRobot("R-0001");
  ASSERT_TRUE(r1) << r1;
  ASSERT_EQ(r1->size(), 8u);
  for (int i = 0; i < 6; ++i) ExpectSameRecord((*r1)[i], MakeRecord("R-0001", i));
  EXPECT_EQ((*r1)[6].digest, twin_b.digest);
  EXPECT_EQ((*r1)[7].digest, twin_a.digest);

  Result<std::vector<Record>> all = store->All();
  ASSERT_TRUE(all) << all;
  ASSERT_EQ(all->size(), records.size());
  // Grouped by robot in name order, each group oldest first.
  std::vector<std::string> group_order;
  for (size_t i = 0; i < all->size(); ++i) {
    const Record& r = (*all)[i];
    if (group_order.empty() || group_order.back() != r.robot) group_order.push_back(r.robot);
    if (i > 0 && (*all)[i - 1].robot == r.robot) {
      EXPECT_LE((*all)[i - 1].time_utc, r.time_utc) << i;
    }
  }
  EXPECT_EQ(group_order, (std::vector<std::string>{"R-0001", "R-0002", "R-0010"}));
}

void ExpectRoundTripThroughReopen(const std::string& db) {
  // Enough records that every optional part is both present and absent somewhere.
  const std::vector<Record> records = Records("R-0300", 0, 40);
  int with_sigma = 0, without_sigma = 0, no_after = 0;
  for (const Record& r : records) {
    if (!r.after) ++no_after;
    else (r.after->track_mm.sigma ? with_sigma : without_sigma)++;
  }
  ASSERT_GT(with_sigma, 0);
  ASSERT_GT(without_sigma, 0);
  ASSERT_GT(no_after, 0);
  {
    std::unique_ptr<RecordStore> store = MustOpen(db);
    ASSERT_TRUE(store);
    for (const Record& r : records) {
      Result<bool> added = store->Put(r);
      ASSERT_TRUE(added) << added;
      EXPECT_TRUE(*added);
    }
  }
  std::unique_ptr<RecordStore> reopened = MustOpen(db);
  ASSERT_TRUE(reopened);
  Result<std::vector<Record>> back = reopened->ForRobot("R-0300");
  ASSERT_TRUE(back) << back;
  ASSERT_EQ(back->size(), records.size());
  for (size_t i = 0; i < records.size(); ++i) ExpectSameRecord((*back)[i], records[i]);
}

// A writer SIGKILLed while it puts records in a loop, `kills` times, each after a random
// while; then the writes rerun to the end. Every record is whole and kept exactly once.
void ExpectKilledWriterLosesAndDoublesNothing(const std::string& db, int kills) {
  constexpr int kCount = 4000;  // more than a writer gets through before it is killed
  const std::vector<Record> records = Records("R-0777", 0, kCount);
  std::mt19937 rng(kSeed);
  for (int k = 0; k < kills; ++k) {
    int started[2];
    ASSERT_EQ(pipe(started), 0);
    const pid_t pid = fork();
    if (pid == 0) {
      close(started[0]);
      Result<std::unique_ptr<RecordStore>> store = OpenStore(db);
      if (!store) _exit(2);
      // Killed while in its loop of puts, not before it: it says so after the first.
      for (size_t i = 0; i < records.size(); ++i) {
        if (!(*store)->Put(records[i])) _exit(3);
        if (i == 0) (void)!write(started[1], "s", 1);
      }
      _exit(0);
    }
    close(started[1]);
    char c = 0;
    ASSERT_EQ(read(started[0], &c, 1), 1) << "the writer could not open the store or put a record";
    close(started[0]);
    std::this_thread::sleep_for(std::chrono::milliseconds(30 + rng() % 120));
    kill(pid, SIGKILL);
    int status = 0;
    waitpid(pid, &status, 0);
    ASSERT_TRUE(WIFSIGNALED(status)) << "the writer finished before it was killed: raise kCount";

    // The store opens and reads; what is kept is a whole prefix of what the writer put (each
    // put is one transaction, committed in order).
    std::unique_ptr<RecordStore> store = MustOpen(db);
    ASSERT_TRUE(store);
    Result<std::vector<Record>> kept = store->ForRobot("R-0777");
    ASSERT_TRUE(kept) << kept;
    ASSERT_GT(kept->size(), 0u);
    ASSERT_LT(kept->size(), records.size());
    ExpectExactlyOnce(*kept, std::vector<Record>(records.begin(), records.begin() + kept->size()));
  }
  // The rerun adds what is missing, nothing twice.
  size_t before = 0;
  {
    std::unique_ptr<RecordStore> store = MustOpen(db);
    ASSERT_TRUE(store);
    before = store->ForRobot("R-0777")->size();
  }
  const std::vector<Record> rerun(records.begin(), records.begin() + std::min<size_t>(before + 50, kCount));
  const json report = PutAll(db, rerun);
  EXPECT_EQ(report["errors"], json::array());
  EXPECT_EQ(report["kept"].get<size_t>(), before);
  EXPECT_EQ(report["added"].get<size_t>(), rerun.size() - before);
  std::unique_ptr<RecordStore> store = MustOpen(db);
  ASSERT_TRUE(store);
  Result<std::vector<Record>> all = store->All();
  ASSERT_TRUE(all) << all;
  ExpectExactlyOnce(*all, rerun);
}

// ---- SQLite ----------------------------------------------------------------------------------

// Runs `sql` on a SQLite file directly (what another program, or a newer odocal, would do).
void SqliteExec(const std::string& path, const std::string& sql) {
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  char* message = nullptr;
  EXPECT_EQ(sqlite3_exec(db, sql.c_str(), nullptr, nullptr, &message), SQLITE_OK) << (message ? message : "");
  sqlite3_free(message);
  sqlite3_close(db);
}

std::string ReadBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

TEST(SqliteStore, NewFileInANewDirectoryKeepsEachRobotAndDigestOnce) {
  TempDir dir;
  const std::string path = dir / "a/b/records.sqlite";
  ExpectOncePerRobotAndDigest(path);
  EXPECT_TRUE(fs::is_regular_file(path));
  std::unique_ptr<RecordStore> store = MustOpen(path);
  ASSERT_TRUE(store);
  EXPECT_THAT(store->Describe(), HasSubstr(path));
}

TEST(SqliteStore, OrdersEachRobotByTimeAndGroupsAllByRobot) {
  TempDir dir;
  ExpectOrderAndGrouping(dir / "records.sqlite");
}

TEST(SqliteStore, ReopenedFileGivesBackEveryField) {
  TempDir dir;
  ExpectRoundTripThroughReopen(dir / "records.sqlite");
}

TEST(SqliteStore, DamagedFileIsAnErrorNeverAnEmptyStore) {
  TempDir dir;
  std::mt19937 rng(kSeed);
  std::string noise(8192, '\0');
  for (char& c : noise) c = static_cast<char>(rng());
  const std::map<std::string, std::string> files = {
      {"noise.sqlite", noise},
      {"notes.sqlite", "calibrated R-0042 on Tuesday\nEd 1.0021\n"},
      // A database's first bytes and then nothing that makes one.
      {"truncated.sqlite", std::string("SQLite format 3\0", 16) + noise.substr(0, 84)},
  };
  for (const auto& [name, bytes] : files) {
    SCOPED_TRACE(name);
    const std::string path = dir / name;
    std::ofstream(path, std::ios::binary) << bytes;
    Result<std::unique_ptr<RecordStore>> store = OpenStore(path);
    ASSERT_FALSE(store) << "opened as a store";
    EXPECT_EQ(store.status, StatusCode::kBadFile) << store;
    EXPECT_THAT(store.message, HasSubstr(path));
    // Refused, and left as it was.
    EXPECT_EQ(ReadBytes(path), bytes);
  }
}

TEST(SqliteStore, AnotherApplicationsDatabaseIsRefused) {
  TempDir dir;
  const std::string path = dir / "photos.db";
  SqliteExec(path, "CREATE TABLE photos (id INTEGER PRIMARY KEY, name TEXT); INSERT INTO photos (name) VALUES ('a.jpg')");
  Result<std::unique_ptr<RecordStore>> store = OpenStore(path);
  ASSERT_FALSE(store) << "opened as a store";
  EXPECT_THAT(store.message, HasSubstr(path));
  EXPECT_THAT(store.message, HasSubstr("not an odocal record store"));
  // Nothing was added to it.
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  sqlite3_stmt* st = nullptr;
  ASSERT_EQ(sqlite3_prepare_v2(db, "SELECT group_concat(name) FROM sqlite_master WHERE type = 'table'", -1, &st, nullptr),
            SQLITE_OK);
  ASSERT_EQ(sqlite3_step(st), SQLITE_ROW);
  EXPECT_STREQ(reinterpret_cast<const char*>(sqlite3_column_text(st, 0)), "photos");
  sqlite3_finalize(st);
  sqlite3_close(db);
}

TEST(SqliteStore, NewerSchemaIsRefusedNamingBothVersions) {
  TempDir dir;
  const std::string path = dir / "records.sqlite";
  {
    std::unique_ptr<RecordStore> store = MustOpen(path);
    ASSERT_TRUE(store);
    ASSERT_TRUE(store->Put(MakeRecord("R-0001", 0)));
  }
  SqliteExec(path, "INSERT INTO odocal_schema (version, applied_utc) VALUES (99, '2031-01-01T00:00:00Z')");
  Result<std::unique_ptr<RecordStore>> store = OpenStore(path);
  ASSERT_FALSE(store) << "a newer schema was opened";
  EXPECT_EQ(store.status, StatusCode::kVersionMismatch);
  EXPECT_THAT(store.message, HasSubstr(path));
  EXPECT_THAT(store.message, HasSubstr("99"));
  EXPECT_THAT(store.message, HasSubstr("(" + std::to_string(kSchemaVersion) + ")"));
}

// Root writes to any file whatever its mode, and CI runs as root: the writer runs in a child
// that drops to `nobody` (when root) so that chmod means what it says for it. Two cases: the
// file read-only in a directory the writer may write (it opens; Put is refused), and both
// read-only (it does not open: SQLite must make a -shm file beside a WAL store to read it).
// Either way an error naming the file, no record half-kept, and the store reads whole after.
// Not covered: a read-only mount (EROFS), which needs mount privileges a test should not use.
TEST(SqliteStore, ReadOnlyFileRefusesToWriteAndKeepsWhatItHad) {
  TempDir dir;
  const passwd* nobody = geteuid() == 0 ? getpwnam("nobody") : nullptr;
  if (geteuid() == 0) {
    ASSERT_NE(nobody, nullptr) << "running as root with no `nobody` user to drop to";
  }
  const uid_t uid = nobody ? nobody->pw_uid : geteuid();
  const gid_t gid = nobody ? nobody->pw_gid : getegid();
  fs::permissions(dir.path(), fs::perms::owner_all | fs::perms::group_exec | fs::perms::others_exec);

  for (const bool directory_writable : {true, false}) {
    SCOPED_TRACE(directory_writable ? "file read-only" : "file and directory read-only");
    const fs::path folder = dir.path() / (directory_writable ? "rw-dir" : "ro-dir");
    const std::string path = (folder / "records.sqlite").string();
    const std::vector<Record> kept = Records("R-0500", 0, 3);
    ASSERT_TRUE(PutAll(path, kept)["errors"].empty());
    ASSERT_EQ(chmod(path.c_str(), 0444), 0);
    ASSERT_EQ(chown(folder.c_str(), uid, gid), 0);
    ASSERT_EQ(chmod(folder.c_str(), directory_writable ? 0755 : 0555), 0);

    Children children;
    ASSERT_EQ(children.Fork([&] {
      if (nobody && (setgroups(0, nullptr) != 0 || setgid(gid) != 0 || setuid(uid) != 0))
        return json{{"errors", {"cannot drop to nobody"}}, {"setup", true}};
      return PutAll(path, Records("R-0500", 3, 6));
    }), 0);
    children.Go();
    const json report = children.Wait(0);
    ASSERT_FALSE(report.contains("setup")) << report;
    EXPECT_EQ(report["added"], 0) << report;
    ASSERT_FALSE(report["errors"].empty()) << "a read-only store took records";
    const std::string first = report["errors"][0];
    EXPECT_THAT(first, HasSubstr(path));
    EXPECT_THAT(first, HasSubstr("readonly")) << "refused for another reason";
    // Not mistaken for a damaged file.
    EXPECT_THAT(first, Not(HasSubstr("as an odocal record store")));

    ASSERT_EQ(chmod(folder.c_str(), 0755), 0);
    ASSERT_EQ(chmod(path.c_str(), 0644), 0);
    std::unique_ptr<RecordStore> store = MustOpen(path);
    ASSERT_TRUE(store);
    Result<std::vector<Record>> all = store->All();
    ASSERT_TRUE(all) << all;
    ExpectExactlyOnce(*all, kept);
  }
}

// Two stations writing one file at once (through a shared folder, say): each waits for the
// other's transaction (the busy timeout) and nothing is lost, doubled, or refused. They also
// open the new file at the same moment, so the first migration races too.
TEST(SqliteStore, TwoProcessesWritingOneFileAtOnceKeepEachRecordOnce) {
  TempDir dir;
  const std::string path = dir / "shared/records.sqlite";
  // 200 each, 100 of them the same records (the same run processed on both).
  const std::vector<Record> first = Records("R-0600", 0, 200), second = Records("R-0600", 100, 300);
  Children children;
  ASSERT_EQ(children.Fork([&] { return PutAll(path, first); }), 0);
  ASSERT_EQ(children.Fork([&] { return PutAll(path, second); }), 1);
  children.Go();
  const json a = children.Wait(0), b = children.Wait(1);
  EXPECT_EQ(a["errors"], json::array()) << a;
  EXPECT_EQ(b["errors"], json::array()) << b;
  EXPECT_EQ(a["added"].get<int>() + b["added"].get<int>(), 300) << a << b;
  EXPECT_EQ(a["kept"].get<int>() + b["kept"].get<int>(), 100) << a << b;

  std::unique_ptr<RecordStore> store = MustOpen(path);
  ASSERT_TRUE(store);
  Result<std::vector<Record>> all = store->All();
  ASSERT_TRUE(all) << all;
  ExpectExactlyOnce(*all, Records("R-0600", 0, 300));
}

TEST(SqliteStore, WriterKilledMidWriteLeavesWholeRecordsAndARerunCompletes) {
  TempDir dir;
  ExpectKilledWriterLosesAndDoublesNothing(dir / "records.sqlite", 3);
}

// ---- PostgreSQL ------------------------------------------------------------------------------

// One server for the suite (start-up is most of a PostgreSQL test's time); a database per test.
class PostgresStoreTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    Result<std::unique_ptr<records_test::PostgresServer>> server = records_test::PostgresServer::Start();
    if (server) server_ = std::move(*server);
    else start_error_ = server.message;
  }
  static void TearDownTestSuite() { server_.reset(); }
  // A missing server fails every test here, saying why: the PostgreSQL store is part of odocal.
  void SetUp() override { ASSERT_TRUE(server_) << "cannot start a PostgreSQL server: " << start_error_; }

  std::string NewDatabase() {
    const std::string name = std::string("t_") + ::testing::UnitTest::GetInstance()->current_test_info()->name();
    std::string lower;
    for (char c : name) lower += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    Result<std::string> url = server_->CreateDatabase(lower.substr(0, 60));
    EXPECT_TRUE(url) << url;
    return url ? *url : "";
  }

  static std::unique_ptr<records_test::PostgresServer> server_;
  static std::string start_error_;
};
std::unique_ptr<records_test::PostgresServer> PostgresStoreTest::server_;
std::string PostgresStoreTest::start_error_;

TEST_F(PostgresStoreTest, KeepsEachRobotAndDigestOnce) {
  const std::string url = NewDatabase();
  ExpectOncePerRobotAndDigest(url);
  std::unique_ptr<RecordStore> store = MustOpen(url);
  ASSERT_TRUE(store);
  EXPECT_EQ(store->Describe(), "postgresql 127.0.0.1:" + std::to_string(server_->port()) + "/" + url.substr(url.rfind('/') + 1));
}

TEST_F(PostgresStoreTest, OrdersEachRobotByTimeAndGroupsAllByRobot) { ExpectOrderAndGrouping(NewDatabase()); }

TEST_F(PostgresStoreTest, ReconnectedStoreGivesBackEveryField) { ExpectRoundTripThroughReopen(NewDatabase()); }

// Shards of a batch opening one new database at the same moment: the migration is applied
// once (the others wait on its lock and find it done), and the records shared between shards
// are kept once.
TEST_F(PostgresStoreTest, FourShardsOpeningANewDatabaseAtOnceMigrateItOnce) {
  const std::string url = NewDatabase();
  Children children;
  std::vector<Record> expected = Records("R-shared", 0, 20);
  for (int shard = 0; shard < 4; ++shard) {
    std::vector<Record> own = Records("R-shard" + std::to_string(shard), 0, 50);
    expected.insert(expected.end(), own.begin(), own.end());
    std::vector<Record> mine = Records("R-shared", 0, 20);
    mine.insert(mine.begin() + 10, own.begin(), own.end());  // shared ones first and last
    ASSERT_EQ(children.Fork([url, mine] { return PutAll(url, mine); }), shard);
  }
  children.Go();
  int added = 0, kept = 0;
  for (int shard = 0; shard < 4; ++shard) {
    const json report = children.Wait(shard);
    EXPECT_EQ(report["errors"], json::array()) << "shard " << shard << ": " << report;
    added += report.value("added", 0);
    kept += report.value("kept", 0);
  }
  EXPECT_EQ(added, 4 * 50 + 20);
  EXPECT_EQ(kept, 3 * 20);

  const std::string db = url.substr(url.rfind('/') + 1);
  PGconn* conn = PQconnectdb(("host=127.0.0.1 user=postgres port=" + std::to_string(server_->port()) + " dbname=" + db).c_str());
  ASSERT_EQ(PQstatus(conn), CONNECTION_OK) << PQerrorMessage(conn);
  PGresult* r = PQexec(conn, "SELECT count(*), max(version) FROM odocal_schema");
  ASSERT_EQ(PQresultStatus(r), PGRES_TUPLES_OK) << PQerrorMessage(conn);
  EXPECT_STREQ(PQgetvalue(r, 0, 0), "1") << "migrations applied more than once";
  EXPECT_EQ(std::atoi(PQgetvalue(r, 0, 1)), kSchemaVersion);
  PQclear(r);
  PQfinish(conn);

  std::unique_ptr<RecordStore> store = MustOpen(url);
  ASSERT_TRUE(store);
  Result<std::vector<Record>> all = store->All();
  ASSERT_TRUE(all) << all;
  ExpectExactlyOnce(*all, expected);
}

TEST_F(PostgresStoreTest, NewerSchemaIsRefusedNamingBothVersions) {
  const std::string url = NewDatabase();
  ASSERT_TRUE(MustOpen(url));
  const std::string db = url.substr(url.rfind('/') + 1);
  ASSERT_TRUE(server_->Execute(db, "INSERT INTO odocal_schema (version, applied_utc) VALUES (99, '2031-01-01T00:00:00Z')"));
  Result<std::unique_ptr<RecordStore>> store = OpenStore(url);
  ASSERT_FALSE(store) << "a newer schema was opened";
  EXPECT_EQ(store.status, StatusCode::kVersionMismatch);
  EXPECT_THAT(store.message, HasSubstr("99"));
  EXPECT_THAT(store.message, HasSubstr("(" + std::to_string(kSchemaVersion) + ")"));
  EXPECT_THAT(store.message, HasSubstr("/" + db));
}

// A server's databases usually sort text by a language's rules ("r-0001" before "R-0002"); the
// records come back in the same order as from SQLite (by bytes) whatever the database's.
TEST_F(PostgresStoreTest, SortsRobotsAsSqliteDoesWhateverTheDatabasesCollation) {
  const std::string db = "t_collation_en_us";
  ASSERT_TRUE(server_->Execute("postgres", "CREATE DATABASE " + db +
                                               " TEMPLATE template0 LOCALE_PROVIDER icu ICU_LOCALE 'en-US' LOCALE 'C'"));
  // en-US: r-0001 R-0002 R-0010 robot_b Robot-a (case and punctuation weigh least); bytes:
  // R-0002 R-0010 Robot-a r-0001 robot_b.
  const std::vector<std::string> robots = {"R-0002", "r-0001", "Robot-a", "robot_b", "R-0010"};
  TempDir dir;
  for (const std::string& where : {server_->Url(db), dir / "records.sqlite"}) {
    SCOPED_TRACE(where);
    std::unique_ptr<RecordStore> store = MustOpen(where);
    ASSERT_TRUE(store);
    for (const std::string& robot : robots) ASSERT_TRUE(store->Put(MakeRecord(robot, 0)));
    std::vector<std::string> sorted = robots;
    std::sort(sorted.begin(), sorted.end());
    Result<std::vector<std::string>> names = store->Robots();
    ASSERT_TRUE(names) << names;
    EXPECT_EQ(*names, sorted);
    Result<std::vector<Record>> all = store->All();
    ASSERT_TRUE(all) << all;
    std::vector<std::string> order;
    for (const Record& r : *all) order.push_back(r.robot);
    EXPECT_EQ(order, sorted);
  }
}

TEST_F(PostgresStoreTest, ShardKilledMidWriteThenRerunLosesAndDoublesNothing) {
  ExpectKilledWriterLosesAndDoublesNothing(NewDatabase(), 2);
}

// No server needed: a refused connection, and a server that accepts and never answers. Each is
// an error within seconds, naming host and port, never the password.
TEST(PostgresStore, UnreachableServerIsAnErrorNamingItWithoutThePassword) {
  {
    const auto start = Clock::now();
    Result<std::unique_ptr<RecordStore>> store = OpenStore("postgresql://u:secret@127.0.0.1:1/x");
    const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
    ASSERT_FALSE(store);
    EXPECT_LT(seconds, 6.0);
    EXPECT_EQ(store.status, StatusCode::kOpenFailed);
    EXPECT_THAT(store.message, HasSubstr("127.0.0.1:1"));
    EXPECT_THAT(store.message, Not(HasSubstr("secret")));
  }
  // URLs libpq cannot parse: it quotes them in its message.
  for (const std::string url : {"postgresql://u:secret@[::1/x", "postgresql://[::1/x?password=secret",
                                "postgresql://u:secret@127.0.0.1:1/x?application_name=a@b"}) {
    SCOPED_TRACE(url);
    Result<std::unique_ptr<RecordStore>> store = OpenStore(url);
    ASSERT_FALSE(store);
    EXPECT_THAT(store.message, Not(HasSubstr("secret")));
  }
  Result<std::unique_ptr<RecordStore>> with_at = OpenStore("postgresql://u:secret@127.0.0.1:1/x?application_name=a@b");
  EXPECT_THAT(with_at.message, HasSubstr("postgresql 127.0.0.1:1/x: cannot connect"));
  {
    // Listening, with the connection left in the backlog: libpq waits for an answer that does
    // not come, until the connect timeout (the URL's own, here).
    const int fd = socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t len = sizeof(addr);
    ASSERT_EQ(bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)), 0);
    ASSERT_EQ(listen(fd, 4), 0);
    ASSERT_EQ(getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len), 0);
    const std::string where = "127.0.0.1:" + std::to_string(ntohs(addr.sin_port));
    const auto start = Clock::now();
    Result<std::unique_ptr<RecordStore>> store = OpenStore("postgresql://u:secret@" + where + "/x?connect_timeout=2");
    const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
    close(fd);
    ASSERT_FALSE(store);
    EXPECT_GT(seconds, 1.5);
    EXPECT_LT(seconds, 4.0);
    EXPECT_THAT(store.message, HasSubstr(where));
    EXPECT_THAT(store.message, Not(HasSubstr("secret")));
    EXPECT_THAT(store.message, Not(HasSubstr("connect_timeout")));
  }
}

}  // namespace
}  // namespace odocal::records
