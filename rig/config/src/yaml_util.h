// Strict YAML reading shared by the scenario and session parsers (internal to
// rig). Every helper throws YamlError with "LINE: key.path: what is wrong";
// the loaders catch it and prefix the file name.
#ifndef ODOCAL_CONFIG_YAML_UTIL_H_
#define ODOCAL_CONFIG_YAML_UTIL_H_

#include <set>
#include <stdexcept>
#include <string>

#include <yaml-cpp/yaml.h>

#include "odocal/base/units.h"
#include "odocal/calibration/procedures.h"
#include "odocal/calibration/robot_model.h"
#include "odocal/vision/floor_reference.h"
#include "odocal/vision/tag.h"

namespace odocal::config::yaml_util {


struct YamlError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// "LINE: key.path" (or " key.path" when the node has no position).
std::string Where(const YAML::Node& node, const std::string& key_path);
[[noreturn]] void Fail(const YAML::Node& node, const std::string& key_path,
                       const std::string& message);
void ExpectMap(const YAML::Node& node, const std::string& key_path);
// Fails on any key not in `allowed`.
void CheckKeys(const YAML::Node& node, const std::string& key_path,
               const std::set<std::string>& allowed);
std::string Join(const std::string& path, const std::string& key);
double Number(const YAML::Node& node, const std::string& key_path);
double RequiredNumber(const YAML::Node& parent, const std::string& path, const std::string& key);
double OptionalNumber(const YAML::Node& parent, const std::string& path, const std::string& key,
                      double fallback);
double Positive(double value, const YAML::Node& node, const std::string& key_path);
long long Integer(const YAML::Node& node, const std::string& key_path);
std::string String(const YAML::Node& node, const std::string& key_path);
bool Bool(const YAML::Node& node, const std::string& key_path);

// {left_wheel_diameter_mm, right_wheel_diameter_mm, track_mm, ticks_per_rev}
calibration::WheelParams ParseWheels(const YAML::Node& node, const std::string& path,
                                     bool ticks_required, double default_ticks);
// One run of a plan; `extra_keys` are allowed besides the procedure's own.
calibration::RunSpec ParseRun(const YAML::Node& node, const std::string& path,
                              const std::set<std::string>& extra_keys = {});
// {family, id, size_mm, height_mm, offset_mm: {x, y}, yaw_deg}; `extra_keys`
// are allowed besides (the caller reads them).
vision::TagSpec ParseTag(const YAML::Node& node, const std::string& path = "tag",
                         const std::set<std::string>& extra_keys = {});
// {family, tags: [{id, size_mm}], distances: [{between: [A, B], mm, sigma_mm}],
//  tag_height_sigma_mm} (vision/floor_reference.h), checked.
vision::FloorReference ParseFloorReference(const YAML::Node& node, const std::string& path);
void EmitFloorReference(YAML::Emitter& out, const vision::FloorReference& reference);

}  // namespace odocal::config::yaml_util

#endif  // ODOCAL_CONFIG_YAML_UTIL_H_
