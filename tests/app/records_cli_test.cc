// The record store from the command line (issue 27): every batch keeps one record per robot
// and session however often it runs, an unreachable or broken store never costs a run or
// passes for an empty history, the line's limits give PASS or FAIL with exit 6, shards over a
// list keep every session once, and `history` reads wear and a repair back out of a simulated
// year of a fleet. The sessions are the virtual robot's (odocal simulate, no camera) seen by a
// motion-capture stand-in: the true path with seeded noise, as a tracker logs it.
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <regex>
#include <sstream>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "../records/postgres_server.h"
#include "odocal/base/utc_time.h"
#include "odocal/test_util/test_util.h"

namespace odocal {
namespace {

using ::testing::HasSubstr;
using test_util::CommandResult;
using test_util::Odocal;
using test_util::ReadJson;
using test_util::RunCommand;
namespace fs = std::filesystem;

struct Wheels {
  double left_mm = 72.0, right_mm = 72.0, track_mm = 300.0;
};

std::string WheelsYaml(const Wheels& w, bool ticks) {
  std::ostringstream os;
  os.precision(10);
  os << "{left_wheel_diameter_mm: " << w.left_mm << ", right_wheel_diameter_mm: " << w.right_mm
     << ", track_mm: " << w.track_mm << (ticks ? ", ticks_per_rev: 2048}" : "}");
  return os.str();
}

// The plan: squares both ways (UMBMark, two a direction for its sigma), a straight and an
// out-and-back (the distance scale: wear) and spins both ways (the track).
const char* kPlanYaml = R"(runs:
  - {name: sq_cw_1, procedure: umbmark, direction: cw, side_mm: 1000}
  - {name: sq_ccw_1, procedure: umbmark, direction: ccw, side_mm: 1000}
  - {name: sq_cw_2, procedure: umbmark, direction: cw, side_mm: 1000}
  - {name: sq_ccw_2, procedure: umbmark, direction: ccw, side_mm: 1000}
  - {name: line, procedure: straight, distance_mm: 2000}
  - {name: oab, procedure: out_and_back, distance_mm: 1500, repeats: 1}
  - {name: spin_ccw, procedure: spin, direction: ccw, turns: 2}
  - {name: spin_cw, procedure: spin, direction: cw, turns: 2}
)";

struct SessionSpec {
  std::string robot;       // robot.id ("" : none)
  Wheels nominal, truth;
  std::string recorded_utc;
  double odometer_km = 0.0;
  int seed = 1;
};

// simulate (no camera) into DIR/sim, then DIR/session.yaml whose runs are the true paths with
// 0.2 mm / 0.02 deg of seeded tracker noise, and the telemetry the robot logged.
void MakeSession(const std::string& dir, const SessionSpec& s) {
  fs::create_directories(dir);
  {
    std::ofstream scenario(dir + "/scenario.yaml");
    scenario << "seed: " << s.seed << "\nrobot:\n  nominal: " << WheelsYaml(s.nominal, true)
             << "\n  true: " << WheelsYaml(s.truth, false)
             << "\n  speed_mm_s: 400\n  turn_rate_deg_s: 90\n  noise: {wheel_mm_per_sqrt_m: 0.05}\n"
             << std::regex_replace(kPlanYaml, std::regex("name: [a-z_0-9]+, "), "");  // a scenario's runs have no names
  }
  const CommandResult sim = RunCommand(Odocal("simulate --scenario " + dir + "/scenario.yaml --out " + dir + "/sim"));
  ASSERT_EQ(sim.exit_code, 0) << sim.err;
  const nlohmann::json truth = ReadJson(dir + "/sim/truth.json");
  std::mt19937 rng(s.seed);
  std::normal_distribution<double> mm(0.0, 0.2), deg(0.0, 0.02);
  std::ofstream session(dir + "/session.yaml");
  session.precision(10);
  if (!s.recorded_utc.empty()) session << "recorded_utc: " << s.recorded_utc << "\n";
  session << "robot:\n  nominal: " << WheelsYaml(s.nominal, true) << "\n";
  if (!s.robot.empty()) session << "  id: " << s.robot << "\n";
  if (s.odometer_km > 0) session << "  odometer_km: " << s.odometer_km << "\n";
  session << "runs:\n";
  std::istringstream plan(kPlanYaml);
  std::string line;
  std::getline(plan, line);  // "runs:"
  int k = 0;
  while (std::getline(plan, line)) {
    const nlohmann::json& run = truth["runs"][k++];
    const std::string name = run["name"];
    std::ifstream in(dir + "/sim/" + run["trajectory"].get<std::string>());
    std::ofstream out(dir + "/" + name + ".poses.csv");
    std::string row;
    std::getline(in, row);
    out << "t_s,x_mm,y_mm,heading_deg\n";
    out.precision(10);
    while (std::getline(in, row)) {
      double t, x, y, h;
      if (std::sscanf(row.c_str(), "%lf,%lf,%lf,%lf", &t, &x, &y, &h) != 4) continue;
      out << t << "," << x + mm(rng) << "," << y + mm(rng) << "," << h + deg(rng) << "\n";
    }
    // "  - {name: ..., ...}" -> "  - {name: ..., ..., poses: F, telemetry: T}"
    line.pop_back();
    session << line << ", poses: " << name << ".poses.csv, telemetry: sim/" << run["telemetry"].get<std::string>()
            << "}\n";
  }
}


// A report page in headless Chromium at `width` px: it draws (a screenshot with ink on it, SVG
// charts in the DOM) and nothing is wider than the window (the page measured inside an iframe of
// that width, as a phone would show it).
void ExpectReadableInChromium(const std::string& page, const std::string& dir, int width) {
  ASSERT_EQ(RunCommand("command -v chromium").exit_code, 0) << "chromium is missing: bash scripts/install-deps.sh installs it";
  const std::string chromium = "chromium --headless=new --no-sandbox --disable-gpu --disable-dev-shm-usage "
                               "--hide-scrollbars --allow-file-access-from-files --user-data-dir=" + dir +
                               "/chromium --virtual-time-budget=3000 ";
  const std::string probe = dir + "/probe_" + std::to_string(width) + ".html";
  std::ofstream(probe) << "<html><body style='margin:0'><iframe id='f' src='file://" << page << "' style='width:" << width
                       << "px;height:900px;border:0'></iframe><script>f.onload=()=>{const d=f.contentDocument;"
                          "document.body.setAttribute('data-scroll',d.documentElement.scrollWidth);"
                          "document.body.setAttribute('data-svgs',d.querySelectorAll('svg').length);};</script></body></html>";
  const CommandResult dom = RunCommand(chromium + "--dump-dom file://" + probe);
  ASSERT_EQ(dom.exit_code, 0) << dom.err;
  std::smatch m;
  ASSERT_TRUE(std::regex_search(dom.out, m, std::regex(R"re(data-scroll="(\d+)")re"))) << dom.out.substr(0, 800);
  EXPECT_LE(std::stoi(m[1]), width) << "the page scrolls sideways at " << width << " px";
  ASSERT_TRUE(std::regex_search(dom.out, m, std::regex(R"re(data-svgs="(\d+)")re")));
  EXPECT_GE(std::stoi(m[1]), 2) << "its charts";
  const std::string png = dir + "/shot_" + std::to_string(width) + ".png";
  const CommandResult shot =
      RunCommand(chromium + "--window-size=" + std::to_string(width) + ",900 --screenshot=" + png + " file://" + page);
  ASSERT_EQ(shot.exit_code, 0) << shot.err;
  const cv::Mat image = cv::imread(png, cv::IMREAD_GRAYSCALE);
  ASSERT_EQ(image.cols, width);
  EXPECT_GT(cv::countNonZero(image < 128), image.total() / 200) << "ink on the page: text and charts";
}

class RecordsCli : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = test_util::MakeTempDir("odocal_records_cli");
    SessionSpec s;
    s.robot = "R-0001";
    s.truth = {71.95, 72.08, 302.0};
    s.recorded_utc = "2026-03-02T09:00:00Z";
    MakeSession(dir_ + "/s1", s);
  }
  static void TearDownTestSuite() {
    if (getenv("ODOCAL_KEEP_TEST_DIRS") == nullptr) fs::remove_all(dir_);
  }
  static std::string dir_;
};
std::string RecordsCli::dir_;

