// Strict YAML reading shared by the scenario and session parsers: every
// failure names the line and the key path (`12: runs[1].procedure: ...`).
#include "yaml_util.h"

#include <cmath>
#include <sstream>

#include "odocal/base/units.h"
#include "odocal/vision/tag.h"

namespace odocal::config::yaml_util {

using calibration::RunSpec;


using calibration::RunSpec;


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
  throw YamlError(Where(node, key_path) + ": " + message);
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
                                     bool ticks_required, double default_ticks) {
  CheckKeys(node, path,
            {"left_wheel_diameter_mm", "right_wheel_diameter_mm", "track_mm", "ticks_per_rev"});
  calibration::WheelParams p;
  p.left_wheel_diameter_m =
      Positive(RequiredNumber(node, path, "left_wheel_diameter_mm"), node,
               Join(path, "left_wheel_diameter_mm")) * kMmToM;
  p.right_wheel_diameter_m =
      Positive(RequiredNumber(node, path, "right_wheel_diameter_mm"), node,
               Join(path, "right_wheel_diameter_mm")) * kMmToM;
  p.track_m = Positive(RequiredNumber(node, path, "track_mm"), node, Join(path, "track_mm")) * kMmToM;
  if (node["ticks_per_rev"]) {
    const double ticks = Number(node["ticks_per_rev"], Join(path, "ticks_per_rev"));
    if (!(ticks > 0.0) || ticks > double(1LL << 30))
      Fail(node["ticks_per_rev"], Join(path, "ticks_per_rev"), "must be a positive number");
    p.ticks_per_rev = ticks;
  } else if (ticks_required) {
    Fail(node, Join(path, "ticks_per_rev"), "missing (required)");
  } else {
    p.ticks_per_rev = default_ticks;
  }
  return p;
}

namespace {

// Which keys each procedure takes; anything else is a mistake worth naming.
void CheckProcedureKeys(const YAML::Node& node, const std::string& path, const std::string& name,
                        calibration::Procedure procedure, const std::set<std::string>& extra_keys) {
  std::set<std::string> takes = {"procedure", "speed_mm_s", "turn_rate_deg_s"};
  takes.insert(extra_keys.begin(), extra_keys.end());
  switch (procedure) {
    case calibration::Procedure::kUmbmark: takes.insert({"direction", "side_mm"}); break;
    case calibration::Procedure::kStraight: takes.insert({"distance_mm"}); break;
    case calibration::Procedure::kSpin: takes.insert({"turns", "direction", "reference"}); break;
    case calibration::Procedure::kOutAndBack:
      takes.insert({"distance_mm", "repeats", "direction", "reference"});
      break;
    case calibration::Procedure::kRecorded: break;  // no plan: nothing to size
    case calibration::Procedure::kCircle: takes.insert({"radius_mm", "turns", "direction"}); break;
  }
  for (const auto& entry : node) {
    const std::string key = entry.first.as<std::string>();
    if (!takes.count(key))
      Fail(entry.first, Join(path, key), "does not apply to procedure " + name);
  }
}

// The run's size as its procedure needs it: the square's side, the distance,
// the circle's radius, the turns; and the repeats.
void ParseRunSize(const YAML::Node& node, const std::string& path, const std::string& name, RunSpec& spec) {
  if (spec.procedure == calibration::Procedure::kUmbmark)
    spec.side_m = Positive(RequiredNumber(node, path, "side_mm"), node["side_mm"],
                           Join(path, "side_mm")) * kMmToM;
  if (spec.procedure == calibration::Procedure::kStraight ||
      spec.procedure == calibration::Procedure::kOutAndBack)
    spec.distance_m = Positive(RequiredNumber(node, path, "distance_mm"), node["distance_mm"],
                               Join(path, "distance_mm")) * kMmToM;
  if (spec.procedure == calibration::Procedure::kCircle)
    spec.radius_m = Positive(RequiredNumber(node, path, "radius_mm"), node["radius_mm"],
                             Join(path, "radius_mm")) * kMmToM;
  if (spec.procedure == calibration::Procedure::kSpin ||
      spec.procedure == calibration::Procedure::kCircle) {
    if (!node["turns"]) Fail(node, Join(path, "turns"), "missing (required for " + name + ")");
    const long long turns = Integer(node["turns"], Join(path, "turns"));
    if (turns <= 0 || turns > 1000) Fail(node["turns"], Join(path, "turns"), "must be 1 to 1000");
    spec.turns = static_cast<int>(turns);
  }
  if (const YAML::Node r = node["repeats"]) {
    const long long repeats = Integer(r, Join(path, "repeats"));
    if (repeats <= 0 || repeats > 1000) Fail(r, Join(path, "repeats"), "must be 1 to 1000");
    spec.repeats = static_cast<int>(repeats);
  }
}

}  // namespace

