// odocal station --scenario S.yaml --out DIR   the built-in virtual robot on a
//                                               pseudo-terminal, the virtual camera
//     [--driver link|command|operator --run-command T --stop-command T --apply-command T]
//     [--plan scenario|default]
// odocal station --config station.yaml [--out DIR]   a real robot and camera
//
// The hands-off loop of station.h. Progress on stderr, the operator's
// instructions on stdout, DIR/report.json at the end (also after a failure,
// with its status and message), each run's driver log in DIR/runs/, Ctrl-C
// stops the robot and leaves its parameters as they were. With the virtual
// robot, a command driver's commands find its device in $ODOCAL_ROBOT_PORT
// and this odocal in $ODOCAL.
//
// station.yaml (millimetres and degrees; paths relative to the file):
//   robot:  {driver: link, port: /dev/ttyUSB0, baud: 115200, timeout_ms: 200, run_timeout_s: 120}
//        or {driver: command, command: "...{direction} {side_mm}...", stop_command, apply: "... {file}",
//            apply_timeout_s, run_timeout_s, params: {left_wheel_diameter_mm, ..., ticks_per_rev}}
//        or {driver: operator, apply, params}
//   camera: {device: "0" | "rtsp://...", calibration: camera.yaml,
//            mount_guess: {x_mm, y_mm, height_mm, roll_deg, pitch_deg, yaw_deg},
//            flush_frames: 5, settle_s: 0.5}
//   tag:    {family, id, size_mm, size_sigma_mm, height_mm, offset_mm: {x, y}, yaw_deg}
//   floor_reference: {family, tags: [{id, size_mm}], distances: [{between: [A, B], mm, sigma_mm}],
//                     tag_height_sigma_mm}              # optional, as in session.yaml
//   plan:   {side_mm: 2000, runs_per_direction: 3} | default | {default: {slow_turn_rate_deg_s,
//            fast_turn_rate_deg_s}} | [{procedure: umbmark, direction, side_mm}, {procedure: straight,
//            distance_mm}, {procedure: spin, turns, direction, turn_rate_deg_s}, {procedure: out_and_back, ...}]
//   max_rounds: 3
#include <atomic>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <tuple>

#include <unistd.h>

#include "cli_util.h"
#include "commands.h"
#include "record_util.h"
#include "odocal/base/units.h"
#include "odocal/records/digest.h"
#include "odocal/config/camera_file.h"
#include "odocal/config/files.h"
#include "odocal/config/scenario.h"
#include "odocal/config/station_file.h"
#include "odocal/live/live_server.h"
#include "odocal/live/live_state.h"
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

