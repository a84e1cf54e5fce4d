#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>

#include <yaml-cpp/yaml.h>

#include "file_result.h"
#include "odocal/base/units.h"
#include "odocal/base/utc_time.h"
#include "odocal/config/camera_file.h"
#include "odocal/config/files.h"
#include "odocal/config/scenario.h"
#include "odocal/config/session.h"
#include "yaml_util.h"

namespace odocal::config {
namespace {

using namespace yaml_util;
namespace fs = std::filesystem;

std::string Resolve(const fs::path& dir, const std::string& file) {
  if (file.empty()) return file;
  const fs::path p(file);
  return (p.is_absolute() ? p : dir / p).lexically_normal().string();
}

// `dir` is absolute; `file` may be relative to the working directory.
std::string Relative(const fs::path& dir, const std::string& file) {
  if (file.empty()) return file;
  return fs::absolute(file).lexically_normal().lexically_relative(dir).string();
}

void EmitRun(YAML::Emitter& out, const SessionRun& run, const fs::path& dir) {
  const calibration::RunSpec& spec = run.spec;
  out << YAML::Flow << YAML::BeginMap;
  out << YAML::Key << "name" << YAML::Value << run.name;
  out << YAML::Key << "procedure" << YAML::Value
      << (run.infer_procedure ? std::string("auto") : std::string(calibration::ToString(spec.procedure)));
  switch (run.infer_procedure ? calibration::Procedure::kRecorded : spec.procedure) {
    case calibration::Procedure::kUmbmark:
      out << YAML::Key << "direction" << YAML::Value << std::string(calibration::ToString(spec.direction));
      out << YAML::Key << "side_mm" << YAML::Value << spec.side_m * kMToMm;
      break;
    case calibration::Procedure::kStraight:
      out << YAML::Key << "distance_mm" << YAML::Value << spec.distance_m * kMToMm;
      break;
    case calibration::Procedure::kSpin:
      out << YAML::Key << "direction" << YAML::Value << std::string(calibration::ToString(spec.direction));
      out << YAML::Key << "turns" << YAML::Value << spec.turns;
      out << YAML::Key << "reference" << YAML::Value << std::string(calibration::ToString(spec.reference));
      break;
    case calibration::Procedure::kOutAndBack:
      out << YAML::Key << "direction" << YAML::Value << std::string(calibration::ToString(spec.direction));
      out << YAML::Key << "distance_mm" << YAML::Value << spec.distance_m * kMToMm;
      out << YAML::Key << "repeats" << YAML::Value << spec.repeats;
      out << YAML::Key << "reference" << YAML::Value << std::string(calibration::ToString(spec.reference));
      break;
    case calibration::Procedure::kRecorded: break;
    case calibration::Procedure::kCircle:
      out << YAML::Key << "direction" << YAML::Value << std::string(calibration::ToString(spec.direction));
      out << YAML::Key << "radius_mm" << YAML::Value << spec.radius_m * kMToMm;
      out << YAML::Key << "turns" << YAML::Value << spec.turns;
      break;
  }
  if (spec.speed_m_s) out << YAML::Key << "speed_mm_s" << YAML::Value << *spec.speed_m_s * kMToMm;
  if (spec.turn_rate_rad_s)
    out << YAML::Key << "turn_rate_deg_s" << YAML::Value << *spec.turn_rate_rad_s / kDegToRad;
  if (!run.poses.empty()) {
    out << YAML::Key << "poses" << YAML::Value << Relative(dir, run.poses);
  } else {
    out << YAML::Key << "video" << YAML::Value << Relative(dir, run.video);
  }
  if (!run.timestamps.empty())
    out << YAML::Key << "timestamps" << YAML::Value << Relative(dir, run.timestamps);
  if (!run.telemetry.empty())
    out << YAML::Key << "telemetry" << YAML::Value << Relative(dir, run.telemetry);
  // A pose log's span defaults to the whole log: say only what differs.
  if (run.poses.empty() || run.start_s != 0.0)
    out << YAML::Key << "start_s" << YAML::Value << run.start_s;
  if (std::isfinite(run.end_s)) out << YAML::Key << "end_s" << YAML::Value << run.end_s;
  out << YAML::EndMap;
}

}  // namespace

Status WriteSession(const Session& session, const std::string& path, const std::vector<std::string>& comment) {
  const fs::path dir = fs::absolute(path).lexically_normal().parent_path();
  if (session.has_camera) {
    CameraFile camera;
    camera.intrinsics = session.intrinsics;
    if (Status written = WriteCameraFile(session.camera_file, camera, CameraFileFormat::kOpenCv); !written)
      return written;
  }
  YAML::Emitter out;
  out << YAML::Comment("odocal session: what the operator knows (no truth)");
  out << YAML::Newline;
  for (const std::string& line : comment) out << YAML::Comment(line) << YAML::Newline;
  out << YAML::BeginMap;
  if (session.has_camera) {
    out << YAML::Key << "camera_file" << YAML::Value << Relative(dir, fs::absolute(session.camera_file).string());
    const vision::CameraMount& m = session.camera_mount_guess;
    out << YAML::Key << "camera_mount_guess" << YAML::Value << YAML::Flow << YAML::BeginMap
        << YAML::Key << "x_mm" << YAML::Value << m.x_mm << YAML::Key << "y_mm" << YAML::Value << m.y_mm
        << YAML::Key << "height_mm" << YAML::Value << m.height_mm << YAML::Key << "roll_deg"
        << YAML::Value << m.roll_deg << YAML::Key << "pitch_deg" << YAML::Value << m.pitch_deg
        << YAML::Key << "yaw_deg" << YAML::Value << m.yaw_deg << YAML::EndMap;
    const vision::TagSpec& t = session.tag;
    out << YAML::Key << "tag" << YAML::Value << YAML::Flow << YAML::BeginMap << YAML::Key << "family"
        << YAML::Value << t.family << YAML::Key << "id" << YAML::Value << t.id << YAML::Key
        << "size_mm" << YAML::Value << t.size_mm;
    if (session.tag_size_sigma_mm) out << YAML::Key << "size_sigma_mm" << YAML::Value << *session.tag_size_sigma_mm;
    out << YAML::Key << "height_mm" << YAML::Value
        << t.height_mm << YAML::Key << "offset_mm" << YAML::Value << YAML::BeginMap << YAML::Key
        << "x" << YAML::Value << t.offset_x_mm << YAML::Key << "y" << YAML::Value << t.offset_y_mm
        << YAML::EndMap << YAML::Key << "yaw_deg" << YAML::Value << t.yaw_deg << YAML::EndMap;
    if (session.floor_reference) {
      out << YAML::Key << "floor_reference" << YAML::Value;
      EmitFloorReference(out, *session.floor_reference);
    }
  }
  bool any_poses = false;
  for (const SessionRun& run : session.runs) any_poses = any_poses || !run.poses.empty();
  if (any_poses) {
    const TrackerMount& k = session.tracker;
    out << YAML::Key << "tracker" << YAML::Value << YAML::Flow << YAML::BeginMap << YAML::Key
        << "offset_mm" << YAML::Value << YAML::BeginMap << YAML::Key << "x" << YAML::Value
        << k.offset_x_mm << YAML::Key << "y" << YAML::Value << k.offset_y_mm << YAML::EndMap
        << YAML::Key << "yaw_deg" << YAML::Value << k.yaw_deg << YAML::EndMap;
  }
  const calibration::WheelParams& n = session.nominal;
  out << YAML::Key << "robot" << YAML::Value << YAML::BeginMap << YAML::Key << "nominal"
      << YAML::Value << YAML::Flow << YAML::BeginMap << YAML::Key << "left_wheel_diameter_mm"
      << YAML::Value << n.left_wheel_diameter_m * kMToMm << YAML::Key << "right_wheel_diameter_mm"
      << YAML::Value << n.right_wheel_diameter_m * kMToMm << YAML::Key << "track_mm" << YAML::Value
      << n.track_m * kMToMm << YAML::Key << "ticks_per_rev" << YAML::Value << n.ticks_per_rev
      << YAML::EndMap;
  if (!session.robot_id.empty()) out << YAML::Key << "id" << YAML::Value << session.robot_id;
  if (session.odometer_km) out << YAML::Key << "odometer_km" << YAML::Value << *session.odometer_km;
  out << YAML::EndMap;
  if (!session.recorded_utc.empty()) out << YAML::Key << "recorded_utc" << YAML::Value << session.recorded_utc;
  out << YAML::Key << "runs" << YAML::Value << YAML::BeginSeq;
  for (const SessionRun& run : session.runs) EmitRun(out, run, dir);
  out << YAML::EndSeq << YAML::EndMap;
  return WriteFileAtomically(path, std::string(out.c_str()) + "\n");
}

namespace {

// The camera (its file, where it is believed to be mounted, the tag, the floor): needed only by
// video runs; with pose logs alone a session names no camera at all. (root is not const, here and
// in ParseSessionRobot: a missing key reads as the non-const operator[] has always read it.)
void ParseSessionCamera(YAML::Node& root, const fs::path& dir, Session& s) {
  bool any_video = false;
  if (const YAML::Node runs = root["runs"]; runs && runs.IsSequence())
    for (const YAML::Node& r : runs) any_video = any_video || !r["poses"];
  s.has_camera = any_video || root["camera_file"] || root["camera_mount_guess"] || root["tag"];
  const char* why_camera =
      any_video ? "missing (required: the session has video runs)" : "missing (required once any camera key is given)";
  if (s.has_camera) {
    if (!root["camera_file"]) Fail(root, "camera_file", why_camera);
    s.camera_file = Resolve(dir, String(root["camera_file"], "camera_file"));
    const auto camera = ReadCameraFile(s.camera_file);
    if (!camera) Fail(root["camera_file"], "camera_file", camera.message);
    s.intrinsics = camera->intrinsics;
    if (!root["camera_mount_guess"]) Fail(root, "camera_mount_guess", why_camera);
    const YAML::Node m = root["camera_mount_guess"];
    const std::string mp = "camera_mount_guess";
    CheckKeys(m, mp, {"x_mm", "y_mm", "height_mm", "roll_deg", "pitch_deg", "yaw_deg"});
    s.camera_mount_guess.x_mm = OptionalNumber(m, mp, "x_mm", 0.0);
    s.camera_mount_guess.y_mm = OptionalNumber(m, mp, "y_mm", 0.0);
    s.camera_mount_guess.height_mm = Positive(RequiredNumber(m, mp, "height_mm"), m["height_mm"], mp + ".height_mm");
    s.camera_mount_guess.roll_deg = OptionalNumber(m, mp, "roll_deg", 0.0);
    s.camera_mount_guess.pitch_deg = OptionalNumber(m, mp, "pitch_deg", 0.0);
    s.camera_mount_guess.yaw_deg = OptionalNumber(m, mp, "yaw_deg", 0.0);
    if (!root["tag"]) Fail(root, "tag", why_camera);
    s.tag = ParseTag(root["tag"], "tag", {"size_sigma_mm"});
    if (const YAML::Node sigma = root["tag"]["size_sigma_mm"]) {
      s.tag_size_sigma_mm = Number(sigma, "tag.size_sigma_mm");
      if (!(*s.tag_size_sigma_mm >= 0.0)) Fail(sigma, "tag.size_sigma_mm", "must not be negative");
    }
    if (const YAML::Node floor = root["floor_reference"])
      s.floor_reference = ParseFloorReference(floor, "floor_reference");
  } else if (root["floor_reference"]) {
    Fail(root["floor_reference"], "floor_reference", "needs a camera (camera_file, camera_mount_guess, tag)");
  }
}

// Where the tracker sits on the robot (pose-log runs).
void ParseSessionTracker(const YAML::Node& k, Session& s) {
  CheckKeys(k, "tracker", {"offset_mm", "yaw_deg"});
  if (const YAML::Node offset = k["offset_mm"]) {
    CheckKeys(offset, "tracker.offset_mm", {"x", "y"});
    s.tracker.offset_x_mm = OptionalNumber(offset, "tracker.offset_mm", "x", 0.0);
    s.tracker.offset_y_mm = OptionalNumber(offset, "tracker.offset_mm", "y", 0.0);
  }
  s.tracker.yaw_deg = OptionalNumber(k, "tracker", "yaw_deg", 0.0);
}

// The robot (its nominal set, id and odometer) and when the session was recorded.
void ParseSessionRobot(YAML::Node& root, Session& s) {
  if (!root["robot"]) Fail(root, "robot", "missing (required)");
  CheckKeys(root["robot"], "robot", {"nominal", "id", "odometer_km"});
  if (!root["robot"]["nominal"]) Fail(root["robot"], "robot.nominal", "missing (required)");
  s.nominal = ParseWheels(root["robot"]["nominal"], "robot.nominal", true, 0);
  if (const YAML::Node id = root["robot"]["id"]) s.robot_id = String(id, "robot.id");
  if (const YAML::Node km = root["robot"]["odometer_km"]) {
    s.odometer_km = Number(km, "robot.odometer_km");
    if (*s.odometer_km < 0) Fail(km, "robot.odometer_km", "must be >= 0");
  }
  if (const YAML::Node when = root["recorded_utc"]) {
    s.recorded_utc = String(when, "recorded_utc");
    if (!ParseUtc(s.recorded_utc))
      Fail(when, "recorded_utc", "`" + s.recorded_utc + "` is not ISO 8601 (2026-11-27T14:05:00Z, or a date)");
  }
}

// Run i of the session: its procedure, its recording (a video or a pose log, relative to dir) and its span.
SessionRun ParseSessionRun(const YAML::Node& r, size_t i, const fs::path& dir) {
  const std::string rp = "runs[" + std::to_string(i) + "]";
  SessionRun run;
  // `procedure: auto`: whatever the recording shows (segment_runs.h).
  if (r["procedure"] && r["procedure"].IsScalar() && r["procedure"].Scalar() == "auto") {
    CheckKeys(r, rp, {"name", "procedure", "video", "poses", "timestamps", "telemetry", "start_s", "end_s"});
    run.spec.procedure = calibration::Procedure::kRecorded;
    run.infer_procedure = true;
  } else {
    run.spec = ParseRun(r, rp, {"name", "video", "poses", "timestamps", "telemetry", "start_s", "end_s"});
  }
  run.name = r["name"] ? String(r["name"], Join(rp, "name")) : RunName(static_cast<int>(i), run.spec);
  if (r["video"] && r["poses"]) Fail(r["poses"], Join(rp, "poses"), "a run has a video or a pose log, not both");
  if (const YAML::Node p = r["poses"]) {
    run.poses = Resolve(dir, String(p, Join(rp, "poses")));
    if (!fs::exists(run.poses)) Fail(p, Join(rp, "poses"), run.poses + ": no such file");
    // The model is driven by the ticks: a pose log without them is useless.
    if (!r["telemetry"]) Fail(r, Join(rp, "telemetry"), "missing (required with poses)");
    if (r["timestamps"]) Fail(r["timestamps"], Join(rp, "timestamps"), "applies to video runs only");
  } else {
    if (!r["video"]) Fail(r, Join(rp, "video"), "missing (required: video or poses)");
    run.video = Resolve(dir, String(r["video"], Join(rp, "video")));
    if (!fs::exists(run.video)) Fail(r["video"], Join(rp, "video"), run.video + ": no such file");
  }
  if (r["timestamps"]) {
    run.timestamps = Resolve(dir, String(r["timestamps"], Join(rp, "timestamps")));
    if (!fs::exists(run.timestamps)) Fail(r["timestamps"], Join(rp, "timestamps"), run.timestamps + ": no such file");
  }
  if (r["telemetry"]) run.telemetry = Resolve(dir, String(r["telemetry"], Join(rp, "telemetry")));
  if (!run.poses.empty() && !fs::exists(run.telemetry))
    Fail(r["telemetry"], Join(rp, "telemetry"), run.telemetry + ": no such file");
  run.start_s = OptionalNumber(r, rp, "start_s", 0.0);
  run.end_s = OptionalNumber(r, rp, "end_s", std::numeric_limits<double>::infinity());
  if (!(run.end_s > run.start_s)) Fail(r, Join(rp, "end_s"), "must be after start_s");
  return run;
}

// The parser; the public function wraps its error line in a Result.
std::optional<Session> LoadSessionOrError(const std::string& path, std::string* error) {
  auto fail = [&](const std::string& message) -> std::optional<Session> {
    if (error) *error = message;
    return std::nullopt;
  };
  if (!fs::exists(path)) return fail(path + ": no such file");
  if (fs::is_directory(path)) return fail(path + ": is a directory, not a session file");
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const YAML::Exception& e) {
    return fail(path + ":" + std::to_string(e.mark.line + 1) + ": not valid YAML: " + e.msg);
  }
  if (!root || root.IsNull()) return fail(path + ": empty session file");
  const fs::path dir = fs::absolute(path).parent_path();
  try {
    CheckKeys(root, "",
              {"camera_file", "camera_mount_guess", "tag", "floor_reference", "tracker", "robot", "runs", "recorded_utc"});
    Session s;
    s.path = path;
    ParseSessionCamera(root, dir, s);
    if (const YAML::Node k = root["tracker"]) ParseSessionTracker(k, s);
    ParseSessionRobot(root, s);
    const YAML::Node runs = root["runs"];
    if (!runs) Fail(root, "runs", "missing (required)");
    if (!runs.IsSequence() || runs.size() == 0)
      Fail(runs, "runs", "expected a non-empty list of runs");
    for (size_t i = 0; i < runs.size(); ++i) s.runs.push_back(ParseSessionRun(runs[i], i, dir));
    return s;
  } catch (const YamlError& e) {
    return fail(path + ":" + e.what());
  } catch (const YAML::Exception& e) {
    return fail(path + ":" + std::to_string(e.mark.line + 1) + ": " + e.msg);
  }
}

}  // namespace

Result<Session> LoadSession(const std::string& path) {
  return ReadFileAs<Session>(path, [&](std::string* error) { return LoadSessionOrError(path, error); });
}

std::vector<std::string> SessionFiles(const Session& session) {
  std::vector<std::string> files = {session.path};
  auto add = [&files](const std::string& f) {
    if (!f.empty() && std::find(files.begin(), files.end(), f) == files.end()) files.push_back(f);
  };
  add(session.camera_file);
  for (const SessionRun& run : session.runs)
    for (const std::string* f : {&run.video, &run.poses, &run.timestamps, &run.telemetry}) add(*f);
  return files;
}

}  // namespace odocal::config
