#include <cmath>
#include <filesystem>
#include <functional>
#include <set>
#include <sstream>
#include <stdexcept>

#include <yaml-cpp/yaml.h>

#include "odocal/rig/scenario.h"

namespace odocal::rig {
namespace {

using calibration::RunSpec;

constexpr double kDegToRad = M_PI / 180.0;

// A parse failure that already carries the key path and the line.
struct ScenarioError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

std::string Where(const YAML::Node& node, const std::string& key_path) {
  std::ostringstream os;
  if (node.Mark().line >= 0) {
    os << (node.Mark().line + 1) << ": ";
  } else {
    os << " ";
  }
  os << key_path;
  return os.str();
}

[[noreturn]] void Fail(const YAML::Node& node, const std::string& key_path,
                       const std::string& message) {
  throw ScenarioError(Where(node, key_path) + ": " + message);
}

void ExpectMap(const YAML::Node& node, const std::string& key_path) {
  if (!node.IsMap()) Fail(node, key_path, "expected a mapping of keys");
}

void CheckKeys(const YAML::Node& node, const std::string& key_path,
               const std::set<std::string>& allowed) {
  ExpectMap(node, key_path);
  for (const auto& entry : node) {
    const std::string key = entry.first.as<std::string>();
    if (!allowed.count(key)) {
      std::string list;
      for (const std::string& a : allowed) list += (list.empty() ? "" : ", ") + a;
      Fail(entry.first, key_path.empty() ? key : key_path + "." + key,
           "unknown key (expected one of: " + list + ")");
    }
  }
}

std::string Join(const std::string& path, const std::string& key) {
  return path.empty() ? key : path + "." + key;
}

double Number(const YAML::Node& node, const std::string& key_path) {
  if (!node.IsScalar()) Fail(node, key_path, "expected a number");
  double value = 0.0;
  if (!YAML::convert<double>::decode(node, value) || !std::isfinite(value))
    Fail(node, key_path, "expected a number, got '" + node.Scalar() + "'");
  return value;
}

double RequiredNumber(const YAML::Node& parent, const std::string& path, const std::string& key) {
  const YAML::Node node = parent[key];
  if (!node) Fail(parent, Join(path, key), "missing (required)");
  return Number(node, Join(path, key));
}

double OptionalNumber(const YAML::Node& parent, const std::string& path, const std::string& key,
                      double fallback) {
  const YAML::Node node = parent[key];
  return node ? Number(node, Join(path, key)) : fallback;
}

double Positive(double value, const YAML::Node& node, const std::string& key_path) {
  if (!(value > 0.0)) Fail(node, key_path, "must be positive");
  return value;
}

long long Integer(const YAML::Node& node, const std::string& key_path) {
  const double value = Number(node, key_path);
  if (value != std::floor(value)) Fail(node, key_path, "expected a whole number");
  return static_cast<long long>(value);
}

std::string String(const YAML::Node& node, const std::string& key_path) {
  if (!node.IsScalar()) Fail(node, key_path, "expected a word");
  return node.Scalar();
}

bool Bool(const YAML::Node& node, const std::string& key_path) {
  bool value = false;
  if (!node.IsScalar() || !YAML::convert<bool>::decode(node, value))
    Fail(node, key_path, "expected true or false");
  return value;
}

calibration::WheelParams ParseWheels(const YAML::Node& node, const std::string& path,
                                     bool ticks_required, int default_ticks) {
  CheckKeys(node, path,
            {"left_wheel_diameter_mm", "right_wheel_diameter_mm", "track_mm", "ticks_per_rev"});
  calibration::WheelParams p;
  p.left_wheel_diameter_m =
      Positive(RequiredNumber(node, path, "left_wheel_diameter_mm"), node,
               Join(path, "left_wheel_diameter_mm")) * 1e-3;
  p.right_wheel_diameter_m =
      Positive(RequiredNumber(node, path, "right_wheel_diameter_mm"), node,
               Join(path, "right_wheel_diameter_mm")) * 1e-3;
  p.track_m = Positive(RequiredNumber(node, path, "track_mm"), node, Join(path, "track_mm")) * 1e-3;
  if (node["ticks_per_rev"]) {
    const long long ticks = Integer(node["ticks_per_rev"], Join(path, "ticks_per_rev"));
    if (ticks <= 0 || ticks > (1LL << 30))
      Fail(node["ticks_per_rev"], Join(path, "ticks_per_rev"), "must be a positive integer");
    p.ticks_per_rev = static_cast<int>(ticks);
  } else if (ticks_required) {
    Fail(node, Join(path, "ticks_per_rev"), "missing (required)");
  } else {
    p.ticks_per_rev = default_ticks;
  }
  return p;
}

sim::RobotConfig ParseRobot(const YAML::Node& node) {
  const std::string path = "robot";
  CheckKeys(node, path,
            {"nominal", "true", "start_pose", "speed_mm_s", "turn_rate_deg_s", "accel_mm_s2",
             "turn_accel_deg_s2", "noise", "control_rate_hz", "telemetry_rate_hz", "rest_s",
             "pause_s"});
  sim::RobotConfig c;
  if (!node["nominal"]) Fail(node, "robot.nominal", "missing (required)");
  if (!node["true"]) Fail(node, "robot.true", "missing (required)");
  c.nominal = ParseWheels(node["nominal"], "robot.nominal", true, 0);
  c.truth = ParseWheels(node["true"], "robot.true", false, c.nominal.ticks_per_rev);
  if (const YAML::Node pose = node["start_pose"]) {
    CheckKeys(pose, "robot.start_pose", {"x_mm", "y_mm", "heading_deg"});
    c.start_pose = calibration::Pose2::FromXYHeading(
        OptionalNumber(pose, "robot.start_pose", "x_mm", 0.0) * 1e-3,
        OptionalNumber(pose, "robot.start_pose", "y_mm", 0.0) * 1e-3,
        OptionalNumber(pose, "robot.start_pose", "heading_deg", 0.0) * kDegToRad);
  }
  auto positive = [&](const char* key, double fallback) {
    const double v = OptionalNumber(node, path, key, fallback);
    return Positive(v, node[key] ? node[key] : node, Join(path, key));
  };
  c.limits.speed_m_s = positive("speed_mm_s", 250.0) * 1e-3;
  c.limits.turn_rate_rad_s = positive("turn_rate_deg_s", 60.0) * kDegToRad;
  c.limits.accel_m_s2 = positive("accel_mm_s2", 500.0) * 1e-3;
  c.limits.turn_accel_rad_s2 = positive("turn_accel_deg_s2", 120.0) * kDegToRad;
  c.control_rate_hz = positive("control_rate_hz", 1000.0);
  c.telemetry_rate_hz = positive("telemetry_rate_hz", 50.0);
  if (c.telemetry_rate_hz > c.control_rate_hz)
    Fail(node, "robot.telemetry_rate_hz", "must not exceed robot.control_rate_hz");
  c.rest_s = OptionalNumber(node, path, "rest_s", 1.0);
  if (c.rest_s < 0.0) Fail(node["rest_s"], "robot.rest_s", "must not be negative");
  c.pause_s = OptionalNumber(node, path, "pause_s", 0.3);
  if (c.pause_s < 0.0) Fail(node["pause_s"], "robot.pause_s", "must not be negative");
  // Realistic defaults: a little wheel noise, encoders at an arbitrary phase.
  c.noise.wheel_sigma_m_per_sqrt_m = 0.05e-3;
  c.noise.random_encoder_phase = true;
  if (const YAML::Node noise = node["noise"]) {
    CheckKeys(noise, "robot.noise", {"wheel_mm_per_sqrt_m", "random_encoder_phase"});
    c.noise.wheel_sigma_m_per_sqrt_m =
        OptionalNumber(noise, "robot.noise", "wheel_mm_per_sqrt_m", 0.05) * 1e-3;
    if (c.noise.wheel_sigma_m_per_sqrt_m < 0.0)
      Fail(noise["wheel_mm_per_sqrt_m"], "robot.noise.wheel_mm_per_sqrt_m", "must not be negative");
    if (noise["random_encoder_phase"])
      c.noise.random_encoder_phase =
          Bool(noise["random_encoder_phase"], "robot.noise.random_encoder_phase");
  }
  return c;
}

RunSpec ParseRun(const YAML::Node& node, const std::string& path) {
  CheckKeys(node, path,
            {"procedure", "direction", "side_mm", "distance_mm", "turns", "repeats", "reference",
             "speed_mm_s", "turn_rate_deg_s"});
  if (!node["procedure"]) Fail(node, Join(path, "procedure"), "missing (required)");
  const std::string name = String(node["procedure"], Join(path, "procedure"));
  const auto procedure = calibration::ParseProcedure(name);
  if (!procedure) {
    Fail(node["procedure"], Join(path, "procedure"),
         "unknown procedure '" + name + "' (expected umbmark, straight, spin, out_and_back)");
  }
  RunSpec spec;
  spec.procedure = *procedure;
  // Which keys each procedure takes; anything else is a mistake worth naming.
  std::set<std::string> takes = {"procedure", "speed_mm_s", "turn_rate_deg_s"};
  switch (spec.procedure) {
    case calibration::Procedure::kUmbmark: takes.insert({"direction", "side_mm"}); break;
    case calibration::Procedure::kStraight: takes.insert({"distance_mm"}); break;
    case calibration::Procedure::kSpin: takes.insert({"turns", "direction", "reference"}); break;
    case calibration::Procedure::kOutAndBack:
      takes.insert({"distance_mm", "repeats", "direction", "reference"});
      break;
  }
  for (const auto& entry : node) {
    const std::string key = entry.first.as<std::string>();
    if (!takes.count(key))
      Fail(entry.first, Join(path, key), "does not apply to procedure " + name);
  }
  spec.direction = calibration::Direction::kCcw;
  if (const YAML::Node d = node["direction"]) {
    const std::string dir = String(d, Join(path, "direction"));
    const auto parsed = calibration::ParseDirection(dir);
    if (!parsed) Fail(d, Join(path, "direction"), "expected cw or ccw, got '" + dir + "'");
    spec.direction = *parsed;
  } else if (spec.procedure == calibration::Procedure::kUmbmark) {
    Fail(node, Join(path, "direction"), "missing (required for umbmark: cw or ccw)");
  }
  if (spec.procedure == calibration::Procedure::kUmbmark)
    spec.side_m = Positive(RequiredNumber(node, path, "side_mm"), node["side_mm"],
                           Join(path, "side_mm")) * 1e-3;
  if (spec.procedure == calibration::Procedure::kStraight ||
      spec.procedure == calibration::Procedure::kOutAndBack)
    spec.distance_m = Positive(RequiredNumber(node, path, "distance_mm"), node["distance_mm"],
                               Join(path, "distance_mm")) * 1e-3;
  if (spec.procedure == calibration::Procedure::kSpin) {
    if (!node["turns"]) Fail(node, Join(path, "turns"), "missing (required for spin)");
    const long long turns = Integer(node["turns"], Join(path, "turns"));
    if (turns <= 0 || turns > 1000) Fail(node["turns"], Join(path, "turns"), "must be 1 to 1000");
    spec.turns = static_cast<int>(turns);
  }
  if (const YAML::Node r = node["repeats"]) {
    const long long repeats = Integer(r, Join(path, "repeats"));
    if (repeats <= 0 || repeats > 1000) Fail(r, Join(path, "repeats"), "must be 1 to 1000");
    spec.repeats = static_cast<int>(repeats);
  }
  if (const YAML::Node r = node["reference"]) {
    const std::string ref = String(r, Join(path, "reference"));
    const auto parsed = calibration::ParseReference(ref);
    if (!parsed) Fail(r, Join(path, "reference"), "expected camera or wall, got '" + ref + "'");
    spec.reference = *parsed;
  }
  if (const YAML::Node v = node["speed_mm_s"])
    spec.speed_m_s = Positive(Number(v, Join(path, "speed_mm_s")), v, Join(path, "speed_mm_s")) * 1e-3;
  if (const YAML::Node v = node["turn_rate_deg_s"])
    spec.turn_rate_rad_s = Positive(Number(v, Join(path, "turn_rate_deg_s")), v,
                                    Join(path, "turn_rate_deg_s")) * kDegToRad;
  std::string why;
  if (!spec.IsValid(&why)) Fail(node, path, why);
  return spec;
}

sim::Effects ParseEffects(const YAML::Node& effects) {
  if (!effects.IsSequence()) Fail(effects, "effects", "expected a list");
  sim::Effects out;
  for (size_t i = 0; i < effects.size(); ++i) {
    const YAML::Node e = effects[i];
    const std::string path = "effects[" + std::to_string(i) + "]";
    ExpectMap(e, path);
    if (!e["name"]) Fail(e, Join(path, "name"), "missing (required)");
    const std::string name = String(e["name"], Join(path, "name"));
    auto twice = [&](bool already) {
      if (already) Fail(e, path, "effect '" + name + "' is listed twice");
    };
    if (name == "tag_offset") {
      CheckKeys(e, path, {"name", "x_mm", "y_mm"});
      twice(out.tag_offset.has_value());
      out.tag_offset = sim::TagOffsetEffect{RequiredNumber(e, path, "x_mm") * 1e-3,
                                            RequiredNumber(e, path, "y_mm") * 1e-3};
    } else if (name == "camera_latency") {
      CheckKeys(e, path, {"name", "ms"});
      twice(out.camera_latency.has_value());
      out.camera_latency = sim::CameraLatencyEffect{RequiredNumber(e, path, "ms") * 1e-3};
    } else if (name == "turn_slip") {
      CheckKeys(e, path, {"name", "fraction_at_1rad_s"});
      twice(out.turn_slip.has_value());
      const double f = RequiredNumber(e, path, "fraction_at_1rad_s");
      if (f < 0.0 || f >= 0.5) Fail(e["fraction_at_1rad_s"], Join(path, "fraction_at_1rad_s"), "must be in [0, 0.5)");
      out.turn_slip = sim::TurnSlipEffect{f};
    } else if (name == "lens_distortion") {
      CheckKeys(e, path, {"name", "k1"});
      twice(out.lens_distortion.has_value());
      out.lens_distortion = sim::LensDistortionEffect{RequiredNumber(e, path, "k1")};
    } else if (name == "encoder_backlash") {
      CheckKeys(e, path, {"name", "ticks"});
      twice(out.encoder_backlash.has_value());
      const double ticks = RequiredNumber(e, path, "ticks");
      if (ticks < 0.0) Fail(e["ticks"], Join(path, "ticks"), "must not be negative");
      out.encoder_backlash = sim::EncoderBacklashEffect{ticks};
    } else if (name == "carpet_drift") {
      CheckKeys(e, path, {"name", "grain_deg", "rate_mm_per_m"});
      twice(out.carpet_drift.has_value());
      out.carpet_drift = sim::CarpetDriftEffect{RequiredNumber(e, path, "grain_deg") * kDegToRad,
                                                RequiredNumber(e, path, "rate_mm_per_m") * 1e-3};
    } else {
      Fail(e["name"], Join(path, "name"),
           "unknown effect '" + name +
               "' (expected tag_offset, camera_latency, turn_slip, lens_distortion, "
               "encoder_backlash, carpet_drift)");
    }
  }
  return out;
}

}  // namespace

std::optional<Scenario> LoadScenario(const std::string& path, std::string* error) {
  auto fail = [&](const std::string& message) -> std::optional<Scenario> {
    if (error) *error = message;
    return std::nullopt;
  };
  if (!std::filesystem::exists(path)) return fail(path + ": no such file");
  if (std::filesystem::is_directory(path)) return fail(path + ": is a directory, not a scenario file");
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const YAML::Exception& e) {
    return fail(path + ":" + std::to_string(e.mark.line + 1) + ": not valid YAML: " + e.msg);
  }
  if (!root || root.IsNull()) return fail(path + ": empty scenario file");
  try {
    CheckKeys(root, "", {"seed", "robot", "runs", "effects"});
    Scenario s;
    s.path = path;
    if (const YAML::Node seed = root["seed"]) {
      const long long value = Integer(seed, "seed");
      if (value < 0) Fail(seed, "seed", "must not be negative");
      s.seed = static_cast<std::uint64_t>(value);
    }
    if (!root["robot"]) Fail(root, "robot", "missing (required)");
    s.robot = ParseRobot(root["robot"]);
    s.robot.seed = s.seed;
    const YAML::Node runs = root["runs"];
    if (!runs) Fail(root, "runs", "missing (required)");
    if (!runs.IsSequence() || runs.size() == 0) Fail(runs, "runs", "expected a non-empty list of runs");
    for (size_t i = 0; i < runs.size(); ++i)
      s.runs.push_back(ParseRun(runs[i], "runs[" + std::to_string(i) + "]"));
    if (const YAML::Node effects = root["effects"]) s.robot.effects = ParseEffects(effects);
    return s;
  } catch (const ScenarioError& e) {
    return fail(path + ":" + e.what());
  } catch (const YAML::Exception& e) {
    return fail(path + ":" + std::to_string(e.mark.line + 1) + ": " + e.msg);
  }
}

std::string RunName(int index, const RunSpec& spec) {
  char name[64];
  const bool has_direction = spec.procedure != calibration::Procedure::kStraight;
  std::snprintf(name, sizeof(name), "run%02d_%s%s%s", index + 1,
                std::string(calibration::ToString(spec.procedure)).c_str(), has_direction ? "_" : "",
                has_direction ? std::string(calibration::ToString(spec.direction)).c_str() : "");
  return name;
}

}  // namespace odocal::rig