std::atomic<bool> g_station_stop{false};
void OnStationSignal(int) { g_station_stop = true; }

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
void Finish(station::StationSetup& setup, const station::StationOptions& options, const std::string& out,
            nlohmann::json extra, const report::ExportRequests& exports, const std::string& live_bind, int live_port,
            const RecordArgs& record_args, const records::Limits& limits) {
  setup.run_log_dir = out + "/runs";
  // The live view (rig/live): the page shows what the station sees while it runs.
  std::unique_ptr<live::LiveState> live_state;
  std::unique_ptr<live::LiveServer> live_server;
  if (live_port >= 0) {
    live::LiveServerOptions o;
    o.bind_address = live_bind;
    o.port = live_port;
    std::string why;
    if (!o.IsValid(&why)) Fail("station", kExitBadInput, "--live-bind " + live_bind + ": " + why);
    live_state = std::make_unique<live::LiveState>();
    live_state->SetSource(setup.camera->Describe());
    auto started = live::LiveServer::Start(*live_state, o);
    if (!started) Fail("station", kExitBadInput, "--live-port " + std::to_string(live_port) + ": " + started.message);
    live_server = std::move(*started.value);
    Progress("live view: " + live_server->url());
    setup.live = live_state.get();
  }
  const station::StationResult result = station::RunStation(setup, options);
  live_server.reset();
  setup.live = nullptr;
  nlohmann::json report = station::StationReportJson(result);
  for (auto it = extra.begin(); it != extra.end(); ++it) report[it.key()] = it.value();
  Status written = config::EnsureDirectory(out);
  if (written) written = config::WriteFileAtomically(out + "/report.json", report.dump(2) + "\n");
  if (written) written = report::WriteReportHtml(report, "odocal station", out + "/report.html");
  // A set the driver could not apply: written for the user to load.
  if (written && result.params_recommended && result.params_initial) {
    const calibration::WheelParams nominal = robot_link::ToWheelParams(*result.params_initial);
    const calibration::WheelParams corrected = robot_link::ToWheelParams(*result.params_recommended);
    written = config::WriteFileAtomically(out + "/corrected.firmware.yaml", report::FirmwareExportYaml(corrected));
    if (written)
      written = config::WriteFileAtomically(out + "/corrected.ros2.yaml", report::Ros2ExportYaml(nominal, corrected));
  }
  if (!result.ok()) {
    Fail("station", ExitCode(result.status),
         result.message + (result.cleanup.empty() ? "" : " (" + result.cleanup + ")"));
  }
  if (!written) Fail("station", kExitFailure, written.message);
  // Exports: the robot's set at the start is the nominal; the read-back set,
  // or the one to load, the corrected.
  const std::optional<robot_link::ParamSet> corrected =
      result.params_recommended ? result.params_recommended : result.params_final;
  if (result.params_initial && corrected) {
    if (const Status e = report::WriteExports(exports, robot_link::ToWheelParams(*result.params_initial),
                                              robot_link::ToWheelParams(*corrected));
        !e)
      Fail("station", kExitFailure, e.message);
  }
  const station::StationIteration& first = result.iterations.front();
  const station::StationIteration& last = result.iterations.back();
  if (first.estimate.ok() && last.estimate.ok())
    std::fprintf(stderr, "station: E_max,syst %.3f mm -> %.3f mm in %zu rounds (%.0fx), %.1f s\n",
                 first.estimate.emax_syst_m * kMToMm, last.estimate.emax_syst_m * kMToMm, result.iterations.size(),
                 result.improvement.value_or(1.0), result.wall_s);
  else
    std::fprintf(stderr, "station: %zu rounds, %.1f s\n", result.iterations.size(), result.wall_s);
  for (const std::string& f : result.findings) std::fprintf(stderr, "station: finding: %s\n", f.c_str());
  if (result.params_recommended)
    std::printf("corrected set (not applied): %s/corrected.firmware.yaml, %s/corrected.ros2.yaml\n", out.c_str(),
                out.c_str());
  std::printf("report: %s/report.json and report.html\n", out.c_str());
  // The record: the robot's name on the link (or --robot), keyed by what this station measured.
  RunIdentity run;
  run.kind = records::RunKind::kStation;
  run.folder = out;
  nlohmann::json measured = report;
  for (const char* volatile_key : {"wall_s", "live"}) measured.erase(volatile_key);
  run.digest = records::DigestText("station " + measured.dump());
  const records::Record record = KeepRecord("station", report, run, record_args, limits);
  if (const std::string line = VerdictLine(record, limits); !line.empty()) {
    std::printf("%s\n", line.c_str());
    if (record.verdict == records::Verdict::kFail)
      Fail("station", kExitOutsideLimits, "calibrated, but outside the line's limits (" + line.substr(13) + ")");
  }
}

// The command and operator drivers' options from the templates and the set.
station::ExternalDriverOptions ExternalOptions(const std::string& run, const std::string& stop,
                                               const std::string& apply, double apply_timeout_s,
                                               const calibration::WheelParams& params, const std::string& out) {
  station::ExternalDriverOptions o;
  o.run_command = run;
  o.stop_command = stop;
  o.apply_command = apply;
  o.apply_timeout = std::chrono::milliseconds(static_cast<long>(apply_timeout_s * kSToMs));
  const Result<robot_link::ParamSet> set = robot_link::ToParamSet(params);
  if (!set) Fail("station", kExitBadInput, "robot.params: " + set.message);
  o.params = *set;
  o.work_dir = out;
  o.prompt = &std::cout;
  for (const auto& [text, kind, name] : {std::tuple{run, "run", "the run command"},
                                         std::tuple{stop, "run", "the stop command"},
                                         std::tuple{apply, "apply", "the apply command"}}) {
    if (text.empty()) continue;
    if (const Status checked = station::CheckTemplate(text, kind); !checked)
      Fail("station", kExitBadInput, std::string(name) + ": " + checked.message);
  }
  return o;
}

