// odocal robot-sim --scenario S.yaml [--storage FILE] [--time-scale X]
//
// The scenario's virtual robot (true and believed parameters) behind the
// firmware library on a real pseudo-terminal. Prints the device path to pass
// to `odocal robot ... --port` (or to a station), then serves until
// interrupted. Parameters persist to --storage the way firmware persists to
// flash (two slots: write the new record, then switch).
#include <cmath>
#include <csignal>
#include <cstdio>
#include <iostream>
#include <memory>
#include <thread>

#include "cli_util.h"
#include "commands.h"
#include "odocal/config/scenario.h"
#include "odocal/robot_link/firmware_host.h"
#include "odocal/sim/sim_motion_backend.h"

namespace odocal::app {
namespace {

volatile std::sig_atomic_t g_robot_sim_stop = 0;
void OnSignal(int) { g_robot_sim_stop = 1; }

}  // namespace

struct RobotSimArgs {
  std::string scenario;
  std::string storage = "odocal_robot_params.bin";
  double time_scale = 1.0;
  double seconds = 0.0;
};

void RunRobotSim(const RobotSimArgs& args) {
  const std::string name = "robot-sim";
  std::string error;
  const auto scenario = config::LoadScenario(args.scenario);
  if (!scenario) Fail(name, kExitBadInput, scenario.message);
  if (!(args.time_scale > 0.0) || args.time_scale > 1000.0)
    Fail(name, kExitBadInput, "--time-scale must be in (0, 1000]");
  sim::SimMotionBackend backend(scenario->robot);
  robot_link::FirmwareHostOptions options;
  options.storage_path = args.storage;
  options.time_scale = args.time_scale;
  const Result<robot_link::ParamSet> defaults = robot_link::ToParamSet(scenario->robot.nominal);
  if (!defaults) Fail(name, kExitBadInput, "robot.nominal." + defaults.message);
  options.robot.defaults = *defaults;
  auto host = robot_link::FirmwareHost::Start(options, backend);
  if (!host.ok()) Fail(name, kExitFailure, host.message);
  std::signal(SIGINT, OnSignal);
  std::signal(SIGTERM, OnSignal);
  std::cout << (*host.value)->device_path() << std::endl;
  std::cerr << "robot-sim: serving the virtual robot of " << args.scenario << " on "
            << (*host.value)->device_path() << " (Ctrl-C to stop)" << std::endl;
  const auto start = std::chrono::steady_clock::now();
  while (!g_robot_sim_stop) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    if (args.seconds > 0.0 &&
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() > args.seconds)
      break;
  }
}

void RegisterRobotSimCommand(CLI::App& app) {
  auto args = std::make_shared<RobotSimArgs>();
  CLI::App* cmd = app.add_subcommand(
      "robot-sim", "Serve the scenario's virtual robot on a pseudo-terminal; prints the device path");
  cmd->add_option("--scenario", args->scenario, "Scenario file (YAML)")->required();
  cmd->add_option("--storage", args->storage, "Parameter storage file (the robot's flash)");
  cmd->add_option("--time-scale", args->time_scale, "Robot seconds per wall-clock second");
  cmd->add_option("--seconds", args->seconds, "Stop after this many wall-clock seconds (0: until Ctrl-C)");
  cmd->callback([args]() { RunRobotSim(*args); });
}

}  // namespace odocal::app
