#include "odocal/simulation/simulation.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

#include "odocal/base/units.h"
#include "odocal/config/files.h"
#include "odocal/config/session.h"
#include "odocal/report/json.h"
#include "odocal/simulation/camera_sim.h"

namespace odocal::simulation {
namespace {


std::string TelemetryCsv(const sim::RunRecord& run) {
  std::string csv = "t_s,left_ticks,right_ticks,x_mm,y_mm,heading_deg,moving\n";
  char line[160];
  for (const sim::TelemetrySample& s : run.telemetry) {
    std::snprintf(line, sizeof(line), "%.3f,%lld,%lld,%.4f,%.4f,%.6f,%d\n", s.t_s,
                  static_cast<long long>(s.left_ticks), static_cast<long long>(s.right_ticks),
                  s.odometry.x() * kMToMm, s.odometry.y() * kMToMm, s.odometry.heading() * kRadToDeg,
                  s.moving ? 1 : 0);
    csv += line;
  }
  return csv;
}

// The true trajectory at the telemetry times (the full control-rate record
// stays in memory for the renderer).
std::string TrajectoryCsv(const sim::RunRecord& run) {
  std::string csv = "t_s,x_mm,y_mm,heading_deg\n";
  char line[128];
  size_t k = 0;
  for (const sim::TelemetrySample& s : run.telemetry) {
    while (k + 1 < run.trajectory.size() && run.trajectory[k].t_s < s.t_s - 1e-9) ++k;
    const calibration::Pose2& T = run.trajectory[k].T_world_robot;
    std::snprintf(line, sizeof(line), "%.3f,%.4f,%.4f,%.6f\n", s.t_s, T.x() * kMToMm, T.y() * kMToMm,
                  T.heading() * kRadToDeg);
    csv += line;
  }
  return csv;
}

nlohmann::json RunSpecJson(const calibration::RunSpec& spec) {
  nlohmann::json j = {{"procedure", calibration::ToString(spec.procedure)}};
  switch (spec.procedure) {
    case calibration::Procedure::kUmbmark:
      j["direction"] = calibration::ToString(spec.direction);
      j["side_mm"] = spec.side_m * kMToMm;
      break;
    case calibration::Procedure::kStraight:
      j["distance_mm"] = spec.distance_m * kMToMm;
      break;
    case calibration::Procedure::kSpin:
      j["direction"] = calibration::ToString(spec.direction);
      j["turns"] = spec.turns;
      j["reference"] = calibration::ToString(spec.reference);
      break;
    case calibration::Procedure::kOutAndBack:
      j["direction"] = calibration::ToString(spec.direction);
      j["distance_mm"] = spec.distance_m * kMToMm;
      j["repeats"] = spec.repeats;
      j["reference"] = calibration::ToString(spec.reference);
      break;
    case calibration::Procedure::kRecorded: break;  // refused by the scenario parser
    case calibration::Procedure::kCircle:
      j["direction"] = calibration::ToString(spec.direction);
      j["radius_mm"] = spec.radius_m * kMToMm;
      j["turns"] = spec.turns;
      break;
  }
  return j;
}

}  // namespace

SimulationResult Simulate(const config::Scenario& scenario,
                          const std::optional<calibration::WheelParams>& believed) {
  SimulationResult result;
  sim::VirtualRobot robot(scenario.robot);
  if (believed) robot.SetBelievedParams(*believed);
  result.truth = calibration::ErrorFactorsFrom(robot.believed_params(), scenario.robot.truth);
  for (size_t i = 0; i < scenario.runs.size(); ++i) {
    result.run_names.push_back(config::RunName(static_cast<int>(i), scenario.runs[i]));
    result.runs.push_back(robot.Execute(scenario.runs[i]));
  }
  return result;
}

namespace {

// WriteSimulation's steps.

// A run's entry in truth.json, with its video's files when it was recorded.
nlohmann::json RunTruthJson(const sim::RunRecord& run, const std::string& name, const RecordedRun* recorded) {
  nlohmann::json j = RunSpecJson(run.spec);
  j["name"] = name;
  j["start_time_s"] = run.start_time_s;
  j["end_time_s"] = run.end_time_s;
  j["true_start"] = report::PoseJson(run.true_start);
  j["true_end"] = report::PoseJson(run.true_end);
  j["true_return_error"] = report::ReturnErrorJson(run.TrueEndInStartFrame());
  j["odometry_end"] = report::PoseJson(run.odometry_end);
  j["telemetry"] = name + ".telemetry.csv";
  j["trajectory"] = name + ".trajectory.csv";
  if (recorded) {
    // The file names as written (one video for every run with camera.one_video).
    j["video"] = std::filesystem::path(recorded->video).filename().string();
    j["frames"] = std::filesystem::path(recorded->frames).filename().string();
    j["frames_written"] = recorded->frames_written;
    j["frames_visible"] = recorded->frames_visible;
  }
  return j;
}

// The session's runs as an operator would list them: each run's video,
// timestamps and telemetry (and its span in the video unless one video
// holds them all).
std::vector<config::SessionRun> SessionRuns(const SimulationResult& result, const std::string& dir,
                                            const std::vector<RecordedRun>& recorded, bool one_video) {
  std::vector<config::SessionRun> runs;
  for (size_t i = 0; i < result.runs.size(); ++i) {
    config::SessionRun run;
    run.name = result.run_names[i];
    run.spec = result.runs[i].spec;
    run.video = recorded[i].video;
    run.timestamps = recorded[i].timestamps;
    run.telemetry = dir + "/" + run.name + ".telemetry.csv";
    if (!one_video) {  // one video: batch finds the runs in it
      run.start_s = recorded[i].start_s;
      run.end_s = recorded[i].end_s;
    }
    runs.push_back(run);
  }
  return runs;
}

}  // namespace

Status WriteSimulation(const config::Scenario& scenario, const SimulationResult& result, const std::string& dir,
                       const std::vector<RecordedRun>* recorded) {
  if (const Status error = config::EnsureDirectory(dir); !error) return error;
  nlohmann::json runs = nlohmann::json::array();
  for (size_t i = 0; i < result.runs.size(); ++i) {
    const sim::RunRecord& run = result.runs[i];
    const std::string& name = result.run_names[i];
    runs.push_back(RunTruthJson(run, name, recorded ? &(*recorded)[i] : nullptr));
    if (const Status error = config::WriteFileAtomically(dir + "/" + name + ".telemetry.csv", TelemetryCsv(run));
        !error)
      return error;
    if (const Status error = config::WriteFileAtomically(dir + "/" + name + ".trajectory.csv", TrajectoryCsv(run));
        !error)
      return error;
  }
  nlohmann::json truth = {
      {"scenario", scenario.path},
      {"seed", scenario.seed},
      {"truth", {{"Ed", result.truth.Ed}, {"Eb", result.truth.Eb}, {"Es", result.truth.Es}}},
      {"robot",
       {{"nominal", report::WheelParamsJson(scenario.robot.nominal)},
        {"true", report::WheelParamsJson(scenario.robot.truth)}}},
      {"runs", runs},
  };
  if (recorded) {
    const config::CameraScenario& cam = *scenario.camera;
    const vision::CameraMount& m = cam.mount;
    truth["camera"] = {{"mount", {{"x_mm", m.x_mm}, {"y_mm", m.y_mm}, {"height_mm", m.height_mm},
                                  {"roll_deg", m.roll_deg}, {"pitch_deg", m.pitch_deg},
                                  {"yaw_deg", m.yaw_deg}}}};
    truth["effects"] = scenario.robot.effects.Names();
    // What the operator knows.
    config::Session session;
    session.camera_file = dir + "/camera.yaml";
    session.intrinsics = cam.intrinsics;
    session.camera_mount_guess = OperatorMountGuess(cam.mount);
    session.tag = *scenario.tag;
    if (cam.floor_tags) {
      // The tape's readings: the truth plus the tape's error.
      std::vector<double> true_mm;
      const vision::FloorReference reference = TapedFloorReference(*cam.floor_tags, &true_mm);
      nlohmann::json tape = nlohmann::json::array();
      for (size_t i = 0; i < true_mm.size(); ++i)
        tape.push_back({{"between", {reference.distances[i].id_a, reference.distances[i].id_b}},
                        {"true_mm", true_mm[i]}});
      session.floor_reference = reference;
      truth["floor_tags"] = {{"print_scale", cam.tag_print_scale}, {"distances", tape}};
    }
    session.nominal = scenario.robot.nominal;
    session.runs = SessionRuns(result, dir, *recorded, cam.one_video);
    if (const Status error = config::WriteSession(session, dir + "/session.yaml"); !error) return error;
  }
  return config::WriteFileAtomically(dir + "/truth.json", truth.dump(2) + "\n");
}

}  // namespace odocal::simulation
