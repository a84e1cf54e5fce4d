// The hands-off station: the virtual robot behind the
// firmware library on a real pseudo-terminal, the virtual camera rendering it
// live, the whole loop in-process so the test can see the truth, plus the
// failure paths, each injected with an existing seam (a MotionBackend, a
// Transport or a FrameSource wrapper, FirmwareHost's cable pull, the robot's
// storage) and checked the same way: the robot is stopped, its parameters
// read back are bitwise the ones it had, and the result says why.
#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <optional>
#include <sstream>
#include <thread>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "odocal/config/camera_file.h"
#include "odocal/config/scenario.h"
#include "odocal/robot_link/client.h"
#include "odocal/robot_link/firmware_host.h"
#include "odocal/robot_link/serial_transport.h"
#include "odocal/sim/sim_motion_backend.h"
#include "odocal/simulation/camera_sim.h"
#include "odocal/simulation/sim_camera_source.h"
#include "odocal/live/live_state.h"
#include "odocal/station/driver.h"
#include "odocal/station/report_json.h"
#include "odocal/station/station.h"
#include "odocal/test_util/test_util.h"

namespace odocal {
namespace {

using namespace std::chrono_literals;
using robot_link::ParamSet;

// The standard pixel scale on a small sensor over the home area
// (tests/rig/camera_pipeline_test.cc): the robot leaves the view on a square.
// `camera_extra`: more keys of camera:, each line indented by two spaces.
std::string ScenarioText(const std::string& true_wheels, double start_x_mm, double start_y_mm,
                         double side_mm, int per_direction, const std::string& camera_extra = "") {
  std::ostringstream os;
  os << "seed: 7\nrobot:\n"
     << "  nominal: {left_wheel_diameter_mm: 70.0, right_wheel_diameter_mm: 70.0, track_mm: 300.0, "
        "ticks_per_rev: 2048}\n"
     << "  true: " << true_wheels << "\n"
     << "  start_pose: {x_mm: " << start_x_mm << ", y_mm: " << start_y_mm << ", heading_deg: 0}\n"
     << "  speed_mm_s: 500\n  accel_mm_s2: 800\n  turn_rate_deg_s: 180\n  turn_accel_deg_s2: 360\n"
     << "  rest_s: 0.1\n  pause_s: 0.2\n  noise: {wheel_mm_per_sqrt_m: 0.0}\n"
     << "runs:\n";
  for (int i = 0; i < per_direction; ++i) {
    os << "  - {procedure: umbmark, direction: cw, side_mm: " << side_mm << "}\n"
       << "  - {procedure: umbmark, direction: ccw, side_mm: " << side_mm << "}\n";
  }
  os << "tag: {family: tag36h11, id: 5, size_mm: 80, height_mm: 150, offset_mm: {x: 0, y: 0}}\n"
     << "camera:\n  width: 960\n  height: 540\n  fx: 1400\n  fy: 1400\n  cx: 480\n  cy: 270\n"
     << "  distortion: [-0.12, 0.05, 0, 0, 0]\n"
     << "  pose: {x_mm: 0, y_mm: -1000, height_mm: 2000, roll_deg: 0, pitch_deg: 3, yaw_deg: 0}\n"
     << "  fps: 30\n  noise_sigma: 2.0\n  blur_sigma_px: 0.8\n  exposure_ms: 4\n" << camera_extra;
  return os.str();
}

const char* kMisCalibrated = "{left_wheel_diameter_mm: 69.95, right_wheel_diameter_mm: 70.06, track_mm: 303.0}";

// The virtual station: scenario, simulated robot on a pty, virtual camera.
struct VirtualStation {
  config::Scenario scenario;
  std::unique_ptr<sim::SimMotionBackend> backend;
  std::unique_ptr<robot_link::MotionBackend> wrapper;  // optional fault injector
  std::unique_ptr<robot_link::FirmwareHost> host;
  std::unique_ptr<robot_link::SerialTransport> port;
  std::unique_ptr<simulation::SimCameraSource> camera;
  station::StationSetup setup;
  std::vector<std::string> log;

