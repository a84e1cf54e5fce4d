// The robot's odometry parameter set as the host sees it. Units at this edge
// are the robot's: millimetres and encoder ticks per wheel revolution (the
// calibration module works in metres; convert where the two meet).
#ifndef ODOCAL_ROBOT_LINK_PARAMS_H_
#define ODOCAL_ROBOT_LINK_PARAMS_H_

#include <array>
#include <cstdint>
#include <iosfwd>
#include <optional>
#include <string>
#include <string_view>
#include <variant>

#include "odocal/base/status.h"
#include "odocal/calibration/robot_model.h"
#include "odocal/robot_link/codec.h"

namespace odocal::robot_link {

enum class ParamType : uint8_t { kF64 = 1, kU32 = 2 };
using ParamValue = std::variant<double, uint32_t>;

struct ParamInfo {
  std::string_view name;
  ParamType type;
  double min_value;  // inclusive, as the firmware table checks them
  double max_value;
};

// The host's copy of the firmware table, in wire order. Hello compares its
// checksum with the robot's, so a robot with another table is refused.
const std::array<ParamInfo, 4>& ParamTable();

// The body of a PARAM_SET or STAGE_PUT request for table entry `index`:
// name (str8), type (u8), value (f64 or u32, little-endian).
Bytes ParamBody(size_t index, const ParamValue& value);
std::optional<size_t> FindParam(std::string_view name);
uint32_t ParamTableCrc();

struct ParamSet {
  double left_wheel_diameter_mm = 0.0;
  double right_wheel_diameter_mm = 0.0;
  double track_mm = 0.0;
  uint32_t ticks_per_rev = 0;

  ParamValue Get(size_t index) const;
  void Set(size_t index, const ParamValue& value);
  // Canonical bytes (table order, f64/u32 little-endian): what the checksum
  // covers and what "the same set" means. Read-backs compare these bytes, so
  // equality is bitwise, not within a tolerance: a set is pushed exactly.
  Bytes Serialize() const;
  uint32_t Checksum() const { return Crc32(Serialize()); }
  bool SameBits(const ParamSet& other) const { return Serialize() == other.Serialize(); }
  // Range check against the table; `why` names the offending parameter.
  bool IsValid(std::string* why) const;
};

std::ostream& operator<<(std::ostream& os, const ParamSet& set);
std::string FormatValue(const ParamValue& value);
// Parses a value for parameter `index` from text ("72.4", "4096").
std::optional<ParamValue> ParseValue(size_t index, std::string_view text);

// The link's parameter set (millimetres, whole ticks) and the estimators'
// calibration::WheelParams (metres): the one mapping between them.
calibration::WheelParams ToWheelParams(const ParamSet& params);
ParamSet ToParamSet(const calibration::WheelParams& params, uint32_t ticks_per_rev);
// kInvalidArgument naming ticks_per_rev when it is not a whole number the link can carry.
Result<ParamSet> ToParamSet(const calibration::WheelParams& params);

}  // namespace odocal::robot_link

#endif  // ODOCAL_ROBOT_LINK_PARAMS_H_