TEST_F(RecordsCli, ABatchKeepsOneRecordPerRobotAndSessionHoweverOftenItRuns) {
  const std::string db = dir_ + "/once/records.sqlite";
  const CommandResult first = RunCommand(Odocal("batch " + dir_ + "/s1/session.yaml --out " + dir_ + "/once/a --db " + db));
  ASSERT_EQ(first.exit_code, 0) << first.err;
  EXPECT_THAT(first.out, HasSubstr("record: kept for robot R-0001"));
  const nlohmann::json record = ReadJson(dir_ + "/once/a/record.json");
  const nlohmann::json report = ReadJson(dir_ + "/once/a/report.json");
  EXPECT_EQ(record["robot"], "R-0001");
  EXPECT_EQ(record["time_utc"], "2026-03-02T09:00:00Z") << "the session's recorded_utc, not when it was processed";
  EXPECT_NEAR(record["params_after"]["track_mm"]["value"].get<double>(), report["corrected"]["track_mm"].get<double>(),
              1e-9);
  EXPECT_NEAR(record["params_after"]["track_mm"]["value"].get<double>(), 302.0, 0.5) << "the simulated truth";

  // The same session again, into another folder: found by its content.
  const CommandResult again = RunCommand(Odocal("batch " + dir_ + "/s1/session.yaml --out " + dir_ + "/once/b --db " + db));
  ASSERT_EQ(again.exit_code, 0) << again.err;
  EXPECT_THAT(again.out, HasSubstr("already kept"));
  const CommandResult history = RunCommand(Odocal("history R-0001 --json --db " + db));
  ASSERT_EQ(history.exit_code, 0) << history.err;
  const nlohmann::json h = nlohmann::json::parse(history.out);
  EXPECT_EQ(h["robot"], "R-0001");
  ASSERT_EQ(h["records"].size(), 1u);
  EXPECT_EQ(h["records"][0]["digest"], record["digest"]);

  // --robot names it otherwise: another robot's record.
  const CommandResult renamed =
      RunCommand(Odocal("batch " + dir_ + "/s1/session.yaml --out " + dir_ + "/once/c --robot R-0009 --db " + db));
  ASSERT_EQ(renamed.exit_code, 0) << renamed.err;
  EXPECT_THAT(renamed.out, HasSubstr("kept for robot R-0009"));
}