RunSpec ParseRun(const YAML::Node& node, const std::string& path, const std::set<std::string>& extra_keys) {
  std::set<std::string> allowed = {"procedure", "direction", "side_mm",    "distance_mm",     "turns",
                                   "repeats",   "reference", "speed_mm_s", "turn_rate_deg_s", "radius_mm"};
  allowed.insert(extra_keys.begin(), extra_keys.end());
  CheckKeys(node, path, allowed);
  if (!node["procedure"]) Fail(node, Join(path, "procedure"), "missing (required)");
  const std::string name = String(node["procedure"], Join(path, "procedure"));
  const auto procedure = calibration::ParseProcedure(name);
  if (!procedure) {
    Fail(node["procedure"], Join(path, "procedure"),
         "unknown procedure '" + name +
             "' (expected umbmark, straight, spin, out_and_back, circle, "
             "recorded)");
  }
  RunSpec spec;
  spec.procedure = *procedure;
  CheckProcedureKeys(node, path, name, spec.procedure, extra_keys);
  spec.direction = calibration::Direction::kCcw;
  if (const YAML::Node d = node["direction"]) {
    const std::string dir = String(d, Join(path, "direction"));
    const auto parsed = calibration::ParseDirection(dir);
    if (!parsed) Fail(d, Join(path, "direction"), "expected cw or ccw, got '" + dir + "'");
    spec.direction = *parsed;
  } else if (spec.procedure == calibration::Procedure::kUmbmark) {
    Fail(node, Join(path, "direction"), "missing (required for umbmark: cw or ccw)");
  }
  ParseRunSize(node, path, name, spec);
  if (const YAML::Node r = node["reference"]) {
    const std::string ref = String(r, Join(path, "reference"));
    const auto parsed = calibration::ParseReference(ref);
    if (!parsed) Fail(r, Join(path, "reference"), "expected camera or wall, got '" + ref + "'");
    spec.reference = *parsed;
  }
  if (const YAML::Node v = node["speed_mm_s"])
    spec.speed_m_s = Positive(Number(v, Join(path, "speed_mm_s")), v, Join(path, "speed_mm_s")) * kMmToM;
  if (const YAML::Node v = node["turn_rate_deg_s"])
    spec.turn_rate_rad_s = Positive(Number(v, Join(path, "turn_rate_deg_s")), v,
                                    Join(path, "turn_rate_deg_s")) * kDegToRad;
  std::string why;
  if (!spec.IsValid(&why)) Fail(node, path, why);
  return spec;
}

vision::TagSpec ParseTag(const YAML::Node& node, const std::string& path,
                         const std::set<std::string>& extra_keys) {
  std::set<std::string> keys = {"family", "id", "size_mm", "height_mm", "offset_mm", "yaw_deg"};
  keys.insert(extra_keys.begin(), extra_keys.end());
  CheckKeys(node, path, keys);
  vision::TagSpec tag;
  if (node["family"]) tag.family = String(node["family"], Join(path, "family"));
  if (!vision::IsKnownTagFamily(tag.family))
    Fail(node["family"], Join(path, "family"), "unknown tag family '" + tag.family + "'");
  if (!node["id"]) Fail(node, Join(path, "id"), "missing (required)");
  const long long id = Integer(node["id"], Join(path, "id"));
  if (id < 0 || id > 100000) Fail(node["id"], Join(path, "id"), "must be a tag id (0 or more)");
  tag.id = static_cast<int>(id);
  tag.size_mm = Positive(RequiredNumber(node, path, "size_mm"), node["size_mm"], Join(path, "size_mm"));
  tag.height_mm = OptionalNumber(node, path, "height_mm", 0.0);
  if (tag.height_mm < 0.0) Fail(node["height_mm"], Join(path, "height_mm"), "must not be negative");
  if (const YAML::Node offset = node["offset_mm"]) {
    CheckKeys(offset, Join(path, "offset_mm"), {"x", "y"});
    tag.offset_x_mm = OptionalNumber(offset, Join(path, "offset_mm"), "x", 0.0);
    tag.offset_y_mm = OptionalNumber(offset, Join(path, "offset_mm"), "y", 0.0);
  }
  tag.yaw_deg = OptionalNumber(node, path, "yaw_deg", 0.0);
  return tag;
}

