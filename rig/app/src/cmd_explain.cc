// odocal explain SESSION --out DIR
//
// Where the fitted model and the camera disagree, which missing effect
// explains it (calibration/explain.h), written as DIR/explain.json and a
// self-contained DIR/explain.html with the residuals before and after.
//
// SESSION is a session file (session.yaml: videos measured by the camera
// pipeline, telemetry beside them), or an `odocal simulate --out` directory
// seen through the stand-in camera of simulation/stand_in_camera.h (fast, for
// experiments). It never reads the scenario's effects or truth.json's truth.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <sstream>

#include <nlohmann/json.hpp>

#include "cli_util.h"
#include "commands.h"
#include "record_util.h"
#include "odocal/base/units.h"
#include "odocal/records/digest.h"
#include "odocal/calibration/explain.h"
#include "odocal/config/files.h"
#include "odocal/config/session.h"
#include "odocal/measure/measure.h"
#include "odocal/report/explain_report.h"
#include "odocal/report/json.h"
#include "odocal/simulation/stand_in_camera.h"

namespace odocal::app {
namespace {

std::optional<calibration::MeasuredSession> WithTelemetryOrFail(const std::string& path,
                                                               calibration::MeasuredSession out,
                                                               std::string* error);

// A session file measured by the camera pipeline, with the camera geometry
// the lens candidate needs: the camera's pose over the tag plane (as the
// pipeline estimated it from the videos) and its calibrated lens.
// `k1_correction` is added to the calibrated k1 (the camera refit after a
// lens error was found).
std::optional<calibration::MeasuredSession> MeasureSessionForExplain(const std::string& path,
                                                                    double k1_correction,
                                                                    std::string* error) {
  Result<config::Session> session = config::LoadSession(path);
  if (!session) {
    *error = session.message;
    return std::nullopt;
  }
  if (session->has_camera) session->intrinsics.distortion[0] += k1_correction;
  const auto measured = measure::MeasureSessions({*session}, measure::MeasureOptions{}, TerminalProgressBar("measuring"));
  if (!measured) {
    *error = measured.message;
    return std::nullopt;
  }
  const measure::SessionMeasurement& sm = measured->front();
  calibration::MeasuredSession out = sm.ToMeasuredSession();
  // A session of pose logs has no camera: no lens candidate to weigh.
  if (session->has_camera) out.camera = measure::FloorCameraOf(sm);
  return WithTelemetryOrFail(path, std::move(out), error);
}

// Only runs with telemetry inform the trajectory fit.
std::optional<calibration::MeasuredSession> WithTelemetryOrFail(const std::string& path,
                                                               calibration::MeasuredSession out,
                                                               std::string* error) {
  int with_telemetry = 0;
  for (const auto& run : out.runs) with_telemetry += run.telemetry.empty() ? 0 : 1;
  if (with_telemetry == 0) {
    if (error) *error = path + ": no run has telemetry (runs[].telemetry); explain needs the ticks";
    return std::nullopt;
  }
  return out;
}

}  // namespace

struct ExplainArgs {
  std::string session;
  std::string out;
  double sigma_mm = 1.0;
  double sigma_deg = 0.3;
  double fps = 30.0;
  std::uint64_t seed = 1;
  double home_radius_mm = 0.0;
  std::string camera_centre_mm = "1000,0";
  double camera_height_mm = 2500.0;
  int threads = 0;
  RecordArgs record;
};

// Who, when and what content: a session file's (config::SessionFiles), or a simulate folder's
// files with the stand-in camera's settings (another seed is another measurement).
RunIdentity ExplainIdentity(const ExplainArgs& args) {
  RunIdentity run;
  run.kind = records::RunKind::kExplain;
  run.folder = args.out;
  std::vector<std::string> files;
  std::string label = "explain";
  if (std::filesystem::is_directory(args.session)) {
    for (const auto& e : std::filesystem::directory_iterator(args.session))
      if (e.is_regular_file()) files.push_back(e.path().string());
    std::sort(files.begin(), files.end());
    label += " stand-in " + std::to_string(args.sigma_mm) + " " + std::to_string(args.sigma_deg) + " " +
             std::to_string(args.fps) + " " + std::to_string(args.seed) + " " + std::to_string(args.home_radius_mm) +
             " " + args.camera_centre_mm + " " + std::to_string(args.camera_height_mm);
  } else if (const Result<config::Session> session = config::LoadSession(args.session)) {
    files = config::SessionFiles(*session);
    run.robot = session->robot_id;
    run.time_utc = session->recorded_utc;
    run.odometer_km = session->odometer_km;
  }
  const Result<std::string> digest = records::DigestFiles(label, files);
  if (!digest) Fail("explain", kExitBadInput, digest.message);
  run.digest = *digest;
  return run;
}

void RunExplain(const ExplainArgs& args) {
  simulation::StandInCameraOptions camera;
  camera.sigma_position_m = args.sigma_mm * kMmToM;
  camera.sigma_heading_rad = DegToRad(args.sigma_deg);
  camera.fps = args.fps;
  camera.seed = args.seed;
  if (args.home_radius_mm != 0.0) camera.home_radius_m = args.home_radius_mm * kMmToM;
  const auto centre = ParseNumberList(args.camera_centre_mm);
  if (!centre || centre->size() != 2)
    Fail("explain", kExitBadInput, "--camera-centre-mm: expected X,Y in millimetres");
  camera.camera = calibration::FloorCamera::Overhead(
      Eigen::Vector2d((*centre)[0] * kMmToM, (*centre)[1] * kMmToM), args.camera_height_mm * kMmToM);
  std::string error;
  if (!camera.IsValid(&error)) Fail("explain", kExitBadInput, error);
  std::optional<calibration::MeasuredSession> session;
  nlohmann::json input;
  if (std::filesystem::is_directory(args.session)) {
    Result<calibration::MeasuredSession> loaded = simulation::LoadSimulatedSession(args.session, camera);
    if (!loaded) Fail("explain", kExitBadInput, loaded.message);
    session = std::move(loaded.value);
    input = {{"session", args.session},
             {"camera", "stand-in: simulated true trajectory + seeded noise (not the camera "
                        "pipeline)"},
             {"camera_sigma_mm", args.sigma_mm},
             {"fps", args.fps},
             {"seed", args.seed}};
  } else {
    session = MeasureSessionForExplain(args.session, 0.0, &error);
    if (!session) Fail("explain", kExitBadInput, error);
    input = {{"session", args.session},
             {"camera", session->camera ? "camera pipeline (videos measured)"
                                        : "pose logs (tracker; no camera)"}};
  }
  calibration::ExplainOptions explain_options;
  explain_options.threads = args.threads;
  const calibration::ExplainResult result = calibration::Explain(*session, explain_options);
  if (!result.ok()) Fail("explain", kExitFailure, result.message);
  std::fputs(result.BriefReport().c_str(), stdout);
  nlohmann::json j = report::ExplainJson(*session, result);
  j["input"] = input;
  // A lens error found in videos is a camera-model error: correct k1,
  // measure the videos again (the plane estimate absorbed part of the
  // error, chiefly the camera height, i.e. every distance) and explain again.
  const std::vector<std::string> added = result.EffectsAdded();
  if (!std::filesystem::is_directory(args.session) &&
      std::find(added.begin(), added.end(), "lens_distortion") != added.end()) {
    const double dk1 = result.final_fit.effects.k1_delta();
    std::printf("camera refit: k1 %+.5f, measuring the videos again\n", dk1);
    const auto remeasured = MeasureSessionForExplain(args.session, dk1, &error);
    if (!remeasured) Fail("explain", kExitFailure, "camera refit: " + error);
    const calibration::ExplainResult refit = calibration::Explain(*remeasured, explain_options);
    if (!refit.ok()) Fail("explain", kExitFailure, "camera refit: " + refit.message);
    j["camera_refit"] = report::CameraRefitJson(dk1, *remeasured, refit);
    std::printf("camera refit (k1 corrected by %+.5f):\n", dk1);
    std::fputs(refit.BriefReport().c_str(), stdout);
  }
  if (const Status e = config::EnsureDirectory(args.out); !e) Fail("explain", kExitFailure, e.message);
  if (const Status e = config::WriteFileAtomically(args.out + "/explain.json", j.dump(2) + "\n"); !e)
    Fail("explain", kExitFailure, e.message);
  if (const Status e = config::WriteFileAtomically(args.out + "/explain.html", report::ExplainHtml(*session, result));
      !e)
    Fail("explain", kExitFailure, e.message);
  std::printf("wrote %s/explain.json and explain.html\n", args.out.c_str());
  KeepRecord("explain", j, ExplainIdentity(args), args.record, {});
}

void RegisterExplainCommand(CLI::App& app) {
  auto args = std::make_shared<ExplainArgs>();
  CLI::App* cmd = app.add_subcommand(
      "explain", "Fit the whole trajectory, find the effect the model misses, refit, report");
  cmd->add_option("session", args->session,
                  "Session file (session.yaml), or an `odocal simulate --out` directory (stand-in camera)")
      ->required();
  cmd->add_option("--out", args->out, "Output directory (created)")->required();
  cmd->add_option("--camera-sigma-mm", args->sigma_mm, "Stand-in camera: position noise per frame")
      ->capture_default_str();
  cmd->add_option("--camera-sigma-deg", args->sigma_deg, "Stand-in camera: heading noise per frame")
      ->capture_default_str();
  cmd->add_option("--fps", args->fps, "Stand-in camera: frame rate")->capture_default_str();
  cmd->add_option("--seed", args->seed, "Stand-in camera: noise seed")->capture_default_str();
  cmd->add_option("--home-radius-mm", args->home_radius_mm,
                  "Stand-in camera: sees only within this radius of the origin (0: everywhere)")
      ->capture_default_str();
  cmd->add_option("--camera-centre-mm", args->camera_centre_mm,
                  "Floor point under the optical axis, X,Y")
      ->capture_default_str();
  cmd->add_option("--camera-height-mm", args->camera_height_mm, "Camera height above the floor")
      ->capture_default_str();
  cmd->add_option("--threads", args->threads,
                  "Worker threads for the candidates' fits, the cross-validation and the jackknife (0: one per "
                  "core); the result is the same whatever the number")
      ->check(CLI::Range(0, kMaxCount))
      ->capture_default_str();
  AddRecordOptions(cmd, &args->record, /*with_limits=*/false);
  cmd->callback([args]() { RunExplain(*args); });
}

}  // namespace odocal::app