TEST_F(RecordsCli, ExplainAndCheckKeepTheirOwnRecordsOfTheSameSession) {
  const std::string db = dir_ + "/kinds/records.sqlite";
  const CommandResult explain = RunCommand(Odocal("explain " + dir_ + "/s1/session.yaml --out " + dir_ + "/kinds/e --db " + db));
  ASSERT_EQ(explain.exit_code, 0) << explain.err;
  EXPECT_THAT(explain.out, HasSubstr("record: kept for robot R-0001"));
  const CommandResult check = RunCommand(Odocal("check " + dir_ + "/s1/session.yaml --params " + dir_ +
                                                "/kinds/e/explain.json --out " + dir_ + "/kinds/c --db " + db));
  ASSERT_EQ(check.exit_code, 0) << check.err;
  const nlohmann::json h = nlohmann::json::parse(RunCommand(Odocal("history R-0001 --json --db " + db)).out);
  ASSERT_EQ(h["records"].size(), 2u) << "one session, two commands: two records";
  EXPECT_EQ(h["records"][0]["kind"], "explain");
  EXPECT_EQ(h["records"][1]["kind"], "check");
  // explain's calibrated set is the simulated robot's: D = (71.95 + 72.08) / 2, b = 302.
  const nlohmann::json& after = h["records"][0]["params_after"];
  EXPECT_NEAR(0.5 * (after["left_wheel_diameter_mm"]["value"].get<double>() +
                     after["right_wheel_diameter_mm"]["value"].get<double>()),
              72.015, 0.02);
  EXPECT_NEAR(after["track_mm"]["value"].get<double>(), 302.0, 0.1);
  EXPECT_EQ(h["records"][1]["params_after"]["track_mm"]["value"], after["track_mm"]["value"])
      << "check's record is the set it checked";
}