std::unique_ptr<station::RobotDriver> MakeExternalDriver(bool command, const station::ExternalDriverOptions& o) {
  if (command && o.run_command.empty()) Fail("station", kExitBadInput, "the command driver needs a run command");
  return command ? station::MakeCommandDriver(o) : station::MakeOperatorDriver(o);
}

std::string SelfPath() {
  std::error_code ec;
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  return ec ? "odocal" : self.string();
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
  // The virtual robot's driver (a station file names its own).
  std::string driver = "link";
  std::string run_command, stop_command, apply_command;
  double run_timeout_s = 120.0;
  std::string plan = "scenario";
  int live_port = -1;  // -1: no live view
  std::string live_bind = "127.0.0.1";
  RecordArgs record;
};

// The scenario's true robot in the report's terms (Ed, Eb, Es, turn gain,
// and its turn slip when hidden).
nlohmann::json StationScenarioTruth(const config::Scenario& s) {
  const calibration::WheelParams& t = s.robot.truth;
  const calibration::WheelParams& n = s.robot.nominal;
  const double Ed =
      (t.right_wheel_diameter_m / t.left_wheel_diameter_m) / (n.right_wheel_diameter_m / n.left_wheel_diameter_m);
  const double Eb = t.track_m / n.track_m;
  const double Es =
      (t.left_wheel_diameter_m + t.right_wheel_diameter_m) / (n.left_wheel_diameter_m + n.right_wheel_diameter_m);
  nlohmann::json truth = {{"Ed", Ed}, {"Eb", Eb}, {"Es", Es}, {"turn_gain", Eb / Es}};
  if (s.robot.effects.turn_slip) truth["turn_slip_at_1rad_s"] = s.robot.effects.turn_slip->fraction_at_1rad_s;
  return truth;
}

// The scenario's runs the station drives (`--plan default`: the default plan).
void StationPlanFromScenario(const std::string& plan, const config::Scenario& s, station::StationSetup* setup) {
  if (plan == "default") {
    setup->default_plan = station::DefaultPlanOptions{};
  } else {
    for (const calibration::RunSpec& spec : s.runs) {
      const bool drivable =
          spec.procedure == calibration::Procedure::kUmbmark || spec.procedure == calibration::Procedure::kStraight ||
          spec.procedure == calibration::Procedure::kSpin || spec.procedure == calibration::Procedure::kOutAndBack;
      if (drivable) setup->plan.push_back(spec);
    }
    if (setup->plan.size() != s.runs.size())
      Progress("the scenario's recorded and circle runs are not driven by the station; they are skipped");
  }
}

// The station file's plan: the default plan, its runs, or squares both ways.
void StationPlanFromConfig(const config::StationConfig& c, station::StationSetup* setup) {
  if (c.default_plan) {
    station::DefaultPlanOptions d;
    if (c.slow_turn_rate_deg_s) d.slow_turn_rate_rad_s = DegToRad(*c.slow_turn_rate_deg_s);
    if (c.fast_turn_rate_deg_s) d.fast_turn_rate_rad_s = DegToRad(*c.fast_turn_rate_deg_s);
    setup->default_plan = d;
  } else if (!c.runs.empty()) {
    setup->plan = c.runs;
  } else {
    for (int i = 0; i < c.runs_per_direction; ++i) {
      setup->plan.push_back(calibration::RunSpec::Umbmark(calibration::Direction::kCw, c.side_mm * kMmToM));
      setup->plan.push_back(calibration::RunSpec::Umbmark(calibration::Direction::kCcw, c.side_mm * kMmToM));
    }
  }
}

