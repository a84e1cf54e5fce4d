// Scenario files: the issue's keys load into the right typed values; every
// malformed file is rejected with the file, the line and the key named.
#include "odocal/config/scenario.h"
#include "odocal/config/session.h"

#include "odocal/calibration/effect_registry.h"

#include <cmath>
#include <filesystem>
#include <algorithm>
#include <fstream>
#include <tuple>

#include <gtest/gtest.h>

#include "odocal/test_util/test_util.h"

namespace odocal {
namespace {

std::string WriteTemp(const std::string& text) {
  const std::string dir = test_util::MakeTempDir("odocal_scenario_");
  const std::string path = dir + "/s.yaml";
  std::ofstream(path) << text;
  return path;
}

const char* kIssueScenario = R"(seed: 7
robot:
  nominal: {left_wheel_diameter_mm: 70.0, right_wheel_diameter_mm: 70.0, track_mm: 300.0, ticks_per_rev: 2048}
  true:    {left_wheel_diameter_mm: 69.95, right_wheel_diameter_mm: 70.06, track_mm: 303.0}
  start_pose: {x_mm: 0, y_mm: 0, heading_deg: 0}
  speed_mm_s: 250
  turn_rate_deg_s: 60
runs:
  - {procedure: umbmark, direction: cw, side_mm: 2000}
  - {procedure: umbmark, direction: ccw, side_mm: 2000}
  - {procedure: straight, distance_mm: 1500}
  - {procedure: spin, turns: 3, direction: cw}
  - {procedure: out_and_back, distance_mm: 1000, repeats: 2, reference: wall}
effects: []
)";

TEST(Scenario, LoadsTheIssuesKeys) {
  const auto s = config::LoadScenario(WriteTemp(kIssueScenario));
  ASSERT_TRUE(s) << s.message;
  EXPECT_EQ(s->seed, 7u);
  EXPECT_NEAR(s->robot.nominal.track_m, 0.300, 1e-12);
  EXPECT_DOUBLE_EQ(s->robot.nominal.ticks_per_rev, 2048.0);
  EXPECT_DOUBLE_EQ(s->robot.truth.ticks_per_rev, 2048.0) << "defaults to the nominal encoder";
  EXPECT_NEAR(s->robot.truth.left_wheel_diameter_m, 0.06995, 1e-12);
  EXPECT_NEAR(s->robot.limits.turn_rate_rad_s, M_PI / 3.0, 1e-12);
  ASSERT_EQ(s->runs.size(), 5u);
  EXPECT_EQ(s->runs[0].direction, calibration::Direction::kCw);
  EXPECT_NEAR(s->runs[1].side_m, 2.0, 1e-12);
  EXPECT_EQ(s->runs[3].turns, 3);
  EXPECT_EQ(s->runs[4].reference, calibration::Reference::kWall);
  EXPECT_EQ(config::RunName(0, s->runs[0]), "run01_umbmark_cw");
  EXPECT_EQ(config::RunName(2, s->runs[2]), "run03_straight");
}

struct BadCase {
  std::string name;  // the test's name
  std::string from;  // text replaced in the issue's scenario
  std::string to;
  std::string expected;  // must appear in the error
};

void PrintTo(const BadCase& c, std::ostream* os) { *os << c.name; }

class ScenarioErrors : public ::testing::TestWithParam<BadCase> {};

TEST_P(ScenarioErrors, NameTheField) {
  std::string text = kIssueScenario;
  const BadCase& c = GetParam();
  const size_t at = text.find(c.from);
  ASSERT_NE(at, std::string::npos) << c.from;
  text.replace(at, c.from.size(), c.to);
  const std::string path = WriteTemp(text);
  std::string error;
  error = test_util::ErrorOf(config::LoadScenario(path));
  EXPECT_THAT(error, ::testing::HasSubstr(c.expected)) << error;
  EXPECT_THAT(error, ::testing::HasSubstr(path)) << "names the file: " << error;
  EXPECT_THAT(error, ::testing::Not(::testing::HasSubstr("\n"))) << "one line: " << error;
}

INSTANTIATE_TEST_SUITE_P(
    Malformed, ScenarioErrors,
    ::testing::Values(
        BadCase{"UnknownProcedure", "procedure: straight", "procedure: spiral", "runs[2].procedure: unknown procedure 'spiral'"},
        BadCase{"NegativeTrack", "track_mm: 300.0", "track_mm: -300.0", "robot.nominal.track_mm: must be positive"},
        BadCase{"TrackNotANumber", "track_mm: 300.0", "track_mm: abc", "robot.nominal.track_mm: expected a number"},
        BadCase{"MissingTrack", "track_mm: 300.0, ", "", "robot.nominal.track_mm: missing"},
        BadCase{"UnknownTopLevelKey", "seed: 7", "sede: 7", "sede: unknown key"},
        BadCase{"UnknownRobotKey", "speed_mm_s: 250", "sped_mm_s: 250", "robot.sped_mm_s: unknown key"},
        BadCase{"UnknownDirection", "direction: cw, side_mm", "direction: left, side_mm", "runs[0].direction: expected cw or ccw"},
        BadCase{"ZeroSide", "side_mm: 2000}\n  - {procedure: umbmark, direction: ccw", "side_mm: 0}\n  - {procedure: umbmark, direction: ccw", "runs[0].side_mm: must be positive"},
        BadCase{"FractionalTurns", "turns: 3", "turns: 2.5", "runs[3].turns: expected a whole number"},
        BadCase{"SideOnAStraight", "{procedure: straight, distance_mm: 1500}", "{procedure: straight, distance_mm: 1500, side_mm: 3}", "runs[2].side_mm: does not apply to procedure straight"},
        BadCase{"UnknownEffect", "effects: []", "effects: [{name: warp_drive}]", "effects[0].name: unknown effect 'warp_drive'"},
        BadCase{"UnknownEffectKey", "effects: []", "effects: [{name: turn_slip, fraction: 0.1}]", "effects[0].fraction: unknown key"},
        BadCase{"LatencyWithoutMs", "effects: []", "effects: [{name: camera_latency}]", "effects[0].ms: missing"},
        BadCase{"RollingShutterWithoutMs", "effects: []", "effects: [{name: rolling_shutter}]", "effects[0].ms: missing"},
        BadCase{"NegativeRollingShutter", "effects: []", "effects: [{name: rolling_shutter, ms: -5}]", "effects[0].ms: must be in [0, 1000]"},
        BadCase{"EmptyRuns", "  - {procedure: umbmark, direction: cw, side_mm: 2000}\n"
                             "  - {procedure: umbmark, direction: ccw, side_mm: 2000}\n"
                             "  - {procedure: straight, distance_mm: 1500}\n"
                             "  - {procedure: spin, turns: 3, direction: cw}\n"
                             "  - {procedure: out_and_back, distance_mm: 1000, repeats: 2, reference: wall}\n",
                             "  []\n", "runs: expected a non-empty list"},
        BadCase{"ZeroTicksPerRev", "ticks_per_rev: 2048}", "ticks_per_rev: 0}", "ticks_per_rev: must be a positive number"},
        BadCase{"InvalidYaml", "left_wheel_diameter_mm: 70.0,", "left_wheel_diameter_mm: [70.0,", "not valid YAML"}),
    [](const ::testing::TestParamInfo<BadCase>& info) { return info.param.name; });

// Every candidate effect explain can name (calibration/effect_registry.h)
// has the simulator's counterpart of the same name, hidden in a scenario:
// named alone it is not an unknown effect (a missing parameter, at most).
TEST(Scenario, EveryRegisteredEffectHasItsSimulatorCounterpart) {
  for (const calibration::EffectDescriptor& d : calibration::Effects()) {
    std::string text = kIssueScenario;
    text.replace(text.find("effects: []"), 11, "effects: [{name: " + std::string(d.name) + "}]");
    const auto s = config::LoadScenario(WriteTemp(text));
    if (!s) {
      EXPECT_EQ(s.message.find("unknown effect"), std::string::npos) << d.name << ": " << s.message;
    }
  }
}

TEST(Scenario, LoadsEveryEffect) {
  std::string text = kIssueScenario;
  text.replace(text.find("effects: []"), 11,
               "effects:\n"
               "  - {name: tag_offset, x_mm: 20, y_mm: -5}\n"
               "  - {name: camera_latency, ms: 40}\n"
               "  - {name: turn_slip, fraction_at_1rad_s: 0.02}\n"
               "  - {name: lens_distortion, k1: 0.01}\n"
               "  - {name: encoder_backlash, ticks: 3}\n"
               "  - {name: carpet_drift, grain_deg: 90, rate_mm_per_m: 2}\n"
               "  - {name: tracker_yaw, deg: -1.5}\n"
               "  - {name: speed_slip, fraction_at_1m_s: 0.03}\n"
               "  - {name: eccentric_wheel, wheel: right, amplitude: 0.02, phase_deg: 90}\n"
               "  - {name: arc_scale, fraction_at_1_per_m: 0.001}\n"
               "  - {name: rolling_shutter, ms: 20}\n");
  const auto s = config::LoadScenario(WriteTemp(text));
  ASSERT_TRUE(s) << s.message;
  const sim::Effects& e = s->robot.effects;
  EXPECT_EQ(e.Names().size(), 11u);
  EXPECT_NEAR(e.rolling_shutter->readout_s, 0.020, 1e-12);
  EXPECT_NEAR(e.arc_scale->fraction_at_1_per_m, 0.001, 1e-12);
  EXPECT_NEAR(e.tracker_yaw->yaw_rad, -1.5 * M_PI / 180, 1e-12);
  EXPECT_NEAR(e.speed_slip->fraction_at_1m_s, 0.03, 1e-12);
  EXPECT_FALSE(e.eccentric_wheel->left);
  EXPECT_NEAR(e.eccentric_wheel->amplitude, 0.02, 1e-12);
  EXPECT_NEAR(e.eccentric_wheel->phase_rad, M_PI / 2, 1e-12);
  EXPECT_NEAR(e.tag_offset->x_m, 0.020, 1e-12);
  EXPECT_NEAR(e.camera_latency->latency_s, 0.040, 1e-12);
  EXPECT_NEAR(e.turn_slip->fraction_at_1rad_s, 0.02, 1e-12);
  EXPECT_NEAR(e.lens_distortion->k1_delta, 0.01, 1e-12);
  EXPECT_NEAR(e.encoder_backlash->ticks, 3.0, 1e-12);
  EXPECT_NEAR(e.carpet_drift->grain_rad, M_PI / 2, 1e-12);
  EXPECT_NEAR(e.carpet_drift->rate_m_per_m, 0.002, 1e-12);
}

// A hidden rolling shutter is rendered as the camera's: it replaces a
// profile's readout, and the scenario may not also give the camera's key.
TEST(Scenario, ARollingShutterEffectIsTheCamerasAndGivenOnce) {
  std::string text = kIssueScenario;
  text.replace(text.find("effects: []"), 11, "effects: [{name: rolling_shutter, ms: 20}]");
  text += "tag: {family: tag36h11, id: 5, size_mm: 80, height_mm: 150}\n"
          "camera: {width: 640, height: 480, fx: 700, fy: 700, cx: 320, cy: 240, "
          "pose: {height_mm: 1200}, profile: webcam}\n";
  const auto s = config::LoadScenario(WriteTemp(text));
  ASSERT_TRUE(s) << s.message;
  EXPECT_NEAR(s->robot.effects.rolling_shutter->readout_s, 0.020, 1e-12);
  std::string both = text;
  both.replace(both.find("profile: webcam"), 15, "rolling_shutter_ms: 20");
  const auto refused = config::LoadScenario(WriteTemp(both));
  ASSERT_FALSE(refused);
  EXPECT_THAT(refused.message, ::testing::HasSubstr("camera.rolling_shutter_ms"));
  EXPECT_THAT(refused.message, ::testing::HasSubstr("give the readout once"));
}

TEST(Scenario, LoadsACircle) {
  std::string text = kIssueScenario;
  text.replace(text.find("  - {procedure: spin, turns: 3, direction: cw}"), 46,
               "  - {procedure: circle, radius_mm: 320, turns: 2, direction: cw}");
  std::string error;
  const auto s = config::LoadScenario(WriteTemp(text));
  ASSERT_TRUE(s) << s.message;
  const calibration::RunSpec* circle = nullptr;
  for (const auto& r : s->runs)
    if (r.procedure == calibration::Procedure::kCircle) circle = &r;
  ASSERT_NE(circle, nullptr);
  EXPECT_NEAR(circle->radius_m, 0.320, 1e-12);
  EXPECT_EQ(circle->turns, 2);
  EXPECT_EQ(circle->direction, calibration::Direction::kCw);
  // A circle without its radius is named.
  text.replace(text.find("radius_mm: 320, "), 16, "");
  error = test_util::ErrorOf(config::LoadScenario(WriteTemp(text)));
  EXPECT_THAT(error, ::testing::HasSubstr("radius_mm")) << error;
}

TEST(Scenario, MissingEmptyAndDirectoryFilesAreNamed) {
  std::string error;
  error = test_util::ErrorOf(config::LoadScenario("/nonexistent/s.yaml"));
  EXPECT_THAT(error, ::testing::HasSubstr("/nonexistent/s.yaml: no such file")) << error;
  error = test_util::ErrorOf(config::LoadScenario(WriteTemp("")));
  EXPECT_THAT(error, ::testing::HasSubstr("empty scenario file")) << error;
  error = test_util::ErrorOf(config::LoadScenario(test_util::MakeTempDir("odocal_dir_")));
  EXPECT_THAT(error, ::testing::HasSubstr("is a directory")) << error;
}

// A session keeps a circle's size and direction through a write and a load.
TEST(Session, ACircleRunRoundTrips) {
  const std::string dir = test_util::MakeTempDir("odocal_session_circle_");
  std::ofstream(dir + "/run01.poses.csv") << "t_s,x_mm,y_mm,heading_deg\n0,0,0,0\n";
  std::ofstream(dir + "/run01.telemetry.csv") << "t_s,left_ticks,right_ticks\n0,0,0\n";
  config::Session session;
  session.has_camera = false;
  session.nominal.left_wheel_diameter_m = 0.084;
  session.nominal.right_wheel_diameter_m = 0.084;
  session.nominal.track_m = 0.2;
  session.nominal.ticks_per_rev = 2796.8;
  config::SessionRun run;
  run.name = "circle_cw";
  run.spec = calibration::RunSpec::Circle(0.32, 2, calibration::Direction::kCw);
  run.poses = dir + "/run01.poses.csv";
  run.telemetry = dir + "/run01.telemetry.csv";
  run.end_s = 10.0;
  session.runs.push_back(run);
  ASSERT_TRUE(config::WriteSession(session, dir + "/session.yaml").ok());
  const auto loaded = config::LoadSession(dir + "/session.yaml");
  ASSERT_TRUE(loaded) << loaded.message;
  ASSERT_EQ(loaded->runs.size(), 1u);
  const calibration::RunSpec& spec = loaded->runs[0].spec;
  EXPECT_EQ(spec.procedure, calibration::Procedure::kCircle);
  EXPECT_NEAR(spec.radius_m, 0.32, 1e-9);
  EXPECT_EQ(spec.turns, 2);
  EXPECT_EQ(spec.direction, calibration::Direction::kCw);
}

// A session with a floor reference and a measured tag size: through a write
// and a load, and its bad keys named.
config::Session FloorSession(const std::string& dir) {
  std::ofstream(dir + "/run01.mp4") << "not read here";
  config::Session session;
  session.camera_file = dir + "/camera.yaml";
  session.intrinsics = vision::Intrinsics{640, 480, 700, 700, 320, 240, {0, 0, 0, 0, 0}};
  session.camera_mount_guess.height_mm = 1200;
  session.tag.id = 5;
  session.tag_size_sigma_mm = 0.05;
  vision::FloorReference reference;
  reference.tags = {{1, 80.0}, {2, 80.0}, {3, 60.0}};
  reference.distances = {{1, 2, 1040.5, 0.3}, {2, 3, 742.1, 0.5}};
  reference.tag_height_sigma_mm = 0.8;
  session.floor_reference = reference;
  session.nominal.left_wheel_diameter_m = session.nominal.right_wheel_diameter_m = 0.07;
  session.nominal.track_m = 0.3;
  session.nominal.ticks_per_rev = 2048;
  config::SessionRun run;
  run.name = "run01";
  run.spec = calibration::RunSpec::Straight(0.4);
  run.video = dir + "/run01.mp4";
  session.runs.push_back(run);
  return session;
}

TEST(Session, AFloorReferenceRoundTrips) {
  const std::string dir = test_util::MakeTempDir("odocal_session_floor_");
  ASSERT_TRUE(config::WriteSession(FloorSession(dir), dir + "/session.yaml").ok());
  const auto loaded = config::LoadSession(dir + "/session.yaml");
  ASSERT_TRUE(loaded) << loaded.message;
  ASSERT_TRUE(loaded->tag_size_sigma_mm);
  EXPECT_NEAR(*loaded->tag_size_sigma_mm, 0.05, 1e-12);
  ASSERT_TRUE(loaded->floor_reference);
  const vision::FloorReference& r = *loaded->floor_reference;
  ASSERT_EQ(r.tags.size(), 3u);
  EXPECT_EQ(r.tags[2].id, 3);
  EXPECT_NEAR(r.tags[2].size_mm, 60.0, 1e-12);
  ASSERT_EQ(r.distances.size(), 2u);
  EXPECT_EQ(r.distances[1].id_a, 2);
  EXPECT_EQ(r.distances[1].id_b, 3);
  EXPECT_NEAR(r.distances[1].mm, 742.1, 1e-9);
  EXPECT_NEAR(r.distances[1].sigma_mm, 0.5, 1e-12);
  EXPECT_NEAR(r.tag_height_sigma_mm, 0.8, 1e-12);
  std::string why;
  EXPECT_TRUE(r.IsValid(&why)) << why;
}

TEST(Session, BadFloorReferenceKeysAreNamed) {
  const std::string dir = test_util::MakeTempDir("odocal_session_floor_bad_");
  ASSERT_TRUE(config::WriteSession(FloorSession(dir), dir + "/good.yaml").ok());
  const std::string good = test_util::Slurp(dir + "/good.yaml");
  for (const auto& [from, to, expected] : std::vector<std::tuple<std::string, std::string, std::string>>{
           {"between: [2, 3]", "between: [2, 9]", "floor_reference.distances[1].between: tag 9 is not in floor_reference.tags"},
           {"between: [2, 3]", "between: [2, 2]", "joins a tag to itself"},
           {"between: [2, 3]", "between: [2]", "expected two tag ids"},
           {"mm: 742.1", "mm: -742.1", "floor_reference.distances[1].mm"},
           {"sigma_mm: 0.5", "sigma_mm: 0", "floor_reference.distances[1].sigma_mm"},
           {"{id: 3, size_mm: 60}", "{id: 2, size_mm: 60}", "tag 2 listed twice"},
           {"{id: 3, size_mm: 60}", "{id: 3}", "floor_reference.tags[2].size_mm"},
           {"tag_height_sigma_mm: 0.8", "tag_height_sigma: 0.8", "floor_reference.tag_height_sigma: unknown key"},
           {"size_sigma_mm: 0.05", "size_sigma_mm: -1", "tag.size_sigma_mm: must not be negative"}}) {
    std::string text = good;
    const size_t at = text.find(from);
    ASSERT_NE(at, std::string::npos) << from << " not in\n" << good;
    text.replace(at, from.size(), to);
    std::ofstream(dir + "/bad.yaml") << text;
    const std::string error = test_util::ErrorOf(config::LoadSession(dir + "/bad.yaml"));
    EXPECT_THAT(error, ::testing::HasSubstr(expected)) << from << " -> " << to;
  }
}

TEST(Session, WhoAndWhenRoundTripAndABadTimeIsNamed) {
  const std::string dir = test_util::MakeTempDir("odocal_session_who_");
  config::Session session = FloorSession(dir);
  session.robot_id = "R-0042";
  session.odometer_km = 812.5;
  session.recorded_utc = "2026-03-02T09:00:00Z";
  ASSERT_TRUE(config::WriteSession(session, dir + "/session.yaml").ok());
  const auto loaded = config::LoadSession(dir + "/session.yaml");
  ASSERT_TRUE(loaded) << loaded.message;
  EXPECT_EQ(loaded->robot_id, "R-0042");
  ASSERT_TRUE(loaded->odometer_km);
  EXPECT_NEAR(*loaded->odometer_km, 812.5, 1e-12);
  EXPECT_EQ(loaded->recorded_utc, "2026-03-02T09:00:00Z");
  // Its content, for the record's digest: the session file and the run's video, once each.
  const std::vector<std::string> files = config::SessionFiles(*loaded);
  EXPECT_EQ(files.front(), dir + "/session.yaml");
  EXPECT_EQ(std::count(files.begin(), files.end(), dir + "/run01.mp4"), 1);

  std::string text = test_util::Slurp(dir + "/session.yaml");
  text.replace(text.find("2026-03-02T09:00:00Z"), 20, "last tuesday");
  std::ofstream(dir + "/bad.yaml") << text;
  const std::string error = test_util::ErrorOf(config::LoadSession(dir + "/bad.yaml"));
  EXPECT_THAT(error, ::testing::HasSubstr("recorded_utc"));
  EXPECT_THAT(error, ::testing::HasSubstr("last tuesday"));
}

}  // namespace
}  // namespace odocal
