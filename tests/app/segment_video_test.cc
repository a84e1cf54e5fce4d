// One continuous video for a whole plan (issue 13 §3, automatic
// segmentation), end to end through the real binary: `simulate` with
// camera.one_video writes a session whose runs all name recording.mp4 with no
// start_s/end_s; `batch` finds the runs in the video, matches them to the
// plan and measures each against the simulator's truth. A session that plans
// a run the video does not hold, or a square the other way round, is an error
// naming both runs, and no report is written. And setup-check on the
// video's first second predicts what batch then measures, within a factor
// 1.5 pooled over this video and three more (issue 13 §5).
// A small camera (640x360, 15 fps, 37-45 s of video each) keeps it to ~75 s.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

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
  static void SetupCheckPredictsWhatBatchThenMeasures();
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
  {
    SCOPED_TRACE("setup-check on the first second (the robot still)");
    SetupCheckPredictsWhatBatchThenMeasures();
  }
}

// The errors batch made on the closed runs (the squares and the spin: a
// straight's x is its length, the camera's scale) against the simulator's
// truth: x, y per axis (mm) and heading (deg) of true - odometry, as batch
// measures a return error.
struct ClosedRunErrors {
  std::vector<double> position_mm, heading_deg;
};

void AddClosedRunErrors(const nlohmann::json& truth, const nlohmann::json& report, ClosedRunErrors* out) {
  for (const nlohmann::json& run : report["runs"]) {
    const nlohmann::json* t = nullptr;
    for (const nlohmann::json& r : truth["runs"])
      if (r["name"] == run["name"]) t = &r;
    ASSERT_NE(t, nullptr) << run["name"];
    if ((*t)["procedure"] == "straight") continue;
    ASSERT_TRUE(run["return_error"].is_object()) << run.dump();
    const nlohmann::json &e = run["return_error"], &te = (*t)["true_return_error"], &o = (*t)["odometry_end"];
    out->position_mm.push_back(e["x_mm"].get<double>() - (te["x_mm"].get<double>() - o["x_mm"].get<double>()));
    out->position_mm.push_back(e["y_mm"].get<double>() - (te["y_mm"].get<double>() - o["y_mm"].get<double>()));
    out->heading_deg.push_back(e["theta_deg"].get<double>() -
                               (te["theta_deg"].get<double>() - o["heading_deg"].get<double>()));
  }
}

double Rms(const std::vector<double>& v) {
  double s = 0.0;
  for (double x : v) s += x * x / v.size();
  return std::sqrt(s);
}

