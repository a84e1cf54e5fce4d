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
#include <sstream>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

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
             << kPlanYaml;
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
  static void TearDownTestSuite() { fs::remove_all(dir_); }
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

}  // namespace
}  // namespace odocal