vision::FloorReference ParseFloorReference(const YAML::Node& node, const std::string& path) {
  ExpectMap(node, path);
  CheckKeys(node, path, {"family", "tags", "distances", "tag_height_sigma_mm"});
  vision::FloorReference r;
  if (node["family"]) r.family = String(node["family"], Join(path, "family"));
  if (!vision::IsKnownTagFamily(r.family))
    Fail(node["family"], Join(path, "family"), "unknown tag family '" + r.family + "'");
  const YAML::Node tags = node["tags"];
  if (!tags) Fail(node, Join(path, "tags"), "missing (required: the floor tags, at least two)");
  if (!tags.IsSequence() || tags.size() < 2)
    Fail(tags, Join(path, "tags"), "expected a list of at least two tags {id, size_mm}");
  for (size_t i = 0; i < tags.size(); ++i) {
    const std::string tp = Join(path, "tags") + "[" + std::to_string(i) + "]";
    ExpectMap(tags[i], tp);
    CheckKeys(tags[i], tp, {"id", "size_mm"});
    vision::FloorReference::Tag t;
    if (!tags[i]["id"]) Fail(tags[i], Join(tp, "id"), "missing (required)");
    const long long id = Integer(tags[i]["id"], Join(tp, "id"));
    if (id < 0 || id > 100000) Fail(tags[i]["id"], Join(tp, "id"), "must be a tag id (0 or more)");
    t.id = static_cast<int>(id);
    for (const auto& other : r.tags)
      if (other.id == t.id) Fail(tags[i]["id"], Join(tp, "id"), "tag " + std::to_string(t.id) + " listed twice");
    t.size_mm = Positive(RequiredNumber(tags[i], tp, "size_mm"), tags[i]["size_mm"], Join(tp, "size_mm"));
    r.tags.push_back(t);
  }
  const YAML::Node distances = node["distances"];
  if (!distances) Fail(node, Join(path, "distances"), "missing (required: at least one measured distance)");
  if (!distances.IsSequence() || distances.size() == 0)
    Fail(distances, Join(path, "distances"), "expected a list of {between: [A, B], mm, sigma_mm}");
  for (size_t i = 0; i < distances.size(); ++i) {
    const std::string dp = Join(path, "distances") + "[" + std::to_string(i) + "]";
    const YAML::Node d = distances[i];
    ExpectMap(d, dp);
    CheckKeys(d, dp, {"between", "mm", "sigma_mm"});
    const YAML::Node between = d["between"];
    if (!between) Fail(d, Join(dp, "between"), "missing (required: the two tag ids)");
    if (!between.IsSequence() || between.size() != 2)
      Fail(between, Join(dp, "between"), "expected two tag ids [A, B]");
    vision::FloorReference::Distance m;
    m.id_a = static_cast<int>(Integer(between[0], Join(dp, "between")));
    m.id_b = static_cast<int>(Integer(between[1], Join(dp, "between")));
    for (const int id : {m.id_a, m.id_b}) {
      bool known = false;
      for (const auto& t : r.tags) known = known || t.id == id;
      if (!known) Fail(between, Join(dp, "between"), "tag " + std::to_string(id) + " is not in " + Join(path, "tags"));
    }
    if (m.id_a == m.id_b) Fail(between, Join(dp, "between"), "joins a tag to itself");
    m.mm = Positive(RequiredNumber(d, dp, "mm"), d["mm"], Join(dp, "mm"));
    m.sigma_mm = Positive(OptionalNumber(d, dp, "sigma_mm", m.sigma_mm), d["sigma_mm"], Join(dp, "sigma_mm"));
    r.distances.push_back(m);
  }
  r.tag_height_sigma_mm = OptionalNumber(node, path, "tag_height_sigma_mm", r.tag_height_sigma_mm);
  if (!(r.tag_height_sigma_mm >= 0.0))
    Fail(node["tag_height_sigma_mm"], Join(path, "tag_height_sigma_mm"), "must not be negative");
  return r;
}

void EmitFloorReference(YAML::Emitter& out, const vision::FloorReference& r) {
  out << YAML::BeginMap;
  out << YAML::Key << "family" << YAML::Value << r.family;
  out << YAML::Key << "tags" << YAML::Value << YAML::BeginSeq;
  for (const auto& t : r.tags)
    out << YAML::Flow << YAML::BeginMap << YAML::Key << "id" << YAML::Value << t.id << YAML::Key
        << "size_mm" << YAML::Value << t.size_mm << YAML::EndMap;
  out << YAML::EndSeq << YAML::Key << "distances" << YAML::Value << YAML::BeginSeq;
  for (const auto& d : r.distances)
    out << YAML::Flow << YAML::BeginMap << YAML::Key << "between" << YAML::Value << YAML::Flow
        << YAML::BeginSeq << d.id_a << d.id_b << YAML::EndSeq << YAML::Key << "mm" << YAML::Value
        << d.mm << YAML::Key << "sigma_mm" << YAML::Value << d.sigma_mm << YAML::EndMap;
  out << YAML::EndSeq << YAML::Key << "tag_height_sigma_mm" << YAML::Value << r.tag_height_sigma_mm;
  out << YAML::EndMap;
}

}  // namespace odocal::config::yaml_util
