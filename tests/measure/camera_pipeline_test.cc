// The camera replaces the tape measure: rendered sessions with
// exact truth, measured by the real odocal binary from their H.264 videos.
// Small sensors at the standard condition's pixel scale (fx = 1400, the
// 80 mm tag ~60 px wide) keep the clips short; the full 1080p figures are in
// bench/ and docs/performance.md.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "odocal/calibration/umbmark.h"
#include "odocal/config/session.h"
#include "odocal/measure/measure.h"
#include "odocal/media/video.h"
#include "odocal/test_util/test_util.h"
#include "odocal/vision/renderer.h"

namespace odocal {
namespace {

namespace fs = std::filesystem;
using test_util::CommandResult;
using test_util::RunCommand;

using test_util::Odocal;

using test_util::ReadJson;

// The standard camera (pose, distortion, pixel scale, noise, blur, exposure)
// on a smaller sensor centred on the same optical axis.
std::string Camera(int width, int height) {
  std::ostringstream os;
  os << "tag: {family: tag36h11, id: 5, size_mm: 80, height_mm: 150, offset_mm: {x: 0, y: 0}}\n"
     << "camera:\n  width: " << width << "\n  height: " << height
     << "\n  fx: 1400\n  fy: 1400\n  cx: " << width / 2.0 << "\n  cy: " << height / 2.0
     << "\n  distortion: [-0.12, 0.05, 0, 0, 0]\n"
     << "  pose: {x_mm: 0, y_mm: -1000, height_mm: 2000, roll_deg: 0, pitch_deg: 3, yaw_deg: 0}\n"
     << "  fps: 30\n  noise_sigma: 2.0\n  blur_sigma_px: 0.8\n  exposure_ms: 4\n";
  return os.str();
}

std::string Robot(const std::string& true_wheels, double start_x_mm, double start_y_mm,
                  double rest_s, double noise) {
  std::ostringstream os;
  os << "robot:\n"
     << "  nominal: {left_wheel_diameter_mm: 70.0, right_wheel_diameter_mm: 70.0, track_mm: 300.0, ticks_per_rev: 2048}\n"
     << "  true: " << true_wheels << "\n"
     << "  start_pose: {x_mm: " << start_x_mm << ", y_mm: " << start_y_mm << ", heading_deg: 0}\n"
     << "  speed_mm_s: 500\n  accel_mm_s2: 800\n  turn_rate_deg_s: 180\n  turn_accel_deg_s2: 360\n"
     << "  rest_s: " << rest_s << "\n  pause_s: 0.2\n"
     << "  noise: {wheel_mm_per_sqrt_m: " << noise << "}\n";
  return os.str();
}

std::string SimulateInto(const std::string& name, const std::string& scenario_text) {
  const std::string dir = test_util::MakeTempDir("odocal_cam_" + name + "_");
  std::ofstream(dir + "/scenario.yaml") << scenario_text;
  const CommandResult r =
      RunCommand(Odocal("simulate --scenario " + dir + "/scenario.yaml --out " + dir + "/sim"));
  EXPECT_EQ(r.exit_code, 0) << r.err;
  return dir + "/sim";
}

// ---------------------------------------------------------------------------
// Accuracy against rendered truth, across the image and across headings.
// The session is measured once, as batch measures it (MeasureSessions with
// batch's defaults); both checks read that one measurement. That batch's
// report prints these numbers is CameraEndToEnd's and the golden snapshot's
// to check.
class CameraAccuracy : public ::testing::Test {
 protected:
  static void ReturnErrorsMatchRenderedTruth(const measure::SessionMeasurement& measured);
  static void MovingTagPosePerFrameWithinAMillimetre(const measure::SessionMeasurement& measured);
  static void SetUpTestSuite() {
    sim_ = new std::string(SimulateInto(
        "accuracy",
        "seed: 21\n" +
            Robot("{left_wheel_diameter_mm: 69.95, right_wheel_diameter_mm: 70.06, track_mm: 303.0}",
                  -300, -1000, 1.5, 0.05) +
            "runs:\n"
            "  - {procedure: straight, distance_mm: 250}\n"
            "  - {procedure: spin, turns: 1, direction: cw}\n"
            "  - {procedure: out_and_back, distance_mm: 150, repeats: 1}\n"
            "  - {procedure: umbmark, direction: ccw, side_mm: 200}\n" +
            Camera(960, 540)));
  }
  static void TearDownTestSuite() { delete sim_; }
  static std::string* sim_;
};
std::string* CameraAccuracy::sim_ = nullptr;

void CameraAccuracy::ReturnErrorsMatchRenderedTruth(const measure::SessionMeasurement& measured) {
  const nlohmann::json truth = ReadJson(*sim_ + "/truth.json");
  ASSERT_EQ(measured.runs.size(), truth["runs"].size());
  for (size_t i = 0; i < truth["runs"].size(); ++i) {
    // A return error is true - odometry (docs/conventions.md): the true end
    // pose in the start frame less the firmware's own belief of its end (the
    // plan, to within a tick: a straight's return error is its error, not
    // its length).
    const nlohmann::json& t = truth["runs"][i]["true_return_error"];
    const nlohmann::json& o = truth["runs"][i]["odometry_end"];
    const calibration::MeasuredRun& m = measured.runs[i].measured;
    ASSERT_TRUE(m.return_error.has_value()) << m.name;
    EXPECT_TRUE(m.flags.empty()) << m.name << ": " << m.flags.size() << " flags";
    const calibration::ReturnError got = calibration::ReturnError::FromMmDeg(
        m.return_error->pose.x() * 1e3, m.return_error->pose.y() * 1e3,
        m.return_error->pose.heading() * 180.0 / M_PI);
    const calibration::ReturnError expected = calibration::ReturnError::FromMmDeg(
        t["x_mm"].get<double>() - o["x_mm"].get<double>(), t["y_mm"].get<double>() - o["y_mm"].get<double>(),
        t["theta_deg"].get<double>() - o["heading_deg"].get<double>());
    std::printf("%-24s error vs truth: x %+.4f mm, y %+.4f mm, theta %+.5f deg\n", m.name.c_str(),
                (got.x_m - expected.x_m) * 1e3, (got.y_m - expected.y_m) * 1e3,
                calibration::WrapAngle(*got.heading_rad - *expected.heading_rad) * 180.0 / M_PI);
    EXPECT_THAT(got, test_util::IsNearReturnError(expected, 0.15, 0.01)) << m.name;
    // Every number comes with its quality.
    EXPECT_GT(m.return_error->sigma_x_m(), 0.0) << m.name;
  }
}

void CameraAccuracy::MovingTagPosePerFrameWithinAMillimetre(const measure::SessionMeasurement& measured) {
  // Truth per frame, in the world; the measurement's frame differs from it by
  // the gauge the camera cannot see (its x, y, yaw guess): align by a rigid fit.
  std::vector<Eigen::Vector2d> measured_xy, true_xy;
  std::vector<double> measured_h, true_h;
  for (const measure::RunMeasurement& rm : measured.runs) {
    std::ifstream in(*sim_ + "/" + rm.run.name + ".frames.csv");
    std::string line;
    std::getline(in, line);
    for (const calibration::CameraRecord& c : rm.measured.camera) {
      ASSERT_TRUE(std::getline(in, line));
      if (!c.valid) continue;
      std::vector<double> v;
      std::stringstream ss(line);
      std::string f;
      while (std::getline(ss, f, ',')) v.push_back(std::stod(f));
      measured_xy.emplace_back(c.T_world_robot.x(), c.T_world_robot.y());
      measured_h.push_back(c.T_world_robot.heading());
      true_xy.emplace_back(v[4] * 1e-3, v[5] * 1e-3);
      true_h.push_back(v[6] * M_PI / 180.0);
    }
  }
  ASSERT_GT(measured_xy.size(), 200u);
  // Rigid 2-D fit (Procrustes): rotation from the centred cross-covariance.
  Eigen::Vector2d ca = Eigen::Vector2d::Zero(), cb = Eigen::Vector2d::Zero();
  for (size_t i = 0; i < measured_xy.size(); ++i) {
    ca += measured_xy[i] / measured_xy.size();
    cb += true_xy[i] / true_xy.size();
  }
  double sin_sum = 0.0, cos_sum = 0.0;
  for (size_t i = 0; i < measured_xy.size(); ++i) {
    const Eigen::Vector2d a = measured_xy[i] - ca, b = true_xy[i] - cb;
    cos_sum += a.dot(b);
    sin_sum += a.x() * b.y() - a.y() * b.x();
  }
  const double yaw = std::atan2(sin_sum, cos_sum);
  const Eigen::Rotation2Dd R(yaw);
  double worst_mm = 0.0, worst_deg = 0.0;
  for (size_t i = 0; i < measured_xy.size(); ++i) {
    const Eigen::Vector2d p = R * (measured_xy[i] - ca) + cb;
    worst_mm = std::max(worst_mm, (p - true_xy[i]).norm() * 1e3);
    worst_deg = std::max(worst_deg, std::abs(calibration::WrapAngle(measured_h[i] + yaw - true_h[i])) * 180 / M_PI);
  }
  std::printf("per-frame pose over %zu frames (moving included): worst %.3f mm, %.4f deg\n",
              measured_xy.size(), worst_mm, worst_deg);
  EXPECT_LE(worst_mm, 1.0);
}

// One test for both checks: ctest runs each test in its own process, and the
// suite's rendering and measurement would be made once per test.
TEST_F(CameraAccuracy, ReturnErrorsAndPerFramePosesAgainstRenderedTruth) {
  const auto session = config::LoadSession(*sim_ + "/session.yaml");
  ASSERT_TRUE(session) << session.message;
  const auto measured = measure::MeasureSessions({*session}, measure::MeasureOptions{}, {});
  ASSERT_TRUE(measured) << measured.message;
  {
    SCOPED_TRACE("ReturnErrorsMatchRenderedTruth");
    ReturnErrorsMatchRenderedTruth(measured->front());
  }
  {
    SCOPED_TRACE("MovingTagPosePerFrameWithinAMillimetre");
    MovingTagPosePerFrameWithinAMillimetre(measured->front());
  }
}

// ---------------------------------------------------------------------------
// End to end: a mis-calibrated robot, one cw and one ccw 2 m square, a camera
// that sees only the home area (the tag leaves and comes back).
TEST(CameraEndToEnd, BatchRecoversEdAndEbFromOneSquareEachWay) {
  const std::string sim = SimulateInto(
      "e2e", "seed: 5\n" +
                 Robot("{left_wheel_diameter_mm: 69.92, right_wheel_diameter_mm: 70.08, track_mm: 304.5}",
                       -100, -1000, 0.8, 0.0) +
                 "runs:\n"
                 "  - {procedure: umbmark, direction: cw, side_mm: 2000}\n"
                 "  - {procedure: umbmark, direction: ccw, side_mm: 2000}\n" +
                 Camera(960, 540));
  const std::string out = test_util::MakeTempDir("odocal_cam_e2e_");
  const CommandResult r = RunCommand(Odocal("batch " + sim + "/session.yaml --out " + out));
  ASSERT_EQ(r.exit_code, 0) << r.err << r.out;
  const nlohmann::json truth = ReadJson(sim + "/truth.json");
  const nlohmann::json report = ReadJson(out + "/report.json");
  const double Ed = truth["truth"]["Ed"], Eb = truth["truth"]["Eb"], Es = truth["truth"]["Es"];
  const nlohmann::json& estimate = report["umbmark"]["estimate"];
  std::printf("Ed %.7f (truth %.7f), Eb %.7f (turn gain truth %.7f)\n", estimate["Ed"].get<double>(),
              Ed, estimate["Eb"].get<double>(), Eb / Es);
  EXPECT_NEAR(estimate["Ed"].get<double>(), Ed, 5e-5);
  EXPECT_NEAR(estimate["Eb"].get<double>(), Eb / Es, 2e-4);
  bool left_view = false;
  for (const auto& run : report["runs"])
    for (const auto& flag : run["flags"])
      left_view = left_view || flag.get<std::string>().rfind("tag_out_of_view_mid_run", 0) == 0;
  EXPECT_TRUE(left_view) << "the home-area camera loses the tag on the square";
  for (const char* key : {"left_wheel_diameter_mm", "right_wheel_diameter_mm", "track_mm", "ticks_per_rev"})
    EXPECT_TRUE(report["corrected"].contains(key)) << key;
}

// ---------------------------------------------------------------------------
// Bad input: a clear line, a flagged gap, a non-zero exit when nothing could
// be measured; never a number without its flags.
class CameraBadInput : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    sim_ = new std::string(SimulateInto(
        "bad", "seed: 9\n" +
                   Robot("{left_wheel_diameter_mm: 69.95, right_wheel_diameter_mm: 70.06, track_mm: 303.0}",
                         -150, -1000, 1.0, 0.0) +
                   "runs:\n  - {procedure: straight, distance_mm: 150}\n" + Camera(640, 360)));
  }
  static void TearDownTestSuite() { delete sim_; }

