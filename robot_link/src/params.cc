#include "odocal/robot_link/params.h"

#include <charconv>
#include <cmath>
#include <ostream>
#include <sstream>

#include "odocal/base/units.h"

namespace odocal::robot_link {

const std::array<ParamInfo, 4>& ParamTable() {
  // Must match robot_link/firmware/src/olf_params.c; Hello's table checksum
  // and the firmware round-trip tests catch a drift.
  static const std::array<ParamInfo, 4> kTable = {{
      {"left_wheel_diameter_mm", ParamType::kF64, 1.0, 2000.0},
      {"right_wheel_diameter_mm", ParamType::kF64, 1.0, 2000.0},
      {"track_mm", ParamType::kF64, 10.0, 10000.0},
      {"ticks_per_rev", ParamType::kU32, 1.0, 16777216.0},
  }};
  return kTable;
}

std::optional<size_t> FindParam(std::string_view name) {
  for (size_t i = 0; i < ParamTable().size(); ++i) {
    if (ParamTable()[i].name == name) return i;
  }
  return std::nullopt;
}

uint32_t ParamTableCrc() {
  Bytes bytes;
  for (const ParamInfo& p : ParamTable()) {
    bytes.insert(bytes.end(), p.name.begin(), p.name.end());
    bytes.push_back(0);
    bytes.push_back(static_cast<uint8_t>(p.type));
  }
  return Crc32(bytes);
}

ParamValue ParamSet::Get(size_t index) const {
  switch (index) {
    case 0: return left_wheel_diameter_mm;
    case 1: return right_wheel_diameter_mm;
    case 2: return track_mm;
    default: return ticks_per_rev;
  }
}

void ParamSet::Set(size_t index, const ParamValue& value) {
  switch (index) {
    case 0: left_wheel_diameter_mm = std::get<double>(value); break;
    case 1: right_wheel_diameter_mm = std::get<double>(value); break;
    case 2: track_mm = std::get<double>(value); break;
    default: ticks_per_rev = std::get<uint32_t>(value); break;
  }
}

Bytes ParamSet::Serialize() const {
  ByteWriter w;
  w.F64(left_wheel_diameter_mm).F64(right_wheel_diameter_mm).F64(track_mm).U32(ticks_per_rev);
  return w.Take();
}

bool ParamSet::IsValid(std::string* why) const {
  for (size_t i = 0; i < ParamTable().size(); ++i) {
    const ParamInfo& p = ParamTable()[i];
    const ParamValue v = Get(i);
    const double d = std::holds_alternative<double>(v) ? std::get<double>(v)
                                                       : static_cast<double>(std::get<uint32_t>(v));
    if (!(d >= p.min_value && d <= p.max_value)) {
      if (why) {
        std::ostringstream os;
        os << p.name << " = " << FormatValue(v) << " is outside [" << p.min_value << ", "
           << p.max_value << "]";
        *why = os.str();
      }
      return false;
    }
  }
  return true;
}

std::string FormatValue(const ParamValue& value) {
  if (std::holds_alternative<uint32_t>(value)) return std::to_string(std::get<uint32_t>(value));
  // 17 significant digits: the text round-trips to the same double.
  std::ostringstream os;
  os.precision(17);
  os << std::get<double>(value);
  return os.str();
}

std::optional<ParamValue> ParseValue(size_t index, std::string_view text) {
  if (index >= ParamTable().size() || text.empty()) return std::nullopt;
  const char* first = text.data();
  const char* last = text.data() + text.size();
  if (ParamTable()[index].type == ParamType::kU32) {
    uint32_t v;
    auto [ptr, ec] = std::from_chars(first, last, v);
    if (ec != std::errc() || ptr != last) return std::nullopt;
    return v;
  }
  double v;
  auto [ptr, ec] = std::from_chars(first, last, v);
  if (ec != std::errc() || ptr != last || !std::isfinite(v)) return std::nullopt;
  return v;
}

std::ostream& operator<<(std::ostream& os, const ParamSet& set) {
  for (size_t i = 0; i < ParamTable().size(); ++i) {
    os << (i ? ", " : "{") << ParamTable()[i].name << "=" << FormatValue(set.Get(i));
  }
  return os << "}";
}

Bytes ParamBody(size_t index, const ParamValue& value) {
  const ParamInfo& info = ParamTable()[index];
  ByteWriter w;
  w.Str8(std::string(info.name)).U8(static_cast<uint8_t>(info.type));
  if (info.type == ParamType::kF64) {
    w.F64(std::get<double>(value));
  } else {
    w.U32(std::get<uint32_t>(value));
  }
  return w.Take();
}

calibration::WheelParams ToWheelParams(const ParamSet& p) {
  calibration::WheelParams w;
  w.left_wheel_diameter_m = p.left_wheel_diameter_mm * kMmToM;
  w.right_wheel_diameter_m = p.right_wheel_diameter_mm * kMmToM;
  w.track_m = p.track_mm * kMmToM;
  w.ticks_per_rev = p.ticks_per_rev;
  return w;
}

ParamSet ToParamSet(const calibration::WheelParams& w, uint32_t ticks_per_rev) {
  return ParamSet{w.left_wheel_diameter_m * kMToMm, w.right_wheel_diameter_m * kMToMm, w.track_m * kMToMm,
                  ticks_per_rev};
}

Result<ParamSet> ToParamSet(const calibration::WheelParams& w) {
  if (!(w.ticks_per_rev >= 1.0 && w.ticks_per_rev <= 4294967295.0) ||
      std::abs(w.ticks_per_rev - std::round(w.ticks_per_rev)) > 1e-9)
    return Result<ParamSet>::Error(StatusCode::kInvalidArgument,
                                   "ticks_per_rev: the robot link carries whole ticks per revolution");
  return Result<ParamSet>::Ok(ToParamSet(w, static_cast<uint32_t>(std::round(w.ticks_per_rev))));
}

}  // namespace odocal::robot_link
