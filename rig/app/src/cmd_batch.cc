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
#include "fleet_batch.h"
#include "record_util.h"
#include "odocal/base/units.h"
#include "odocal/calibration/corrections.h"
#include "odocal/calibration/trajectory_fit.h"
#include "odocal/config/files.h"
#include "odocal/config/session.h"
#include "odocal/measure/estimate_session.h"
#include "odocal/measure/estimator_choice.h"
#include "odocal/measure/measure.h"
#include "odocal/report/exports.h"
#include "odocal/report/html_report.h"
#include "odocal/report/json.h"
#include "odocal/report/measurement_json.h"
#include "odocal/report/session_estimate_json.h"
#include "odocal/records/digest.h"

namespace odocal::app {
namespace {

std::vector<config::Session> LoadSessionsOrFail(const std::string& command,
                                        const std::vector<std::string>& paths) {
  std::vector<config::Session> sessions;
  for (const std::string& path : paths) {
    const auto s = config::LoadSession(path);
    if (!s) Fail(command, kExitBadInput, s.message);
    sessions.push_back(*s);
  }
  return sessions;
}

void PrintRuns(const std::vector<measure::SessionMeasurement>& measured) {
  std::printf("  %-22s %22s %22s %20s  %s\n", "run", "x [mm]", "y [mm]", "theta [deg]", "flags");
  for (const measure::SessionMeasurement& sm : measured) {
    for (const measure::RunMeasurement& rm : sm.runs) {
      std::string flags;
      for (const calibration::RunFlag& f : rm.measured.flags) flags += (flags.empty() ? "" : ", ") + f.ToString();
      const calibration::RelativePose* r = measure::UsableReturnError(rm.measured);
      if (!r) {
        std::printf("  %-22s %22s %22s %20s  %s\n", rm.measured.name.c_str(), "-", "-", "-",
                    flags.empty() ? "no measurement" : flags.c_str());
        continue;
      }
      char x[40], y[40], t[40];
      std::snprintf(x, sizeof(x), "%.3f +/- %.3f", r->pose.x() * kMToMm, r->sigma_x_m() * kMToMm);
      std::snprintf(y, sizeof(y), "%.3f +/- %.3f", r->pose.y() * kMToMm, r->sigma_y_m() * kMToMm);
      std::snprintf(t, sizeof(t), "%.4f +/- %.4f", r->pose.heading() * kRadToDeg,
                    r->sigma_heading_rad() * kRadToDeg);
      std::printf("  %-22s %22s %22s %20s  %s\n", rm.measured.name.c_str(), x, y, t,
                  flags.empty() ? "ok" : flags.c_str());
    }
  }
}

}  // namespace

namespace {

struct BatchArgs {
  std::vector<std::string> sessions;
  std::string out;
  int threads = 0;
  report::ExportRequests exports;
  std::string estimator = "auto";
  int edge_shift_views = measure::MeasureOptions{}.edge_shift_views;
  RecordArgs record;
  std::string list;
  std::string shard;
  bool each = false;
};

// The report's measurements: each session's camera plane and scale, its
// runs and their trajectories.
nlohmann::json BatchMeasuredJson(const std::vector<measure::SessionMeasurement>& measured) {
  nlohmann::json report = {{"command", "batch"},
                           {"sessions", nlohmann::json::array()},
                           {"runs", nlohmann::json::array()},
                           {"trajectories", nlohmann::json::array()}};
  for (const measure::SessionMeasurement& sm : measured) {
    report["sessions"].push_back({{"session", sm.session.path},
                                  {"camera_plane", report::PlaneJson(sm)},
                                  {"camera_scale", report::CameraScaleJson(sm)},
                                  {"flags", measure::ToStrings(sm.flags)}});
    if (!sm.segments.empty()) {
      nlohmann::json found = nlohmann::json::array();
      for (const measure::SegmentAssignment& a : sm.segments)
        found.push_back({{"run", a.run}, {"source", a.source}, {"start_s", a.begin_s}, {"end_s", a.end_s},
                         {"found", a.found}, {"procedure_seen", a.procedure_seen}});
      report["sessions"].back()["segmented_runs"] = found;
    }
    for (const measure::RunMeasurement& rm : sm.runs) {
      nlohmann::json j = report::RunJson(rm);
      j["session"] = sm.session.path;
      report["runs"].push_back(j);
      report["trajectories"].push_back(report::TrajectoryJson(rm));
    }
  }
  return report;
}

// The record's identity of this batch: its robot, time, odometer and the
// digest of every input file.
RunIdentity BatchRunIdentity(const std::string& name, const std::string& out, const std::string& robot,
                             const std::vector<config::Session>& sessions) {
  RunIdentity run;
  run.kind = records::RunKind::kBatch;
  run.folder = out;
  run.robot = robot.empty() ? sessions.front().robot_id : robot;
  run.time_utc = sessions.front().recorded_utc;
  run.odometer_km = sessions.front().odometer_km;
  std::vector<std::string> inputs;
  for (const config::Session& session : sessions)
    for (const std::string& f : config::SessionFiles(session)) inputs.push_back(f);
  const Result<std::string> digest = records::DigestFiles("batch", inputs);
  if (!digest) Fail(name, kExitBadInput, digest.message);
  run.digest = *digest;
  return run;
}

// auto's choice: the candidates' held-out errors, the rule's evidence, notes.
void PrintBatchEstimatorChoice(const std::string& estimator, const measure::EstimatorChoice& choice) {
  std::printf("\nestimator: %s (auto). %s\n", estimator.c_str(), choice.why.c_str());
  if (choice.cross_validated) {
    std::printf("  %-12s %36s %10s %26s\n", "candidate", "held-out final error mean [mm]", "max [mm]",
                "(RMS over the path [mm])");
    for (const measure::CandidateScore& c : choice.candidates)
      std::printf("  %-12s %25.2f +/- %6.2f %10.2f %15.2f +/- %6.2f%s\n", measure::ToString(c.estimator),
                  c.mean_m * kMToMm, c.sigma_m * kMToMm, c.max_m * kMToMm, c.rms_mean_m * kMToMm,
                  c.rms_sigma_m * kMToMm, c.estimator == choice.chosen ? "  <- chosen" : "");
    std::printf(
        "  paired run by run, trajectory - umbmark: %.2f +/- %.2f mm; travel scale: trajectory %.5f "
        "+/- %.5f, umbmark %.5f (%.1f sigma apart); decided by: %s\n",
        choice.paired_difference_m * kMToMm, choice.paired_sigma_m * kMToMm, choice.candidates[1].scale,
        choice.candidates[1].scale_sigma, choice.candidates[0].scale, choice.scale.z(),
        measure::ToString(choice.basis));
  }
  for (const std::string& note : choice.notes) std::printf("note: estimator_choice: %s\n", note.c_str());
}

// What batch prints: the segments found, the runs, the camera scales, the
// estimates and auto's choice.
void PrintBatchResults(const std::vector<measure::SessionMeasurement>& measured,
                       const measure::SessionEstimate& estimates,
                       const std::optional<calibration::TrajectoryFitResult>& fit,
                       const std::optional<measure::EstimatorChoice>& choice, const std::string& estimator) {
  for (const measure::SessionMeasurement& sm : measured)
    for (const measure::SegmentAssignment& a : sm.segments)
      std::printf("found %s at %.1f-%.1f s in %s: %s\n", a.run.c_str(), a.begin_s, a.end_s, a.source.c_str(),
                  a.found.c_str());
  PrintRuns(measured);
  for (const measure::SessionMeasurement& sm : measured)
    if (sm.session.has_camera) std::printf("camera scale: %s\n", sm.camera_scale.explanation.c_str());
  if (estimates.umbmark) std::printf("\n%s\n", estimates.umbmark->BriefReport().c_str());
  if (fit) std::printf("\n%s", fit->BriefReport().c_str());
  if (choice) PrintBatchEstimatorChoice(estimator, *choice);
}

// Why `--estimator trajectory` exported nothing.
std::string NothingExported(const std::optional<calibration::TrajectoryFitResult>& fit, const std::string& out) {
  return "--estimator trajectory: nothing exported: " +
         (fit ? "these runs do not determine " +
                    std::string(fit->unidentifiable.empty() ? "Ed, Es and Eb" : fit->unidentifiable.front()) +
                    " (a plan with straights and turns both ways does)"
              : std::string("no trajectory fit (the runs need telemetry and measured poses)")) +
         "; " + out + "/report.json has the runs and the notes";
}

// One calibration from `session_paths` (pooled: the same robot's sessions) into `out`. Fails
// the command (Fail) on bad input or no result; returns 0, or kExitOutsideLimits when the
// record fails the limits.
int BatchOnce(const BatchArgs& args, const std::vector<std::string>& session_paths, const std::string& out,
              const std::string& robot) {
  const std::string name = "batch";
  const records::Limits limits = LimitsOrFail(name, args.record);
  const std::vector<config::Session> sessions = LoadSessionsOrFail(name, session_paths);
  if (const Status e = report::CheckExports(args.exports); !e) Fail(name, kExitBadInput, e.message);
  measure::MeasureOptions options;
  options.threads = args.threads;
  options.edge_shift_views = args.edge_shift_views;
  const auto measured = measure::MeasureSessions(sessions, options, TerminalProgressBar("measuring"));
  // A malformed pose log (or its telemetry) is the one way measuring fails.
  if (!measured) Fail(name, kExitBadInput, measured.message);
  if (const Status e = config::EnsureDirectory(out); !e) Fail(name, kExitFailure, e.message);

  nlohmann::json report = BatchMeasuredJson(*measured);
  const measure::SessionEstimate estimates = measure::EstimateSession(*measured);
  if (estimates.umbmark) report["umbmark"] = report::SessionUmbmarkJson(estimates);
  if (const nlohmann::json cvra = report::CvraJson(estimates); !cvra.empty()) report["cvra"] = cvra;
  const calibration::WheelParams& nominal = sessions.front().nominal;
  std::optional<calibration::WheelParams> corrected;
  if (estimates.any()) {
    corrected = measure::CorrectedParams(nominal, estimates);
    report["corrected"] = report::WheelParamsJson(*corrected);
    report["ros2"] = report::Ros2Json(calibration::Ros2MultipliersFrom(nominal, *corrected));
  }
  std::vector<std::string> notes = estimates.notes;
  std::vector<calibration::RunLeftOut> left_out;  // the jackknife's refits, auto's folds
  const std::optional<calibration::TrajectoryFitResult> fit =
      measure::FitSessionTrajectories(*measured, &notes, &left_out);
  if (fit) report["trajectory_fit"] = report::TrajectoryFitJson(nominal, *fit);
  // auto: the candidate that predicts held-out runs best (estimator_choice.h).
  std::string estimator = args.estimator;
  std::optional<measure::EstimatorChoice> choice;
  if (estimator == "auto") {
    measure::EstimatorChoiceOptions choice_options;
    choice_options.threads = args.threads;
    choice = measure::ChooseEstimator(*measured, fit ? &*fit : nullptr, choice_options, &left_out);
    estimator = measure::ToString(choice->chosen);
    report["estimator_choice"] = report::EstimatorChoiceJson("auto", *choice);
  }
  // Without a fit that determines Ed, Es and Eb there is nothing to export:
  // the report (the runs, UMBMark, the notes saying why) is still written,
  // and the command fails after it.
  const bool trajectory_missing =
      estimator == "trajectory" && (!fit || !report["trajectory_fit"].contains("corrected"));
  if (trajectory_missing) {
    corrected.reset();
    report.erase("corrected");
    report.erase("ros2");
  } else if (estimator == "trajectory") {
    corrected = calibration::ApplyWheelScales(nominal, fit->scales);
    report["corrected"] = report::WheelParamsJson(*corrected);
    report["ros2"] = report::Ros2Json(calibration::Ros2MultipliersFrom(nominal, *corrected));
  }
  if (corrected) report["corrected_from"] = estimator;
  report["notes"] = notes;
  const int usable = measure::CountUsableRuns(*measured);
  report["quality"] = {{"runs", report["runs"].size()}, {"runs_measured", usable}};
  report["nominal"] = report::WheelParamsJson(nominal);
  const RunIdentity run = BatchRunIdentity(name, out, robot, sessions);
  if (!run.robot.empty()) report["robot_id"] = run.robot;
  if (const Status e = config::WriteFileAtomically(out + "/report.json", report.dump(2) + "\n"); !e)
    Fail(name, kExitFailure, e.message);
  if (const Status e = report::WriteReportHtml(report, "odocal batch", out + "/report.html"); !e)
    Fail(name, kExitFailure, e.message);
  if (!trajectory_missing)
    if (const Status e = report::WriteExports(args.exports, nominal, corrected); !e)
      Fail(name, kExitFailure, e.message);
  // A run that measured nothing is not a calibration: no record.
  const records::Record record =
      usable > 0 && !trajectory_missing ? KeepRecord(name, report, run, args.record, limits) : records::Record{};

  PrintBatchResults(*measured, estimates, fit, choice, estimator);
  for (const std::string& note : notes) std::printf("note: %s\n", note.c_str());
  std::printf("report: %s/report.json, %s/report.html\n", out.c_str(), out.c_str());
  if (usable == 0) Fail(name, kExitFailure, "no run could be measured (see the flags above)");
  if (trajectory_missing) Fail(name, kExitFailure, NothingExported(fit, out));
  if (const std::string line = VerdictLine(record, limits); !line.empty()) std::printf("%s\n", line.c_str());
  return record.verdict == records::Verdict::kFail ? kExitOutsideLimits : 0;
}

}  // namespace

void RegisterBatchCommand(CLI::App& app) {
  auto args = std::make_shared<BatchArgs>();
  CLI::App* cmd = app.add_subcommand(
      "batch", "Measure every run of recorded sessions from their videos; write DIR/report.json");
  cmd->add_option("sessions", args->sessions,
                  "Session files (session.yaml), pooled into one calibration; with --each, --list, --shard or a "
                  "directory: one calibration per session");
  cmd->add_option("--out", args->out, "Output directory (created)")->required();
  cmd->add_option("--threads", args->threads, "Worker threads (default: one per core)");
  AddExportOption(cmd, &args->exports);
  cmd->add_option("--estimator", args->estimator,
                  "What --export writes: auto (the default: whichever of the two below predicts "
                  "the session's runs best when each is left out in turn; umbmark when the runs "
                  "cannot tell), umbmark (UMBMark and CVRA from the return errors; the "
                  "distance scale only from straights) or trajectory (the full-trajectory fit: "
                  "every frame, distance scale included; for pose sources with true lengths)")
      ->check(CLI::IsMember({"auto", "umbmark", "trajectory"}));
  cmd->add_option("--edge-shift-views", args->edge_shift_views,
                  "Plane views in which the tag's edge shift (a tone curve, blur or ink that makes its black "
                  "look larger or smaller, hence the camera nearer or farther) is measured and then removed "
                  "from every view; 0: the tag's size as it looks (docs/vision.md)")
      ->check(CLI::Range(0, kMaxCount));
  cmd->add_flag("--each", args->each, "One calibration (folder, record) per session instead of one for all");
  cmd->add_option("--list", args->list,
                  "A file of sessions, one a line (relative to the file), each optionally followed by robot=ID; "
                  "one calibration per session");
  cmd->add_option("--shard", args->shard,
                  "I/N: only the sessions k with k mod N = I (I from 0), for N machines sharing a record store");
  AddRecordOptions(cmd, &args->record, /*with_limits=*/true);
  cmd->callback([args]() {
    const std::string name = "batch";
    // Bad input is refused before any session is measured.
    if (const Status e = report::CheckExports(args->exports); !e) Fail(name, kExitBadInput, e.message);
    LimitsOrFail(name, args->record);
    const std::optional<FleetBatch> fleet = FleetBatchOrFail(name, args->sessions, args->list, args->shard, args->each);
    if (!fleet) {
      if (args->sessions.empty()) Fail(name, kExitBadInput, "give session files, a directory of sessions or --list FILE");
      const int code = BatchOnce(*args, args->sessions, args->out, args->record.robot);
      if (code != 0) throw CLI::RuntimeError(code);
      return;
    }
    const int code = RunFleetBatch(name, *fleet, args->out, [&](const FleetSession& s, const std::string& out) {
      // Each session's exports go into its own folder, under the names given.
      BatchArgs one = *args;
      for (size_t k = 1; k < one.exports.raw.size(); k += 2)
        one.exports.raw[k] = out + "/" + std::filesystem::path(one.exports.raw[k]).filename().string();
      return BatchOnce(one, {s.path}, out, args->record.robot.empty() ? s.robot : args->record.robot);
    });
    if (code != 0) throw CLI::RuntimeError(code);
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
    const auto measured =
        measure::MeasureSessions({session}, measure::MeasureOptions{}, TerminalProgressBar("measuring"));
    // A malformed pose log (or its telemetry) is the one way measuring fails.
    if (!measured) Fail(name, kExitBadInput, measured.message);
    if (args->json) {
      nlohmann::json j = {{"video", args->video}, {"camera_plane", report::PlaneJson(measured->front())},
                          {"runs", nlohmann::json::array()}};
      for (const measure::RunMeasurement& rm : measured->front().runs) j["runs"].push_back(report::RunJson(rm));
      std::cout << j.dump(2) << std::endl;
    } else {
      for (const measure::SessionMeasurement& sm : *measured)
      for (const measure::SegmentAssignment& a : sm.segments)
        std::printf("found %s at %.1f-%.1f s in %s: %s\n", a.run.c_str(), a.begin_s, a.end_s, a.source.c_str(),
                    a.found.c_str());
    PrintRuns(*measured);
    }
    if (measure::CountUsableRuns(*measured) == 0)
      Fail(name, kExitFailure, "no run could be measured (see the flags above)");
  });
}

}  // namespace odocal::app