  // A copy of the good session with its one video replaced, or its text edited.
  static std::string Variant(const std::string& name, const std::function<void(const std::string&)>& edit) {
    const std::string dir = test_util::MakeTempDir("odocal_bad_" + name + "_");
    fs::copy(*sim_, dir, fs::copy_options::recursive | fs::copy_options::overwrite_existing);
    edit(dir);
    return dir;
  }
  static std::string Video(const std::string& dir) { return dir + "/run01_straight.mp4"; }
  static void ReplaceInSession(const std::string& dir, const std::string& from, const std::string& to) {
    std::ifstream in(dir + "/session.yaml");
    std::stringstream text;
    text << in.rdbuf();
    std::string s = text.str();
    const size_t at = s.find(from);
    ASSERT_NE(at, std::string::npos) << from;
    s.replace(at, from.size(), to);
    std::ofstream(dir + "/session.yaml") << s;
  }
  static CommandResult Batch(const std::string& dir) {
    return RunCommand(Odocal("batch " + dir + "/session.yaml --out " + dir + "/out"));
  }
  static std::string Flags(const std::string& dir) {
    if (!fs::exists(dir + "/out/report.json")) return "";
    const nlohmann::json report = ReadJson(dir + "/out/report.json");
    EXPECT_TRUE(report["runs"][0]["return_error"].is_null()) << "no number without its flags";
    return report["runs"][0]["flags"].dump();
  }
  static std::string* sim_;
};
std::string* CameraBadInput::sim_ = nullptr;

