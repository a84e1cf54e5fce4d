// odocal cvra ratio|scale|track: the three CVRA procedures from raw numbers.
#include <cmath>
#include <iostream>
#include <memory>

#include <nlohmann/json.hpp>

#include "cli_util.h"
#include "commands.h"
#include "odocal/base/units.h"
#include "odocal/calibration/cvra.h"
#include "odocal/calibration/procedures.h"
#include "odocal/calibration/statistics.h"
#include "odocal/calibration/umbmark.h"

namespace odocal::app {
namespace {


// One estimate per measured run: their mean, and the standard error of the
// mean when there are several.
nlohmann::json Combine(const std::string& command, const std::string& key,
                       const std::vector<calibration::CvraResult>& results) {
  std::vector<double> values;
  for (size_t i = 0; i < results.size(); ++i) {
    if (!results[i].ok()) {
      Fail(command, kExitBadInput,
           "run #" + std::to_string(i + 1) + ": " + results[i].message);
    }
    values.push_back(results[i].value);
  }
  const std::optional<double> se = calibration::StandardError(values);
  return {{key, calibration::Mean(values)},
          {"sigma_" + key, se ? nlohmann::json(*se) : nlohmann::json(nullptr)},
          {"n", values.size()},
          {"quality", se ? "standard error of the mean of " + std::to_string(values.size()) + " runs"
                         : "none: one run (repeat it for an uncertainty)"}};
}

void Print(const nlohmann::json& doc, bool json, const std::string& key) {
  if (json) {
    std::cout << doc.dump(2) << std::endl;
    return;
  }
  std::cout << "CVRA " << doc["procedure"].get<std::string>() << ": " << key << " = "
            << doc[key].get<double>();
  if (!doc["sigma_" + key].is_null()) std::cout << " +/- " << doc["sigma_" + key].get<double>();
  std::cout << "  (" << doc["quality"].get<std::string>() << ")\n";
  for (const auto& [k, v] : doc.items()) {
    if (k == key || k == "sigma_" + key || k == "procedure" || k == "quality" || k == "n") continue;
    std::cout << "  " << k << " = " << v.dump() << "\n";
  }
}

calibration::Reference ReferenceOrFail(const std::string& command, const std::string& text) {
  const auto ref = calibration::ParseReference(text);
  if (!ref) Fail(command, kExitBadInput, "--reference: expected wall or camera, got '" + text + "'");
  return *ref;
}

void PositiveOrFail(const std::string& command, const std::string& flag, double value) {
  if (!std::isfinite(value) || value <= 0.0)
    Fail(command, kExitBadInput, flag + " must be a positive number");
}

struct CvraRatioArgs {
  std::string reference;
  double distance_mm = 0.0, track_mm = 0.0;
  std::vector<double> heading_deg;
  bool json = false;
};

void RunCvraRatio(const CvraRatioArgs& args) {
  const std::string name = "cvra ratio";
  const calibration::Reference ref = ReferenceOrFail(name, args.reference);
  PositiveOrFail(name, "--distance-mm", args.distance_mm);
  PositiveOrFail(name, "--track-mm", args.track_mm);
  std::vector<calibration::CvraResult> results;
  for (double h : args.heading_deg) {
    const double d = args.distance_mm * kMmToM, b = args.track_mm * kMmToM;
    results.push_back(ref == calibration::Reference::kWall
                          ? calibration::WheelRatioFromWall(d, h * kDegToRad, b)
                          : calibration::WheelRatioFromCamera(d, h * kDegToRad, b));
  }
  nlohmann::json doc = Combine(name, "Ed", results);
  const double ed = doc["Ed"];
  doc["procedure"] = "ratio";
  doc["reference"] = args.reference;
  doc["gain_factor"] = calibration::WheelGainFactor(ed);
  doc["c_left"] = calibration::CorrectionLeft(ed);
  doc["c_right"] = calibration::CorrectionRight(ed);
  Print(doc, args.json, "Ed");
}

void RegisterRatio(CLI::App* cvra) {
  auto args = std::make_shared<CvraRatioArgs>();
  CLI::App* cmd = cvra->add_subcommand(
      "ratio",
      "Wheel-diameter ratio Ed from out-and-back runs (forward, +180, forward, -180, ...).\n"
      "  wall:   --heading-deg is the odometry heading when pushed back against the wall\n"
      "  camera: --heading-deg is the camera's true - odometry heading at the end");
  cmd->add_option("--reference", args->reference, "wall or camera")->required();
  cmd->add_option("--distance-mm", args->distance_mm,
                  "Total believed travel (mean of the two wheels) from reset to the end [mm]")
      ->required();
  cmd->add_option("--heading-deg", args->heading_deg,
                  "One run's heading [deg]; repeat the flag for more runs")->required();
  cmd->add_option("--track-mm", args->track_mm, "Track the robot used [mm]")->required();
  cmd->add_flag("--json", args->json, "Print one JSON object");
  cmd->callback([args]() { RunCvraRatio(*args); });
}

struct CvraScaleArgs {
  double asked_mm = 0.0;
  std::vector<std::string> ends;
  std::vector<double> real_mm;
  bool json = false;
};

void RunCvraScale(const CvraScaleArgs& args) {
  const std::string name = "cvra scale";
  PositiveOrFail(name, "--asked-mm", args.asked_mm);
  if (args.real_mm.empty() == args.ends.empty())
    Fail(name, kExitBadInput, "give either --real-mm or --end for each run (not both, not neither)");
  std::vector<calibration::CvraResult> results;
  const double asked = args.asked_mm * kMmToM;
  for (double real : args.real_mm)
    results.push_back(calibration::ScaleFromStraight(asked, real * kMmToM, 0.0, 0.0));
  for (size_t i = 0; i < args.ends.size(); ++i) {
    const auto v = ParseNumberList(args.ends[i]);
    if (!v || v->size() != 3)
      Fail(name, kExitBadInput, "--end #" + std::to_string(i + 1) + ": '" + args.ends[i] +
                                    "' is not X,Y,THETA (mm, mm, degrees)");
    results.push_back(calibration::ScaleFromStraight(asked, (*v)[0] * kMmToM, (*v)[1] * kMmToM,
                                                     (*v)[2] * kDegToRad));
  }
  nlohmann::json doc = Combine(name, "scale", results);
  const double scale = doc["scale"];
  doc["procedure"] = "scale";
  doc["diameter_factor"] = scale;
  doc["ticks_per_mm_factor"] = 1.0 / scale;
  Print(doc, args.json, "scale");
}

void RegisterScale(CLI::App* cvra) {
  auto args = std::make_shared<CvraScaleArgs>();
  CLI::App* cmd = cvra->add_subcommand(
      "scale",
      "Travel scale from straight runs: the robot drove until odometry said --asked-mm.\n"
      "Give what really happened per run, either --real-mm (distance along the path) or\n"
      "--end X,Y,THETA (camera: true end in the start frame, mm, mm, deg; the arc is recovered).\n"
      "Diameters scale by real/asked; ticks per mm by asked/real.");
  cmd->add_option("--asked-mm", args->asked_mm, "Distance the robot was asked to drive [mm]")
      ->required();
  cmd->add_option("--real-mm", args->real_mm, "One run's real distance [mm]; repeatable");
  cmd->add_option("--end", args->ends, "One run's true end X,Y,THETA; repeatable");
  cmd->add_flag("--json", args->json, "Print one JSON object");
  cmd->callback([args]() { RunCvraScale(*args); });
}

struct CvraTrackArgs {
  std::string reference;
  std::string direction = "ccw";
  int turns = 0;
  double track_mm = 0.0;
  std::vector<double> heading_deg;
  bool json = false;
};

void RunCvraTrack(const CvraTrackArgs& args) {
  const std::string name = "cvra track";
  const calibration::Reference ref = ReferenceOrFail(name, args.reference);
  const auto direction = calibration::ParseDirection(args.direction);
  if (!direction)
    Fail(name, kExitBadInput, "--direction: expected cw or ccw, got '" + args.direction + "'");
  if (args.turns <= 0) Fail(name, kExitBadInput, "--turns must be a positive integer");
  const double believed =
      (*direction == calibration::Direction::kCcw ? 1.0 : -1.0) * 2.0 * M_PI * args.turns;
  std::vector<calibration::CvraResult> results;
  for (double h : args.heading_deg) {
    results.push_back(ref == calibration::Reference::kWall
                          ? calibration::TrackFromWall(believed, h * kDegToRad)
                          : calibration::TrackFromCamera(believed, h * kDegToRad));
  }
  nlohmann::json doc = Combine(name, "track_factor", results);
  doc["procedure"] = "track";
  doc["reference"] = args.reference;
  if (args.track_mm != 0.0) {
    PositiveOrFail(name, "--track-mm", args.track_mm);
    doc["track_corrected_mm"] = args.track_mm * doc["track_factor"].get<double>();
  }
  Print(doc, args.json, "track_factor");
}

void RegisterTrack(CLI::App* cvra) {
  auto args = std::make_shared<CvraTrackArgs>();
  CLI::App* cmd = cvra->add_subcommand(
      "track",
      "Track from N in-place turns.\n"
      "  wall:   --heading-deg is the odometry heading when pushed back against the wall\n"
      "  camera: --heading-deg is the camera's true - odometry heading at the end");
  cmd->add_option("--reference", args->reference, "wall or camera")->required();
  cmd->add_option("--turns", args->turns, "Number of full turns N")->required();
  cmd->add_option("--direction", args->direction, "ccw (default) or cw");
  cmd->add_option("--heading-deg", args->heading_deg, "One run's heading [deg]; repeatable")
      ->required();
  cmd->add_option("--track-mm", args->track_mm, "Track the robot used [mm], to print the new one");
  cmd->add_flag("--json", args->json, "Print one JSON object");
  cmd->callback([args]() { RunCvraTrack(*args); });
}

}  // namespace

void RegisterCvraCommand(CLI::App& app) {
  CLI::App* cvra = app.add_subcommand(
      "cvra", "CVRA calibration procedures (wheel ratio, scale, track) from raw numbers");
  cvra->require_subcommand(1);
  RegisterRatio(cvra);
  RegisterScale(cvra);
  RegisterTrack(cvra);
}

}  // namespace odocal::app