TEST_F(RecordsCli, AnUnreachableStoreCostsTheRunNothingAndTheFolderCanBeImportedLater) {
  const std::string out = dir_ + "/unreachable/run";
  const CommandResult r = RunCommand(Odocal("batch " + dir_ + "/s1/session.yaml --out " + out +
                                            " --db postgresql://odocal:secret@127.0.0.1:1/none"));
  ASSERT_EQ(r.exit_code, 0) << "the calibration itself worked: " << r.err;
  EXPECT_TRUE(fs::exists(out + "/report.json"));
  EXPECT_TRUE(fs::exists(out + "/record.json"));
  EXPECT_THAT(r.err, HasSubstr("record not kept"));
  EXPECT_THAT(r.err, HasSubstr("127.0.0.1:1"));
  EXPECT_THAT(r.err, HasSubstr("odocal history import " + out));
  EXPECT_THAT(r.err, ::testing::Not(HasSubstr("secret")));

  const std::string db = dir_ + "/unreachable/records.sqlite";
  const CommandResult imported = RunCommand(Odocal("history import " + out + " --db " + db));
  ASSERT_EQ(imported.exit_code, 0) << imported.err;
  EXPECT_THAT(imported.out, HasSubstr("imported 1 record"));
  const CommandResult twice = RunCommand(Odocal("history import " + out + " --db " + db));
  EXPECT_THAT(twice.out, HasSubstr("imported 0 record(s)"));
  EXPECT_THAT(twice.out, HasSubstr("1 already kept"));
}

TEST_F(RecordsCli, ABrokenStoreIsAnErrorNeverAnEmptyHistoryAndAnUnknownRobotNamesTheCloseOnes) {
  const std::string bad = dir_ + "/broken/records.sqlite";
  fs::create_directories(dir_ + "/broken");
  std::ofstream(bad) << "this is a spreadsheet, not a database\n";
  const CommandResult h = RunCommand(Odocal("history R-0001 --db " + bad));
  EXPECT_NE(h.exit_code, 0);
  EXPECT_THAT(h.err, HasSubstr(bad));
  EXPECT_THAT(h.err, HasSubstr("not a database"));
  const CommandResult f = RunCommand(Odocal("fleet --db " + bad));
  EXPECT_NE(f.exit_code, 0);
  // A mistyped --db is not an empty fleet, and reading creates nothing.
  const CommandResult typo = RunCommand(Odocal("fleet --db " + dir_ + "/broken/typo/records.sqlite"));
  EXPECT_EQ(typo.exit_code, 2);
  EXPECT_THAT(typo.err, HasSubstr("typo/records.sqlite: no record store there"));
  EXPECT_FALSE(fs::exists(dir_ + "/broken/typo"));

  const std::string db = dir_ + "/broken/good.sqlite";
  ASSERT_EQ(RunCommand(Odocal("batch " + dir_ + "/s1/session.yaml --out " + dir_ + "/broken/run --db " + db)).exit_code,
            0);
  const CommandResult unknown = RunCommand(Odocal("history R-001 --db " + db));
  EXPECT_EQ(unknown.exit_code, 2);
  EXPECT_THAT(unknown.err, HasSubstr("no robot 'R-001'"));
  EXPECT_THAT(unknown.err, HasSubstr("close names: R-0001"));
}

TEST_F(RecordsCli, TheLinesLimitsGivePassOrFailWithExitSix) {
  const std::string db = dir_ + "/limits/records.sqlite";
  // The robot was built 0.18 % off in Ed (72.08 / 71.95) and 0.67 % in Eb (302 / 300).
  const CommandResult pass = RunCommand(Odocal("batch " + dir_ + "/s1/session.yaml --out " + dir_ +
                                               "/limits/pass --db " + db + " --limits ed=0.5%,eb=1%"));
  ASSERT_EQ(pass.exit_code, 0) << pass.err;
  EXPECT_THAT(pass.out, HasSubstr("limits: PASS"));
  const CommandResult fail = RunCommand(Odocal("batch " + dir_ + "/s1/session.yaml --out " + dir_ +
                                               "/limits/fail --no-record --limits ed=0.1%,eb=1%"));
  EXPECT_EQ(fail.exit_code, 6) << fail.out << fail.err;
  EXPECT_THAT(fail.out, HasSubstr("limits: FAIL: |Ed - 1|"));
  EXPECT_TRUE(fs::exists(dir_ + "/limits/fail/report.json")) << "a FAIL is written like any result";
  EXPECT_EQ(ReadJson(dir_ + "/limits/fail/record.json")["verdict"], "fail");
  // batch does not drive the robot again: a limit on E_max,syst after cannot pass.
  const CommandResult unmeasured = RunCommand(Odocal("batch " + dir_ + "/s1/session.yaml --out " + dir_ +
                                                     "/limits/after --no-record --limits emax_syst_after_mm=2"));
  EXPECT_EQ(unmeasured.exit_code, 6);
  EXPECT_THAT(unmeasured.out, HasSubstr("not measured"));
  const CommandResult typo = RunCommand(Odocal("batch " + dir_ + "/s1/session.yaml --out " + dir_ +
                                               "/limits/typo --limits edd=0.5%"));
  EXPECT_EQ(typo.exit_code, 2);
  EXPECT_THAT(typo.err, HasSubstr("edd"));
  EXPECT_FALSE(fs::exists(dir_ + "/limits/typo")) << "bad input writes nothing";
}