  // The robot's parameters through a fresh client on the same line.
  ParamSet ReadBack() {
    robot_link::Client client(*port);
    const auto hello = client.Hello();
    EXPECT_TRUE(hello.ok()) << hello.message;
    const auto params = client.GetParams();
    EXPECT_TRUE(params.ok()) << params.message;
    return params.value.value_or(ParamSet{});
  }
};

std::unique_ptr<VirtualStation> MakeStation(
    const std::string& scenario_text, const std::string& storage_path = "",
    std::function<std::unique_ptr<robot_link::MotionBackend>(sim::SimMotionBackend&)> wrap = {},
    double time_scale = 50.0) {
  auto vs = std::make_unique<VirtualStation>();
  const std::string dir = test_util::MakeTempDir("odocal_station_");
  std::ofstream(dir + "/scenario.yaml") << scenario_text;
  const auto scenario = config::LoadScenario(dir + "/scenario.yaml");
  EXPECT_TRUE(scenario) << scenario.message;
  if (!scenario) return nullptr;
  vs->scenario = *scenario;
  vs->backend = std::make_unique<sim::SimMotionBackend>(vs->scenario.robot);
  if (wrap) vs->wrapper = wrap(*vs->backend);
  robot_link::FirmwareHostOptions options;
  options.time_scale = time_scale;
  options.storage_path = storage_path;
  const calibration::WheelParams& n = vs->scenario.robot.nominal;
  options.robot.defaults = ParamSet{n.left_wheel_diameter_m * 1e3, n.right_wheel_diameter_m * 1e3,
                                    n.track_m * 1e3, static_cast<uint32_t>(n.ticks_per_rev)};
  auto host = robot_link::FirmwareHost::Start(
      options, vs->wrapper ? *vs->wrapper : static_cast<robot_link::MotionBackend&>(*vs->backend));
  EXPECT_TRUE(host.ok()) << host.message;
  if (!host.ok()) return nullptr;
  vs->host = std::move(*host.value);
  auto port = robot_link::SerialTransport::Open(vs->host->device_path());
  EXPECT_TRUE(port.ok()) << port.message;
  if (!port.ok()) return nullptr;
  vs->port = std::move(*port.value);
  auto camera = simulation::SimCameraSource::Create(*vs->scenario.camera, *vs->scenario.tag, *vs->backend);
  EXPECT_TRUE(camera.ok()) << camera.message;
  if (!camera.ok()) return nullptr;
  vs->camera = std::move(*camera);
  vs->setup.transport = vs->port.get();
  vs->setup.camera = vs->camera.get();
  vs->setup.camera_on_robot_clock = true;  // the virtual camera renders robot time (as `odocal station` sets)
  vs->setup.intrinsics = vs->scenario.camera->intrinsics;
  vs->setup.mount_guess = vs->scenario.camera->mount;
  vs->setup.tag = *vs->scenario.tag;
  vs->setup.plan = vs->scenario.runs;
  if (vs->scenario.camera->floor_tags)
    vs->setup.floor_reference = simulation::TapedFloorReference(*vs->scenario.camera->floor_tags);
  VirtualStation* raw = vs.get();
  vs->setup.progress = [raw](const std::string& line) {
    raw->log.push_back(line);
    std::fprintf(stderr, "  station: %s\n", line.c_str());
  };
  return vs;
}

const ParamSet kNominal{70.0, 70.0, 300.0, 2048};

// What every failure must leave behind.
void ExpectLeftAsItWas(VirtualStation& vs, const station::StationResult& r) {
  EXPECT_FALSE(r.ok());
  EXPECT_FALSE(r.message.empty());
  // The robot is not running (stopped by the station, or finished by itself).
  for (int i = 0; i < 200 && vs.host->running(); ++i) std::this_thread::sleep_for(20ms);
  EXPECT_FALSE(vs.host->running());
  EXPECT_TRUE(vs.host->active().SameBits(kNominal)) << vs.host->active();
  EXPECT_TRUE(vs.ReadBack().SameBits(kNominal));
}

TEST(StationEndToEnd, CalibratesAMisCalibratedVirtualRobotInAtMostTwoRounds) {
  auto vs = MakeStation(ScenarioText(kMisCalibrated, -100, -1000, 2000, 1));
  ASSERT_TRUE(vs);
  const station::StationResult r = station::RunStation(vs->setup, station::StationOptions{});
  ASSERT_TRUE(r.ok()) << ToString(r.status) << ": " << r.message;
  ASSERT_GE(r.iterations.size(), 2u);
  EXPECT_LE(r.iterations.size(), 2u) << "converged within the measurement uncertainty in two rounds";
  const calibration::WheelParams& n = vs->scenario.robot.nominal;
  const calibration::WheelParams& t = vs->scenario.robot.truth;
  const double Ed = (t.right_wheel_diameter_m / t.left_wheel_diameter_m) /
                    (n.right_wheel_diameter_m / n.left_wheel_diameter_m);
  const double Es = (t.left_wheel_diameter_m + t.right_wheel_diameter_m) /
                    (n.left_wheel_diameter_m + n.right_wheel_diameter_m);
  const double turn_gain = (t.track_m / n.track_m) / Es;
  const station::StationIteration& first = r.iterations.front();
  const station::StationIteration& last = r.iterations.back();
  std::printf("figures: E_max,syst %.3f mm -> %.4f mm (%.0fx) in %zu rounds, %.1f s wall\n",
              first.estimate.emax_syst_m * 1e3, last.estimate.emax_syst_m * 1e3, r.improvement.value_or(0),
              r.iterations.size(), r.wall_s);
  std::printf("figures: Ed %.7f (truth %.7f, diff %.1e), Eb %.7f (turn gain truth %.7f, diff %.1e)\n",
              first.estimate.coupled.Ed, Ed, first.estimate.coupled.Ed - Ed, first.estimate.coupled.Eb,
              turn_gain, first.estimate.coupled.Eb - turn_gain);
  std::printf("figures: camera plane estimated %d from %d views, pitch %.4f deg (true 3)\n",
              r.plane_estimated, r.plane.views_used, r.plane.mount.pitch_deg);
  EXPECT_NEAR(first.estimate.coupled.Ed, Ed, 5e-5);
  EXPECT_NEAR(first.estimate.coupled.Eb, turn_gain, 2e-4);
  ASSERT_TRUE(r.improvement);
  EXPECT_GE(*r.improvement, 50.0);
  // The set pushed in round 1 is what the robot holds, bitwise.
  ASSERT_TRUE(first.pushed);
  EXPECT_FALSE(last.pushed) << "the last round only verifies";
  ASSERT_TRUE(r.params_final);
  EXPECT_TRUE(r.params_final->SameBits(*first.pushed));
  EXPECT_TRUE(vs->ReadBack().SameBits(*first.pushed));
  const calibration::WheelParams pushed{first.pushed->left_wheel_diameter_mm * 1e-3,
                                        first.pushed->right_wheel_diameter_mm * 1e-3,
                                        first.pushed->track_mm * 1e-3, 0.0};
  EXPECT_THAT(vs->backend->BelievedParams(), test_util::IsNearWheelParams(pushed, 1e-9));
  const nlohmann::json report = station::StationReportJson(r);
  for (const char* key : {"iterations", "robot_params_final", "improvement"}) EXPECT_TRUE(report.contains(key)) << key;
  for (const char* key : {"left_wheel_diameter_mm", "right_wheel_diameter_mm", "track_mm", "ticks_per_rev"})
    EXPECT_TRUE(report["iterations"][0]["pushed"].contains(key)) << key;
  EXPECT_TRUE(report["iterations"][0]["estimate"].contains("Ed"));
  EXPECT_TRUE(report["iterations"][0]["estimate"].contains("Eb"));
  // (explain's findings are not asserted here: on this camera's ~10 frames a
  // run while moving, fewer under load, explain once named carpet_drift from
  // 2 moving frames a run; the closing note of stop 35 has it.)
}

// The robot tag printed 0.5 % large (the session says 80 mm, the paper
// carries 80.4 mm) and three tags on the floor around the start, taped once
// (0.3 mm, read to 0.1 mm): the layout of sample_data/scenarios/
// floor_reference_540p.yaml about the station's camera (0, -1000).
const char* kFloorTags =
    "  tag: {print_scale: 1.005}\n"
    "  floor_tags:\n"
    "    size_mm: 80\n"
    "    tags: [{id: 1, x_mm: -520, y_mm: -750}, {id: 2, x_mm: 520, y_mm: -750, yaw_deg: 30}, "
    "{id: 3, x_mm: 0, y_mm: -1280}]\n"
    "    tape_sigma_mm: 0.3\n";

// Two rounds of the station on the virtual robot and camera.
station::StationResult RunTwoRounds(const VirtualStation& vs) {
  station::StationOptions options;
  options.max_rounds = 2;
  return station::RunStation(vs.setup, options);
}

// Whether some progress line contains `text`.
bool Logged(const VirtualStation& vs, const std::string& text) {
  for (const std::string& line : vs.log)
    if (line.find(text) != std::string::npos) return true;
  return false;
}

TEST(StationFloorReference, FindsTheCameraHeightAndTheTagsPrintScale) {
  auto vs = MakeStation(ScenarioText(kMisCalibrated, -100, -1000, 500, 1, kFloorTags));
  ASSERT_TRUE(vs);
  ASSERT_TRUE(vs->setup.floor_reference);
  const station::StationResult r = RunTwoRounds(*vs);
  ASSERT_TRUE(r.ok()) << ToString(r.status) << ": " << r.message;
  const nlohmann::json report = station::StationReportJson(r);
  const nlohmann::json& scale = report["camera_scale"];
  ASSERT_EQ(scale["source"], "floor_reference") << scale.dump(1);
  const double truth_h = vs->scenario.camera->mount.height_mm;  // above the floor
  const double h = scale["camera_height_mm"].get<double>();
  const double sigma_h = scale["sigma_camera_height_mm"].get<double>();
  const double print = scale["tag_print_scale"]["value"].get<double>();
  const double print_sigma = scale["tag_print_scale"]["sigma"].get<double>();
  std::printf("figures: camera height %.2f mm (truth %.1f, error %+.2f mm = %+.2f sigma, sigma %.2f mm); "
              "plane said %.2f mm\n",
              h, truth_h, h - truth_h, (h - truth_h) / sigma_h, sigma_h, r.plane.mount.height_mm);
  std::printf("figures: print scale %.5f (truth 1.005, error %+.5f = %+.2f sigma, sigma %.5f)\n", print,
              print - 1.005, (print - 1.005) / print_sigma, print_sigma);
  // The height's error follows the plane's roll error (views from the live polls: 5 or 6).
  std::printf("figures: plane roll %.3f ± %.3f deg, pitch %.3f ± %.3f deg (truth 0, 3) from %d views\n",
              r.plane.mount.roll_deg, r.plane.sigma_roll_deg, r.plane.mount.pitch_deg, r.plane.sigma_pitch_deg,
              r.plane.views_used);
  EXPECT_LT(sigma_h, 2.0);
  EXPECT_NEAR(h, truth_h, 3.0 * sigma_h);
  EXPECT_LT(print_sigma, 1.5e-3) << "finer than the 0.5 % it has to find";
  EXPECT_NEAR(print, 1.005, 3.0 * print_sigma);
  // The plane alone, fooled by the large print, puts the camera nearer the tag.
  EXPECT_LT(r.plane.mount.height_mm, truth_h - 5.0);
  for (const auto& tag : scale["floor_tags"]) EXPECT_TRUE(tag["flags"].empty()) << tag.dump();
  EXPECT_TRUE(report["flags"].empty()) << report["flags"].dump();
  EXPECT_TRUE(Logged(*vs, "camera scale: from the floor reference (3 distances)"))
      << "the camera-scale line, as batch prints it";
}

TEST(StationFloorReference, UnseenFloorTagsAreSaidAndTheTagSizeScaleStands) {
  // A reference whose tags are not in the scene (none are on the floor).
  auto vs = MakeStation(ScenarioText(kMisCalibrated, -100, -1000, 500, 1));
  ASSERT_TRUE(vs);
  vision::FloorReference reference;
  reference.tags = {{1, 80.0}, {2, 80.0}};
  reference.distances = {{1, 2, 1040.0, 0.3}};
  vs->setup.floor_reference = reference;
  const station::StationResult r = RunTwoRounds(*vs);
  ASSERT_TRUE(r.ok()) << ToString(r.status) << ": " << r.message;
  const nlohmann::json report = station::StationReportJson(r);
  const nlohmann::json& scale = report["camera_scale"];
  EXPECT_EQ(scale["source"], "tag_size") << scale.dump(1);
  EXPECT_THAT(scale["explanation"].get<std::string>(), ::testing::HasSubstr("the floor reference could not be used"));
  EXPECT_NEAR(scale["camera_height_mm"].get<double>(), r.plane.mount.height_mm, 1e-9);
  EXPECT_EQ(report["flags"], nlohmann::json({"floor_reference_unusable"}));
  for (const auto& tag : scale["floor_tags"]) EXPECT_FALSE(tag["flags"].empty()) << tag.dump();
  EXPECT_TRUE(Logged(*vs, "the floor reference could not be used"));
}

TEST(StationFailure, TagNotFoundAtTheStart) {
  // The robot stands 2 m away from the home area: the camera sees floor.
  auto vs = MakeStation(ScenarioText(kMisCalibrated, 2000, 1000, 500, 1));
  ASSERT_TRUE(vs);
  const calibration::Pose2 before = vs->backend->TruePose();
  const station::StationResult r = station::RunStation(vs->setup, station::StationOptions{});
  EXPECT_EQ(r.status, station::StationStatus::kTagNotFound) << r.message;
  EXPECT_THAT(r.message, ::testing::HasSubstr("not found at the start")) << r.message;
  EXPECT_EQ(vs->host->last_run_id(), 0) << "no run was started";
  EXPECT_NEAR((vs->backend->TruePose().translation() - before.translation()).norm(), 0.0, 1e-12);
  ExpectLeftAsItWas(*vs, r);
}

// A camera that goes blind (covered, unplugged behind a frame grabber that
// keeps delivering) after `frames` frames.
class BlindAfter final : public media::FrameSource {
 public:
  BlindAfter(media::FrameSource& inner, int frames) : inner_(inner), left_(frames) {}
  Result<media::CameraFrame> Grab() override {
    auto frame = inner_.Grab();
    if (frame && left_-- <= 0) frame->grey.setTo(cv::Scalar(120));
    return frame;
  }
  std::string Describe() const override { return "blinded " + inner_.Describe(); }

