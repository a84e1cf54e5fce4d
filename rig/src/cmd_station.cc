// odocal station --scenario S.yaml --out DIR   the built-in virtual robot on a
//                                               pseudo-terminal, the virtual camera
// odocal station --config station.yaml [--out DIR]   a real robot and camera
//
// The hands-off loop of station.h. Progress on stderr, DIR/report.json at the
// end (also after a failure, with its status and message), Ctrl-C stops the
// robot and leaves its parameters as they were.
//
// station.yaml (millimetres and degrees; paths relative to the file):
//   robot:  {port: /dev/ttyUSB0, baud: 115200, timeout_ms: 200}
//   camera: {device: "0" | "rtsp://...", calibration: camera.yaml,
//            mount_guess: {x_mm, y_mm, height_mm, roll_deg, pitch_deg, yaw_deg},
//            flush_frames: 5, settle_s: 0.5}
//   tag:    {family, id, size_mm, height_mm, offset_mm: {x, y}, yaw_deg}
//   plan:   {side_mm: 2000, runs_per_direction: 3}
//   max_rounds: 3
#include <atomic>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>

#include "odocal/rig/camera_io.h"
#include "odocal/rig/cli_util.h"
#include "odocal/rig/exports.h"
#include "odocal/rig/html_report.h"
#include "odocal/rig/commands.h"
#include "odocal/rig/output.h"
#include "odocal/rig/scenario.h"
#include "odocal/rig/station.h"
#include "odocal/robot_link/firmware_host.h"
#include "odocal/robot_link/serial_transport.h"
#include "odocal/sim/sim_motion_backend.h"
#include "yaml_util.h"

