// odocal batch SESSION.yaml... --out DIR     every run of every session -> report.json
// odocal measure VIDEO --session S.yaml       the runs of one video and their return errors
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <map>
#include <memory>

#include <nlohmann/json.hpp>

#include "cli_util.h"
#include "commands.h"
#include "odocal/base/units.h"
#include "odocal/calibration/corrections.h"
#include "odocal/calibration/cvra.h"
#include "odocal/calibration/statistics.h"
#include "odocal/calibration/trajectory_fit.h"
#include "odocal/calibration/umbmark.h"
#include "odocal/config/files.h"
#include "odocal/config/session.h"
#include "odocal/measure/measure.h"
#include "odocal/report/exports.h"
#include "odocal/report/html_report.h"
#include "odocal/report/json.h"
#include "odocal/report/measurement_json.h"

namespace odocal::app {
namespace {


bool Usable(const calibration::MeasuredRun& m) { return measure::UsableReturnError(m) != nullptr; }

nlohmann::json PlaneJson(const measure::SessionMeasurement& sm) {
  if (!sm.session.has_camera) return nullptr;  // pose logs only: no camera to place
  if (!sm.plane_estimated) return {{"estimated", false}, {"message", sm.plane.message}};
  const vision::CameraPlaneResult& p = sm.plane;
  return {{"estimated", true},
          {"roll_deg", p.mount.roll_deg},
          {"pitch_deg", p.mount.pitch_deg},
          {"height_mm", p.mount.height_mm},
          {"sigma", {{"roll_deg", p.sigma_roll_deg}, {"pitch_deg", p.sigma_pitch_deg},
                     {"height_mm", p.sigma_height_mm}}},
          {"views", p.views_used},
          {"rms_reprojection_px", p.rms_reprojection_px}};
}

// Combines per-run CVRA results into {key, sigma_key, n, runs}.
nlohmann::json CombineCvra(const std::string& key, const std::vector<double>& values,
                           const std::vector<std::string>& names) {
  const std::optional<double> se = calibration::StandardError(values);
  return {{key, calibration::Mean(values)},
          {"sigma_" + key, se ? nlohmann::json(*se) : nlohmann::json(nullptr)},
          {"n", values.size()},
          {"runs", names}};
}

// The robot's own belief of where the run ended, in its start frame, from the
// odometry it reported (identity without telemetry, or when it reported
// none). A real robot's controller stops within a tolerance of the planned
// end (the OptiOdom robot: ~5 mm and 1-2 deg short of closing its squares),
// so a return error is true - this belief, not true - plan (UMBMark's
// epsilon = x_abs - x_calc); the CVRA estimators need the true displacement
// itself, the return error plus this belief.
calibration::Pose2 OdometryEnd(const calibration::MeasuredRun& m) {
  if (m.telemetry.size() < 2) return calibration::Pose2::Identity();
  return m.telemetry.front().odometry.inverse() * m.telemetry.back().odometry;
}

struct Estimates {
  nlohmann::json umbmark;  // null when no UMBMark
  nlohmann::json cvra = nlohmann::json::object();
  std::optional<calibration::UmbmarkSummary> umbmark_summary;
  std::optional<double> cvra_ratio, cvra_scale, cvra_track;
  std::vector<std::string> notes;
};

Estimates Estimate(const std::vector<measure::SessionMeasurement>& sessions) {
  Estimates e;
  const calibration::WheelParams& nominal = sessions.front().session.nominal;
  calibration::UmbmarkInput input;
  input.track_m = nominal.track_m;
  std::vector<double> ratios, scales, tracks;
  std::vector<std::string> ratio_runs, scale_runs, track_runs;
  for (const measure::SessionMeasurement& sm : sessions) {
    for (const measure::RunMeasurement& rm : sm.runs) {
      const calibration::MeasuredRun& m = rm.measured;
      if (!Usable(m)) continue;
      // true - odometry in the start frame, and the true displacement.
      const calibration::Pose2& error = m.return_error->pose;
      const double ex = error.x(), ey = error.y(), eh = error.heading();
      const calibration::Pose2 odometry = OdometryEnd(m);
      const calibration::Pose2 p = calibration::Pose2::FromXYHeading(
          ex + odometry.x(), ey + odometry.y(), calibration::WrapAngle(eh + odometry.heading()));
      const calibration::RunSpec& spec = m.spec;
      switch (spec.procedure) {
        case calibration::Procedure::kUmbmark: {
          std::string why;
          if (!input.AddRun(spec, error, &why))
            e.notes.push_back(m.name + ": square of another side, not pooled");
          break;
        }
        case calibration::Procedure::kOutAndBack: {
          if (spec.reference == calibration::Reference::kWall) {
            e.notes.push_back(m.name + ": wall-referenced; the camera cannot see the wall's correction");
            break;
          }
          const double travel = 2.0 * spec.distance_m * spec.repeats;
          const calibration::CvraResult r =
              calibration::WheelRatioFromCamera(travel, eh, nominal.track_m);
          if (r.ok()) {
            ratios.push_back(r.value);
            ratio_runs.push_back(m.name);
          }
          break;
        }
        case calibration::Procedure::kStraight: {
          const calibration::CvraResult r =
              calibration::ScaleFromStraight(m.telemetry.size() < 2 ? spec.distance_m : odometry.x(),
                                             p.x(), p.y(), p.heading());
          if (r.ok()) {
            scales.push_back(r.value);
            scale_runs.push_back(m.name);
          }
          break;
        }
        case calibration::Procedure::kSpin: {
          const double planned =
              (spec.direction == calibration::Direction::kCcw ? 1.0 : -1.0) * 2.0 * M_PI * spec.turns;
          // What odometry turned: the plan, corrected by where it stopped.
          const double believed = planned + calibration::WrapAngle(odometry.heading() - planned);
          const calibration::CvraResult r = calibration::TrackFromCamera(believed, eh);
          if (r.ok()) {
            tracks.push_back(r.value);
            track_runs.push_back(m.name);
          }
          break;
        }
        case calibration::Procedure::kRecorded:
        case calibration::Procedure::kCircle:
          // No closed-form UMBMark/CVRA model of these paths: such runs serve
          // the trajectory fit (explain) and the report only.
          break;
      }
    }
  }
  if (!input.cw.empty() || !input.ccw.empty()) {
    // Unequal counts (a flagged run dropped): pair the first n of each.
    const size_t n = std::min(input.cw.size(), input.ccw.size());
    if (input.cw.size() != input.ccw.size()) {
      e.notes.push_back("umbmark: " + std::to_string(input.cw.size()) + " cw and " +
                        std::to_string(input.ccw.size()) + " ccw usable runs; using " +
                        std::to_string(n) + " of each");
      input.cw.resize(n);
      input.ccw.resize(n);
    }
    if (n > 0) {
      const calibration::UmbmarkSummary s = calibration::EstimateUmbmark(input);
      if (s.ok()) {
        e.umbmark = report::UmbmarkJson(input, s);
        e.umbmark_summary = s;
      } else {
        e.notes.push_back("umbmark: " + s.message);
      }
    }
  }
  if (!ratios.empty()) {
    e.cvra["ratio"] = CombineCvra("Ed", ratios, ratio_runs);
    e.cvra_ratio = calibration::Mean(ratios);
  }
  if (!scales.empty()) {
    e.cvra["scale"] = CombineCvra("scale", scales, scale_runs);
    e.cvra_scale = calibration::Mean(scales);
  }
  if (!tracks.empty()) {
    e.cvra["track"] = CombineCvra("track_factor", tracks, track_runs);
    e.cvra_track = calibration::Mean(tracks);
  }
  return e;
}

// UMBMark, when present, sets the ratio and the track (it measures both on
// the same squares); CVRA's scale always applies; CVRA's ratio and track fill
// in without UMBMark.
calibration::WheelParams Corrected(const calibration::WheelParams& nominal, const Estimates& e) {
  if (e.umbmark_summary) {
    calibration::WheelParams p = calibration::ApplyUmbmarkCorrection(
        nominal, e.umbmark_summary->coupled.Ed, e.umbmark_summary->coupled.Eb);
    return calibration::ApplyCvra(p, std::nullopt, e.cvra_scale, std::nullopt);
  }
  return calibration::ApplyCvra(nominal, e.cvra_ratio, e.cvra_scale, e.cvra_track);
}

// The full-trajectory least squares (trajectory_fit.h, base model: both
// wheels' travel per tick and the track) over every run with telemetry and
// measured poses. Unlike UMBMark it uses every frame and measures the
// distance scale Es as well, which a pose source with true lengths (motion
// capture, a camera with a length reference) supports. Sessions recorded
// with different believed parameters are not pooled.
std::optional<calibration::TrajectoryFitResult> FitTrajectories(
    const std::vector<measure::SessionMeasurement>& sessions, std::vector<std::string>* notes) {
  calibration::MeasuredSession pooled;
  bool first = true;
  for (const measure::SessionMeasurement& sm : sessions) {
    calibration::MeasuredSession ms = sm.ToMeasuredSession();
    if (first) {
      pooled.believed = ms.believed;
      pooled.camera_scale_sigma = ms.camera_scale_sigma;
      first = false;
    } else if (std::abs(ms.believed.left_wheel_diameter_m - pooled.believed.left_wheel_diameter_m) > 1e-12 ||
               std::abs(ms.believed.right_wheel_diameter_m - pooled.believed.right_wheel_diameter_m) > 1e-12 ||
               std::abs(ms.believed.track_m - pooled.believed.track_m) > 1e-12 ||
               std::abs(ms.believed.ticks_per_rev - pooled.believed.ticks_per_rev) > 1e-9) {
      notes->push_back("trajectory_fit: " + sm.session.path +
                       " was recorded with other believed parameters; fitted without it");
      continue;
    }
    pooled.camera_scale_sigma = std::max(pooled.camera_scale_sigma, ms.camera_scale_sigma);
    for (calibration::MeasuredRun& run : ms.runs)
      if (!run.telemetry.empty()) pooled.runs.push_back(std::move(run));
  }
  if (pooled.runs.empty()) return std::nullopt;  // no telemetry: nothing to fit
  // The pose source's clock offset against the robot's is fitted with the
  // parameters: a real pose source has one (the OptiOdom rows' poses lead
  // their ticks by up to ~56 ms), and left out the scales absorb what they
  // can of it (the track of the OptiOdom Ivanjko paths moved by 0.1-0.3 %
  // when it was fitted; the squares' by < 0.01 %). Fitting a zero offset
  // costs a little variance.
  calibration::TrajectoryFitOptions options;
  options.effects = {calibration::Effect::kCameraLatency};
  calibration::TrajectoryFitResult fit = calibration::FitTrajectory(pooled, options);
  if (!fit.ok()) {
    notes->push_back("trajectory_fit: " + fit.message);
    return std::nullopt;
  }
  return fit;
}

nlohmann::json TrajectoryFitJson(const calibration::WheelParams& nominal,
                                 const calibration::TrajectoryFitResult& fit) {
  nlohmann::json j = {{"method", "full-trajectory least squares (base model)"},
                      {"frames", fit.n_frames},
                      {"gap_mm", fit.gap_m * 1e3},
                      {"noise_floor_mm", fit.noise_floor_m * 1e3},
                      {"unidentifiable", fit.unidentifiable}};
  int runs_used = 0;
  for (bool used : fit.run_used) runs_used += used ? 1 : 0;
  j["runs_used"] = runs_used;
  // camera_latency: a frame stamped s shows the robot at telemetry time s + latency.
  if (const calibration::ParameterEstimate* p = fit.Find("camera_latency.latency_s")) {
    j["clock_offset_ms"] = {{"value", p->value * 1e3},
                            {"sigma", p->identifiable ? nlohmann::json(p->sigma * 1e3) : nlohmann::json(nullptr)},
                            {"meaning", "a pose stamped s shows the robot at telemetry time s + offset"}};
  }
  bool all_identifiable = true;
  for (const char* key : {"Ed", "Es", "Eb", "turn_gain"}) {
    const calibration::ParameterEstimate* p = fit.Find(key);
    if (!p) continue;
    if (!p->identifiable) all_identifiable = false;
    j[key] = {{"value", p->value},
              {"sigma", p->identifiable ? nlohmann::json(p->sigma) : nlohmann::json(nullptr)},
              {"identifiable", p->identifiable}};
  }
  if (all_identifiable) {
    const calibration::WheelParams corrected = calibration::ApplyWheelScales(nominal, fit.scales);
    j["corrected"] = report::WheelParamsJson(corrected);
    j["ros2"] = report::Ros2Json(calibration::Ros2MultipliersFrom(nominal, corrected));
  }
  return j;
}

std::vector<config::Session> LoadSessionsOrFail(const std::string& command,
                                        const std::vector<std::string>& paths) {
  std::vector<config::Session> sessions;
  for (const std::string& path : paths) {
    std::string error;
    const std::optional<config::Session> s = config::LoadSession(path, &error);
    if (!s) Fail(command, kExitBadInput, error);
    sessions.push_back(*s);
  }
  return sessions;
}

void PrintRuns(const std::vector<measure::SessionMeasurement>& measured) {
  std::printf("  %-22s %22s %22s %20s  %s\n", "run", "x [mm]", "y [mm]", "theta [deg]", "flags");
  for (const measure::SessionMeasurement& sm : measured) {
    for (const measure::RunMeasurement& rm : sm.runs) {
      const nlohmann::json j = report::RunJson(rm);
      std::string flags;
      for (const auto& f : j["flags"]) flags += (flags.empty() ? "" : ", ") + f.get<std::string>();
      if (j["return_error"].is_null()) {
        std::printf("  %-22s %22s %22s %20s  %s\n", rm.measured.name.c_str(), "-", "-", "-",
                    flags.empty() ? "no measurement" : flags.c_str());
        continue;
      }
      char x[40], y[40], t[40];
      std::snprintf(x, sizeof(x), "%.3f +/- %.3f", j["return_error"]["x_mm"].get<double>(),
                    j["sigma"]["x_mm"].get<double>());
      std::snprintf(y, sizeof(y), "%.3f +/- %.3f", j["return_error"]["y_mm"].get<double>(),
                    j["sigma"]["y_mm"].get<double>());
      std::snprintf(t, sizeof(t), "%.4f +/- %.4f", j["return_error"]["theta_deg"].get<double>(),
                    j["sigma"]["theta_deg"].get<double>());
      std::printf("  %-22s %22s %22s %20s  %s\n", rm.measured.name.c_str(), x, y, t,
                  flags.empty() ? "ok" : flags.c_str());
    }
  }
}

int CountUsable(const std::vector<measure::SessionMeasurement>& measured) {
  int usable = 0;
  for (const measure::SessionMeasurement& sm : measured)
    for (const measure::RunMeasurement& rm : sm.runs) usable += Usable(rm.measured) ? 1 : 0;
  return usable;
}

}  // namespace

void RegisterBatchCommand(CLI::App& app) {
  struct Args {
    std::vector<std::string> sessions;
    std::string out;
    int threads = 0;
    report::ExportRequests exports;
    std::string estimator = "umbmark";
  };
  auto args = std::make_shared<Args>();
  CLI::App* cmd = app.add_subcommand(
      "batch", "Measure every run of recorded sessions from their videos; write DIR/report.json");
  cmd->add_option("sessions", args->sessions, "Session files (session.yaml)")->required();
  cmd->add_option("--out", args->out, "Output directory (created)")->required();
  cmd->add_option("--threads", args->threads, "Worker threads (default: one per core)");
  AddExportOption(cmd, &args->exports);
  cmd->add_option("--estimator", args->estimator,
                  "What --export writes: umbmark (UMBMark and CVRA from the return errors; the "
                  "distance scale only from straights) or trajectory (the full-trajectory fit: "
                  "every frame, distance scale included; for pose sources with true lengths)")
      ->check(CLI::IsMember({"umbmark", "trajectory"}));
  cmd->callback([args]() {
    const std::string name = "batch";
    if (auto e = report::CheckExports(args->exports)) Fail(name, kExitBadInput, *e);
    const std::vector<config::Session> sessions = LoadSessionsOrFail(name, args->sessions);
    measure::MeasureOptions options;
    options.threads = args->threads;
    std::string error;
    const auto measured = measure::MeasureSessions(sessions, options, TerminalProgressBar("measuring"), &error);
    // A malformed pose log (or its telemetry) is the one way measuring fails.
    if (!measured) Fail(name, kExitBadInput, error);
    if (auto e = config::EnsureDirectory(args->out)) Fail(name, kExitFailure, *e);

    nlohmann::json report = {{"command", "batch"},
                             {"sessions", nlohmann::json::array()},
                             {"runs", nlohmann::json::array()},
                             {"trajectories", nlohmann::json::array()}};
    for (const measure::SessionMeasurement& sm : *measured) {
      report["sessions"].push_back(
          {{"session", sm.session.path}, {"camera_plane", PlaneJson(sm)}, {"flags", sm.flags}});
      for (const measure::RunMeasurement& rm : sm.runs) {
        nlohmann::json j = report::RunJson(rm);
        j["session"] = sm.session.path;
        report["runs"].push_back(j);
        report["trajectories"].push_back(report::TrajectoryJson(rm));
      }
    }
    const Estimates estimates = Estimate(*measured);
    if (!estimates.umbmark.is_null()) report["umbmark"] = estimates.umbmark;
    if (!estimates.cvra.empty()) report["cvra"] = estimates.cvra;
    const calibration::WheelParams& nominal = sessions.front().nominal;
    const bool any_estimate = estimates.umbmark_summary || estimates.cvra_ratio ||
                              estimates.cvra_scale || estimates.cvra_track;
    std::optional<calibration::WheelParams> corrected;
    if (any_estimate) {
      corrected = Corrected(nominal, estimates);
      report["corrected"] = report::WheelParamsJson(*corrected);
      report["ros2"] = report::Ros2Json(calibration::Ros2MultipliersFrom(nominal, *corrected));
    }
    std::vector<std::string> notes = estimates.notes;
    const std::optional<calibration::TrajectoryFitResult> fit = FitTrajectories(*measured, &notes);
    if (fit) report["trajectory_fit"] = TrajectoryFitJson(nominal, *fit);
    if (args->estimator == "trajectory") {
      if (!fit || !report["trajectory_fit"].contains("corrected"))
        Fail(name, kExitFailure,
             "--estimator trajectory: no trajectory fit with Ed, Es and Eb determined (the runs "
             "need telemetry and measured poses; see report notes)");
      corrected = calibration::ApplyWheelScales(nominal, fit->scales);
      report["corrected"] = report::WheelParamsJson(*corrected);
      report["ros2"] = report::Ros2Json(calibration::Ros2MultipliersFrom(nominal, *corrected));
    }
    if (corrected) report["corrected_from"] = args->estimator;
    report["notes"] = notes;
    const int usable = CountUsable(*measured);
    report["quality"] = {{"runs", report["runs"].size()}, {"runs_measured", usable}};
    if (auto e = config::WriteFileAtomically(args->out + "/report.json", report.dump(2) + "\n"))
      Fail(name, kExitFailure, *e);
    if (auto e = report::WriteReportHtml(report, "odocal batch", args->out + "/report.html"))
      Fail(name, kExitFailure, *e);
    if (auto e = report::WriteExports(args->exports, nominal, corrected)) Fail(name, kExitFailure, *e);

    PrintRuns(*measured);
    if (estimates.umbmark_summary) std::printf("\n%s\n", estimates.umbmark_summary->BriefReport().c_str());
    if (fit) std::printf("\n%s", fit->BriefReport().c_str());
    for (const std::string& note : notes) std::printf("note: %s\n", note.c_str());
    std::printf("report: %s/report.json, %s/report.html\n", args->out.c_str(), args->out.c_str());
    if (usable == 0) Fail(name, kExitFailure, "no run could be measured (see the flags above)");
  });
}

void RegisterMeasureCommand(CLI::App& app) {
  struct Args {
    std::string video;
    std::string session;
    bool json = false;
  };
  auto args = std::make_shared<Args>();
  CLI::App* cmd = app.add_subcommand(
      "measure", "Measure the runs of one video of a session: return errors with sigma and flags");
  cmd->add_option("video", args->video, "Video file (one of the session's)")->required();
  cmd->add_option("--session", args->session, "Session file (session.yaml)")->required();
  cmd->add_flag("--json", args->json, "Print one JSON object");
  cmd->callback([args]() {
    const std::string name = "measure";
    config::Session session = LoadSessionsOrFail(name, {args->session}).front();
    namespace fs = std::filesystem;
    if (!fs::exists(args->video)) Fail(name, kExitBadInput, args->video + ": no such file");
    std::vector<config::SessionRun> runs;
    for (const config::SessionRun& run : session.runs) {
      if (!run.video.empty() && fs::equivalent(run.video, args->video)) runs.push_back(run);
    }
    if (runs.empty())
      Fail(name, kExitBadInput, args->video + " is not a run of " + args->session +
                                    " (list it under runs: with its procedure and time span)");
    session.runs = runs;
    std::string error;
    const auto measured = measure::MeasureSessions({session}, measure::MeasureOptions{}, TerminalProgressBar("measuring"), &error);
    // A malformed pose log (or its telemetry) is the one way measuring fails.
    if (!measured) Fail(name, kExitBadInput, error);
    if (args->json) {
      nlohmann::json j = {{"video", args->video}, {"camera_plane", PlaneJson(measured->front())},
                          {"runs", nlohmann::json::array()}};
      for (const measure::RunMeasurement& rm : measured->front().runs) j["runs"].push_back(report::RunJson(rm));
      std::cout << j.dump(2) << std::endl;
    } else {
      PrintRuns(*measured);
    }
    if (CountUsable(*measured) == 0)
      Fail(name, kExitFailure, "no run could be measured (see the flags above)");
  });
}

}  // namespace odocal::app