 private:
  media::FrameSource& inner_;
  int left_;
};

TEST(StationFailure, CameraLostAfterTheStart) {
  auto vs = MakeStation(ScenarioText(kMisCalibrated, -100, -1000, 500, 1));
  ASSERT_TRUE(vs);
  const station::StationOptions options;
  BlindAfter blind(*vs->camera, options.rest_frames);  // the start rest is seen
  vs->setup.camera = &blind;
  const station::StationResult r = station::RunStation(vs->setup, options);
  EXPECT_EQ(r.status, station::StationStatus::kCameraLost) << r.message;
  EXPECT_THAT(r.message, ::testing::HasSubstr("camera lost the tag")) << r.message;
  ExpectLeftAsItWas(*vs, r);
}

// A camera whose grabber stops delivering frames (unplugged) after `frames`.
class UnpluggedAfter final : public media::FrameSource {
 public:
  UnpluggedAfter(media::FrameSource& inner, int frames) : inner_(inner), left_(frames) {}
  Result<media::CameraFrame> Grab() override {
    if (left_-- <= 0) return Result<media::CameraFrame>::Error(StatusCode::kIoError, "no frame (unplugged)");
    return inner_.Grab();
  }
  std::string Describe() const override { return "unplugged " + inner_.Describe(); }

