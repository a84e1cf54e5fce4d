#include "odocal/config/optiodom.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>
#include <vector>

#include "odocal/base/units.h"
#include "odocal/config/files.h"
#include "odocal/config/session.h"

namespace odocal::config {
namespace {

namespace fs = std::filesystem;

constexpr char kAttribution[] =
    "Source: OptiOdom data set (Sousa, Petry, Costa et al., \"OptiOdom: a generic approach for "
    "odometry calibration of wheeled mobile robots\", J. Intell. Robot. Syst. 2022), MIT licence";

std::vector<std::string> Split(const std::string& line) {
  std::vector<std::string> fields;
  std::stringstream ss(line);
  std::string f;
  while (std::getline(ss, f, ',')) {
    while (!f.empty() && (f.back() == '\r' || f.back() == ' ')) f.pop_back();
    fields.push_back(f);
  }
  return fields;
}

bool ToNumber(const std::string& field, double* value) {
  if (field.empty()) return false;
  char* end = nullptr;
  *value = std::strtod(field.c_str(), &end);
  return end == field.c_str() + field.size() && std::isfinite(*value);
}

struct Metadata {
  std::string type = "diff";  // the robot's drive: diff, omni3, omni4, tricycle
  double ticks_per_rev = 0.0;
  double track_m = 0.0;
  double right_diameter_m = 0.0;
  double left_diameter_m = 0.0;
  int runs = 0;
  std::optional<double> side_m;
};

// The metadata's numbers: `key,v1,v2,...` rows; nullopt with an error naming
// the file (and line).
std::optional<Metadata> ReadMetadata(const std::string& path, std::string* error) {
  std::ifstream in(path);
  if (!in) {
    *error = path + ": cannot read";
    return std::nullopt;
  }
  std::map<std::string, std::pair<int, std::vector<std::string>>> rows;
  std::string line;
  for (int line_no = 1; std::getline(in, line); ++line_no) {
    std::vector<std::string> fields = Split(line);
    if (fields.empty() || fields[0].empty()) continue;
    const std::string key = fields[0];
    fields.erase(fields.begin());
    while (!fields.empty() && fields.back().empty()) fields.pop_back();
    rows[key] = {line_no, fields};
  }
  auto number = [&](const std::string& key, size_t index, double* value) {
    const auto it = rows.find(key);
    if (it == rows.end()) {
      *error = path + ": no row '" + key + "'";
      return false;
    }
    const auto& [line_no, values] = it->second;
    if (index >= values.size() || !ToNumber(values[index], value)) {
      *error = path + ":" + std::to_string(line_no) + ": " + key + ": expected a number in column " +
               std::to_string(index + 2);
      return false;
    }
    return true;
  };
  Metadata m;
  // Older layouts have no `type` row: they are all differential drives.
  if (const auto it = rows.find("type"); it != rows.end() && !it->second.second.empty())
    m.type = it->second.second.front();
  if (m.type != "diff") {
    *error = path + ":" + std::to_string(rows["type"].first) + ": type " + m.type +
             ": not a differential-drive robot (type diff); odocal calibrates differential drives";
    return m;  // read no further: the other rows mean other things for other drives
  }
  double ngear = 0.0, enc = 0.0, n = 0.0;
  if (!number("ngear", 0, &ngear) || !number("encRes", 0, &enc) || !number("Li", 0, &m.track_m) ||
      !number("Di", 0, &m.right_diameter_m) || !number("Di", 1, &m.left_diameter_m) ||
      !number("N", 0, &n))
    return std::nullopt;
  m.ticks_per_rev = ngear * enc;
  m.runs = static_cast<int>(std::lround(n));
  if (!(m.ticks_per_rev > 0.0) || !(m.track_m > 0.0) || !(m.right_diameter_m > 0.0) ||
      !(m.left_diameter_m > 0.0) || m.runs <= 0) {
    *error = path + ": ngear, encRes, Li, Di and N must be positive";
    return std::nullopt;
  }
  if (rows.count("L") && !rows["L"].second.empty()) {
    double side = 0.0;
    if (!number("L", 0, &side)) return std::nullopt;
    if (side > 0.0) m.side_m = side;
  }
  return m;
}

struct ConvertedRun {
  double net_heading_rad = 0.0;
  int rows = 0;
};

// One run file -> its pose log and its telemetry (cumulative ticks).
std::optional<ConvertedRun> ConvertRun(const std::string& path, const std::string& poses_path,
                                       const std::string& telemetry_path, std::string* error) {
  std::ifstream in(path);
  if (!in) {
    *error = path + ": cannot read";
    return std::nullopt;
  }
  std::string poses = "t_s,x_mm,y_mm,heading_deg\n";
  std::string telemetry = "t_s,left_ticks,right_ticks\n";
  long long left = 0, right = 0;
  ConvertedRun run;
  double first_theta = 0.0, last_theta = 0.0;
  std::string line;
  char buffer[160];
  for (int line_no = 1; std::getline(in, line); ++line_no) {
    if (line.empty() || line == "\r") continue;
    const std::vector<std::string> f = Split(line);
    if (f.size() != 6) {
      *error = path + ":" + std::to_string(line_no) + ": expected 6 fields (time_s, x_m, y_m, " +
               "theta_rad, right_ticks, left_ticks), got " + std::to_string(f.size());
      return std::nullopt;
    }
    double v[6];
    for (int i = 0; i < 6; ++i) {
      if (!ToNumber(f[i], &v[i])) {
        *error = path + ":" + std::to_string(line_no) + ":" + std::to_string(i + 1) +
                 ": not a number: '" + f[i] + "'";
        return std::nullopt;
      }
    }
    right += std::llround(v[4]);
    left += std::llround(v[5]);
    std::snprintf(buffer, sizeof(buffer), "%.4f,%.4f,%.4f,%.5f\n", v[0], v[1] * kMToMm, v[2] * kMToMm,
                  RadToDeg(v[3]));
    poses += buffer;
    std::snprintf(buffer, sizeof(buffer), "%.4f,%lld,%lld\n", v[0], left, right);
    telemetry += buffer;
    if (run.rows == 0) first_theta = v[3];
    last_theta = v[3];
    ++run.rows;
  }
  if (run.rows < 2) {
    *error = path + ": fewer than two rows";
    return std::nullopt;
  }
  run.net_heading_rad = last_theta - first_theta;  // theta is logged unwrapped
  if (const Status e = WriteFileAtomically(poses_path, poses); !e) {
    *error = e.message;
    return std::nullopt;
  }
  if (const Status e = WriteFileAtomically(telemetry_path, telemetry); !e) {
    *error = e.message;
    return std::nullopt;
  }
  return run;
}

}  // namespace

namespace {

// The import: the number of runs, or nullopt with one error line and its
// code (kBadFile unless the output could not be written).
std::optional<int> ImportSet(const fs::path& set_dir, const std::string& category, const fs::path& out_dir,
                             std::string* error, StatusCode* code) {
  *code = StatusCode::kBadFile;
  const std::string set = set_dir.filename().string();
  const auto meta = ReadMetadata((set_dir / (set + "_metadata.csv")).string(), error);
  if (!meta || meta->type != "diff") return std::nullopt;
  // Every run file the metadata names, before anything is written: a set
  // that cannot be imported leaves no partial output behind.
  for (int k = 1; k <= meta->runs; ++k) {
    char nn[16];
    std::snprintf(nn, sizeof(nn), "%02d", k);
    const fs::path source = set_dir / (set + "_run-" + nn + ".csv");
    if (!fs::exists(source)) {
      *error = source.string() + ": no such file (the metadata says N = " + std::to_string(meta->runs) + ")";
      return std::nullopt;
    }
  }
  if (const Status e = EnsureDirectory(out_dir.string()); !e) {
    *error = e.message;
    *code = StatusCode::kIoError;
    return std::nullopt;
  }
  Session session;
  session.path = (out_dir / "session.yaml").string();
  session.has_camera = false;
  session.nominal.left_wheel_diameter_m = meta->left_diameter_m;
  session.nominal.right_wheel_diameter_m = meta->right_diameter_m;
  session.nominal.track_m = meta->track_m;
  session.nominal.ticks_per_rev = meta->ticks_per_rev;
  const bool square = category == "square";
  if (square && !meta->side_m) {
    *error = (set_dir / (set + "_metadata.csv")).string() + ": a square set needs L (the side)";
    return std::nullopt;
  }
  for (int k = 1; k <= meta->runs; ++k) {
    char nn[16];
    std::snprintf(nn, sizeof(nn), "%02d", k);
    const fs::path source = set_dir / (set + "_run-" + nn + ".csv");
    SessionRun run;
    run.name = category + "_run" + nn;
    run.poses = (out_dir / (std::string("run") + nn + ".poses.csv")).string();
    run.telemetry = (out_dir / (std::string("run") + nn + ".telemetry.csv")).string();
    run.end_s = std::numeric_limits<double>::infinity();
    const auto converted = ConvertRun(source.string(), run.poses, run.telemetry, error);
    if (!converted) return std::nullopt;
    if (square) {
      const auto direction = converted->net_heading_rad < 0.0 ? calibration::Direction::kCw
                                                               : calibration::Direction::kCcw;
      run.spec = calibration::RunSpec::Umbmark(direction, *meta->side_m);
    } else {
      run.spec.procedure = calibration::Procedure::kRecorded;
    }
    session.runs.push_back(run);
  }
  const std::vector<std::string> comment = {
      kAttribution,
      "Imported by `odocal import optiodom` from " + (category.empty() ? "" : category + "/") + set +
          " (see SOURCE.md)"};
  if (const Status e = WriteSession(session, session.path, comment); !e) {
    *error = e.message;
    *code = StatusCode::kIoError;
    return std::nullopt;
  }
  const std::string source_md =
      "# Source\n\n" + std::string(kAttribution) +
      ".\nPublished with the authors' MATLAB code; the data are used under its MIT licence.\n\n"
      "Set `" + (category.empty() ? "" : category + "/") + set + "`, converted by `odocal import "
      "optiodom`: the motion capture poses (already at the robot centre, synchronised with the "
      "50 ms control cycles) as `runNN.poses.csv` in millimetres and degrees, the per-cycle "
      "encoder increments summed into cumulative ticks as `runNN.telemetry.csv`; the nominal "
      "parameters from `" + set + "_metadata.csv` (Di right, left; Li; encRes x ngear).\n";
  if (const Status e = WriteFileAtomically((out_dir / "SOURCE.md").string(), source_md); !e) {
    *error = e.message;
    *code = StatusCode::kIoError;
    return std::nullopt;
  }
  return meta->runs;
}

}  // namespace

Result<int> ImportOptiodomSet(const fs::path& set_dir, const std::string& category, const fs::path& out_dir) {
  std::string error;
  StatusCode code = StatusCode::kBadFile;
  const std::optional<int> runs = ImportSet(set_dir, category, out_dir, &error, &code);
  if (!runs) return Result<int>::Error(code, error);
  return Result<int>::Ok(*runs);
}

std::string OptiodomRobotType(const fs::path& set_dir) {
  std::string error;
  const auto meta = ReadMetadata((set_dir / (set_dir.filename().string() + "_metadata.csv")).string(), &error);
  return meta ? meta->type : "diff";
}

bool IsOptiodomSet(const fs::path& dir) {
  return fs::is_directory(dir) &&
         fs::exists(dir / (dir.filename().string() + "_metadata.csv"));
}


}  // namespace odocal::config