// Four shards of one list writing into one PostgreSQL at once, one of them killed while it works
// and run again: every session kept exactly once (the key is robot and content, the write one
// statement).
TEST_F(RecordsCli, FourShardsIntoOnePostgresKeepEverySessionOnceAKilledShardRerunLosesAndDoublesNothing) {
  auto server = records_test::PostgresServer::Start();
  ASSERT_TRUE(server.ok()) << server.message;
  const Result<std::string> url = (*server)->CreateDatabase("line");
  ASSERT_TRUE(url.ok()) << url.message;
  const std::string dir = dir_ + "/shards";
  fs::create_directories(dir);
  {
    // Eight units: the same recorded session under eight serial numbers (distinct keys).
    std::ofstream list(dir + "/sessions.txt");
    list << "# unit sessions\n";
    for (int k = 0; k < 8; ++k) list << "../s1/session.yaml robot=U-" << k << "\n";
  }
  auto shard = [&](int i) {
    return Odocal("batch --list " + dir + "/sessions.txt --shard " + std::to_string(i) + "/4 --out " + dir +
                  "/out --db " + *url + " --threads 1 --export firmware fw.yaml");
  };
  // Shard 3 is killed a moment after it starts; the other three run to the end beside it.
  const CommandResult all = RunCommand("(" + shard(0) + " > " + dir + "/0.log 2>&1 & " + shard(1) + " > " + dir +
                                       "/1.log 2>&1 & " + shard(2) + " > " + dir + "/2.log 2>&1 & " + shard(3) +
                                       " > " + dir + "/3.log 2>&1 & k=$!; sleep 1.5; kill -9 $k; wait)");
  ASSERT_EQ(all.exit_code, 0) << all.err;
  for (int i = 0; i < 3; ++i) {
    const nlohmann::json summary = ReadJson(dir + "/out/shard-" + std::to_string(i) + "-of-4.json");
    ASSERT_EQ(summary["sessions"].size(), 2u);
    for (const nlohmann::json& s : summary["sessions"]) EXPECT_EQ(s["exit_code"], 0) << s.dump();
  }
  const CommandResult rerun = RunCommand(shard(3));
  ASSERT_EQ(rerun.exit_code, 0) << rerun.out << rerun.err;
  const CommandResult again = RunCommand(shard(3));
  EXPECT_THAT(again.out, HasSubstr("already kept"));
  const CommandResult fleet = RunCommand(Odocal("fleet --json --db " + *url));
  ASSERT_EQ(fleet.exit_code, 0) << fleet.err;
  const nlohmann::json f = nlohmann::json::parse(fleet.out);
  ASSERT_EQ(f["robots"].size(), 8u);
  EXPECT_EQ(f["records"], 8);
  for (int k = 0; k < 8; ++k) EXPECT_EQ(f["robots"][k]["robot"], "U-" + std::to_string(k));
  // One folder a session (the same file eight times: s1, s1-2, ...), each with its own export.
  EXPECT_TRUE(fs::exists(dir + "/out/s1/fw.yaml"));
  EXPECT_TRUE(fs::exists(dir + "/out/s1-8/fw.yaml"));
  EXPECT_TRUE(fs::exists(dir + "/out/s1-8/record.json"));
}

