// odocal simulate --scenario S.yaml --out DIR
#include <set>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>

#include <unistd.h>

#include "cli_util.h"
#include "commands.h"
#include "odocal/base/units.h"
#include "odocal/config/files.h"
#include "odocal/config/scenario.h"
#include "odocal/report/json.h"
#include "odocal/simulation/camera_sim.h"
#include "odocal/simulation/simulation.h"

namespace odocal::app {

struct SimulateArgs {
  std::string scenario;
  std::string out;
};

void RunSimulate(const SimulateArgs& args) {
  const auto scenario = config::LoadScenario(args.scenario);
  if (!scenario) Fail("simulate", kExitBadInput, scenario.message);
  const simulation::SimulationResult result = simulation::Simulate(*scenario);
  if (const Status dir_error = config::EnsureDirectory(args.out); !dir_error)
    Fail("simulate", kExitFailure, dir_error.message);
  std::vector<simulation::RecordedRun> recorded;
  if (scenario->camera) {
    if (const Status record_error = simulation::RecordRuns(*scenario, result, args.out, isatty(2), &recorded);
        !record_error)
      Fail("simulate", kExitFailure, record_error.message);
  }
  if (const Status write_error =
          simulation::WriteSimulation(*scenario, result, args.out, scenario->camera ? &recorded : nullptr);
      !write_error)
    Fail("simulate", kExitFailure, write_error.message);
  std::printf("simulated %zu runs: Ed %.6f  Eb %.6f  Es %.6f (truth, relative to nominal)\n",
              result.runs.size(), result.truth.Ed, result.truth.Eb, result.truth.Es);
  std::printf("  %-24s %12s %12s %12s\n", "run", "x [mm]", "y [mm]", "theta [deg]");
  for (size_t i = 0; i < result.runs.size(); ++i) {
    const calibration::Pose2 e = result.runs[i].TrueEndInStartFrame();
    std::printf("  %-24s %12.3f %12.3f %12.5f\n", result.run_names[i].c_str(), e.x() * kMToMm,
                e.y() * kMToMm, RadToDeg(e.heading()));
  }
  if (scenario->camera) {
    int frames = 0, visible = 0;
    std::set<std::string> videos;
    for (const simulation::RecordedRun& r : recorded) {
      if (!videos.insert(r.video).second) continue;  // one video for every run
      frames += r.frames_written;
      visible += r.frames_visible;
    }
    std::printf("recorded %d frames (tag in view in %d) to %zu video%s\n", frames, visible, videos.size(),
                videos.size() == 1 ? "" : "s");
    std::printf("wrote %s/session.yaml (what the operator knows)\n", args.out.c_str());
  }
  std::printf("wrote %s/truth.json\n", args.out.c_str());
}

void RegisterSimulateCommand(CLI::App& app) {
  auto args = std::make_shared<SimulateArgs>();
  CLI::App* cmd = app.add_subcommand(
      "simulate", "Run a scenario on the virtual robot; write truth.json and telemetry");
  cmd->add_option("--scenario", args->scenario, "Scenario file (YAML)")->required();
  cmd->add_option("--out", args->out, "Output directory (created)")->required();
  cmd->callback([args]() { RunSimulate(*args); });
}

}  // namespace odocal::app