TEST_F(CameraBadInput, TheGoodSessionMeasures) {
  const CommandResult r = Batch(Variant("good", [](const std::string&) {}));
  EXPECT_EQ(r.exit_code, 0) << r.err;
}

TEST_F(CameraBadInput, MissingVideoNamesTheKey) {
  const std::string dir = Variant("missing", [](const std::string& d) { fs::remove(Video(d)); });
  const CommandResult r = Batch(dir);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, ::testing::HasSubstr("runs[0].video")) << r.err;
}

TEST_F(CameraBadInput, EmptyCorruptAndTruncatedVideosAreFlagged) {
  const std::string empty = Variant("empty", [](const std::string& d) { std::ofstream(Video(d), std::ios::trunc); });
  CommandResult r = Batch(empty);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(Flags(empty), ::testing::HasSubstr("video_unreadable")) << r.err;

  const std::string corrupt = Variant("corrupt", [](const std::string& d) {
    std::mt19937 rng(4);
    std::ofstream out(Video(d), std::ios::binary | std::ios::trunc);
    for (int i = 0; i < 200000; ++i) out.put(static_cast<char>(rng() & 0xFF));
  });
  r = Batch(corrupt);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(Flags(corrupt), ::testing::HasSubstr("video_unreadable")) << r.err;

  const std::string truncated = Variant("truncated", [](const std::string& d) {
    fs::resize_file(Video(d), fs::file_size(Video(d)) / 3);
  });
  r = Batch(truncated);
  EXPECT_EQ(r.exit_code, 1) << "the end of the run is missing";
  EXPECT_THAT(Flags(truncated), ::testing::HasSubstr("no_end_rest")) << r.err;
}