// Two stations of a line recording into one SQLite file (WAL) at the same moment: the virtual
// robot calibrated twice side by side under two serial numbers; both records kept, each once.
TEST(StationRecords, TwoStationsIntoOneSqliteFileAtOnceKeepBothRecords) {
  const std::string dir = test_util::MakeTempDir("odocal_two_stations");
  const std::string db = dir + "/line.sqlite";
  auto station = [&](const std::string& unit) {
    return Odocal("station --scenario " + test_util::SourceDir() + "/sample_data/scenarios/station.yaml --out " + dir +
                  "/" + unit + " --robot " + unit + " --db " + db + " --limits emax_syst_after_mm=5");
  };
  const CommandResult both = RunCommand("(" + station("S-1") + " > " + dir + "/1.log 2>&1 & a=$!; " + station("S-2") +
                                        " > " + dir + "/2.log 2>&1; b=$?; wait $a; exit $(( $? | b )))");
  ASSERT_EQ(both.exit_code, 0) << test_util::Slurp(dir + "/1.log") << test_util::Slurp(dir + "/2.log");
  for (const char* unit : {"S-1", "S-2"}) {
    const std::string log = test_util::Slurp(dir + (std::string(unit) == "S-1" ? "/1.log" : "/2.log"));
    EXPECT_THAT(log, HasSubstr(std::string("record: kept for robot ") + unit));
    EXPECT_THAT(log, HasSubstr("limits: PASS"));
  }
  const CommandResult fleet = RunCommand(Odocal("fleet --json --db " + db));
  ASSERT_EQ(fleet.exit_code, 0) << fleet.err;
  const nlohmann::json f = nlohmann::json::parse(fleet.out);
  ASSERT_EQ(f["robots"].size(), 2u);
  EXPECT_EQ(f["records"], 2);
  EXPECT_EQ(f["passed"], 2);
  for (const nlohmann::json& r : f["robots"]) {
    EXPECT_EQ(r["last"]["kind"], "station");
    EXPECT_LT(r["last"]["emax_syst_after_mm"]["value"].get<double>(), 5.0);
    EXPECT_GT(r["last"]["emax_syst_before_mm"]["value"].get<double>(), 50.0) << "the virtual robot comes miscalibrated";
  }
  if (!::testing::Test::HasFailure()) fs::remove_all(dir);
}

