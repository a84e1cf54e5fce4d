#include "odocal/config/calib_target.h"

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include <yaml-cpp/yaml.h>

#include "file_result.h"
#include "yaml_util.h"

namespace odocal::config {

namespace {

// The parser: the board, or nullopt with one error line.
std::optional<vision::CalibrationBoard> ParseTargetText(const std::string& text, const std::string& name,
                                                        std::string* error) {
  using namespace yaml_util;
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    *error = name + ":" + std::to_string(e.mark.line + 1) + ": not valid YAML: " + e.msg;
    return std::nullopt;
  }
  try {
    ExpectMap(root, "");
    // Kalibr: the target at the top level; yac: under calib_target, snake_case.
    const bool yac = !root["target_type"] && root["calib_target"];
    const YAML::Node t = yac ? root["calib_target"] : root;
    const std::string path = yac ? "calib_target" : "";
    ExpectMap(t, path);
    auto key = [&](const char* kalibr, const char* snake) { return std::string(yac ? snake : kalibr); };
    if (!t["target_type"]) Fail(t, Join(path, "target_type"), "missing (required; Kalibr's target.yaml)");
    const std::string type = String(t["target_type"], Join(path, "target_type"));
    if (type != "aprilgrid") {
      Fail(t["target_type"], Join(path, "target_type"),
           "'" + type + "': only aprilgrid targets are read from a file (a checkerboard is "
           "--board chessboard:COLSxROWS:SQUARE_MM, inner corners)");
    }
    if (yac) {
      CheckKeys(t, path, {"target_type", "tag_rows", "tag_cols", "tag_size", "tag_spacing", "code_offset"});
    } else {
      CheckKeys(t, path, {"target_type", "tagRows", "tagCols", "tagSize", "tagSpacing", "codeOffset"});
    }
    vision::CalibrationBoard board;
    board.type = vision::CalibrationBoard::Type::kAprilgrid;
    auto count = [&](const std::string& k) {
      if (!t[k]) Fail(t, Join(path, k), "missing (required)");
      const long long v = Integer(t[k], Join(path, k));
      if (v < 1 || v > 1000) Fail(t[k], Join(path, k), "must be a whole number in [1, 1000]");
      return static_cast<int>(v);
    };
    board.cols = count(key("tagCols", "tag_cols"));
    board.rows = count(key("tagRows", "tag_rows"));
    const std::string size_key = key("tagSize", "tag_size"), spacing_key = key("tagSpacing", "tag_spacing");
    board.square_m = Positive(RequiredNumber(t, path, size_key), t[size_key], Join(path, size_key));
    board.spacing = Positive(RequiredNumber(t, path, spacing_key), t[spacing_key], Join(path, spacing_key));
    const std::string offset_key = key("codeOffset", "code_offset");
    if (t[offset_key]) {
      const long long v = Integer(t[offset_key], Join(path, offset_key));
      if (v < 0) Fail(t[offset_key], Join(path, offset_key), "must be >= 0");
      board.first_id = static_cast<int>(v);
    }
    std::string why;
    if (!board.IsValid(&why)) Fail(t, path.empty() ? "target" : path, why);
    return board;
  } catch (const YamlError& e) {
    *error = name + ":" + e.what();
    return std::nullopt;
  }
}

}  // namespace

Result<vision::CalibrationBoard> ParseCalibrationTarget(const std::string& text, const std::string& name) {
  std::string error;
  std::optional<vision::CalibrationBoard> board = ParseTargetText(text, name, &error);
  if (!board) return Result<vision::CalibrationBoard>::Error(StatusCode::kBadFile, error);
  return Result<vision::CalibrationBoard>::Ok(std::move(*board));
}

Result<vision::CalibrationBoard> ReadCalibrationTarget(const std::string& path) {
  return ReadFileAs<vision::CalibrationBoard>(path, [&](std::string* error) -> std::optional<vision::CalibrationBoard> {
    std::ifstream in(path, std::ios::binary);
    if (!in) {
      *error = path + ": cannot open file";
      return std::nullopt;
    }
    std::stringstream buffer;
    buffer << in.rdbuf();
    return ParseTargetText(buffer.str(), path, error);
  });
}

Result<std::vector<YacAprilgridCorner>> ReadYacAprilgridCsv(const std::string& path) {
  return ReadFileAs<std::vector<YacAprilgridCorner>>(
      path, [&](std::string* error) -> std::optional<std::vector<YacAprilgridCorner>> {
        std::ifstream in(path);
        if (!in) {
          *error = path + ": cannot open file";
          return std::nullopt;
        }
        std::vector<YacAprilgridCorner> out;
        std::string line;
        for (int number = 1; std::getline(in, line); ++number) {
          if (!line.empty() && line.back() == '\r') line.pop_back();
          if (line.empty() || line[0] == '#') continue;
          std::vector<double> v;
          std::stringstream fields(line);
          bool numbers = true;
          for (std::string f; std::getline(fields, f, ',');) {
            char* end = nullptr;
            const double x = std::strtod(f.c_str(), &end);
            numbers = numbers && end != f.c_str() && std::isfinite(x);
            v.push_back(x);
          }
          if (!numbers || v.size() != 12) {
            *error = path + ":" + std::to_string(number) +
                     ": expected 12 numbers (ts, tag_rows, tag_cols, tag_size, tag_spacing, kp_x, kp_y, p_x, p_y, "
                     "p_z, tag_id, corner_idx)";
            return std::nullopt;
          }
          YacAprilgridCorner c;
          c.tag_id = static_cast<int>(v[10]);
          c.corner = static_cast<int>(v[11]);
          if (c.corner < 0 || c.corner > 3) {
            *error = path + ":" + std::to_string(number) + ": corner_idx " + std::to_string(c.corner) +
                     " is not 0..3";
            return std::nullopt;
          }
          c.x_px = v[5];
          c.y_px = v[6];
          c.board_x_m = v[7];
          c.board_y_m = v[8];
          out.push_back(c);
        }
        return out;
      });
}

}  // namespace odocal::config