// The built-in virtual robot behind a pty and its rendered camera.
void RunVirtualStation(const StationArgs& args, const records::Limits& limits, station::StationOptions options,
                       station::StationSetup setup) {
  const std::string name = "station";
  const auto s = config::LoadScenario(args.scenario);
  if (!s) Fail(name, kExitBadInput, s.message);
  if (!s->camera || !s->tag)
    Fail(name, kExitBadInput, args.scenario + ": the station needs the scenario's camera: and tag:");
  if (!(args.time_scale > 0.0) || args.time_scale > 1000.0)
    Fail(name, kExitBadInput, "--time-scale must be in (0, 1000]");
  StationPlanFromScenario(args.plan, *s, &setup);
  options.run_timeout = std::chrono::milliseconds(static_cast<long>(args.run_timeout_s * kSToMs));
  // The virtual robot's fastest turn is known: the heading check unwraps
  // every gap it could not turn 120 deg in.
  options.max_turn_rate_rad_s = 1.25 * s->robot.limits.turn_rate_rad_s;
  sim::SimMotionBackend backend(s->robot);
  robot_link::FirmwareHostOptions host_options;
  host_options.time_scale = args.time_scale;
  const Result<robot_link::ParamSet> defaults = robot_link::ToParamSet(s->robot.nominal);
  if (!defaults) Fail(name, kExitBadInput, "robot.nominal." + defaults.message);
  host_options.robot.defaults = *defaults;
  auto host = robot_link::FirmwareHost::Start(host_options, backend);
  if (!host) Fail(name, kExitFailure, "virtual robot: " + host.message);
  auto port = robot_link::SerialTransport::Open((*host.value)->device_path());
  if (!port) Fail(name, kExitFailure, "virtual robot: " + port.message);
  auto camera = simulation::SimCameraSource::Create(*s->camera, *s->tag, backend);
  if (!camera) Fail(name, kExitFailure, camera.message);
  char scale[64];
  std::snprintf(scale, sizeof(scale), ", %g robot seconds per wall second", args.time_scale);
  Progress("virtual robot on " + (*host.value)->device_path() + scale);
  std::unique_ptr<station::RobotDriver> driver;
  if (args.driver == "link") {
    if (!args.run_command.empty() || !args.apply_command.empty() || !args.stop_command.empty())
      Fail(name, kExitBadInput, "--run-command, --stop-command and --apply-command need --driver command or operator");
    setup.transport = port.value->get();
  } else {
    // The commands reach the virtual robot through its device; the
    // station's own connection is closed so they have it alone.
    port.value->reset();
    station::ExternalDriverOptions o =
        ExternalOptions(args.run_command, args.stop_command, args.apply_command, 60.0, s->robot.nominal, args.out);
    o.environment = {{"ODOCAL_ROBOT_PORT", (*host.value)->device_path()}, {"ODOCAL", SelfPath()}};
    driver = MakeExternalDriver(args.driver == "command", o);
    setup.driver = driver.get();
  }
  setup.camera = camera->get();
  setup.camera_on_robot_clock = true;  // the virtual camera renders robot time
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
  const nlohmann::json truth = StationScenarioTruth(*s);
  Finish(setup, options, args.out, {{"scenario", args.scenario}, {"truth", truth}}, args.exports, args.live_bind,
         args.live_port, args.record, limits);
}

// A real robot (link, command or operator driver) and camera, from the station file.
void RunRealStation(const StationArgs& args, records::Limits limits, station::StationOptions options,
                    station::StationSetup setup) {
  const std::string name = "station";
  const auto c = config::LoadStationConfig(args.config);
  if (!c) Fail(name, kExitBadInput, c.message);
  limits = LimitsOrFail(name, args.record, c->limits);
  if (!args.max_rounds_given) options.max_rounds = c->max_rounds;
  options.rest_flush_frames = c->flush_frames;
  options.settle_s = c->settle_s;
  const auto camera_file = config::ReadCameraFile(c->camera_file);
  if (!camera_file) Fail(name, kExitBadInput, camera_file.message);
  std::unique_ptr<robot_link::SerialTransport> port;
  std::unique_ptr<station::RobotDriver> driver;
  if (c->driver == config::StationDriver::kLink) {
    robot_link::SerialOptions serial;
    serial.baud = c->baud;
    auto opened = robot_link::SerialTransport::Open(c->port, serial);
    if (!opened) Fail(name, kExitBadInput, "robot: " + opened.message);
    port = std::move(*opened.value);
    setup.transport = port.get();
    setup.client.reply_timeout = std::chrono::milliseconds(c->timeout_ms);
  } else {
    const station::ExternalDriverOptions o = ExternalOptions(c->run_command, c->stop_command, c->apply_command,
                                                             c->apply_timeout_s, *c->params, args.out);
    driver = MakeExternalDriver(c->driver == config::StationDriver::kCommand, o);
    setup.driver = driver.get();
  }
  options.run_timeout = std::chrono::milliseconds(static_cast<long>(c->run_timeout_s * kSToMs));
  auto camera = media::CaptureSource::Open(c->camera_device);
  if (!camera) Fail(name, kExitBadInput, camera.message);
  StationPlanFromConfig(*c, &setup);
  setup.camera = camera->get();
  setup.intrinsics = camera_file->intrinsics;
  setup.mount_guess = c->mount_guess;
  setup.tag = c->tag;
  setup.tag_size_sigma_mm = c->tag_size_sigma_mm;
  setup.floor_reference = c->floor_reference;
  Finish(setup, options, args.out, {{"config", args.config}}, args.exports, args.live_bind, args.live_port, args.record,
         limits);
}