namespace odocal::rig {
namespace {

namespace fs = std::filesystem;

std::atomic<bool> g_stop{false};
void OnStationSignal(int) { g_stop = true; }

// Exit codes, one per cause (the robot command's where they overlap).
int ExitCode(StationStatus status) {
  switch (status) {
    case StationStatus::kOk: return 0;
    case StationStatus::kInvalidInput: return kExitBadInput;
    case StationStatus::kRobotLink: return 3;
    case StationStatus::kTagNotFound:
    case StationStatus::kCameraLost: return 4;
    case StationStatus::kRunNotCompleted: return 5;
    case StationStatus::kPushRefused: return 7;
    case StationStatus::kEstimateFailed: return kExitFailure;
    case StationStatus::kInterrupted: return 130;
  }
  return kExitFailure;
}

struct StationConfig {
  std::string port;
  int baud = 115200;
  int timeout_ms = 200;
  std::string camera_device;
  std::string camera_file;
  vision::CameraMount mount_guess;
  int flush_frames = 5;
  double settle_s = 0.5;
  vision::TagSpec tag;
  double side_mm = 2000.0;
  int runs_per_direction = 3;
  int max_rounds = 3;
};

std::optional<StationConfig> LoadStationConfig(const std::string& path, std::string* error) {
  using namespace yaml_util;
  if (!fs::exists(path)) {
    *error = path + ": no such file";
    return std::nullopt;
  }
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const YAML::Exception& e) {
    *error = path + ":" + std::to_string(e.mark.line + 1) + ": not valid YAML: " + e.msg;
    return std::nullopt;
  }
  const fs::path dir = fs::absolute(path).parent_path();
  try {
    ExpectMap(root, "");
    CheckKeys(root, "", {"robot", "camera", "tag", "plan", "max_rounds"});
    StationConfig c;
    for (const char* key : {"robot", "camera", "tag"})
      if (!root[key]) yaml_util::Fail(root, key, "missing (required)");
    const YAML::Node robot = root["robot"];
    ExpectMap(robot, "robot");
    CheckKeys(robot, "robot", {"port", "baud", "timeout_ms"});
    if (!robot["port"]) yaml_util::Fail(robot, "robot.port", "missing (required)");
    c.port = String(robot["port"], "robot.port");
    c.baud = static_cast<int>(OptionalNumber(robot, "robot", "baud", 115200));
    c.timeout_ms = static_cast<int>(Positive(OptionalNumber(robot, "robot", "timeout_ms", 200), robot, "robot.timeout_ms"));
    const YAML::Node camera = root["camera"];
    ExpectMap(camera, "camera");
    CheckKeys(camera, "camera", {"device", "calibration", "mount_guess", "flush_frames", "settle_s"});
    for (const char* key : {"device", "calibration", "mount_guess"})
      if (!camera[key]) yaml_util::Fail(camera, Join("camera", key), "missing (required)");
    c.camera_device = String(camera["device"], "camera.device");
    c.camera_file = (dir / String(camera["calibration"], "camera.calibration")).lexically_normal().string();
    const YAML::Node m = camera["mount_guess"];
    ExpectMap(m, "camera.mount_guess");
    CheckKeys(m, "camera.mount_guess", {"x_mm", "y_mm", "height_mm", "roll_deg", "pitch_deg", "yaw_deg"});
    c.mount_guess.x_mm = OptionalNumber(m, "camera.mount_guess", "x_mm", 0.0);
    c.mount_guess.y_mm = OptionalNumber(m, "camera.mount_guess", "y_mm", 0.0);
    c.mount_guess.height_mm =
        Positive(RequiredNumber(m, "camera.mount_guess", "height_mm"), m, "camera.mount_guess.height_mm");
    c.mount_guess.roll_deg = OptionalNumber(m, "camera.mount_guess", "roll_deg", 0.0);
    c.mount_guess.pitch_deg = OptionalNumber(m, "camera.mount_guess", "pitch_deg", 0.0);
    c.mount_guess.yaw_deg = OptionalNumber(m, "camera.mount_guess", "yaw_deg", 0.0);
    c.flush_frames = static_cast<int>(OptionalNumber(camera, "camera", "flush_frames", 5));
    c.settle_s = OptionalNumber(camera, "camera", "settle_s", 0.5);
    if (c.flush_frames < 0 || c.settle_s < 0.0) yaml_util::Fail(camera, "camera", "flush_frames and settle_s must not be negative");
    c.tag = ParseTag(root["tag"]);
    if (const YAML::Node plan = root["plan"]) {
      ExpectMap(plan, "plan");
      CheckKeys(plan, "plan", {"side_mm", "runs_per_direction"});
      c.side_mm = Positive(OptionalNumber(plan, "plan", "side_mm", 2000.0), plan, "plan.side_mm");
      c.runs_per_direction = static_cast<int>(Positive(OptionalNumber(plan, "plan", "runs_per_direction", 3), plan, "plan.runs_per_direction"));
    }
    if (root["max_rounds"]) c.max_rounds = static_cast<int>(Integer(root["max_rounds"], "max_rounds"));
    return c;
  } catch (const YamlError& e) {
    *error = path + ":" + e.what();
    return std::nullopt;
  }
}

void Progress(const std::string& line) { std::cerr << "station: " << line << std::endl; }

// Runs the loop, writes the report, prints the outcome; exits non-zero on failure.
calibration::WheelParams ToWheelParams(const robot_link::ParamSet& p) {
  calibration::WheelParams w;
  w.left_wheel_diameter_m = p.left_wheel_diameter_mm * 1e-3;
  w.right_wheel_diameter_m = p.right_wheel_diameter_mm * 1e-3;
  w.track_m = p.track_mm * 1e-3;
  w.ticks_per_rev = p.ticks_per_rev;
  return w;
}

void Finish(const StationSetup& setup, const StationOptions& options, const std::string& out,
            nlohmann::json extra, const ExportRequests& exports) {
  const StationResult result = RunStation(setup, options);
  nlohmann::json report = StationReportJson(result);
  for (auto it = extra.begin(); it != extra.end(); ++it) report[it.key()] = it.value();
  std::optional<std::string> write_error = EnsureDirectory(out);
  if (!write_error) write_error = WriteFileAtomically(out + "/report.json", report.dump(2) + "\n");
  if (!write_error) write_error = WriteReportHtml(report, "odocal station", out + "/report.html");
  if (!result.ok()) {
    Fail("station", ExitCode(result.status),
         result.message + (result.cleanup.empty() ? "" : " (" + result.cleanup + ")"));
  }
  if (write_error) Fail("station", kExitFailure, *write_error);
  // Exports: the robot's set at the start is the nominal, the read-back set the corrected.
  if (result.params_initial && result.params_final) {
    if (auto e = WriteExports(exports, ToWheelParams(*result.params_initial),
                              ToWheelParams(*result.params_final)))
      Fail("station", kExitFailure, *e);
  }
  const StationIteration& first = result.iterations.front();
  const StationIteration& last = result.iterations.back();
  std::fprintf(stderr, "station: E_max,syst %.3f mm -> %.3f mm in %zu rounds (%.0fx), %.1f s\n",
               first.estimate.emax_syst_m * 1e3, last.estimate.emax_syst_m * 1e3, result.iterations.size(),
               result.improvement.value_or(1.0), result.wall_s);
  std::printf("report: %s/report.json and report.html\n", out.c_str());
}

}  // namespace