 private:
  media::FrameSource& inner_;
  int left_;
};

// A camera unplugged at the first grab after `now()` turns true.
class UnpluggedOnce final : public media::FrameSource {
 public:
  UnpluggedOnce(media::FrameSource& inner, std::function<bool()> now) : inner_(inner), now_(std::move(now)) {}
  Result<media::CameraFrame> Grab() override {
    if (unplugged_ || (unplugged_ = now_()))
      return Result<media::CameraFrame>::Error(StatusCode::kIoError, "no frame (unplugged)");
    return inner_.Grab();
  }
  std::string Describe() const override { return "unplugged " + inner_.Describe(); }

 private:
  media::FrameSource& inner_;
  std::function<bool()> now_;
  bool unplugged_ = false;
};

TEST(StationFailure, CameraUnpluggedDuringARun) {
  auto vs = MakeStation(ScenarioText(kMisCalibrated, -100, -1000, 2000, 1));
  ASSERT_TRUE(vs);
  const station::StationOptions options;
  UnpluggedAfter unplugged(*vs->camera, options.rest_frames + 2);  // two frames into the run
  vs->setup.camera = &unplugged;
  const station::StationResult r = station::RunStation(vs->setup, options);
  EXPECT_EQ(r.status, station::StationStatus::kCameraLost) << r.message;
  EXPECT_THAT(r.message, ::testing::HasSubstr("unplugged")) << r.message;
  EXPECT_THAT(r.cleanup, ::testing::HasSubstr("robot stopped")) << r.cleanup;
  ExpectLeftAsItWas(*vs, r);
}

// The command driver when the camera goes mid-run: the command (here
// `odocal robot run`, which stops the robot over the link when it is
// terminated) is killed with its process group, the parameters untouched.
TEST(StationFailure, CameraUnpluggedWhileACommandDrives) {
  auto vs = MakeStation(ScenarioText(kMisCalibrated, -100, -1000, 2000, 1));
  ASSERT_TRUE(vs);
  station::ExternalDriverOptions o;
  o.run_command = "\"$ODOCAL\" robot run --port \"$ODOCAL_ROBOT_PORT\" --procedure {procedure} "
                  "--direction {direction} --side-mm {side_mm}";
  o.params = kNominal;
  o.work_dir = test_util::MakeTempDir("odocal_station_command_unplugged_");
  o.environment = {{"ODOCAL_ROBOT_PORT", vs->host->device_path()}, {"ODOCAL", test_util::OdocalBinary()}};
  const std::unique_ptr<station::RobotDriver> driver = station::MakeCommandDriver(o);
  vs->setup.driver = driver.get();
  vs->setup.run_log_dir = o.work_dir + "/runs";
  station::StationOptions options;
  // Unplugged once the robot has started the square (the command's log says
  // so), not after a count of frames: on a loaded machine the frames can
  // come before the command has even opened the link.
  const std::string log = o.work_dir + "/runs/round1/run01_umbmark_cw.log";
  UnpluggedOnce unplugged(*vs->camera, [&log] {
    return test_util::Slurp(log).find("started") != std::string::npos;
  });
  vs->setup.camera = &unplugged;
  const station::StationResult r = station::RunStation(vs->setup, options);
  EXPECT_EQ(r.status, station::StationStatus::kCameraLost) << r.message;
  EXPECT_THAT(r.cleanup, ::testing::HasSubstr("the run's command killed")) << r.cleanup;
  // The killed `robot run` stopped the robot: the square was not finished.
  EXPECT_THAT(test_util::Slurp(log), ::testing::HasSubstr("interrupted: robot stopped"));
  ExpectLeftAsItWas(*vs, r);
}

// A line on which the robot stops answering after `writes` writes (the
// handshake, the parameter read, telemetry off, telemetry on for the run,
// the run start).
class SilentAfter final : public robot_link::Transport {
 public:
  SilentAfter(robot_link::Transport& inner, int writes) : inner_(inner), left_(writes) {}
  robot_link::IoResult Write(std::span<const uint8_t> data) override {
    if (left_-- > 0) return inner_.Write(data);
    return {robot_link::IoStatus::kOk, data.size(), ""};
  }
  robot_link::IoResult Read(std::span<uint8_t> buffer, std::chrono::milliseconds timeout) override {
    if (left_ > 0) return inner_.Read(buffer, timeout);
    std::this_thread::sleep_for(timeout);
    return {robot_link::IoStatus::kTimeout, 0, ""};
  }
  std::string Describe() const override { return inner_.Describe(); }

