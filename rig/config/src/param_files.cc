#include "odocal/config/param_files.h"

#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>
#include <yaml-cpp/yaml.h>

#include "file_result.h"
#include "yaml_util.h"

#include "odocal/base/units.h"
#include "odocal/calibration/effect_registry.h"

namespace odocal::config {
namespace {

namespace fs = std::filesystem;
using calibration::Effect;
using calibration::EffectParams;
using yaml_util::YamlError;

bool IsName(const std::string& s) {
  if (s.empty()) return false;
  for (char c : s)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_' && c != '-' && c != '.')
      return false;
  return true;
}

// Thrown inside the readers with "key.path: what"; the caller prefixes the file.
struct KeyError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

ReplaySet FromFirmware(const YAML::Node& root, const calibration::WheelParams& believed) {
  // Strict: the four keys and no other (rig/exports.h writes exactly these).
  const calibration::WheelParams p = yaml_util::ParseWheels(root, "", true, 0.0);
  ReplaySet set;
  set.kind = ParamFileKind::kFirmware;
  set.model.scales.r_left = p.LeftMetresPerTick() / believed.LeftMetresPerTick();
  set.model.scales.r_right = p.RightMetresPerTick() / believed.RightMetresPerTick();
  set.model.scales.Eb = p.track_m / believed.track_m;
  return set;
}

ReplaySet FromRos2(const YAML::Node& root) {
  const YAML::Node controller = root["diff_drive_controller"];
  yaml_util::ExpectMap(controller, "diff_drive_controller");
  const YAML::Node params = controller["ros__parameters"];
  if (!params) yaml_util::Fail(controller, "diff_drive_controller.ros__parameters", "missing (required)");
  const std::string path = "diff_drive_controller.ros__parameters";
  yaml_util::ExpectMap(params, path);
  auto multiplier = [&](const std::string& key) {
    const double v = yaml_util::RequiredNumber(params, path, key);
    return yaml_util::Positive(v, params[key], yaml_util::Join(path, key));
  };
  ReplaySet set;
  set.kind = ParamFileKind::kRos2;
  set.model.scales.r_left = multiplier("left_wheel_radius_multiplier");
  set.model.scales.r_right = multiplier("right_wheel_radius_multiplier");
  set.model.scales.Eb = multiplier("wheel_separation_multiplier");
  return set;
}

// final.parameters.<key>.value
double FitValue(const nlohmann::json& parameters, const std::string& key, bool positive) {
  const std::string where = "final.parameters." + key;
  if (!parameters.contains(key)) throw KeyError(where + ": missing (required)");
  const nlohmann::json& p = parameters[key];
  if (!p.is_object() || !p.contains("value") || !p["value"].is_number())
    throw KeyError(where + ".value: expected a number");
  const double v = p["value"].get<double>();
  if (!std::isfinite(v) || (positive && !(v > 0.0)))
    throw KeyError(where + ".value: must be a " + std::string(positive ? "positive " : "") +
                   "number, got " + p["value"].dump());
  return v;
}

ReplaySet FromExplain(const nlohmann::json& j, const calibration::WheelParams& believed) {
  if (!j["final"].is_object() || !j["final"].contains("parameters") ||
      !j["final"]["parameters"].is_object())
    throw KeyError("final.parameters: missing (required)");
  const nlohmann::json& p = j["final"]["parameters"];
  const double ed = FitValue(p, "Ed", true), es = FitValue(p, "Es", true),
               eb = FitValue(p, "Eb", true);
  ReplaySet set;
  set.kind = ParamFileKind::kExplain;
  // Ed = r_r / r_l and Es = (r_l D_L + r_r D_R) / (D_L + D_R) (trajectory_fit.cc).
  const double dl = believed.left_wheel_diameter_m, dr = believed.right_wheel_diameter_m;
  set.model.scales.r_left = es * (dl + dr) / (dl + ed * dr);
  set.model.scales.r_right = ed * set.model.scales.r_left;
  set.model.scales.Eb = eb;
  // The fit's scales are relative to the beliefs of the session it was fitted
  // on; when explain.json states them, re-express the physical robot relative
  // to this session's (the same robot recorded with other beliefs).
  if (j.contains("believed") && j["believed"].is_object()) {
    const nlohmann::json& b = j["believed"];
    auto mm = [&](const char* key) {
      if (!b.contains(key) || !b[key].is_number() || !(b[key].get<double>() > 0.0))
        throw KeyError(std::string("believed.") + key + ": expected a positive number");
      return b[key].get<double>();
    };
    calibration::WheelParams fitted_on;
    fitted_on.left_wheel_diameter_m = mm("left_wheel_diameter_mm") * kMmToM;
    fitted_on.right_wheel_diameter_m = mm("right_wheel_diameter_mm") * kMmToM;
    fitted_on.track_m = mm("track_mm") * kMmToM;
    fitted_on.ticks_per_rev = mm("ticks_per_rev");
    const double rl = es * (fitted_on.left_wheel_diameter_m + fitted_on.right_wheel_diameter_m) /
                      (fitted_on.left_wheel_diameter_m + ed * fitted_on.right_wheel_diameter_m);
    set.model.scales.r_left = rl * fitted_on.LeftMetresPerTick() / believed.LeftMetresPerTick();
    set.model.scales.r_right =
        ed * rl * fitted_on.RightMetresPerTick() / believed.RightMetresPerTick();
    set.model.scales.Eb = eb * fitted_on.track_m / believed.track_m;
  }
  if (!j.contains("effects_added")) throw KeyError("effects_added: missing (required)");
  if (!j["effects_added"].is_array()) throw KeyError("effects_added: expected a list of effects");
  for (const nlohmann::json& name : j["effects_added"]) {
    const std::optional<Effect> effect =
        name.is_string() ? calibration::EffectNamed(name.get<std::string>()) : std::nullopt;
    if (!effect) throw KeyError("effects_added: unknown effect " + name.dump());
    set.effects.push_back(*effect);
    const std::string prefix = std::string(calibration::ToString(*effect)) + ".";
    if (*effect == Effect::kCarpetDrift) {
      // Reported as rate and grain; the model holds rate (cos grain, sin grain).
      const double rate = FitValue(p, prefix + "rate_m_per_m", false);
      const double grain = FitValue(p, prefix + "grain_rad", false);
      set.model.effects.values[EffectParams::kDriftA] = rate * std::cos(grain);
      set.model.effects.values[EffectParams::kDriftB] = rate * std::sin(grain);
      continue;
    }
    const std::vector<int> indices = calibration::EffectParamIndices(*effect);
    const std::vector<std::string> names = calibration::EffectParamNames(*effect);
    for (size_t k = 0; k < indices.size(); ++k)
      set.model.effects.values[indices[k]] = FitValue(p, prefix + names[k], false);
  }
  return set;
}

std::string Keys(const YAML::Node& root) {
  std::string keys;
  for (const auto& kv : root) keys += (keys.empty() ? "" : ", ") + kv.first.as<std::string>("?");
  return keys;
}

}  // namespace

std::string_view ToString(ParamFileKind kind) {
  switch (kind) {
    case ParamFileKind::kNominal: return "nominal";
    case ParamFileKind::kFirmware: return "firmware";
    case ParamFileKind::kRos2: return "ros2";
    case ParamFileKind::kExplain: return "explain";
  }
  return "?";
}

calibration::WheelParams ReplaySet::Equivalent(const calibration::WheelParams& believed) const {
  calibration::WheelParams p = believed;
  p.left_wheel_diameter_m *= model.scales.r_left;
  p.right_wheel_diameter_m *= model.scales.r_right;
  p.track_m *= model.scales.Eb;
  return p;
}

Result<ParamSpec> ParseParamSpec(const std::string& text) {
  auto fail = [&](const std::string& m) {
    return Result<ParamSpec>::Error(StatusCode::kInvalidArgument, "--params " + text + ": " + m);
  };
  ParamSpec spec;
  const size_t eq = text.find('=');
  if (eq != std::string::npos && IsName(text.substr(0, eq))) {
    spec.name = text.substr(0, eq);
    spec.path = text.substr(eq + 1);
  } else if (eq == 0) {
    return fail("empty NAME in NAME=FILE");
  } else {
    spec.path = text;
    spec.name = fs::path(text).stem().string();
  }
  if (spec.path.empty()) return fail("no file (NAME=FILE or FILE)");
  if (spec.name.empty()) return fail("no name; write NAME=FILE");
  return Result<ParamSpec>::Ok(std::move(spec));
}

ReplaySet NominalReplaySet() {
  ReplaySet set;
  set.name = "nominal";
  set.kind = ParamFileKind::kNominal;
  return set;
}

namespace {

// The parser; the public function wraps its error line in a Result.
std::optional<ReplaySet> ReadReplaySetOrError(const ParamSpec& spec, const calibration::WheelParams& believed,
                                     std::string* error) {
  const std::string& path = spec.path;
  auto fail = [&](const std::string& m) -> std::optional<ReplaySet> {
    if (error) *error = path + ": " + m;
    return std::nullopt;
  };
  std::string why;
  if (!believed.IsValid(&why)) return fail("the session's nominal parameters: " + why);
  if (fs::is_directory(path)) return fail("is a directory, not a parameter file");
  std::ifstream in(path);
  if (!in) return fail(fs::exists(path) ? "cannot be read" : "no such file");
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string text = ss.str();

  std::optional<ReplaySet> set;
  const nlohmann::json j = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (j.is_object() && j.contains("final")) {
    try {
      set = FromExplain(j, believed);
    } catch (const KeyError& e) {
      return fail(std::string("explain.json: ") + e.what());
    }
  } else {
    YAML::Node root;
    try {
      root = YAML::Load(text);
    } catch (const YAML::Exception& e) {
      if (error)
        *error = path + ":" + std::to_string(e.mark.line + 1) + ": not valid YAML or JSON: " + e.msg;
      return std::nullopt;
    }
    const char* kKnown =
        "expected a firmware export (left_wheel_diameter_mm, right_wheel_diameter_mm, track_mm, "
        "ticks_per_rev), a ROS 2 file (diff_drive_controller.ros__parameters) or an "
        "explain.json (final.parameters)";
    if (!root.IsMap()) return fail(std::string("no parameter set: ") + kKnown);
    try {
      if (root["diff_drive_controller"]) {
        set = FromRos2(root);
      } else if (root["left_wheel_diameter_mm"] || root["right_wheel_diameter_mm"] ||
                 root["track_mm"] || root["ticks_per_rev"]) {
        set = FromFirmware(root, believed);
      } else {
        return fail("no parameter set (keys: " + Keys(root) + "): " + kKnown);
      }
    } catch (const YamlError& e) {
      // "FILE:LINE: key: what", as the session and scenario loaders say it.
      if (error) *error = path + ":" + e.what();
      return std::nullopt;
    } catch (const YAML::Exception& e) {
      if (error) *error = path + ":" + std::to_string(e.mark.line + 1) + ": " + e.msg;
      return std::nullopt;
    }
  }
  // Every kind ends as scales: one check that they are physical.
  const calibration::WheelScales& s = set->model.scales;
  for (double v : {s.r_left, s.r_right, s.Eb})
    if (!std::isfinite(v) || !(v > 0.0))
      return fail("the wheel scales (" + std::to_string(s.r_left) + ", " +
                  std::to_string(s.r_right) + ", " + std::to_string(s.Eb) +
                  ") are not positive numbers");
  for (double v : set->model.effects.values)
    if (!std::isfinite(v)) return fail("an effect parameter is not a finite number");
  set->name = spec.name;
  set->path = path;
  return set;
}

}  // namespace

Result<ReplaySet> ReadReplaySet(const ParamSpec& spec, const calibration::WheelParams& believed) {
  return ReadFileAs<ReplaySet>(spec.path, [&](std::string* error) { return ReadReplaySetOrError(spec, believed, error); });
}

}  // namespace odocal::config
