#include "odocal/config/station_file.h"

#include <filesystem>

#include <yaml-cpp/yaml.h>

#include "file_result.h"
#include "yaml_util.h"

namespace odocal::config {

namespace fs = std::filesystem;

namespace {

// The robot: its driver and what that driver needs.
void ParseStationRobot(const YAML::Node& robot, StationConfig& c) {
  using namespace yaml_util;
  ExpectMap(robot, "robot");
  CheckKeys(robot, "robot",
            {"driver", "port", "baud", "timeout_ms", "command", "stop_command", "apply", "apply_timeout_s",
             "run_timeout_s", "params"});
  const std::string driver = robot["driver"] ? String(robot["driver"], "robot.driver") : "link";
  if (driver == "link") {
    c.driver = StationDriver::kLink;
  } else if (driver == "command") {
    c.driver = StationDriver::kCommand;
  } else if (driver == "operator") {
    c.driver = StationDriver::kOperator;
  } else {
    yaml_util::Fail(robot["driver"], "robot.driver", "'" + driver + "': expected link, command or operator");
  }
  auto only_for = [&](const char* key, bool allowed, const char* drivers) {
    if (robot[key] && !allowed)
      yaml_util::Fail(robot[key], Join("robot", key), "not used by the " + driver + " driver (only " + drivers + ")");
  };
  const bool link = c.driver == StationDriver::kLink, command = c.driver == StationDriver::kCommand;
  for (const char* key : {"port", "baud", "timeout_ms"}) only_for(key, link, "link");
  for (const char* key : {"command", "stop_command"}) only_for(key, command, "command");
  for (const char* key : {"apply", "apply_timeout_s", "params"}) only_for(key, !link, "command and operator");
  if (link) {
    if (!robot["port"]) yaml_util::Fail(robot, "robot.port", "missing (required by the link driver)");
    c.port = String(robot["port"], "robot.port");
    c.baud = static_cast<int>(OptionalNumber(robot, "robot", "baud", 115200));
    c.timeout_ms =
        static_cast<int>(Positive(OptionalNumber(robot, "robot", "timeout_ms", 200), robot, "robot.timeout_ms"));
  } else {
    if (command && !robot["command"])
      yaml_util::Fail(robot, "robot.command", "missing (required by the command driver)");
    if (!robot["params"])
      yaml_util::Fail(
          robot, "robot.params",
          "missing (required by the " + driver + " driver: the set the robot runs with, which it cannot read)");
    c.params = ParseWheels(robot["params"], "robot.params", true, 0.0);
    if (command) c.run_command = String(robot["command"], "robot.command");
    if (robot["stop_command"]) c.stop_command = String(robot["stop_command"], "robot.stop_command");
    if (robot["apply"]) c.apply_command = String(robot["apply"], "robot.apply");
    c.apply_timeout_s =
        Positive(OptionalNumber(robot, "robot", "apply_timeout_s", 60.0), robot, "robot.apply_timeout_s");
  }
  c.run_timeout_s = Positive(OptionalNumber(robot, "robot", "run_timeout_s", 120.0), robot, "robot.run_timeout_s");
}

// The camera: its device, its calibration file (relative to dir, the station file's folder) and
// where it is believed to be mounted.
void ParseStationCamera(const YAML::Node& camera, const fs::path& dir, StationConfig& c) {
  using namespace yaml_util;
  ExpectMap(camera, "camera");
  CheckKeys(camera, "camera", {"device", "calibration", "mount_guess", "flush_frames", "settle_s"});
  for (const char* key : {"device", "calibration", "mount_guess"})
    if (!camera[key]) yaml_util::Fail(camera, Join("camera", key), "missing (required)");
  c.camera_device = String(camera["device"], "camera.device");
  c.camera_file = (dir / String(camera["calibration"], "camera.calibration")).lexically_normal().string();
  const YAML::Node m = camera["mount_guess"];
  ExpectMap(m, "camera.mount_guess");
  CheckKeys(m, "camera.mount_guess", {"x_mm", "y_mm", "height_mm", "roll_deg", "pitch_deg", "yaw_deg"});
  c.mount_guess.x_mm = OptionalNumber(m, "camera.mount_guess", "x_mm", 0.0);
  c.mount_guess.y_mm = OptionalNumber(m, "camera.mount_guess", "y_mm", 0.0);
  c.mount_guess.height_mm =
      Positive(RequiredNumber(m, "camera.mount_guess", "height_mm"), m, "camera.mount_guess.height_mm");
  c.mount_guess.roll_deg = OptionalNumber(m, "camera.mount_guess", "roll_deg", 0.0);
  c.mount_guess.pitch_deg = OptionalNumber(m, "camera.mount_guess", "pitch_deg", 0.0);
  c.mount_guess.yaw_deg = OptionalNumber(m, "camera.mount_guess", "yaw_deg", 0.0);
  c.flush_frames = static_cast<int>(OptionalNumber(camera, "camera", "flush_frames", 5));
  c.settle_s = OptionalNumber(camera, "camera", "settle_s", 0.5);
  if (c.flush_frames < 0 || c.settle_s < 0.0)
    yaml_util::Fail(camera, "camera", "flush_frames and settle_s must not be negative");
}

// The limits, as `odocal records --limits` reads them (key=value, comma-separated).
records::Limits ParseStationLimits(const YAML::Node& limits) {
  using namespace yaml_util;
  ExpectMap(limits, "limits");
  std::string text;
  for (const auto& kv : limits) {
    const std::string key = kv.first.as<std::string>();
    if (!text.empty()) text += ',';
    text += key;
    text += '=';
    text += String(kv.second, "limits." + key);
  }
  const Result<records::Limits> parsed = records::ParseLimits(text);
  if (!parsed) yaml_util::Fail(limits, "limits", parsed.message);
  return *parsed;
}

// The plan: `default`, {default: {turn rates}}, a list of runs, or {side_mm, runs_per_direction}.
void ParseStationPlan(const YAML::Node& plan, StationConfig& c) {
  using namespace yaml_util;
  if (plan.IsScalar()) {
    if (String(plan, "plan") != "default")
      yaml_util::Fail(plan, "plan", "expected `default`, a list of runs, or {side_mm, runs_per_direction}");
    c.default_plan = true;
  } else if (plan.IsSequence()) {
    if (plan.size() == 0) yaml_util::Fail(plan, "plan", "an empty list");
    for (size_t i = 0; i < plan.size(); ++i) c.runs.push_back(ParseRun(plan[i], "plan[" + std::to_string(i) + "]"));
  } else if (plan["default"]) {
    ExpectMap(plan, "plan");
    CheckKeys(plan, "plan", {"default"});
    c.default_plan = true;
    const YAML::Node d = plan["default"];
    ExpectMap(d, "plan.default");
    CheckKeys(d, "plan.default", {"slow_turn_rate_deg_s", "fast_turn_rate_deg_s"});
    if (d["slow_turn_rate_deg_s"])
      c.slow_turn_rate_deg_s = Positive(Number(d["slow_turn_rate_deg_s"], "plan.default.slow_turn_rate_deg_s"), d,
                                        "plan.default.slow_turn_rate_deg_s");
    if (d["fast_turn_rate_deg_s"])
      c.fast_turn_rate_deg_s = Positive(Number(d["fast_turn_rate_deg_s"], "plan.default.fast_turn_rate_deg_s"), d,
                                        "plan.default.fast_turn_rate_deg_s");
  } else {
    ExpectMap(plan, "plan");
    CheckKeys(plan, "plan", {"side_mm", "runs_per_direction"});
    c.side_mm = Positive(OptionalNumber(plan, "plan", "side_mm", 2000.0), plan, "plan.side_mm");
    c.runs_per_direction = static_cast<int>(
        Positive(OptionalNumber(plan, "plan", "runs_per_direction", 3), plan, "plan.runs_per_direction"));
  }
}

// The parser; the public function wraps its error line in a Result.
std::optional<StationConfig> LoadStationConfigOrError(const std::string& path, std::string* error) {
  using namespace yaml_util;
  if (!fs::exists(path)) {
    *error = path + ": no such file";
    return std::nullopt;
  }
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const YAML::Exception& e) {
    *error = path + ":" + std::to_string(e.mark.line + 1) + ": not valid YAML: " + e.msg;
    return std::nullopt;
  }
  const fs::path dir = fs::absolute(path).parent_path();
  try {
    ExpectMap(root, "");
    CheckKeys(root, "", {"robot", "camera", "tag", "floor_reference", "plan", "max_rounds", "limits"});
    StationConfig c;
    for (const char* key : {"robot", "camera", "tag"})
      if (!root[key]) yaml_util::Fail(root, key, "missing (required)");
    ParseStationRobot(root["robot"], c);
    ParseStationCamera(root["camera"], dir, c);
    c.tag = ParseTag(root["tag"], "tag", {"size_sigma_mm"});
    if (const YAML::Node sigma = root["tag"]["size_sigma_mm"]) {
      c.tag_size_sigma_mm = Number(sigma, "tag.size_sigma_mm");
      if (!(*c.tag_size_sigma_mm >= 0.0)) yaml_util::Fail(sigma, "tag.size_sigma_mm", "must not be negative");
    }
    if (const YAML::Node floor = root["floor_reference"])
      c.floor_reference = ParseFloorReference(floor, "floor_reference");
    if (const YAML::Node limits = root["limits"]) c.limits = ParseStationLimits(limits);
    if (const YAML::Node plan = root["plan"]) ParseStationPlan(plan, c);
    if (root["max_rounds"]) c.max_rounds = static_cast<int>(Integer(root["max_rounds"], "max_rounds"));
    return c;
  } catch (const YamlError& e) {
    *error = path + ":" + e.what();
    return std::nullopt;
  }
}

}  // namespace

Result<StationConfig> LoadStationConfig(const std::string& path) {
  return ReadFileAs<StationConfig>(path, [&](std::string* error) { return LoadStationConfigOrError(path, error); });
}

}  // namespace odocal::config