 private:
  robot_link::Transport& inner_;
  int left_;
};

TEST(StationFailure, RobotStopsAnsweringDuringARun) {
  auto vs = MakeStation(ScenarioText(kMisCalibrated, -100, -1000, 500, 1));
  ASSERT_TRUE(vs);
  SilentAfter silent(*vs->port, 5);
  vs->setup.transport = &silent;
  vs->setup.client.reply_timeout = 50ms;
  const station::StationResult r = station::RunStation(vs->setup, station::StationOptions{});
  EXPECT_EQ(r.status, station::StationStatus::kRobotLink) << r.message;
  EXPECT_THAT(r.message, ::testing::HasSubstr("not answering")) << r.message;
  EXPECT_FALSE(r.robot_stopped) << "a stop cannot reach a robot that does not answer";
  EXPECT_THAT(r.cleanup, ::testing::HasSubstr("could not stop")) << r.cleanup;
  ExpectLeftAsItWas(*vs, r);  // the robot ends its square by itself
}

TEST(StationFailure, CablePulledDuringARun) {
  auto vs = MakeStation(ScenarioText(kMisCalibrated, -100, -1000, 500, 1));
  ASSERT_TRUE(vs);
  auto log = vs->setup.progress;
  vs->setup.progress = [&, log](const std::string& line) {
    log(line);
    if (line.find("started") != std::string::npos) vs->host->CutCable();
  };
  const station::StationResult r = station::RunStation(vs->setup, station::StationOptions{});
  EXPECT_EQ(r.status, station::StationStatus::kRobotLink) << r.message;
  EXPECT_FALSE(r.robot_stopped);
  EXPECT_THAT(r.cleanup, ::testing::HasSubstr("line is gone")) << r.cleanup;
  for (int i = 0; i < 200 && vs->host->running(); ++i) std::this_thread::sleep_for(20ms);
  EXPECT_TRUE(vs->host->active().SameBits(kNominal)) << "nothing was pushed";
}

// The robot's motion code reports a failed run (a stalled wheel) after one
// second of robot time.
class FailingMotion final : public robot_link::MotionBackend {
 public:
  explicit FailingMotion(sim::SimMotionBackend& inner) : inner_(inner) {}
  bool StartRun(const robot_link::RunCommand& c) override {
    elapsed_s_ = 0.0;
    return inner_.StartRun(c);
  }
  robot_link::StepResult Step(double dt_s) override {
    robot_link::StepResult r = inner_.Step(dt_s);
    elapsed_s_ += dt_s;
    if (!r.finished && elapsed_s_ > 1.0) {
      inner_.Stop();
      r = inner_.Step(0.0);
      r.finished = true;
      r.status = robot_link::RunStatus::kFailed;
    }
    return r;
  }
  void Stop() override { inner_.Stop(); }
  void SetParams(const ParamSet& p) override { inner_.SetParams(p); }