// A simulated year of a fleet: three robots re-calibrated every six weeks through batch --list
// (two shards at once into one SQLite file), each round driven with the set the last calibration
// exported, while their wheels wear (mm a week, left / right):
//   R-A  -0.030 / -0.026          (nearly even)
//   R-B  -0.070 / -0.050          (uneven: its E_max,syst grows fastest between calibrations)
//   R-C  -0.030 / -0.030, and before the sixth calibration a repair that moves the track by +3 mm
// history must read each wear rate within its sigma of the simulated one, name R-C's repair as a
// step and only that, and fleet must put R-B first to cross the E_max,syst limit.
TEST(FleetYear, HistoryReadsTheWearTheRepairAndWhoCrossesTheLimitFirst) {
  const std::string dir = test_util::MakeTempDir("odocal_fleet_year");
  const std::string db = dir + "/fleet.sqlite";
  struct Robot {
    std::string id;
    double wear_left, wear_right;  // mm a week
    Wheels built;
    Wheels nominal;
  };
  std::vector<Robot> robots = {{"R-A", -0.030, -0.026, {72.00, 72.04, 301.0}, {}},
                               {"R-B", -0.070, -0.050, {71.98, 72.00, 299.5}, {}},
                               {"R-C", -0.030, -0.030, {72.02, 72.00, 300.5}, {}}};
  const double start = *ParseUtc("2026-01-05T08:00:00Z");
  // Nine calibrations six weeks apart: 48 weeks.
  const int rounds = 9, repair_round = 5;
  const double period_days = 42.0;
  for (int m = 0; m < rounds; ++m) {
    const double weeks = period_days * m / 7.0;
    const std::string month = dir + "/m" + std::to_string(m);
    std::ofstream list(month + ".txt");
    for (size_t r = 0; r < robots.size(); ++r) {
      Robot& robot = robots[r];
      SessionSpec s;
      s.robot = robot.id;
      s.nominal = robot.nominal;
      s.truth = {robot.built.left_mm + robot.wear_left * weeks, robot.built.right_mm + robot.wear_right * weeks,
                 robot.built.track_mm + (robot.id == "R-C" && m >= repair_round ? 3.0 : 0.0)};
      s.recorded_utc = FormatUtc(start + period_days * 86400.0 * m);
      s.odometer_km = 55.0 * m;
      s.seed = 100 * m + static_cast<int>(r) + 1;
      MakeSession(month + "/" + robot.id, s);
      ASSERT_FALSE(::testing::Test::HasFatalFailure());
      list << "m" << m << "/" << robot.id << "/session.yaml\n";
    }
    list.close();
    auto shard = [&](int i) {
      return Odocal("batch --list " + month + ".txt --shard " + std::to_string(i) + "/2 --out " + month +
                    "/out --db " + db + " --threads 1");
    };
    const CommandResult both = RunCommand("(" + shard(0) + " > " + month + ".0.log 2>&1 & a=$!; " + shard(1) + " > " +
                                          month + ".1.log 2>&1; b=$?; wait $a; exit $(( $? | b )))");
    ASSERT_EQ(both.exit_code, 0) << test_util::Slurp(month + ".0.log") << test_util::Slurp(month + ".1.log");
    // The robot is updated: next round it drives with what this round exported.
    for (Robot& robot : robots) {
      const nlohmann::json c = ReadJson(month + "/out/" + robot.id + "/report.json")["corrected"];
      robot.nominal = {c["left_wheel_diameter_mm"], c["right_wheel_diameter_mm"], c["track_mm"]};
    }
  }
  const std::string now = "2027-01-01";
  const std::string limits = " --limits emax_syst_after_mm=4,recalibrate_days=42 --now " + now;
  for (const Robot& robot : robots) {
    SCOPED_TRACE(robot.id);
    const CommandResult h = RunCommand(Odocal("history " + robot.id + " --json --db " + db + limits));
    ASSERT_EQ(h.exit_code, 0) << h.err;
    const nlohmann::json a = nlohmann::json::parse(h.out)["analysis"];
    ASSERT_EQ(nlohmann::json::parse(h.out)["records"].size(), static_cast<size_t>(rounds));
    ASSERT_TRUE(a["wear_mm_per_week"].is_object()) << a.dump();
    const double wear = a["wear_mm_per_week"]["value"], sigma = a["wear_mm_per_week"]["sigma"];
    const double truth = 0.5 * (robot.wear_left + robot.wear_right);
    EXPECT_LT(sigma, 0.01) << "a year of calibrations tells the wear to a hundredth of a mm a week";
    EXPECT_NEAR(wear, truth, 2.0 * sigma) << "wear " << wear << " +/- " << sigma;
    if (robot.id == "R-C") {
      ASSERT_EQ(a["steps"].size(), 1u) << a["steps"].dump();
      EXPECT_EQ(a["steps"][0]["index"], repair_round);
      EXPECT_EQ(a["steps"][0]["parameter"], "track_mm");
      EXPECT_NEAR(a["steps"][0]["change"].get<double>(), 3.0, 0.5);
    } else {
      EXPECT_EQ(a["steps"].size(), 0u) << a["steps"].dump();
    }
  }
  const CommandResult fleet = RunCommand(Odocal("fleet --json --db " + db + limits + " --out " + dir + "/fleet"));
  ASSERT_EQ(fleet.exit_code, 0) << fleet.err;
  const nlohmann::json f = nlohmann::json::parse(fleet.out);
  ASSERT_EQ(f["robots"].size(), 3u);
  ASSERT_TRUE(f["first_to_cross"].is_object()) << f.dump(1);
  EXPECT_EQ(f["first_to_cross"]["robot"], "R-B") << f.dump(1);
  ASSERT_TRUE(fs::exists(dir + "/fleet/report.html"));
  const CommandResult hist = RunCommand(Odocal("history R-C --db " + db + limits + " --out " + dir + "/history"));
  ASSERT_EQ(hist.exit_code, 0) << hist.err;
  EXPECT_THAT(hist.out, HasSubstr("track_mm"));
  for (const std::string page : {dir + "/fleet/report.html", dir + "/history/report.html"}) {
    SCOPED_TRACE(page);
    ExpectReadableInChromium(page, dir, 1280);
    ExpectReadableInChromium(page, dir, 390);
  }
  if (!::testing::Test::HasFailure()) fs::remove_all(dir);  // kept to look at when it fails
}

}  // namespace
}  // namespace odocal