TEST_F(CameraBadInput, WrongTagIdOrFamilyIsNamed) {
  const std::string id = Variant("id", [](const std::string& d) { ReplaceInSession(d, "id: 5", "id: 7"); });
  CommandResult r = Batch(id);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(Flags(id), ::testing::HasSubstr("wrong_tag_id"));
  const std::string family =
      Variant("family", [](const std::string& d) { ReplaceInSession(d, "tag36h11", "tag25h9"); });
  r = Batch(family);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(Flags(family), ::testing::HasSubstr("tag_never_seen"));
}

TEST_F(CameraBadInput, TwoTagsWithTheSameIdAreNotMeasured) {
  const std::string dir = Variant("duplicate", [](const std::string& d) {
    // The robot's tag and a second copy 150 mm away, composited per pixel.
    vision::Intrinsics in{640, 360, 1400, 1400, 320, 180, {-0.12, 0.05, 0, 0, 0}};
    vision::TagSpec tag;
    tag.id = 5;
    tag.size_mm = 80;
    tag.height_mm = 150;
    const vision::CameraModel camera(in, vision::CameraMount{0, -1000, 2000, 0, 3, 0});
    vision::RenderOptions options;
    options.body_radius_mm = 60.0;
    auto created = vision::Renderer::Create(camera, tag, options);
    ASSERT_TRUE(created.ok()) << created.message;
    media::Mp4Writer writer;
    media::Mp4WriterOptions wo;
    wo.backend = media::Mp4WriterOptions::Backend::kFfmpegCli;
    ASSERT_TRUE(writer.Open(Video(d), 30, cv::Size(640, 360), wo).ok());
    cv::Mat bg;
    created.renderer->background().convertTo(bg, CV_8U);
    for (int k = 0; k < 60; ++k) {
      const cv::Mat a = created.renderer->Render(calibration::Pose2::FromXYHeading(-0.15, -1.0, 0.0)).image;
      const cv::Mat b = created.renderer->Render(calibration::Pose2::FromXYHeading(0.05, -1.0, 0.3)).image;
      cv::Mat da, db, frame = a.clone();
      cv::absdiff(a, bg, da);
      cv::absdiff(b, bg, db);
      b.copyTo(frame, db > da);
      ASSERT_TRUE(writer.Write(frame, k / 30.0).ok());
    }
    ASSERT_TRUE(writer.Close().ok());
    ASSERT_TRUE(writer.WriteTimestamps(d + "/run01_straight.timestamps.csv").ok());
  });
  const CommandResult r = Batch(dir);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(Flags(dir), ::testing::HasSubstr("duplicate_tag_id")) << r.err;
}