// setup-check (issue 13 §5) on the video's first 0.9 s, the robot standing
// still, against the rendered truth; then its predicted accuracy against the
// errors batch then made, pooled over this video and kMoreClips more.
void SegmentVideo::SetupCheckPredictsWhatBatchThenMeasures() {
  const std::string video = dir_ + "/sim/recording.mp4", calibration = dir_ + "/sim/camera.yaml";
  const std::string common = "setup-check --camera " + video + " --calibration " + calibration +
                             " --tag tag36h11:5:80:150 --seconds 0.9 --runs 1";
  const CommandResult r = RunCommand(Odocal(common + " --square-mm 250 --out " + dir_ + "/setup"));
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_THAT(r.out, HasSubstr("the 250 mm squares fit"));
  const nlohmann::json j = ReadJson(dir_ + "/setup/setup_check.json");
  EXPECT_TRUE(std::filesystem::exists(dir_ + "/setup/setup_check.png"));
  // The truth: an 80 mm tag 1850 mm below a 933 px lens: 40 px; the camera
  // 2000 mm over the floor, pitched 3 deg.
  EXPECT_NEAR(j["quality"]["side_px"].get<double>(), 933.3 * 80.0 / 1850.0, 1.5);
  EXPECT_NEAR(j["camera_mount"]["height_mm"].get<double>(), 2000.0, 20.0);
  EXPECT_NEAR(j["camera_mount"]["pitch_deg"].get<double>(), 3.0, 0.5);
  EXPECT_TRUE(j["floor"]["squares_fit"].get<bool>());
  // odocal's renderer draws the print exactly: the edge shift is measured and
  // is about nothing.
  ASSERT_TRUE(j.contains("edge_shift")) << j.dump(1);
  EXPECT_LT(std::abs(j["edge_shift"]["shift_px"].get<double>()), 0.06);
  EXPECT_THAT(r.out, HasSubstr("the tag's edges lie"));

  // The prediction against the errors batch then made. One video holds
  // three closed runs (6 position, 3 heading errors) and one still second
  // (one draw of the image error setup-check reads its prediction from):
  // too few to tell a factor 1.5. Pooled over 4 videos, each its own seed
  // (image noise, wheel noise) and start pose: 24 position and 12 heading
  // errors, whose RMS is known to +-14 % and +-20 % (1 sigma, chi-square),
  // the predictions' mean square over 4 still seconds to +-9 % (of the
  // sigma). The issue's bound, 1/1.5..1.5, is then 2.4 and 1.8 sigma of the
  // ratio. The sweep behind the model (12 seeds, two resolutions, three
  // camera presets): bench/setup_check/setup_check_sweep.py, docs/vision.md.
  ClosedRunErrors errors;
  AddClosedRunErrors(truth_, ReadJson(dir_ + "/report/report.json"), &errors);
  ASSERT_FALSE(HasFatalFailure());
  std::vector<double> predicted_p = {j["predicted"]["return_error_position_mm"].get<double>()};
  std::vector<double> predicted_h = {j["predicted"]["return_error_heading_deg"].get<double>()};
  struct Clip {
    int seed;
    const char* start_pose;
  };
  constexpr Clip kMoreClips[] = {{21, "{x_mm: -200, y_mm: 5, heading_deg: 1.2}"},
                                 {22, "{x_mm: 150, y_mm: -5, heading_deg: 178.6}"},
                                 {23, "{x_mm: -60, y_mm: 0, heading_deg: -1.5}"}};
  for (const Clip& clip : kMoreClips) {
    SCOPED_TRACE("clip seed " + std::to_string(clip.seed));
    // The same camera and robot: the squares and the spin, no straight.
    std::string scenario = kScenario;
    scenario.replace(scenario.find("seed: 13"), 8, "seed: " + std::to_string(clip.seed));
    const std::string start = "{x_mm: -125, y_mm: 0, heading_deg: 0}";
    scenario.replace(scenario.find(start), start.size(), clip.start_pose);
    const std::string straight = "  - {procedure: straight, distance_mm: 400}\n";
    scenario.erase(scenario.find(straight), straight.size());
    const std::string d = dir_ + "/clip" + std::to_string(clip.seed);
    std::filesystem::create_directories(d);
    std::ofstream(d + "/scenario.yaml") << scenario;
    const CommandResult sim = RunCommand(Odocal("simulate --scenario " + d + "/scenario.yaml --out " + d + "/sim"));
    ASSERT_EQ(sim.exit_code, 0) << sim.err;
    const CommandResult check = RunCommand(Odocal("setup-check --camera " + d + "/sim/recording.mp4 --calibration " +
                                                  d + "/sim/camera.yaml --tag tag36h11:5:80:150 --seconds 0.9 "
                                                  "--runs 1 --square-mm 250 --out " + d + "/setup"));
    ASSERT_EQ(check.exit_code, 0) << check.out << check.err;
    const nlohmann::json p = ReadJson(d + "/setup/setup_check.json")["predicted"];
    predicted_p.push_back(p["return_error_position_mm"].get<double>());
    predicted_h.push_back(p["return_error_heading_deg"].get<double>());
    const CommandResult batch = RunCommand(Odocal("batch " + d + "/sim/session.yaml --out " + d + "/report"));
    ASSERT_EQ(batch.exit_code, 0) << batch.out << batch.err;
    AddClosedRunErrors(ReadJson(d + "/sim/truth.json"), ReadJson(d + "/report/report.json"), &errors);
    ASSERT_FALSE(HasFatalFailure());
  }
  ASSERT_EQ(errors.position_mm.size(), 24u);
  ASSERT_EQ(errors.heading_deg.size(), 12u);
  const double pred_p = Rms(predicted_p), pred_h = Rms(predicted_h);
  const double rms_p = Rms(errors.position_mm), rms_h = Rms(errors.heading_deg);
  std::printf("  setup-check predicted %.4f mm, %.5f deg (RMS over 4 videos); batch's errors RMS %.4f mm (24), "
              "%.5f deg (12): ratio %.2f, %.2f\n",
              pred_p, pred_h, rms_p, rms_h, pred_p / rms_p, pred_h / rms_h);
  EXPECT_GT(pred_p, rms_p / 1.5);
  EXPECT_LT(pred_p, rms_p * 1.5);
  EXPECT_GT(pred_h, rms_h / 1.5);
  EXPECT_LT(pred_h, rms_h * 1.5);

  // A square too large for the view: said, exit 1.
  const CommandResult big = RunCommand(Odocal(common + " --square-mm 1500 --out " + dir_ + "/setup-big"));
  EXPECT_EQ(big.exit_code, 1) << big.out << big.err;
  EXPECT_THAT(big.out, HasSubstr("the 1500 mm squares do NOT fit"));
  // Bad input: named, exit 2.
  const CommandResult bad = RunCommand(Odocal("setup-check --camera " + video + " --calibration " + calibration +
                                              " --tag tag36h11:five:80 --out " + dir_ + "/setup-bad"));
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_THAT(bad.err, HasSubstr("--tag tag36h11:five:80"));
  // The wrong tag: not found, said, exit 1.
  const CommandResult wrong = RunCommand(Odocal("setup-check --camera " + video + " --calibration " + calibration +
                                                " --tag tag36h11:7:80 --seconds 0.5 --out " + dir_ + "/setup-wrong"));
  EXPECT_EQ(wrong.exit_code, 1);
  EXPECT_THAT(wrong.err, HasSubstr("tags seen, but never id 7"));
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