 private:
  sim::SimMotionBackend& inner_;
  double elapsed_s_ = 0.0;
};

TEST(StationFailure, RunNotCompleted) {
  auto vs = MakeStation(ScenarioText(kMisCalibrated, -100, -1000, 500, 1), "",
                        [](sim::SimMotionBackend& b) { return std::make_unique<FailingMotion>(b); });
  ASSERT_TRUE(vs);
  const station::StationResult r = station::RunStation(vs->setup, station::StationOptions{});
  EXPECT_EQ(r.status, station::StationStatus::kRunNotCompleted) << r.message;
  EXPECT_THAT(r.message, ::testing::HasSubstr("failed")) << r.message;
  ExpectLeftAsItWas(*vs, r);
}

TEST(StationFailure, PushRefusedByTheRobot) {
  // The robot's flash cannot be written (its temporary image is a
  // directory): COMMIT is answered NACK STORAGE and the old set is kept.
  const std::string dir = test_util::MakeTempDir("odocal_station_flash_");
  auto vs = MakeStation(ScenarioText(kMisCalibrated, -100, -1000, 500, 1), dir + "/flash.bin");
  ASSERT_TRUE(vs);
  std::filesystem::create_directory(dir + "/flash.bin.tmp");
  const station::StationResult r = station::RunStation(vs->setup, station::StationOptions{});
  EXPECT_EQ(r.status, station::StationStatus::kPushRefused) << r.message;
  EXPECT_THAT(r.message, ::testing::HasSubstr("push")) << r.message;
  ASSERT_EQ(r.iterations.size(), 1u);
  EXPECT_TRUE(r.iterations[0].estimate.ok()) << "round 1 was measured before the push";
  EXPECT_FALSE(r.restored) << "nothing reached the robot, nothing to undo";
  ExpectLeftAsItWas(*vs, r);
}

TEST(StationFailure, InterruptStopsTheRobotMidRun) {
  auto vs = MakeStation(ScenarioText(kMisCalibrated, -100, -1000, 2000, 1));
  ASSERT_TRUE(vs);
  std::atomic<bool> stop{false};
  auto log = vs->setup.progress;
  vs->setup.progress = [&, log](const std::string& line) {
    log(line);
    if (line.find("started") != std::string::npos) stop = true;  // Ctrl-C
  };
  vs->setup.stop_requested = &stop;
  const station::StationResult r = station::RunStation(vs->setup, station::StationOptions{});
  EXPECT_EQ(r.status, station::StationStatus::kInterrupted) << r.message;
  EXPECT_TRUE(r.robot_stopped);
  EXPECT_THAT(r.cleanup, ::testing::HasSubstr("robot stopped")) << r.cleanup;
  // Stopped well short of the 8 m square: it is near where it started.
  const double moved_m = (vs->backend->TruePose().translation() - vs->scenario.robot.start_pose.translation()).norm();
  EXPECT_LT(moved_m, 1.5);
  ExpectLeftAsItWas(*vs, r);
}

// Ctrl-C while a push is under way: the push runs to its end (staged, read
// back, committed, verified), the station stops at the next step and, the new
// set not being verified by runs, puts the initial one back.
TEST(StationFailure, InterruptDuringAPushLetsItFinishThenRestores) {
  auto vs = MakeStation(ScenarioText(kMisCalibrated, -100, -1000, 500, 1));
  ASSERT_TRUE(vs);
  std::atomic<bool> stop{false};
  auto log = vs->setup.progress;
  vs->setup.progress = [&, log](const std::string& line) {
    log(line);
    if (line.rfind("pushing", 0) == 0) stop = true;
  };
  vs->setup.stop_requested = &stop;
  const station::StationResult r = station::RunStation(vs->setup, station::StationOptions{});
  EXPECT_EQ(r.status, station::StationStatus::kInterrupted) << r.message;
  ASSERT_EQ(r.iterations.size(), 1u);
  ASSERT_TRUE(r.iterations[0].pushed) << "the push was not cut short";
  bool verified = false;
  for (const std::string& line : vs->log) verified = verified || line.rfind("pushed and verified", 0) == 0;
  EXPECT_TRUE(verified);
  EXPECT_TRUE(r.restored);
  ExpectLeftAsItWas(*vs, r);
}

// The live view (rig/live) sees what the station saw: the last run of the
// plan, the tag where the robot ended, the round's path, the estimates.
// ---- A camera over the start only (issue 23) --------------------------------
// 1280x720, 1.8 m over the start: a 2.3 m x 1.3 m view. The 2 m squares leave
// it on their first leg and come back on their last, so most of each run is
// unseen and the frames that arrive (few, under time scale and load) cannot
// unwrap the turn.
std::string HomeAreaScenario(int seed) {
  std::ostringstream os;
  os << "seed: " << seed << "\nrobot:\n"
     << "  nominal: {left_wheel_diameter_mm: 70.0, right_wheel_diameter_mm: 70.0, track_mm: 300.0, "
        "ticks_per_rev: 2048}\n"
     << "  true: " << kMisCalibrated << "\n"
     << "  start_pose: {x_mm: 0, y_mm: 0, heading_deg: 0}\n"
     << "  speed_mm_s: 500\n  accel_mm_s2: 800\n  turn_rate_deg_s: 180\n  turn_accel_deg_s2: 360\n"
     << "  rest_s: 0.1\n  pause_s: 0.2\n  noise: {wheel_mm_per_sqrt_m: 0.05}\n"
     << "runs:\n"
     << "  - {procedure: umbmark, direction: cw, side_mm: 2000}\n"
     << "  - {procedure: umbmark, direction: ccw, side_mm: 2000}\n"
     << "tag: {family: tag36h11, id: 5, size_mm: 80, height_mm: 150, offset_mm: {x: 0, y: 0}}\n"
     << "camera:\n  width: 1280\n  height: 720\n  fx: 900\n  fy: 900\n  cx: 640\n  cy: 360\n"
     << "  distortion: [-0.05, 0.01, 0, 0, 0]\n"
     << "  pose: {x_mm: 0, y_mm: 0, height_mm: 1800, roll_deg: 0, pitch_deg: 1, yaw_deg: 0}\n"
     << "  fps: 30\n  noise_sigma: 2.0\n  blur_sigma_px: 0.8\n  exposure_ms: 4\n";
  return os.str();
}

// Keeps both cores busy while it lives (a machine doing other work).
class CpuHog {
 public:
  CpuHog() {
    for (int i = 0; i < 2; ++i)
      threads_.emplace_back([this] {
        volatile double x = 1.0;
        while (!stop_) x = x * 1.0000001 + 1e-9;
      });
  }
  ~CpuHog() {
    stop_ = true;
    for (std::thread& t : threads_) t.join();
  }

