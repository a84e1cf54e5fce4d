// The station's drivers and plans end to end, from the command line (issue
// 13 §1-2): the virtual robot on a pseudo-terminal, the virtual camera
// rendering it, and
//   - a command driver whose command is a small script driving the robot
//     over its pty (`odocal robot run`), its apply command pushing the set;
//   - an operator driver with a scripted "operator" reading the station's
//     instructions and driving what it is told (or, once, the wrong square);
//   - the default plan sized to the view, recovering Ed, Es and a hidden
//     turn slip against the scenario's truth;
//   - bad input: a command that exits non-zero, hangs, never moves the
//     robot; an apply that fails. Each: the exit code for its cause, the
//     report says why, the robot's parameters unchanged.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "odocal/test_util/test_util.h"

namespace odocal {
namespace {

using test_util::CommandResult;
using test_util::Odocal;
using test_util::ReadJson;
using test_util::RunCommand;
using ::testing::HasSubstr;

// A wide camera over the robot (2.5 m x 1.4 m of floor at the tag's
// height): every run of the plan stays in view, so the camera also checks
// each run's heading change. `runs`: the plan's lines.
std::string ScenarioText(const std::string& runs, const std::string& effects = "[]") {
  std::ostringstream os;
  os << "seed: 11\nrobot:\n"
     << "  nominal: {left_wheel_diameter_mm: 70.0, right_wheel_diameter_mm: 70.0, track_mm: 300.0, "
        "ticks_per_rev: 2048}\n"
     << "  true: {left_wheel_diameter_mm: 69.95, right_wheel_diameter_mm: 70.06, track_mm: 303.0}\n"
     << "  start_pose: {x_mm: -300, y_mm: -1000, heading_deg: 0}\n"
     << "  speed_mm_s: 400\n  accel_mm_s2: 800\n  turn_rate_deg_s: 90\n  turn_accel_deg_s2: 360\n"
     << "  rest_s: 0.1\n  pause_s: 0.2\n  noise: {wheel_mm_per_sqrt_m: 0.0}\n"
     << "runs:\n" << runs
     << "tag: {family: tag36h11, id: 5, size_mm: 100, height_mm: 150, offset_mm: {x: 0, y: 0}}\n"
     << "camera:\n  width: 960\n  height: 540\n  fx: 700\n  fy: 700\n  cx: 480\n  cy: 270\n"
     << "  distortion: [-0.05, 0.01, 0, 0, 0]\n"
     << "  pose: {x_mm: 0, y_mm: -1000, height_mm: 2000, roll_deg: 0, pitch_deg: 2, yaw_deg: 0}\n"
     << "  fps: 30\n  noise_sigma: 2.0\n  blur_sigma_px: 0.8\n  exposure_ms: 4\n"
     << "effects: " << effects << "\n";
  return os.str();
}

const char* kSquares =
    "  - {procedure: umbmark, direction: cw, side_mm: 500}\n"
    "  - {procedure: umbmark, direction: ccw, side_mm: 500}\n";

// What a robot's own drive script looks like to the command driver: it is
// given the run's values and drives (here: over the virtual robot's pty).
const char* kDriveScript =
    "#!/bin/sh\n"
    "# drive.sh PROCEDURE DIRECTION SIDE_MM DISTANCE_MM TURNS TURN_RATE_DEG_S TELEMETRY_CSV\n"
    "exec \"$ODOCAL\" robot run --port \"$ODOCAL_ROBOT_PORT\" --procedure \"$1\" --direction \"$2\" \\\n"
    "  --side-mm \"$3\" --distance-mm \"$4\" --turns \"$5\" --turn-rate-deg-s \"$6\" --telemetry \"$7\"\n";
const char* kRunTemplate = "{procedure} {direction} {side_mm} {distance_mm} {turns} {turn_rate_deg_s} {telemetry}";
const char* kApplyTemplate =
    "\"$ODOCAL\" robot push --port \"$ODOCAL_ROBOT_PORT\" left_wheel_diameter_mm={left_wheel_diameter_mm} "
    "right_wheel_diameter_mm={right_wheel_diameter_mm} track_mm={track_mm}";

struct Bench {
  std::string dir;
  Bench(const std::string& name, const std::string& scenario) : dir(test_util::MakeTempDir(name)) {
    std::ofstream(dir + "/s.yaml") << scenario;
    std::ofstream(dir + "/drive.sh") << kDriveScript;
    std::filesystem::permissions(dir + "/drive.sh", std::filesystem::perms::owner_all);
  }
  std::string Station(const std::string& args) const {
    return Odocal("station --scenario " + dir + "/s.yaml --out " + dir + "/out " + args);
  }
  std::string Drive() const { return "'" + dir + "/drive.sh " + kRunTemplate + "'"; }
  nlohmann::json Report() const { return ReadJson(dir + "/out/report.json"); }
};

void ExpectParamsAsTheyWere(const nlohmann::json& report) {
  ASSERT_TRUE(report["robot_params_final"].is_object()) << report.dump(1);
  EXPECT_EQ(report["robot_params_final"], report["robot_params_initial"]);
}

TEST(StationCommandDriver, AScriptDrivesTheRobotAndTheApplyCommandPushesTheSet) {
  const Bench b("odocal_station_command_", ScenarioText(kSquares));
  // Time scale 10, not 20: the turn check below needs the camera's frames, and
  // at 20 a machine busy with the suite's other test dropped 512 of a run's
  // (the station then honestly says "not checked", which this test cannot use).
  const CommandResult r = RunCommand(b.Station("--time-scale 10 --max-rounds 2 --driver command --run-command " +
                                               b.Drive() + " --apply-command '" + kApplyTemplate + "'"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json report = b.Report();
  EXPECT_THAT(report["driver"].get<std::string>(), HasSubstr("drive.sh"));
  ASSERT_EQ(report["iterations"].size(), 2u);
  // Each run's log holds the script's output; the camera saw each turn the planned way.
  for (const nlohmann::json& run : report["iterations"][0]["runs"]) {
    EXPECT_THAT(test_util::Slurp(run["log"].get<std::string>()), HasSubstr("completed")) << run.dump();
    ASSERT_TRUE(run["turned_deg"].is_number()) << run.dump();
    EXPECT_NEAR(std::abs(run["turned_deg"].get<double>()), 360.0, 5.0);
  }
  // The set applied by the script is the robot's (read back by the verification
  // round's robot run through the same firmware), and it corrects the truth.
  const nlohmann::json& pushed = report["iterations"][0]["pushed"];
  EXPECT_NEAR(pushed["right_wheel_diameter_mm"].get<double>() / pushed["left_wheel_diameter_mm"].get<double>(),
              70.06 / 69.95, 2e-5);
  EXPECT_GT(report["improvement"].get<double>(), 10.0);
  EXPECT_THAT(test_util::Slurp(b.dir + "/out/apply/round1.log"), HasSubstr("verified: checksum"));
  // The script's telemetry CSVs, put on the camera's clock by when the
  // motion started and ended: explain's base model fits the first round to
  // well under a millimetre (a clock off by 0.1 s would leave centimetres).
  const nlohmann::json& explain = report["explain"];
  ASSERT_TRUE(explain.is_object() && explain.contains("gap_before_mm")) << explain.dump(1).substr(0, 2000);
  EXPECT_LT(explain["gap_before_mm"].get<double>(), 1.0) << explain["base"].dump(1).substr(0, 2000);
}

TEST(StationCommandDriver, ACommandThatFailsNamesItsExitAndLeavesTheParameters) {
  const Bench b("odocal_station_command_fail_", ScenarioText(kSquares));
  const CommandResult r = RunCommand(
      b.Station("--time-scale 20 --driver command --run-command 'echo motor driver fault >&2; exit 3'"));
  EXPECT_EQ(r.exit_code, 5) << r.err;
  EXPECT_THAT(r.err, HasSubstr("exited with 3: motor driver fault")) << r.err;
  const nlohmann::json report = b.Report();
  EXPECT_EQ(report["status"], "run_not_completed");
  EXPECT_THAT(report["message"].get<std::string>(), HasSubstr("run01_umbmark_cw.log"));
  ExpectParamsAsTheyWere(report);
}

TEST(StationCommandDriver, ACommandThatHangsIsKilledAtTheTimeout) {
  const Bench b("odocal_station_command_hang_", ScenarioText(kSquares));
  // `sleep 613` in a shell that would outlive a plain kill of the shell alone.
  const CommandResult r = RunCommand(b.Station(
      "--time-scale 20 --driver command --run-timeout-s 2 --run-command 'sh -c \"sleep 613\"; true' "
      "--stop-command 'echo stop > " + b.dir + "/stopped'"));
  EXPECT_EQ(r.exit_code, 5) << r.err;
  EXPECT_THAT(r.err, HasSubstr("not completed within 2 s")) << r.err;
  EXPECT_THAT(r.err, HasSubstr("the run's command killed; stop command exited with 0")) << r.err;
  EXPECT_TRUE(std::filesystem::exists(b.dir + "/stopped")) << "the stop command ran";
  // The whole process group is gone, not only the shell.
  // ([p]: the pattern does not match the shell that runs pgrep.)
  EXPECT_NE(RunCommand("pgrep -f 'slee[p] 613'").exit_code, 0) << "a child of the command survived";
  ExpectParamsAsTheyWere(b.Report());
}

TEST(StationCommandDriver, ACommandThatNeverMovesTheRobotIsCaught) {
  const Bench b("odocal_station_command_still_", ScenarioText(kSquares));
  const CommandResult r = RunCommand(b.Station("--time-scale 20 --driver command --run-command 'sleep 0.3'"));
  EXPECT_EQ(r.exit_code, 5) << r.err;
  EXPECT_THAT(r.err, HasSubstr("the robot did not move")) << r.err;
  ExpectParamsAsTheyWere(b.Report());
}

TEST(StationCommandDriver, AnApplyThatFailsLeavesTheParametersAndSaysSo) {
  const Bench b("odocal_station_apply_fail_", ScenarioText(kSquares));
  const CommandResult r = RunCommand(b.Station("--time-scale 20 --driver command --run-command " + b.Drive() +
                                               " --apply-command 'echo robot busy; exit 4'"));
  EXPECT_EQ(r.exit_code, 7) << r.err;
  EXPECT_THAT(r.err, HasSubstr("apply: the command exited with 4: robot busy")) << r.err;
  ExpectParamsAsTheyWere(b.Report());
  // The corrected set was still written where the apply command got it.
  EXPECT_THAT(test_util::Slurp(b.dir + "/out/apply/round1.firmware.yaml"), HasSubstr("track_mm"));
}

TEST(StationCommandDriver, UnknownPlaceholderIsBadInput) {
  const Bench b("odocal_station_template_", ScenarioText(kSquares));
  const CommandResult r = RunCommand(b.Station("--driver command --run-command 'drive {sides_mm}'"));
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_THAT(r.err, HasSubstr("unknown placeholder {sides_mm}")) << r.err;
}

// A scripted operator: reads the station's instructions on stdout and drives
// each run it is asked for over the virtual robot's pty (named on the
// station's stderr); with WRONG=N it drives run N the other way round.
const char* kOperatorScript = R"(#!/bin/bash
dev=""
while IFS= read -r line; do
  echo "$line" >> "$DIR/operator.log"
  case "$line" in
    "==> run "*)
      n=${line#==> run }; n=${n%%/*}
      while [ -z "$dev" ]; do dev=$(grep -o '/dev/pts/[0-9]*' "$DIR/station.err" | head -1); sleep 0.1; done
      dir=cw; case "$line" in *counter-clockwise*) dir=ccw;; esac
      if [ "$n" = "$WRONG" ]; then if [ $dir = cw ]; then dir=ccw; else dir=cw; fi; fi
      side=$(echo "$line" | grep -o '[0-9]* mm UMBMark' | grep -o '^[0-9]*')
      sleep 0.5
      "$ODOCAL" robot run --port "$dev" --procedure umbmark --direction $dir --side-mm $side >> "$DIR/operator.log" 2>&1 ;;
  esac
done
)";

CommandResult RunWithOperator(const Bench& b, const std::string& wrong) {
  std::ofstream(b.dir + "/operator.sh") << kOperatorScript;
  std::ofstream(b.dir + "/run.sh") << "#!/bin/bash\n"
                                   << "export DIR=" << b.dir << " ODOCAL=" << test_util::OdocalBinary()
                                   << " WRONG=" << wrong << "\n"
                                   << b.Station("--time-scale 10 --driver operator") << " 2> " << b.dir
                                   << "/station.err | bash " << b.dir << "/operator.sh\n"
                                   << "exit ${PIPESTATUS[0]}\n";
  CommandResult r = RunCommand("bash " + b.dir + "/run.sh");
  r.err = test_util::Slurp(b.dir + "/station.err");
  return r;
}

TEST(StationOperatorDriver, TheCameraSeesEachRunStartAndEnd) {
  const Bench b("odocal_station_operator_", ScenarioText(kSquares));
  const CommandResult r = RunWithOperator(b, "0");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string said = test_util::Slurp(b.dir + "/operator.log");
  EXPECT_THAT(said, HasSubstr("==> run 1/2: drive the clockwise 500 mm UMBMark square now")) << said;
  EXPECT_THAT(said, HasSubstr("==> run 2/2: drive the counter-clockwise 500 mm UMBMark square now")) << said;
  // No apply command: one round, the corrected set written for the user.
  EXPECT_THAT(said, HasSubstr("corrected set (not applied)")) << said;
  const nlohmann::json report = b.Report();
  ASSERT_EQ(report["iterations"].size(), 1u);
  ExpectParamsAsTheyWere(report);
  const nlohmann::json& corrected = report["robot_params_recommended"];
  ASSERT_TRUE(corrected.is_object()) << report.dump(1);
  EXPECT_NEAR(corrected["right_wheel_diameter_mm"].get<double>() / corrected["left_wheel_diameter_mm"].get<double>(),
              70.06 / 69.95, 1e-4);
  EXPECT_THAT(test_util::Slurp(b.dir + "/out/corrected.firmware.yaml"), HasSubstr("track_mm"));
  // The station ended each run when the robot had been still (its end rest
  // measured), not at a timeout. Its turn, judged where the sightings could
  // unwrap it (~0.7 s of robot time apart at time scale 10, against 1.07 s
  // for this 90 deg/s robot; a busy machine spaces them more), is the square's.
  int judged = 0;
  for (const nlohmann::json& run : report["iterations"][0]["runs"]) {
    EXPECT_TRUE(run["return_error"].is_object()) << run.dump();
    if (run["turned_deg"].is_null()) continue;
    ++judged;
    EXPECT_NEAR(std::abs(run["turned_deg"].get<double>()), 360.0, 5.0) << run.dump();
  }
  std::printf("figures: %d of 2 runs' total turn judged\n", judged);
}

TEST(StationOperatorDriver, AnOperatorWhoDrivesTheWrongSquareIsStopped) {
  const Bench b("odocal_station_operator_wrong_", ScenarioText(kSquares));
  const CommandResult r = RunWithOperator(b, "1");
  EXPECT_EQ(r.exit_code, 5) << r.err;
  // Judged on the whole turn (+360 deg) when the sightings could unwrap it,
  // else on a corner turned left in view: caught either way.
  EXPECT_THAT(r.err, HasSubstr("run 1/2 (umbmark cw, side 500 mm): ")) << r.err;
  EXPECT_THAT(r.err, ::testing::AnyOf(HasSubstr("the camera saw the robot turn +3"),
                                      HasSubstr("where the plan turns between -360 and +0 deg")))
      << r.err;
  EXPECT_THAT(r.err, HasSubstr("was another run driven")) << r.err;
  EXPECT_THAT(test_util::Slurp(b.dir + "/operator.log"), HasSubstr("==> STOP the robot now"));
  ExpectParamsAsTheyWere(b.Report());
}

// The default plan on a robot with Ed, Eb, Es off and a hidden turn slip of
// 3 % at 1 rad/s (sample_data/scenarios/station_full_plan.yaml).
TEST(StationFullPlan, RecoversEdEsAndTheHiddenTurnSlip) {
  const std::string dir = test_util::MakeTempDir("odocal_station_full_plan_");
  const CommandResult r =
      RunCommand(Odocal("station --scenario " + test_util::SourceDir() +
                        "/sample_data/scenarios/station_full_plan.yaml --plan default --max-rounds 2 --time-scale 20 "
                        "--out " + dir + "/out"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.err, HasSubstr("default plan: 2+2 UMBMark squares of")) << r.err;
  EXPECT_THAT(r.err, HasSubstr("finding: turn slip")) << r.err;
  const nlohmann::json report = ReadJson(dir + "/out/report.json");
  const nlohmann::json& truth = report["truth"];
  const nlohmann::json& first = report["iterations"][0];  // the robot as it came: nominal parameters
  // Es: the straights' scale, within its stated sigma (the tag's print
  // tolerance dominates it; the statistical part alone is ~2e-5).
  const nlohmann::json& scale = first["cvra"]["scale"];
  EXPECT_NEAR(scale["scale"].get<double>(), truth["Es"].get<double>(), 3.0 * scale["sigma_total"].get<double>());
  // The rendered tag prints exactly: what remains is the camera height from
  // the tag's apparent size (4e-4 relative, systematic_scale_sigma in measure.h).
  EXPECT_NEAR(scale["scale"].get<double>(), truth["Es"].get<double>(), 3.0 * 4e-4);
  // Turn slip from the spins at 30 and 120 deg/s. The model takes the
  // commanded rate; the robot's acceleration ramps make the mean rate of a
  // fast spin lower, biasing f low by up to w^2 / (alpha Theta) relative
  // (alpha 360 deg/s^2, Theta 2 turns: 5.6 % at 120 deg/s; docs/calibration.md, "Turn slip").
  const nlohmann::json& slip = first["turn_slip"];
  ASSERT_TRUE(slip["significant"].get<bool>()) << slip.dump(1);
  const double f = truth["turn_slip_at_1rad_s"].get<double>();
  const double w = 120.0 * M_PI / 180.0, alpha = 360.0 * M_PI / 180.0, theta = 4.0 * M_PI;
  const double ramp = w * w / (alpha * theta);
  EXPECT_NEAR(slip["slip_at_1rad_s"].get<double>(), f, 4.0 * slip["sigma_slip_at_1rad_s"].get<double>() + ramp * f);
  // At rest (no slip) the spins' track factor is the turn gain Eb/Es.
  EXPECT_NEAR(slip["track_factor_at_rest"].get<double>(), truth["turn_gain"].get<double>(),
              4.0 * slip["sigma_track_factor_at_rest"].get<double>() + ramp * f * 30.0 * M_PI / 180.0);
  // Ed: UMBMark is first order, and the track is 5 % off on the robot as it
  // came (and its turns slip): the first round's Ed came out 0.9e-4 to
  // 1.2e-4 from the truth, several of its stated (statistical) sigmas; a
  // further round would correct it (three rounds: 4e-5, docs/calibration.md).
  const nlohmann::json& final_set = report["robot_params_final"];
  EXPECT_NEAR(final_set["right_wheel_diameter_mm"].get<double>() / final_set["left_wheel_diameter_mm"].get<double>(),
              truth["Ed"].get<double>(), 2.5e-4);
  EXPECT_NEAR(first["estimate"]["Ed"].get<double>(), truth["Ed"].get<double>(), 2.5e-4);
  // The second round, on the corrected set, measures what is left: Ed within 2e-4 of 1.
  EXPECT_NEAR(report["iterations"][1]["estimate"]["Ed"].get<double>(), 1.0, 2e-4);
}

}  // namespace
}  // namespace odocal
