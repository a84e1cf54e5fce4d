// One continuous video for a whole plan (issue 13 §3, automatic
// segmentation), end to end through the real binary: `simulate` with
// camera.one_video writes a session whose runs all name recording.mp4 with no
// start_s/end_s; `batch` finds the runs in the video, matches them to the
// plan and measures each against the simulator's truth. A session that plans
// a run the video does not hold, or a square the other way round, is an error
// naming both runs, and no report is written.
// A small camera (640x360, 15 fps, ~45 s of video) keeps it to ~15 s.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <regex>
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

constexpr const char* kScenario = R"(seed: 13
robot:
  nominal: {left_wheel_diameter_mm: 70.0, right_wheel_diameter_mm: 70.0, track_mm: 300.0, ticks_per_rev: 2048}
  true:    {left_wheel_diameter_mm: 69.95, right_wheel_diameter_mm: 70.06, track_mm: 302.0}
  start_pose: {x_mm: -125, y_mm: 0, heading_deg: 0}
  speed_mm_s: 300
  turn_rate_deg_s: 120
  rest_s: 1.0
  noise: {wheel_mm_per_sqrt_m: 0.05}
runs:
  - {procedure: umbmark, direction: cw, side_mm: 250}
  - {procedure: umbmark, direction: ccw, side_mm: 250}
  - {procedure: straight, distance_mm: 400}
  - {procedure: spin, direction: ccw, turns: 1}
tag: {family: tag36h11, id: 5, size_mm: 80, height_mm: 150}
camera:
  width: 640
  height: 360
  fx: 933.3
  fy: 933.3
  cx: 320
  cy: 180
  distortion: [-0.12, 0.05, 0, 0, 0]
  pose: {x_mm: 0, y_mm: 0, height_mm: 2000, roll_deg: 0, pitch_deg: 3, yaw_deg: 0}
  fps: 15
  noise_sigma: 0.5
  blur_sigma_px: 0.8
  exposure_ms: 4
  crf: 12
  one_video: true
effects: []
)";

// Both checks share one rendering: one test, two parts (ctest runs each test
// in its own process, so a suite fixture would render twice).
class SegmentVideo : public ::testing::Test {
 protected:
  static void Render() {
    dir_ = test_util::MakeTempDir("odocal_segment_video_");
    std::ofstream(dir_ + "/scenario.yaml") << kScenario;
    const CommandResult sim =
        RunCommand(Odocal("simulate --scenario " + dir_ + "/scenario.yaml --out " + dir_ + "/sim"));
    ASSERT_EQ(sim.exit_code, 0) << sim.err;
    ASSERT_THAT(sim.out, HasSubstr("to 1 video"));
    truth_ = ReadJson(dir_ + "/sim/truth.json");
  }
  static void FindsEachRunAndMeasuresIt();
  static void APlanTheVideoDoesNotHoldIsAnErrorNamingTheRuns();
  static std::string dir_;
  static nlohmann::json truth_;
};
std::string SegmentVideo::dir_;
nlohmann::json SegmentVideo::truth_;

TEST_F(SegmentVideo, OneVideoForAWholePlan) {
  Render();
  ASSERT_FALSE(HasFatalFailure());
  {
    SCOPED_TRACE("the plan as driven");
    FindsEachRunAndMeasuresIt();
  }
  {
    SCOPED_TRACE("a plan the video does not hold");
    APlanTheVideoDoesNotHoldIsAnErrorNamingTheRuns();
  }
}

