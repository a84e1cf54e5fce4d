#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>

#include <yaml-cpp/yaml.h>

#include "odocal/rig/camera_io.h"
#include "odocal/rig/output.h"
#include "odocal/rig/scenario.h"
#include "odocal/rig/session.h"
#include "yaml_util.h"

namespace odocal::rig {
namespace {

using namespace yaml_util;
namespace fs = std::filesystem;

std::string Resolve(const fs::path& dir, const std::string& file) {
  if (file.empty()) return file;
  const fs::path p(file);
  return (p.is_absolute() ? p : dir / p).lexically_normal().string();
}

std::string Relative(const fs::path& dir, const std::string& file) {
  if (file.empty()) return file;
  return fs::path(file).lexically_relative(dir).string();
}

void EmitRun(YAML::Emitter& out, const SessionRun& run, const fs::path& dir) {
  const calibration::RunSpec& spec = run.spec;
  out << YAML::Flow << YAML::BeginMap;
  out << YAML::Key << "name" << YAML::Value << run.name;
  out << YAML::Key << "procedure" << YAML::Value << std::string(calibration::ToString(spec.procedure));
  switch (spec.procedure) {
    case calibration::Procedure::kUmbmark:
      out << YAML::Key << "direction" << YAML::Value << std::string(calibration::ToString(spec.direction));
      out << YAML::Key << "side_mm" << YAML::Value << spec.side_m * 1e3;
      break;
    case calibration::Procedure::kStraight:
      out << YAML::Key << "distance_mm" << YAML::Value << spec.distance_m * 1e3;
      break;
    case calibration::Procedure::kSpin:
      out << YAML::Key << "direction" << YAML::Value << std::string(calibration::ToString(spec.direction));
      out << YAML::Key << "turns" << YAML::Value << spec.turns;
      out << YAML::Key << "reference" << YAML::Value << std::string(calibration::ToString(spec.reference));
      break;
    case calibration::Procedure::kOutAndBack:
      out << YAML::Key << "direction" << YAML::Value << std::string(calibration::ToString(spec.direction));
      out << YAML::Key << "distance_mm" << YAML::Value << spec.distance_m * 1e3;
      out << YAML::Key << "repeats" << YAML::Value << spec.repeats;
      out << YAML::Key << "reference" << YAML::Value << std::string(calibration::ToString(spec.reference));
      break;
  }
  if (spec.speed_m_s) out << YAML::Key << "speed_mm_s" << YAML::Value << *spec.speed_m_s * 1e3;
  if (spec.turn_rate_rad_s)
    out << YAML::Key << "turn_rate_deg_s" << YAML::Value << *spec.turn_rate_rad_s / kDegToRad;
  out << YAML::Key << "video" << YAML::Value << Relative(dir, run.video);
  if (!run.timestamps.empty())
    out << YAML::Key << "timestamps" << YAML::Value << Relative(dir, run.timestamps);
  if (!run.telemetry.empty())
    out << YAML::Key << "telemetry" << YAML::Value << Relative(dir, run.telemetry);
  out << YAML::Key << "start_s" << YAML::Value << run.start_s;
  out << YAML::Key << "end_s" << YAML::Value << run.end_s;
  out << YAML::EndMap;
}

}  // namespace

std::optional<std::string> WriteSession(const Session& session, const std::string& path) {
  const fs::path dir = fs::absolute(path).parent_path();
  CameraFile camera;
  camera.intrinsics = session.intrinsics;
  if (auto e = WriteCameraFile(session.camera_file, camera, CameraFileFormat::kOpenCv)) return e;
  YAML::Emitter out;
  out << YAML::Comment("odocal session: what the operator knows (no truth)");
  out << YAML::BeginMap;
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
      << "size_mm" << YAML::Value << t.size_mm << YAML::Key << "height_mm" << YAML::Value
      << t.height_mm << YAML::Key << "offset_mm" << YAML::Value << YAML::BeginMap << YAML::Key
      << "x" << YAML::Value << t.offset_x_mm << YAML::Key << "y" << YAML::Value << t.offset_y_mm
      << YAML::EndMap << YAML::Key << "yaw_deg" << YAML::Value << t.yaw_deg << YAML::EndMap;
  const calibration::WheelParams& n = session.nominal;
  out << YAML::Key << "robot" << YAML::Value << YAML::BeginMap << YAML::Key << "nominal"
      << YAML::Value << YAML::Flow << YAML::BeginMap << YAML::Key << "left_wheel_diameter_mm"
      << YAML::Value << n.left_wheel_diameter_m * 1e3 << YAML::Key << "right_wheel_diameter_mm"
      << YAML::Value << n.right_wheel_diameter_m * 1e3 << YAML::Key << "track_mm" << YAML::Value
      << n.track_m * 1e3 << YAML::Key << "ticks_per_rev" << YAML::Value << n.ticks_per_rev
      << YAML::EndMap << YAML::EndMap;
  out << YAML::Key << "runs" << YAML::Value << YAML::BeginSeq;
  for (const SessionRun& run : session.runs) EmitRun(out, run, dir);
  out << YAML::EndSeq << YAML::EndMap;
  return WriteFileAtomically(path, std::string(out.c_str()) + "\n");
}

std::optional<Session> LoadSession(const std::string& path, std::string* error) {
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
    CheckKeys(root, "", {"camera_file", "camera_mount_guess", "tag", "robot", "runs"});
    Session s;
    s.path = path;
    if (!root["camera_file"]) Fail(root, "camera_file", "missing (required)");
    s.camera_file = Resolve(dir, String(root["camera_file"], "camera_file"));
    std::string camera_error;
    const auto camera = ReadCameraFile(s.camera_file, &camera_error);
    if (!camera) Fail(root["camera_file"], "camera_file", camera_error);
    s.intrinsics = camera->intrinsics;
    if (!root["camera_mount_guess"]) Fail(root, "camera_mount_guess", "missing (required)");
    const YAML::Node m = root["camera_mount_guess"];
    const std::string mp = "camera_mount_guess";
    CheckKeys(m, mp, {"x_mm", "y_mm", "height_mm", "roll_deg", "pitch_deg", "yaw_deg"});
    s.camera_mount_guess.x_mm = OptionalNumber(m, mp, "x_mm", 0.0);
    s.camera_mount_guess.y_mm = OptionalNumber(m, mp, "y_mm", 0.0);
    s.camera_mount_guess.height_mm =
        Positive(RequiredNumber(m, mp, "height_mm"), m["height_mm"], mp + ".height_mm");
    s.camera_mount_guess.roll_deg = OptionalNumber(m, mp, "roll_deg", 0.0);
    s.camera_mount_guess.pitch_deg = OptionalNumber(m, mp, "pitch_deg", 0.0);
    s.camera_mount_guess.yaw_deg = OptionalNumber(m, mp, "yaw_deg", 0.0);
    if (!root["tag"]) Fail(root, "tag", "missing (required)");
    s.tag = ParseTag(root["tag"]);
    if (!root["robot"]) Fail(root, "robot", "missing (required)");
    CheckKeys(root["robot"], "robot", {"nominal"});
    if (!root["robot"]["nominal"]) Fail(root["robot"], "robot.nominal", "missing (required)");
    s.nominal = ParseWheels(root["robot"]["nominal"], "robot.nominal", true, 0);
    const YAML::Node runs = root["runs"];
    if (!runs) Fail(root, "runs", "missing (required)");
    if (!runs.IsSequence() || runs.size() == 0)
      Fail(runs, "runs", "expected a non-empty list of runs");
    for (size_t i = 0; i < runs.size(); ++i) {
      const std::string rp = "runs[" + std::to_string(i) + "]";
      const YAML::Node r = runs[i];
      SessionRun run;
      run.spec = ParseRun(r, rp, {"name", "video", "timestamps", "telemetry", "start_s", "end_s"});
      run.name = r["name"] ? String(r["name"], Join(rp, "name")) : RunName(static_cast<int>(i), run.spec);
      if (!r["video"]) Fail(r, Join(rp, "video"), "missing (required)");
      run.video = Resolve(dir, String(r["video"], Join(rp, "video")));
      if (!fs::exists(run.video)) Fail(r["video"], Join(rp, "video"), run.video + ": no such file");
      if (r["timestamps"]) {
        run.timestamps = Resolve(dir, String(r["timestamps"], Join(rp, "timestamps")));
        if (!fs::exists(run.timestamps))
          Fail(r["timestamps"], Join(rp, "timestamps"), run.timestamps + ": no such file");
      }
      if (r["telemetry"]) run.telemetry = Resolve(dir, String(r["telemetry"], Join(rp, "telemetry")));
      run.start_s = OptionalNumber(r, rp, "start_s", 0.0);
      run.end_s = OptionalNumber(r, rp, "end_s", std::numeric_limits<double>::infinity());
      if (!(run.end_s > run.start_s)) Fail(r, Join(rp, "end_s"), "must be after start_s");
      s.runs.push_back(run);
    }
    return s;
  } catch (const YamlError& e) {
    return fail(path + ":" + e.what());
  } catch (const YAML::Exception& e) {
    return fail(path + ":" + std::to_string(e.mark.line + 1) + ": " + e.msg);
  }
}

}  // namespace odocal::rig