void RegisterStationCommand(CLI::App& app) {
  struct Args {
    std::string scenario;
    std::string config;
    std::string out = "odocal-station";
    int max_rounds = 3;
    double time_scale = 20.0;
    int rest_frames = 12;
    ExportRequests exports;
  };
  auto args = std::make_shared<Args>();
  CLI::App* cmd = app.add_subcommand(
      "station", "Hands-off calibration: drive the squares, measure with the camera, push, verify");
  auto* scenario = cmd->add_option("--scenario", args->scenario,
                                   "Scenario (YAML, with camera: and tag:): the built-in virtual robot and camera");
  auto* config = cmd->add_option("--config", args->config, "Station file (YAML): a real robot and camera");
  scenario->excludes(config);
  cmd->add_option("--out", args->out, "Output directory for report.json")->capture_default_str();
  auto* rounds = cmd->add_option("--max-rounds", args->max_rounds,
                                 "Measured rounds at most (the last one only verifies)");
  rounds->capture_default_str();
  cmd->add_option("--time-scale", args->time_scale, "Virtual robot: robot seconds per wall second")
      ->capture_default_str();
  cmd->add_option("--rest-frames", args->rest_frames, "Frames averaged per rest")->capture_default_str();
  cmd->footer(
      "Exit codes: 0 calibrated, 2 bad input, 3 robot link (not answering, line cut), 4 tag not found "
      "or camera lost, 5 run not completed, 7 push refused, 1 estimate failed, 130 interrupted.");
  AddExportOption(cmd, &args->exports);
  cmd->callback([args, rounds]() {
    if (auto e = CheckExports(args->exports)) Fail("station", kExitBadInput, *e);
    const std::string name = "station";
    if (args->scenario.empty() == args->config.empty())
      Fail(name, kExitBadInput, "give --scenario (virtual robot) or --config (real robot)");
    std::signal(SIGINT, OnStationSignal);
    std::signal(SIGTERM, OnStationSignal);
    StationOptions options;
    options.max_rounds = args->max_rounds;
    options.rest_frames = args->rest_frames;
    StationSetup setup;
    setup.stop_requested = &g_stop;
    setup.progress = Progress;
    std::string error;

    if (!args->scenario.empty()) {
      const std::optional<Scenario> s = LoadScenario(args->scenario, &error);
      if (!s) Fail(name, kExitBadInput, error);
      if (!s->camera || !s->tag)
        Fail(name, kExitBadInput, args->scenario + ": the station needs the scenario's camera: and tag:");
      if (!(args->time_scale > 0.0) || args->time_scale > 1000.0)
        Fail(name, kExitBadInput, "--time-scale must be in (0, 1000]");
      for (const calibration::RunSpec& spec : s->runs)
        if (spec.procedure == calibration::Procedure::kUmbmark) setup.plan.push_back(spec);
      if (setup.plan.size() != s->runs.size())
        Progress("only the scenario's UMBMark squares are driven; its other runs are skipped");
      sim::SimMotionBackend backend(s->robot);
      robot_link::FirmwareHostOptions host_options;
      host_options.time_scale = args->time_scale;
      const calibration::WheelParams& n = s->robot.nominal;
      if (std::abs(n.ticks_per_rev - std::round(n.ticks_per_rev)) > 1e-9)
        Fail(name, kExitBadInput,
             "robot.nominal.ticks_per_rev: the robot link carries whole ticks per revolution");
      host_options.robot.defaults = robot_link::ParamSet{n.left_wheel_diameter_m * 1e3,
                                                         n.right_wheel_diameter_m * 1e3, n.track_m * 1e3,
                                                         static_cast<uint32_t>(n.ticks_per_rev)};
      auto host = robot_link::FirmwareHost::Start(host_options, backend);
      if (!host) Fail(name, kExitFailure, "virtual robot: " + host.message);
      auto port = robot_link::SerialTransport::Open((*host.value)->device_path());
      if (!port) Fail(name, kExitFailure, "virtual robot: " + port.message);
      auto camera = SimCameraSource::Create(*s->camera, *s->tag, backend, &error);
      if (!camera) Fail(name, kExitFailure, error);
      char scale[64];
      std::snprintf(scale, sizeof(scale), ", %g robot seconds per wall second", args->time_scale);
      Progress("virtual robot on " + (*host.value)->device_path() + scale);
      setup.transport = port.value->get();
      setup.camera = camera.get();
      setup.intrinsics = s->camera->intrinsics;
      // The operator's guess is where the camera was hung; the station
      // refines its tilt and height from the views.
      setup.mount_guess = s->camera->mount;
      setup.tag = *s->tag;
      const calibration::WheelParams& t = s->robot.truth;
      const double Ed = (t.right_wheel_diameter_m / t.left_wheel_diameter_m) /
                        (n.right_wheel_diameter_m / n.left_wheel_diameter_m);
      const double Eb = t.track_m / n.track_m;
      const double Es = (t.left_wheel_diameter_m + t.right_wheel_diameter_m) /
                        (n.left_wheel_diameter_m + n.right_wheel_diameter_m);
      Finish(setup, options, args->out,
             {{"scenario", args->scenario},
              {"truth", {{"Ed", Ed}, {"Eb", Eb}, {"Es", Es}, {"turn_gain", Eb / Es}}}},
             args->exports);
      return;
    }

    const std::optional<StationConfig> c = LoadStationConfig(args->config, &error);
    if (!c) Fail(name, kExitBadInput, error);
    if (rounds->count() == 0) options.max_rounds = c->max_rounds;
    options.rest_flush_frames = c->flush_frames;
    options.settle_s = c->settle_s;
    const std::optional<CameraFile> camera_file = ReadCameraFile(c->camera_file, &error);
    if (!camera_file) Fail(name, kExitBadInput, error);
    robot_link::SerialOptions serial;
    serial.baud = c->baud;
    auto port = robot_link::SerialTransport::Open(c->port, serial);
    if (!port) Fail(name, kExitBadInput, "robot: " + port.message);
    auto camera = CaptureSource::Open(c->camera_device, &error);
    if (!camera) Fail(name, kExitBadInput, error);
    for (int i = 0; i < c->runs_per_direction; ++i) {
      setup.plan.push_back(calibration::RunSpec::Umbmark(calibration::Direction::kCw, c->side_mm * 1e-3));
      setup.plan.push_back(calibration::RunSpec::Umbmark(calibration::Direction::kCcw, c->side_mm * 1e-3));
    }
    setup.transport = port.value->get();
    setup.client.reply_timeout = std::chrono::milliseconds(c->timeout_ms);
    setup.camera = camera.get();
    setup.intrinsics = camera_file->intrinsics;
    setup.mount_guess = c->mount_guess;
    setup.tag = c->tag;
    Finish(setup, options, args->out, {{"config", args->config}}, args->exports);
  });
}

}  // namespace odocal::rig
