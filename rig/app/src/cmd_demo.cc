// odocal demo --scenario S.yaml --out DIR
//
// The main job until the station exists: a mis-calibrated virtual robot
// drives the scenario's UMBMark squares, odocal estimates Ed and Eb, corrects
// the robot's parameters and drives the squares again to show the
// improvement. Return errors come from the simulator's truth (an ideal
// measurement); the camera replaces it in the station.
#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>

#include <nlohmann/json.hpp>

#include "cli_util.h"
#include "commands.h"
#include "odocal/base/units.h"
#include "odocal/calibration/corrections.h"
#include "odocal/calibration/umbmark.h"
#include "odocal/config/files.h"
#include "odocal/config/scenario.h"
#include "odocal/report/exports.h"
#include "odocal/report/html_report.h"
#include "odocal/report/json.h"
#include "odocal/simulation/simulation.h"

namespace odocal::app {
namespace {

// The UMBMark input of a simulated round (its squares' true return errors).
std::optional<calibration::UmbmarkInput> UmbmarkFrom(const simulation::SimulationResult& result,
                                                     double track_m, std::string* why) {
  calibration::UmbmarkInput input;
  input.track_m = track_m;
  for (const sim::RunRecord& run : result.runs) {
    if (run.spec.procedure != calibration::Procedure::kUmbmark) continue;
    if (!input.AddRun(run.spec, run.TrueEndInStartFrame())) {
      *why = "runs: UMBMark squares of different sides cannot be pooled";
      return std::nullopt;
    }
  }
  if (!input.IsValid(why)) {
    *why = "runs: " + *why + " (the demo needs UMBMark squares, as many cw as ccw)";
    return std::nullopt;
  }
  return input;
}

}  // namespace

struct DemoArgs {
  std::string scenario;
  std::string out;
  report::ExportRequests exports;
};

void RunDemo(const DemoArgs& args) {
  const std::string name = "demo";
  if (const Status e = report::CheckExports(args.exports); !e) Fail(name, kExitBadInput, e.message);
  std::string error;
  const auto scenario = config::LoadScenario(args.scenario);
  if (!scenario) Fail(name, kExitBadInput, scenario.message);
  const calibration::WheelParams& nominal = scenario->robot.nominal;

  const simulation::SimulationResult before = simulation::Simulate(*scenario);
  const auto input_before = UmbmarkFrom(before, nominal.track_m, &error);
  if (!input_before) Fail(name, kExitBadInput, args.scenario + ": " + error);
  const calibration::UmbmarkSummary estimate = calibration::EstimateUmbmark(*input_before);
  if (!estimate.ok()) Fail(name, kExitFailure, estimate.message);
  const calibration::WheelParams corrected =
      calibration::ApplyUmbmarkCorrection(nominal, estimate.coupled.Ed, estimate.coupled.Eb);

  config::Scenario again = *scenario;
  again.robot.seed = scenario->seed + 1;  // new runs, new noise
  const simulation::SimulationResult after = simulation::Simulate(again, corrected);
  const auto input_after = UmbmarkFrom(after, corrected.track_m, &error);
  const calibration::UmbmarkSummary verify = calibration::EstimateUmbmark(*input_after);
  if (!verify.ok()) Fail(name, kExitFailure, "verification: " + verify.message);
  const double improvement = estimate.emax_syst_m / verify.emax_syst_m;

  if (const Status e = simulation::WriteSimulation(*scenario, before, args.out + "/round1"); !e)
    Fail(name, kExitFailure, e.message);
  if (const Status e = simulation::WriteSimulation(again, after, args.out + "/round2"); !e)
    Fail(name, kExitFailure, e.message);
  const nlohmann::json report = {
      {"command", "demo"},
      {"scenario", args.scenario},
      {"measurement", "simulator truth (ideal measurement)"},
      {"truth", {{"Ed", before.truth.Ed}, {"Eb", before.truth.Eb}, {"Es", before.truth.Es}}},
      {"iterations",
       {{{"emax_syst_mm", estimate.emax_syst_m * kMToMm},
         {"umbmark", report::UmbmarkJson(*input_before, estimate)},
         {"estimate", {{"Ed", estimate.coupled.Ed}, {"Eb", estimate.coupled.Eb}}},
         {"pushed", report::WheelParamsJson(corrected)}},
        {{"emax_syst_mm", verify.emax_syst_m * kMToMm},
         {"umbmark", report::UmbmarkJson(*input_after, verify)},
         {"estimate", {{"Ed", verify.coupled.Ed}, {"Eb", verify.coupled.Eb}}}}}},
      {"robot_params_final", report::WheelParamsJson(corrected)},
      {"ros2", report::Ros2Json(calibration::Ros2MultipliersFrom(nominal, corrected))},
      {"improvement", improvement},
  };
  if (const Status e = config::WriteFileAtomically(args.out + "/report.json", report.dump(2) + "\n"); !e)
    Fail(name, kExitFailure, e.message);
  if (const Status e = report::WriteReportHtml(report, "odocal demo", args.out + "/report.html"); !e)
    Fail(name, kExitFailure, e.message);
  if (const Status e = report::WriteExports(args.exports, nominal, corrected); !e) Fail(name, kExitFailure, e.message);

  std::printf("odocal demo: %zu UMBMark squares of %.0f mm on a virtual robot\n",
              input_before->cw.size() + input_before->ccw.size(), input_before->side_m * kMToMm);
  std::printf("  (return errors from the simulator's truth: an ideal measurement)\n\n");
  // UMBMark sees the turn gain b_true / (b_nominal Es): the Eb it can
  // measure when the distance scale is not calibrated (docs/calibration.md).
  std::printf("                 truth        estimate\n");
  std::printf("  Ed          %.6f   %.6f", before.truth.Ed, estimate.coupled.Ed);
  if (estimate.coupled.sigma_Ed) std::printf(" +/- %.6f", *estimate.coupled.sigma_Ed);
  std::printf("\n  Eb / Es     %.6f   %.6f", before.truth.Eb / before.truth.Es, estimate.coupled.Eb);
  if (estimate.coupled.sigma_Eb) std::printf(" +/- %.6f", *estimate.coupled.sigma_Eb);
  std::printf("\n  (Eb %.6f, Es %.6f: UMBMark measures the turn gain Eb / Es)\n", before.truth.Eb,
              before.truth.Es);
  std::printf("\n  parameters   nominal -> corrected (true)\n");
  std::printf("  D_L [mm]     %.4f -> %.4f (%.4f)\n", nominal.left_wheel_diameter_m * kMToMm,
              corrected.left_wheel_diameter_m * kMToMm, scenario->robot.truth.left_wheel_diameter_m * kMToMm);
  std::printf("  D_R [mm]     %.4f -> %.4f (%.4f)\n", nominal.right_wheel_diameter_m * kMToMm,
              corrected.right_wheel_diameter_m * kMToMm, scenario->robot.truth.right_wheel_diameter_m * kMToMm);
  std::printf("  track [mm]   %.3f -> %.3f (%.3f)\n\n", nominal.track_m * kMToMm,
              corrected.track_m * kMToMm, scenario->robot.truth.track_m * kMToMm);
  std::printf("  E_max,syst   %.2f mm before, %.2f mm after: %.0fx smaller\n",
              estimate.emax_syst_m * kMToMm, verify.emax_syst_m * kMToMm, improvement);
  std::printf("\nreport: %s/report.json, %s/report.html\n", args.out.c_str(), args.out.c_str());
}

void RegisterDemoCommand(CLI::App& app) {
  auto args = std::make_shared<DemoArgs>();
  CLI::App* cmd = app.add_subcommand(
      "demo", "Calibrate a mis-calibrated virtual robot with UMBMark and show the improvement");
  cmd->add_option("--scenario", args->scenario, "Scenario file (YAML)")->required();
  cmd->add_option("--out", args->out, "Output directory (created)")->required();
  AddExportOption(cmd, &args->exports);
  cmd->callback([args]() { RunDemo(*args); });
}

}  // namespace odocal::app