TEST(CameraNoRest, ARunWithoutRestsHasNoReturnError) {
  const std::string sim = SimulateInto(
      "norest", "seed: 3\n" +
                    Robot("{left_wheel_diameter_mm: 69.95, right_wheel_diameter_mm: 70.06, track_mm: 303.0}",
                          -150, -1000, 0.0, 0.0) +
                    "runs:\n  - {procedure: straight, distance_mm: 300}\n" + Camera(640, 360));
  const std::string out = test_util::MakeTempDir("odocal_norest_");
  const CommandResult r = RunCommand(Odocal("batch " + sim + "/session.yaml --out " + out));
  EXPECT_EQ(r.exit_code, 1);
  const nlohmann::json report = ReadJson(out + "/report.json");
  EXPECT_TRUE(report["runs"][0]["return_error"].is_null());
  EXPECT_THAT(report["runs"][0]["flags"].dump(), ::testing::HasSubstr("no_start_rest"));
}

// The rolling shutter and the camera plane, on rendered video (the
// renderer's band-wise readout, not the plane model's first-order shear):
// the standard camera's pixel scale on 960x540 with a 20 ms readout, a
// straight, a spin and a square (with the straight and the spin alone the
// views are fewer and the readout and the tilt trade off: 3.6 deg without
// the readout, 0.49 deg with it; docs/vision.md). The plane's views move; without the readout
// in the plane estimate their shear tilts it, with it the tilt is as good as
// a global shutter's (0.018 deg, measured on the same plan) and the readout
// comes out near 20 ms.
TEST(CameraRollingShutter, TheReadoutDoesNotTiltTheCameraPlane) {
  auto plane = [](const std::string& sim, bool fit_readout) {
    const auto session = config::LoadSession(sim + "/session.yaml");
    EXPECT_TRUE(session) << session.message;
    measure::MeasureOptions options;
    if (!fit_readout) options.plane.rolling_shutter_min_shear_px = 1e9;  // never fitted
    // The plane is fitted to the tracked frames before any rest is refined:
    // the rests' edge-model refinement, most of a measurement's time, does
    // not change it.
    options.exact_rest_refinement = false;
    options.model_free_rest_refinement = false;
    const auto measured = measure::MeasureSessions({*session}, options, {});
    EXPECT_TRUE(measured) << measured.message;
    return measured->front().plane;
  };
  const std::string runs =
      "runs:\n"
      "  - {procedure: straight, distance_mm: 250}\n"
      "  - {procedure: spin, turns: 1, direction: cw}\n"
      "  - {procedure: umbmark, direction: ccw, side_mm: 200}\n";
  const std::string robot =
      Robot("{left_wheel_diameter_mm: 69.95, right_wheel_diameter_mm: 70.06, track_mm: 303.0}", -300, -1000, 1.0,
            0.05);
  const std::string rolling =
      SimulateInto("rs_plane", "seed: 4\n" + robot + runs + Camera(960, 540) + "  rolling_shutter_ms: 20\n");
  const vision::CameraPlaneResult rs_plain = plane(rolling, false), rs_aware = plane(rolling, true);
  ASSERT_TRUE(rs_plain.ok() && rs_aware.ok());
  auto tilt_error = [](const vision::CameraPlaneResult& p) {
    return std::hypot(p.mount.roll_deg - 0.0, p.mount.pitch_deg - 3.0);
  };
  std::printf("[figure] plane tilt error (truth roll 0, pitch 3 deg, height 2000 mm): rolling shutter without "
              "the readout %.3f deg (%.2f mm), with it %.3f deg (%.2f mm), readout %.2f +- %.2f ms\n",
              tilt_error(rs_plain), rs_plain.mount.height_mm - 2000.0, tilt_error(rs_aware),
              rs_aware.mount.height_mm - 2000.0, rs_aware.rolling_shutter_ms, rs_aware.sigma_rolling_shutter_ms);
  ASSERT_TRUE(rs_aware.rolling_shutter_fitted);
  EXPECT_NEAR(rs_aware.rolling_shutter_ms, 20.0, 3.0 * rs_aware.sigma_rolling_shutter_ms + 1.0);
  // The shear's tilt is gone: far better than without, and within the
  // plane's stated sigma of the truth.
  EXPECT_LT(tilt_error(rs_aware), 0.2 * tilt_error(rs_plain));
  EXPECT_LT(std::abs(rs_aware.mount.roll_deg), 3.0 * rs_aware.sigma_roll_deg + 0.05);
  EXPECT_LT(std::abs(rs_aware.mount.pitch_deg - 3.0), 3.0 * rs_aware.sigma_pitch_deg + 0.05);
}

}  // namespace
}  // namespace odocal