void RunStation(const StationArgs& args) {
  if (const Status e = report::CheckExports(args.exports); !e) Fail("station", kExitBadInput, e.message);
  const std::string name = "station";
  if (args.scenario.empty() == args.config.empty())
    Fail(name, kExitBadInput, "give --scenario (virtual robot) or --config (real robot)");
  records::Limits limits = LimitsOrFail(name, args.record);
  std::signal(SIGINT, OnStationSignal);
  std::signal(SIGTERM, OnStationSignal);
  station::StationOptions options;
  options.max_rounds = args.max_rounds;
  options.rest_frames = args.rest_frames;
  station::StationSetup setup;
  setup.stop_requested = &g_station_stop;
  setup.progress = Progress;
  if (!args.scenario.empty()) {
    RunVirtualStation(args, limits, options, setup);
    return;
  }
  RunRealStation(args, limits, options, setup);
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
  cmd->add_option("--driver", args->driver, "Virtual robot: how it is driven (link, command, operator)")
      ->check(CLI::IsMember({"link", "command", "operator"}))
      ->capture_default_str();
  cmd->add_option("--run-command", args->run_command,
                  "Virtual robot, command driver: the command per run ({procedure} {direction} {side_mm} "
                  "{distance_mm} {turns} {repeats} {speed_mm_s} {turn_rate_deg_s} {run} {run_name} {log} "
                  "{telemetry}; $ODOCAL_ROBOT_PORT, $ODOCAL)");
  cmd->add_option("--stop-command", args->stop_command, "Virtual robot, command driver: run after a kill");
  cmd->add_option("--apply-command", args->apply_command,
                  "Virtual robot, command or operator driver: applies a corrected set ({file} {ros2} "
                  "{left_wheel_diameter_mm} {right_wheel_diameter_mm} {track_mm} {ticks_per_rev})");
  cmd->add_option("--run-timeout-s", args->run_timeout_s, "Virtual robot: a run longer than this fails")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  cmd->add_option("--live-port", args->live_port,
                  "Serve the live view (docs/formats.md, \"Live view\") on this port (0: any free port; the URL "
                  "is logged); off by default");
  cmd->add_option("--live-bind", args->live_bind, "The live view's address (0.0.0.0: a phone on the network)")
      ->capture_default_str();
  cmd->add_option("--plan", args->plan, "Virtual robot: the scenario's runs, or the default plan sized to the view")
      ->check(CLI::IsMember({"scenario", "default"}))
      ->capture_default_str();
  cmd->footer(
      "Exit codes: 0 calibrated (or measured, when the driver cannot apply), 2 bad input, 3 robot link (not "
      "answering, line cut), 4 tag not found or camera lost, 5 run not completed (refused, failed, a command "
      "that exits non-zero or times out, no motion seen, the wrong run driven), 7 push or apply refused, "
      "6 calibrated but outside the limits (--limits, station.yaml's limits:), 1 estimate failed, 130 interrupted.");
  AddExportOption(cmd, &args->exports);
  AddRecordOptions(cmd, &args->record, /*with_limits=*/true);
  cmd->callback([args, rounds]() {
    args->max_rounds_given = rounds->count() > 0;
    RunStation(*args);
  });
}

}  // namespace odocal::app