void SegmentVideo::FindsEachRunAndMeasuresIt() {
  std::ifstream yaml(dir_ + "/sim/session.yaml");
  std::stringstream text;
  text << yaml.rdbuf();
  // What the operator gives: one video, the plan, no time spans.
  EXPECT_EQ(std::regex_search(text.str(), std::regex("end_s")), false) << text.str();
  const CommandResult r = RunCommand(Odocal("batch " + dir_ + "/sim/session.yaml --out " + dir_ + "/report"));
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_THAT(r.out, HasSubstr("found run01_umbmark_cw at"));
  EXPECT_THAT(r.out, HasSubstr("umbmark ccw, side 25"));
  EXPECT_THAT(r.out, HasSubstr("found run04_spin_ccw at"));
  const nlohmann::json report = ReadJson(dir_ + "/report/report.json");
  const nlohmann::json& found = report["sessions"][0]["segmented_runs"];
  ASSERT_EQ(found.size(), 4u) << report["sessions"][0].dump(1);
  for (size_t i = 0; i < 4; ++i) {
    const nlohmann::json& truth = truth_["runs"][i];
    SCOPED_TRACE(truth["name"].get<std::string>());
    // Each span holds its run's motion: the simulator's start and end (each
    // with a 1 s rest) lie within half a second of it.
    EXPECT_LT(found[i]["start_s"].get<double>(), truth["start_time_s"].get<double>() + 1.5);
    EXPECT_GT(found[i]["end_s"].get<double>(), truth["end_time_s"].get<double>() - 1.5);
    const nlohmann::json& run = report["runs"][i];
    ASSERT_TRUE(run["return_error"].is_object()) << run.dump();
    EXPECT_TRUE(run["flags"].empty()) << run["flags"].dump();
    if (truth["procedure"] == "straight") continue;  // a straight's x is its length there
    // Closed paths: the true return error is truth.json's (odometry closes).
    const nlohmann::json& e = run["return_error"];
    const nlohmann::json& s = run["sigma"];
    const nlohmann::json& t = truth["true_return_error"];
    EXPECT_NEAR(e["x_mm"].get<double>(), t["x_mm"].get<double>(), 4.0 * s["x_mm"].get<double>() + 0.02);
    EXPECT_NEAR(e["y_mm"].get<double>(), t["y_mm"].get<double>(), 4.0 * s["y_mm"].get<double>() + 0.02);
    EXPECT_NEAR(e["theta_deg"].get<double>(), t["theta_deg"].get<double>(),
                4.0 * s["theta_deg"].get<double>() + 0.005);
  }
}

void SegmentVideo::APlanTheVideoDoesNotHoldIsAnErrorNamingTheRuns() {
  std::ifstream yaml(dir_ + "/sim/session.yaml");
  std::stringstream text;
  text << yaml.rdbuf();
  std::string session = text.str();
  // The operator's plan says the second square was cw and lists a run that
  // was never driven.
  const std::string ccw = "name: run02_umbmark_ccw, procedure: umbmark, direction: ccw";
  ASSERT_NE(session.find(ccw), std::string::npos) << session;
  session.replace(session.find(ccw), ccw.size(), "name: run02_umbmark_ccw, procedure: umbmark, direction: cw");
  const std::string spin_line = session.substr(session.find("  - {name: run04_spin_ccw"));
  session += std::regex_replace(spin_line, std::regex("run04_spin_ccw, procedure: spin, direction: ccw, turns: 1"),
                                "forgotten, procedure: spin, direction: cw, turns: 2");
  std::ofstream(dir_ + "/sim/wrong.yaml") << session;
  const CommandResult r = RunCommand(Odocal("batch " + dir_ + "/sim/wrong.yaml --out " + dir_ + "/wrong-report"));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_THAT(r.err, HasSubstr("recording.mp4: the runs found in it do not match the session's plan"));
  EXPECT_THAT(r.err, HasSubstr("run 'run02_umbmark_ccw' (umbmark cw, side 250 mm): the segment at"));
  EXPECT_THAT(r.err, HasSubstr("is umbmark ccw"));
  EXPECT_THAT(r.err, HasSubstr("run 'forgotten' (spin cw, 2 turns): missing"));
  EXPECT_FALSE(std::filesystem::exists(dir_ + "/wrong-report/report.json"));
}

}  // namespace
}  // namespace odocal