 private:
  std::atomic<bool> stop_{false};
  std::vector<std::thread> threads_;
};

// The false abort: the heading check judged a turn from sightings
// too sparse to judge it. Seeds varied, idle and beside a CPU hog: every
// station completes; the total turn is checked only when it could be.
TEST(StationHomeArea, RunsThatLeaveTheViewNeverAbortTheStationIdleOrUnderLoad) {
  int stations = 0, runs = 0, totals_checked = 0, dropped = 0;
  for (const bool loaded : {false, true}) {
    for (int seed = 1; seed <= 2; ++seed) {
      std::optional<CpuHog> hog;
      if (loaded) hog.emplace();
      auto vs = MakeStation(HomeAreaScenario(seed));
      ASSERT_TRUE(vs);
      station::StationOptions options;
      options.max_rounds = 2;
      const station::StationResult r = station::RunStation(vs->setup, options);
      ASSERT_TRUE(r.ok()) << (loaded ? "under load" : "idle") << ", seed " << seed << ": " << ToString(r.status)
                          << ": " << r.message;
      ++stations;
      for (const station::StationIteration& it : r.iterations)
        for (const station::StationRun& run : it.runs) {
          ++runs;
          totals_checked += run.turned_rad.has_value();
          dropped += run.frames_dropped;
          // The robot left the view: a gap too long to unwrap.
          EXPECT_GT(run.unseen_s, 1.0) << run.name;
          if (run.turned_rad) {
            EXPECT_NEAR(std::abs(*run.turned_rad), 2.0 * M_PI, 0.2) << run.name;
          }
        }
      const nlohmann::json report = station::StationReportJson(r);
      EXPECT_TRUE(report["iterations"][0]["runs"][0].contains("frames_dropped"));
      EXPECT_TRUE(report["iterations"][0]["runs"][0].contains("unseen_s"));
    }
  }
  std::printf("figures: %d home-area stations completed, %d runs, total turn checked in %d, %d frames dropped\n",
              stations, runs, totals_checked, dropped);
  EXPECT_GT(dropped, 0) << "the virtual camera at 30 fps, rendered on a busy machine, drops frames";
}

// The first run driven the other way round: its last corner is turned in
// view, and that is enough to stop the station, robot idle, parameters kept.
class ReversedFirstRun final : public robot_link::MotionBackend {
 public:
  explicit ReversedFirstRun(sim::SimMotionBackend& inner) : inner_(inner) {}
  bool StartRun(const robot_link::RunCommand& command) override {
    robot_link::RunCommand c = command;
    if (runs_++ == 0)
      c.direction = c.direction == calibration::Direction::kCw ? calibration::Direction::kCcw
                                                               : calibration::Direction::kCw;
    return inner_.StartRun(c);
  }
  robot_link::StepResult Step(double dt_s) override { return inner_.Step(dt_s); }
  void Stop() override { inner_.Stop(); }
  void Idle(double dt_s) override { inner_.Idle(dt_s); }
  void SetParams(const ParamSet& p) override { inner_.SetParams(p); }

