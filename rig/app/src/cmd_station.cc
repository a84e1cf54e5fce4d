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
//   tag:    {family, id, size_mm, size_sigma_mm, height_mm, offset_mm: {x, y}, yaw_deg}
//   floor_reference: {family, tags: [{id, size_mm}], distances: [{between: [A, B], mm, sigma_mm}],
//                     tag_height_sigma_mm}              # optional, as in session.yaml
//   plan:   {side_mm: 2000, runs_per_direction: 3}
//   max_rounds: 3
#include <atomic>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>

#include "cli_util.h"
#include "commands.h"
#include "odocal/config/camera_file.h"
#include "odocal/config/files.h"
#include "odocal/config/scenario.h"
#include "odocal/config/station_file.h"
#include "odocal/media/frame_source.h"
#include "odocal/report/exports.h"
#include "odocal/report/html_report.h"
#include "odocal/report/json.h"
#include "odocal/robot_link/firmware_host.h"
#include "odocal/robot_link/serial_transport.h"
#include "odocal/sim/sim_motion_backend.h"
#include "odocal/simulation/camera_sim.h"
#include "odocal/simulation/sim_camera_source.h"
#include "odocal/station/report_json.h"
#include "odocal/station/station.h"

namespace odocal::app {
namespace {

namespace fs = std::filesystem;

std::atomic<bool> g_stop{false};
void OnStationSignal(int) { g_stop = true; }

// Exit codes, one per cause (the robot command's where they overlap).
int ExitCode(station::StationStatus status) {
  switch (status) {
    case station::StationStatus::kOk: return 0;
    case station::StationStatus::kInvalidInput: return kExitBadInput;
    case station::StationStatus::kRobotLink: return 3;
    case station::StationStatus::kTagNotFound:
    case station::StationStatus::kCameraLost: return 4;
    case station::StationStatus::kRunNotCompleted: return 5;
    case station::StationStatus::kPushRefused: return 7;
    case station::StationStatus::kEstimateFailed: return kExitFailure;
    case station::StationStatus::kInterrupted: return 130;
  }
  return kExitFailure;
}

void Progress(const std::string& line) { std::cerr << "station: " << line << std::endl; }

// Runs the loop, writes the report, prints the outcome; exits non-zero on failure.
void Finish(const station::StationSetup& setup, const station::StationOptions& options, const std::string& out,
            nlohmann::json extra, const report::ExportRequests& exports) {
  const station::StationResult result = station::RunStation(setup, options);
  nlohmann::json report = station::StationReportJson(result);
  for (auto it = extra.begin(); it != extra.end(); ++it) report[it.key()] = it.value();
  std::optional<std::string> write_error = config::EnsureDirectory(out);
  if (!write_error) write_error = config::WriteFileAtomically(out + "/report.json", report.dump(2) + "\n");
  if (!write_error) write_error = report::WriteReportHtml(report, "odocal station", out + "/report.html");
  if (!result.ok()) {
    Fail("station", ExitCode(result.status),
         result.message + (result.cleanup.empty() ? "" : " (" + result.cleanup + ")"));
  }
  if (write_error) Fail("station", kExitFailure, *write_error);
  // Exports: the robot's set at the start is the nominal, the read-back set the corrected.
  if (result.params_initial && result.params_final) {
    if (auto e = report::WriteExports(exports, robot_link::ToWheelParams(*result.params_initial),
                              robot_link::ToWheelParams(*result.params_final)))
      Fail("station", kExitFailure, *e);
  }
  const station::StationIteration& first = result.iterations.front();
  const station::StationIteration& last = result.iterations.back();
  std::fprintf(stderr, "station: E_max,syst %.3f mm -> %.3f mm in %zu rounds (%.0fx), %.1f s\n",
               first.estimate.emax_syst_m * 1e3, last.estimate.emax_syst_m * 1e3, result.iterations.size(),
               result.improvement.value_or(1.0), result.wall_s);
  std::printf("report: %s/report.json and report.html\n", out.c_str());
}

}  // namespace

struct StationArgs {
  std::string scenario;
  std::string config;
  std::string out = "odocal-station";
  int max_rounds = 3;
  double time_scale = 20.0;
  int rest_frames = 12;
  report::ExportRequests exports;
  bool max_rounds_given = false;  // --max-rounds on the command line (else the station file's)
};

void RunStation(const StationArgs& args) {
  if (auto e = report::CheckExports(args.exports)) Fail("station", kExitBadInput, *e);
  const std::string name = "station";
  if (args.scenario.empty() == args.config.empty())
    Fail(name, kExitBadInput, "give --scenario (virtual robot) or --config (real robot)");
  std::signal(SIGINT, OnStationSignal);
  std::signal(SIGTERM, OnStationSignal);
  station::StationOptions options;
  options.max_rounds = args.max_rounds;
  options.rest_frames = args.rest_frames;
  station::StationSetup setup;
  setup.stop_requested = &g_stop;
  setup.progress = Progress;
  std::string error;

  if (!args.scenario.empty()) {
    const auto s = config::LoadScenario(args.scenario);
    if (!s) Fail(name, kExitBadInput, s.message);
    if (!s->camera || !s->tag)
      Fail(name, kExitBadInput, args.scenario + ": the station needs the scenario's camera: and tag:");
    if (!(args.time_scale > 0.0) || args.time_scale > 1000.0)
      Fail(name, kExitBadInput, "--time-scale must be in (0, 1000]");
    for (const calibration::RunSpec& spec : s->runs)
      if (spec.procedure == calibration::Procedure::kUmbmark) setup.plan.push_back(spec);
    if (setup.plan.size() != s->runs.size())
      Progress("only the scenario's UMBMark squares are driven; its other runs are skipped");
    sim::SimMotionBackend backend(s->robot);
    robot_link::FirmwareHostOptions host_options;
    host_options.time_scale = args.time_scale;
    const std::optional<robot_link::ParamSet> defaults =
        robot_link::ToParamSet(s->robot.nominal, &error);
    if (!defaults) Fail(name, kExitBadInput, "robot.nominal." + error);
    host_options.robot.defaults = *defaults;
    const calibration::WheelParams& n = s->robot.nominal;
    auto host = robot_link::FirmwareHost::Start(host_options, backend);
    if (!host) Fail(name, kExitFailure, "virtual robot: " + host.message);
    auto port = robot_link::SerialTransport::Open((*host.value)->device_path());
    if (!port) Fail(name, kExitFailure, "virtual robot: " + port.message);
    auto camera = simulation::SimCameraSource::Create(*s->camera, *s->tag, backend, &error);
    if (!camera) Fail(name, kExitFailure, error);
    char scale[64];
    std::snprintf(scale, sizeof(scale), ", %g robot seconds per wall second", args.time_scale);
    Progress("virtual robot on " + (*host.value)->device_path() + scale);
    setup.transport = port.value->get();
    setup.camera = camera.get();
    setup.intrinsics = s->camera->intrinsics;
    // The operator's guess is where the camera was hung; the station
    // refines its tilt and height from the views.
    setup.mount_guess = s->camera->mount;
    setup.tag = *s->tag;
    // Floor tags in the scenario: the virtual camera draws them, and the
    // station gets the tape's readings, as simulate writes them into session.yaml.
    if (s->camera->floor_tags) {
      setup.floor_reference = simulation::TapedFloorReference(*s->camera->floor_tags);
      Progress("floor reference: " + std::to_string(setup.floor_reference->tags.size()) + " floor tags, " +
               std::to_string(setup.floor_reference->distances.size()) + " taped distances");
    }
    const calibration::WheelParams& t = s->robot.truth;
    const double Ed = (t.right_wheel_diameter_m / t.left_wheel_diameter_m) /
                      (n.right_wheel_diameter_m / n.left_wheel_diameter_m);
    const double Eb = t.track_m / n.track_m;
    const double Es = (t.left_wheel_diameter_m + t.right_wheel_diameter_m) /
                      (n.left_wheel_diameter_m + n.right_wheel_diameter_m);
    Finish(setup, options, args.out,
           {{"scenario", args.scenario},
            {"truth", {{"Ed", Ed}, {"Eb", Eb}, {"Es", Es}, {"turn_gain", Eb / Es}}}},
           args.exports);
    return;
  }

  const auto c = config::LoadStationConfig(args.config);
  if (!c) Fail(name, kExitBadInput, c.message);
  if (!args.max_rounds_given) options.max_rounds = c->max_rounds;
  options.rest_flush_frames = c->flush_frames;
  options.settle_s = c->settle_s;
  const auto camera_file = config::ReadCameraFile(c->camera_file);
  if (!camera_file) Fail(name, kExitBadInput, camera_file.message);
  robot_link::SerialOptions serial;
  serial.baud = c->baud;
  auto port = robot_link::SerialTransport::Open(c->port, serial);
  if (!port) Fail(name, kExitBadInput, "robot: " + port.message);
  auto camera = media::CaptureSource::Open(c->camera_device, &error);
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
  setup.tag_size_sigma_mm = c->tag_size_sigma_mm;
  setup.floor_reference = c->floor_reference;
  Finish(setup, options, args.out, {{"config", args.config}}, args.exports);
}

void RegisterStationCommand(CLI::App& app) {
  auto args = std::make_shared<StationArgs>();
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
    args->max_rounds_given = rounds->count() > 0;
    RunStation(*args);
  });
}

}  // namespace odocal::app
