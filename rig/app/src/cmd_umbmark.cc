// odocal umbmark --side-mm L --track-mm B --cw X,Y[,THETA] ... --ccw X,Y[,THETA] ... [--json]
#include <cmath>
#include <iostream>
#include <memory>

#include "cli_util.h"
#include "commands.h"
#include "odocal/base/units.h"
#include "odocal/calibration/corrections.h"
#include "odocal/calibration/umbmark.h"
#include "odocal/report/exports.h"
#include "odocal/report/json.h"

namespace odocal::app {
namespace {

std::vector<calibration::ReturnError> ParseRuns(const std::vector<std::string>& texts,
                                                const std::string& flag) {
  std::vector<calibration::ReturnError> runs;
  for (size_t i = 0; i < texts.size(); ++i) {
    const auto values = ParseNumberList(texts[i]);
    if (!values || values->size() < 2 || values->size() > 3) {
      Fail("umbmark", kExitBadInput,
           flag + " #" + std::to_string(i + 1) + ": '" + texts[i] +
               "' is not X,Y[,THETA] (mm, mm, degrees; finite numbers)");
    }
    runs.push_back(calibration::ReturnError::FromMmDeg(
        (*values)[0], (*values)[1],
        values->size() == 3 ? std::optional<double>((*values)[2]) : std::nullopt));
  }
  return runs;
}

}  // namespace

struct UmbmarkArgs {
  double side_mm = 0.0;
  double track_mm = 0.0;
  std::vector<std::string> cw, ccw;
  bool json = false;
  double left_mm = 0.0, right_mm = 0.0;
  double ticks_per_rev = 0.0;
  report::ExportRequests exports;
};

void RunUmbmark(const UmbmarkArgs& args) {
  if (const Status e = report::CheckExports(args.exports); !e) Fail("umbmark", kExitBadInput, e.message);
  calibration::UmbmarkInput input;
  input.side_m = args.side_mm * kMmToM;
  input.track_m = args.track_mm * kMmToM;
  input.cw = ParseRuns(args.cw, "--cw");
  input.ccw = ParseRuns(args.ccw, "--ccw");
  std::string why;
  if (!input.IsValid(&why)) Fail("umbmark", kExitBadInput, why);
  const calibration::UmbmarkSummary summary = calibration::EstimateUmbmark(input);
  if (summary.status == odocal::StatusCode::kInvalidArgument)
    Fail("umbmark", kExitBadInput, summary.message);
  if (!summary.ok()) Fail("umbmark", kExitFailure, summary.message);
  nlohmann::json doc = report::UmbmarkJson(input, summary);
  const bool have_wheels = args.left_mm > 0.0 && args.right_mm > 0.0;
  if ((args.left_mm != 0.0 || args.right_mm != 0.0) && !have_wheels)
    Fail("umbmark", kExitBadInput,
         "--left-diameter-mm and --right-diameter-mm go together and must be positive");
  std::optional<calibration::WheelParams> corrected_params;
  calibration::WheelParams nominal_params;
  if (have_wheels) {
    calibration::WheelParams nominal;
    nominal.left_wheel_diameter_m = args.left_mm * kMmToM;
    nominal.right_wheel_diameter_m = args.right_mm * kMmToM;
    nominal.track_m = input.track_m;
    nominal.ticks_per_rev = args.ticks_per_rev;
    const calibration::WheelParams corrected = calibration::ApplyUmbmarkCorrection(
        nominal, summary.coupled.Ed, summary.coupled.Eb);
    doc["corrected"] = report::WheelParamsJson(corrected);
    doc["ros2"] = report::Ros2Json(calibration::Ros2MultipliersFrom(nominal, corrected));
    nominal_params = nominal;
    corrected_params = corrected;
  }
  if (!args.exports.raw.empty() && !have_wheels)
    Fail("umbmark", kExitBadInput,
         "--export needs the nominal wheels: --left-diameter-mm, --right-diameter-mm (and --ticks-per-rev)");
  if (const Status e = report::WriteExports(args.exports, nominal_params, corrected_params); !e)
    Fail("umbmark", kExitFailure, e.message);
  if (args.json) {
    std::cout << doc.dump(2) << std::endl;
  } else {
    std::cout << report::UmbmarkTable(input, summary);
    if (have_wheels) {
      std::cout << "\n  corrected parameters " << doc["corrected"].dump() << "\n"
                << "  ROS 2 multipliers    " << doc["ros2"].dump() << "\n";
    }
  }
}

void RegisterUmbmarkCommand(CLI::App& app) {
  auto args = std::make_shared<UmbmarkArgs>();
  CLI::App* cmd = app.add_subcommand(
      "umbmark",
      "UMBMark estimate from return errors measured any way (tape, camera, log).\n"
      "Each --cw/--ccw is one run: X,Y[,THETA] = true - odometry in the run's start frame\n"
      "(x along the start heading, y to the left, theta counter-clockwise), mm and degrees.\n"
      "Negative first values: write --cw=-3.5,2.1");
  cmd->add_option("--side-mm", args->side_mm, "Side L of the square [mm]")->required();
  cmd->add_option("--track-mm", args->track_mm, "Track b the robot used [mm]")->required();
  cmd->add_option("--cw", args->cw, "One clockwise run: X,Y[,THETA]")->required()->allow_extra_args(false);
  cmd->add_option("--ccw", args->ccw, "One counter-clockwise run: X,Y[,THETA]")->required()->allow_extra_args(false);
  cmd->add_option("--left-diameter-mm", args->left_mm, "Nominal left wheel diameter, to print corrected parameters");
  cmd->add_option("--right-diameter-mm", args->right_mm, "Nominal right wheel diameter");
  cmd->add_option("--ticks-per-rev", args->ticks_per_rev, "Encoder ticks per wheel revolution");
  cmd->add_flag("--json", args->json, "Print one JSON object");
  AddExportOption(cmd, &args->exports);
  cmd->callback([args]() { RunUmbmark(*args); });
}

}  // namespace odocal::app