 private:
  sim::SimMotionBackend& inner_;
  int runs_ = 0;
};

// The last corner is judged only when it is seen in frames close enough to
// unwrap: at time scale 2.5 the station's ~10 rendered frames per wall
// second are 0.25 s of robot time apart (at 10, 1 s: the corner unseen, the
// run not judged, which is the honest answer then).
TEST(StationHomeArea, ARunDrivenTheWrongWayIsCaughtByWhatIsSeenInView) {
  auto vs = MakeStation(
      HomeAreaScenario(3), "", [](sim::SimMotionBackend& b) { return std::make_unique<ReversedFirstRun>(b); }, 2.5);
  ASSERT_TRUE(vs);
  const station::StationResult r = station::RunStation(vs->setup, station::StationOptions{});
  EXPECT_EQ(r.status, station::StationStatus::kRunNotCompleted) << r.message;
  EXPECT_THAT(r.message, ::testing::HasSubstr("run 1/2 (umbmark cw, side 2000 mm): while in view at")) << r.message;
  EXPECT_THAT(r.message, ::testing::HasSubstr("was another run driven")) << r.message;
  ExpectLeftAsItWas(*vs, r);
}

TEST(StationLive, TheLiveStateFollowsTheRunsAndTheEstimates) {
  auto vs = MakeStation(ScenarioText(kMisCalibrated, -100, -1000, 500, 1));
  ASSERT_TRUE(vs);
  live::LiveState live;
  vs->setup.live = &live;
  const station::StationResult r = station::RunStation(vs->setup, station::StationOptions{});
  ASSERT_TRUE(r.ok()) << r.message;
  const nlohmann::json j = live.StateJson();
  EXPECT_EQ(j["progress"]["run_index"], 2) << j["progress"].dump();
  EXPECT_EQ(j["progress"]["run_total"], 2);
  EXPECT_THAT(j["progress"]["run_label"].get<std::string>(), ::testing::HasSubstr("umbmark ccw"));
  ASSERT_TRUE(j["tag"]["seen"].get<bool>()) << j["tag"].dump();
  // The pose shown is the robot's, where the simulator put it (the camera
  // model of the round, within the plane estimate's millimetres).
  const calibration::Pose2 truth = vs->backend->TruePose();
  EXPECT_NEAR(j["pose"]["x_mm"].get<double>(), truth.x() * 1e3, 15.0);
  EXPECT_NEAR(j["pose"]["y_mm"].get<double>(), truth.y() * 1e3, 15.0);
  EXPECT_GE(j["trajectory_mm"].size(), 1u) << "the round's path (the squares leave this view)";
  bool emax = false;
  for (const nlohmann::json& e : j["estimates"]) emax = emax || e["name"] == "E_max,syst";
  EXPECT_TRUE(emax) << j["estimates"].dump();
}

// ---- The command line --------------------------------------------------------

using test_util::Odocal;

TEST(StationCli, VirtualRobotWritesTheReport) {
  const std::string dir = test_util::MakeTempDir("odocal_station_cli_");
  std::ofstream(dir + "/s.yaml") << ScenarioText(kMisCalibrated, -100, -1000, 500, 1);
  const test_util::CommandResult r = test_util::RunCommand(
      Odocal("station --scenario " + dir + "/s.yaml --out " + dir + "/out --max-rounds 2 --time-scale 50" +
             " --export firmware " + dir + "/firmware.yaml --export ros2 " + dir + "/ros2.yaml"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.err, ::testing::HasSubstr("station: round 2")) << "progress on stderr";
  EXPECT_TRUE(std::filesystem::exists(dir + "/out/report.html"));
  // The exports carry the set read back from the robot.
  std::ifstream fw(dir + "/firmware.yaml");
  const std::string firmware((std::istreambuf_iterator<char>(fw)), std::istreambuf_iterator<char>());
  EXPECT_THAT(firmware, ::testing::HasSubstr("track_mm: 30")) << firmware;
  std::ifstream ros(dir + "/ros2.yaml");
  const std::string ros2((std::istreambuf_iterator<char>(ros)), std::istreambuf_iterator<char>());
  EXPECT_THAT(ros2, ::testing::HasSubstr("wheel_separation_multiplier: 1.0")) << ros2;
  std::ifstream in(dir + "/out/report.json");
  const nlohmann::json report = nlohmann::json::parse(in);
  ASSERT_EQ(report["iterations"].size(), 2u);
  EXPECT_TRUE(report["iterations"][0]["pushed"].contains("track_mm"));
  EXPECT_TRUE(report["iterations"][1]["estimate"].contains("Eb"));
  EXPECT_TRUE(report["robot_params_final"].contains("ticks_per_rev"));
  EXPECT_GT(report["improvement"].get<double>(), 10.0);
}

TEST(StationCli, AScenarioWithFloorTagsGivesTheStationItsFloorReference) {
  const std::string dir = test_util::MakeTempDir("odocal_station_cli_floor_");
  std::ofstream(dir + "/s.yaml") << ScenarioText(kMisCalibrated, -100, -1000, 500, 1, kFloorTags);
  const test_util::CommandResult r = test_util::RunCommand(
      Odocal("station --scenario " + dir + "/s.yaml --out " + dir + "/out --max-rounds 2 --time-scale 50"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.err, ::testing::HasSubstr("floor reference: 3 floor tags, 3 taped distances")) << r.err;
  EXPECT_THAT(r.err, ::testing::HasSubstr("camera scale: from the floor reference (3 distances)")) << r.err;
  std::ifstream in(dir + "/out/report.json");
  const nlohmann::json report = nlohmann::json::parse(in);
  const nlohmann::json& scale = report["camera_scale"];
  ASSERT_EQ(scale["source"], "floor_reference") << scale.dump(1);
  EXPECT_NEAR(scale["camera_height_mm"].get<double>(), 2000.0, 3.0 * scale["sigma_camera_height_mm"].get<double>());
  EXPECT_NEAR(scale["tag_print_scale"]["value"].get<double>(), 1.005,
              3.0 * scale["tag_print_scale"]["sigma"].get<double>());
  // The tape's readings, to 0.1 mm: 1040.0 between 1 and 2.
  EXPECT_NEAR(scale["floor_reference"]["distances"][0]["tape_mm"].get<double>(), 1040.0, 1e-9);
}

TEST(StationCli, CtrlCStopsTheRobotAndExits130) {
  const std::string dir = test_util::MakeTempDir("odocal_station_sigint_");
  std::ofstream(dir + "/s.yaml") << ScenarioText(kMisCalibrated, -100, -1000, 2000, 1);
  // SIGINT 2.5 s in, while the first 2 m square is driven (about 5 s at 5x).
  const test_util::CommandResult r = test_util::RunCommand(
      "timeout --preserve-status -s INT 2.5 " +
      Odocal("station --scenario " + dir + "/s.yaml --out " + dir + "/out --time-scale 5"));
  EXPECT_EQ(r.exit_code, 130) << r.err;
  EXPECT_THAT(r.err, ::testing::HasSubstr("interrupted")) << r.err;
  EXPECT_THAT(r.err, ::testing::HasSubstr("parameters as they were")) << r.err;
  std::ifstream in(dir + "/out/report.json");
  const nlohmann::json report = nlohmann::json::parse(in);
  EXPECT_EQ(report["status"], "interrupted");
}

TEST(StationCli, RealRobotConfigNamesTheMissingDeviceAndCamera) {
  const std::string dir = test_util::MakeTempDir("odocal_station_cfg_");
  config::CameraFile camera;
  camera.intrinsics.width = 960;
  camera.intrinsics.height = 540;
  camera.intrinsics.fx = camera.intrinsics.fy = 1400;
  camera.intrinsics.cx = 480;
  camera.intrinsics.cy = 270;
  ASSERT_TRUE(config::WriteCameraFile(dir + "/camera.yaml", camera, config::CameraFileFormat::kOpenCv).ok());
  auto config = [&](const std::string& port, const std::string& device) {
    std::ofstream(dir + "/station.yaml")
        << "robot: {port: " << port << ", baud: 115200}\n"
        << "camera: {device: \"" << device << "\", calibration: camera.yaml, "
        << "mount_guess: {x_mm: 0, y_mm: 0, height_mm: 2000}}\n"
        << "tag: {family: tag36h11, id: 5, size_mm: 80, height_mm: 150, offset_mm: {x: 0, y: 0}}\n"
        << "plan: {side_mm: 2000, runs_per_direction: 3}\n";
    return test_util::RunCommand(Odocal("station --config " + dir + "/station.yaml --out " + dir + "/out"));
  };
  const test_util::CommandResult no_robot = config("/dev/odocal-no-such-robot", "0");
  EXPECT_EQ(no_robot.exit_code, 2);
  EXPECT_THAT(no_robot.err, ::testing::HasSubstr("/dev/odocal-no-such-robot")) << no_robot.err;
  // A robot that exists (a virtual one on a pty), a camera that does not.
  auto vs = MakeStation(ScenarioText(kMisCalibrated, -100, -1000, 500, 1));
  ASSERT_TRUE(vs);
  const test_util::CommandResult no_camera = config(vs->host->device_path(), "/nonexistent/camera.mp4");
  EXPECT_EQ(no_camera.exit_code, 2);
  EXPECT_THAT(no_camera.err, ::testing::HasSubstr("cannot open camera '/nonexistent/camera.mp4'"))
      << no_camera.err;
  // A malformed file names the key: unknown keys are errors, required ones are required.
  std::ofstream(dir + "/bad.yaml") << "robot: {port: /dev/x}\nbogus: 1\n";
  const test_util::CommandResult bad = test_util::RunCommand(Odocal("station --config " + dir + "/bad.yaml"));
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_THAT(bad.err, ::testing::HasSubstr("bogus")) << bad.err;
  std::ofstream(dir + "/bad.yaml") << "robot: {port: /dev/x}\n";
  const test_util::CommandResult missing = test_util::RunCommand(Odocal("station --config " + dir + "/bad.yaml"));
  EXPECT_EQ(missing.exit_code, 2);
  EXPECT_THAT(missing.err, ::testing::HasSubstr("camera: missing")) << missing.err;
}

}  // namespace
}  // namespace odocal
