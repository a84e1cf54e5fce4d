#include "cli_util.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <mutex>
#include <sstream>
#include <stdexcept>

#include <unistd.h>

#include <CLI/CLI.hpp>

#include "odocal/base/units.h"
#include "odocal/config/calib_target.h"

namespace odocal::app {
namespace {

std::vector<std::string> Split(const std::string& text, char sep) {
  std::vector<std::string> out;
  std::stringstream s(text);
  std::string field;
  while (std::getline(s, field, sep)) out.push_back(field);
  if (!text.empty() && text.back() == sep) out.emplace_back();
  return out;
}

bool PositiveNumber(const std::string& text, double* value) {
  char* end = nullptr;
  *value = std::strtod(text.c_str(), &end);
  return !text.empty() && *end == '\0' && std::isfinite(*value) && *value > 0.0;
}

bool CountPair(const std::string& text, int* cols, int* rows) {
  const auto parts = Split(text, 'x');
  if (parts.size() != 2) return false;
  for (const std::string& p : parts) {
    if (p.empty() || p.find_first_not_of("0123456789") != std::string::npos || p.size() > 4) return false;
  }
  *cols = std::stoi(parts[0]);
  *rows = std::stoi(parts[1]);
  return true;
}

}  // namespace

void Fail(const std::string& command, int exit_code, const std::string& message) {
  std::cerr << "odocal " << command << ": " << message << std::endl;
  throw CLI::RuntimeError(exit_code);
}

std::optional<std::vector<double>> ParseNumberList(const std::string& text) {
  std::vector<double> values;
  size_t start = 0;
  while (start <= text.size()) {
    const size_t comma = text.find(',', start);
    const std::string field =
        text.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
    if (field.empty()) return std::nullopt;
    char* end = nullptr;
    const double value = std::strtod(field.c_str(), &end);
    if (end == field.c_str() || *end != '\0' || !std::isfinite(value)) return std::nullopt;
    values.push_back(value);
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return values;
}

vision::TagSpec ParseTagOption(const std::string& command, const std::string& option, const std::string& text) {
  std::vector<std::string> parts;
  std::stringstream in(text);
  for (std::string p; std::getline(in, p, ':');) parts.push_back(p);
  auto fail = [&](const std::string& why) {
    Fail(command, kExitBadInput,
         option + " " + text + ": " + why + " (expected FAMILY:ID:SIZE_MM[:HEIGHT_MM], e.g. tag36h11:5:80:150; "
         "tag36h11b2 for Kalibr-style tags with a 2-bit border)");
  };
  if (parts.size() < 3 || parts.size() > 4) fail("wrong number of fields");
  vision::TagSpec tag;
  tag.family = parts[0];
  try {
    size_t used = 0;
    tag.id = std::stoi(parts[1], &used);
    if (used != parts[1].size() || tag.id < 0) fail("ID must be a whole number >= 0");
    tag.size_mm = std::stod(parts[2], &used);
    if (used != parts[2].size() || !(tag.size_mm > 0.0)) fail("SIZE_MM must be a positive number");
    if (parts.size() == 4) {
      tag.height_mm = std::stod(parts[3], &used);
      if (used != parts[3].size() || tag.height_mm < 0.0) fail("HEIGHT_MM must be a number >= 0");
    }
  } catch (const std::exception&) {
    fail("not a number");
  }
  return tag;
}

vision::CameraMount ParseMountOption(const std::string& command, const std::string& option,
                                     const std::string& text) {
  std::vector<double> v;
  std::stringstream in(text);
  for (std::string p; std::getline(in, p, ',');) {
    try {
      size_t used = 0;
      v.push_back(std::stod(p, &used));
      if (used != p.size()) throw std::invalid_argument(p);
    } catch (const std::exception&) {
      Fail(command, kExitBadInput, option + " " + text + ": '" + p + "' is not a number");
    }
  }
  if (v.size() != 6)
    Fail(command, kExitBadInput, option + " " + text + ": expected x,y,height,roll,pitch,yaw (mm, deg)");
  return {v[0], v[1], v[2], v[3], v[4], v[5]};
}

namespace {

// The files directly in `dir` whose extension (any case) is one of `extensions`, sorted.
std::vector<std::string> FilesWithExtensions(const std::string& dir, const std::vector<std::string>& extensions,
                                             std::error_code* ec) {
  namespace fs = std::filesystem;
  std::vector<std::string> found;
  for (const fs::directory_entry& e : fs::directory_iterator(dir, *ec)) {
    if (!e.is_regular_file(*ec)) continue;
    std::string ext = e.path().extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    if (std::find(extensions.begin(), extensions.end(), ext) != extensions.end()) found.push_back(e.path().string());
  }
  std::sort(found.begin(), found.end());
  return found;
}

// The folders below `dir` (at most `depth` levels down) holding such files, sorted.
std::vector<std::string> FoldersWithExtensions(const std::string& dir, const std::vector<std::string>& extensions,
                                               int depth) {
  namespace fs = std::filesystem;
  std::vector<std::string> out;
  std::error_code ec;
  for (auto it = fs::recursive_directory_iterator(dir, fs::directory_options::skip_permission_denied, ec);
       !ec && it != fs::recursive_directory_iterator(); it.increment(ec)) {
    if (!it->is_directory(ec)) continue;
    if (it.depth() >= depth) it.disable_recursion_pending();
    std::error_code list_ec;
    if (!FilesWithExtensions(it->path().string(), extensions, &list_ec).empty()) out.push_back(it->path().string());
  }
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace

std::vector<std::string> ExpandDirectories(const std::string& command, const std::vector<std::string>& inputs,
                                           const std::vector<std::string>& extensions) {
  namespace fs = std::filesystem;
  std::vector<std::string> out;
  for (const std::string& input : inputs) {
    std::error_code ec;
    if (!fs::is_directory(input, ec)) {
      out.push_back(input);
      continue;
    }
    std::vector<std::string> found = FilesWithExtensions(input, extensions, &ec);
    if (ec) Fail(command, kExitBadInput, input + ": cannot list the directory (" + ec.message() + ")");
    if (found.empty()) {
      // A data set's top folder (Kalibr's, EuRoC's, TUM-VI's: cam0/data,
      // mav0/cam0/data): the one folder below it that holds such files
      // stands for it; several are listed for the user to name one.
      const std::vector<std::string> below = FoldersWithExtensions(input, extensions, 3);
      std::string list;
      for (const std::string& x : extensions) list += (list.empty() ? "" : " ") + x;
      if (below.empty()) Fail(command, kExitBadInput, input + ": a directory with no " + list + " files");
      if (below.size() > 1) {
        std::string names;
        for (const std::string& b : below) names += (names.empty() ? "" : ", ") + b;
        Fail(command, kExitBadInput, input + ": no " + list + " files in it, but in " + std::to_string(below.size()) +
                                         " folders below it (" + names + "): name one");
      }
      std::cerr << "odocal " << command << ": " << input << ": reading the files in " << below.front() << "\n";
      found = FilesWithExtensions(below.front(), extensions, &ec);
    }
    out.insert(out.end(), found.begin(), found.end());
  }
  return out;
}

const std::vector<std::string>& ImageExtensions() {
  static const std::vector<std::string> kImages = {".png", ".jpg", ".jpeg", ".bmp", ".tif",
                                                   ".tiff", ".pgm", ".ppm", ".webp"};
  return kImages;
}

vision::CalibrationBoard ParseBoardOption(const std::string& command, const std::string& option,
                                          const std::string& text) {
  const std::string usage = option + ": expected chessboard:COLSxROWS:SQUARE_MM (inner corners), "
                            "charuco:COLSxROWS:SQUARE_MM:MARKER_MM:DICT (squares), "
                            "aprilgrid:COLSxROWS:TAG_MM:SPACING[:FIRST_ID] (tags) or a Kalibr target.yaml, got '" +
                            text + "'";
  const auto parts = Split(text, ':');
  vision::CalibrationBoard board;
  double square_mm = 0.0, marker_mm = 0.0;
  const bool spec = !parts.empty() && (parts[0] == "chessboard" || parts[0] == "charuco" || parts[0] == "aprilgrid");
  if (!spec) {
    if (!std::filesystem::exists(text)) Fail(command, kExitBadInput, usage + " (no such file)");
    const auto file = config::ReadCalibrationTarget(text);
    if (!file) Fail(command, kExitBadInput, option + ": " + file.message);
    return *file;
  }
  if (parts[0] == "aprilgrid" && (parts.size() == 4 || parts.size() == 5)) {
    board.type = vision::CalibrationBoard::Type::kAprilgrid;
    if (!CountPair(parts[1], &board.cols, &board.rows) || !PositiveNumber(parts[2], &square_mm) ||
        !PositiveNumber(parts[3], &board.spacing))
      Fail(command, kExitBadInput, usage);
    if (parts.size() == 5) {
      if (parts[4].empty() || parts[4].size() > 6 || parts[4].find_first_not_of("0123456789") != std::string::npos)
        Fail(command, kExitBadInput, usage + " (FIRST_ID must be a whole number >= 0)");
      board.first_id = std::stoi(parts[4]);
    }
    board.square_m = square_mm * kMmToM;
    std::string why;
    if (!board.IsValid(&why)) Fail(command, kExitBadInput, option + " " + text + ": " + why);
    return board;
  }
  if (parts.size() == 3 && parts[0] == "chessboard") {
    board.type = vision::CalibrationBoard::Type::kChessboard;
  } else if (parts.size() == 5 && parts[0] == "charuco") {
    board.type = vision::CalibrationBoard::Type::kCharuco;
    if (!PositiveNumber(parts[3], &marker_mm)) Fail(command, kExitBadInput, usage);
    board.dictionary = parts[4];
  } else {
    Fail(command, kExitBadInput, usage);
  }
  if (!CountPair(parts[1], &board.cols, &board.rows) || !PositiveNumber(parts[2], &square_mm))
    Fail(command, kExitBadInput, usage);
  board.square_m = square_mm * kMmToM;
  board.marker_m = marker_mm * kMmToM;
  if (board.type == vision::CalibrationBoard::Type::kCharuco && !vision::CharucoAvailable())
    Fail(command, kExitBadInput,
         option + " charuco: ChArUco boards are not available in this build (OpenCV without the "
         "aruco module); use a chessboard");
  std::string why;
  if (!board.IsValid(&why)) Fail(command, kExitBadInput, option + ": " + why);
  return board;
}


std::function<void(long, long)> TerminalProgressBar(const std::string& label) {
  if (!isatty(2)) return {};
  auto mutex = std::make_shared<std::mutex>();
  return [label, mutex](long done, long total) {
    std::lock_guard<std::mutex> lock(*mutex);
    const double fraction = total > 0 ? std::min(1.0, static_cast<double>(done) / total) : 1.0;
    const int width = 30, filled = static_cast<int>(fraction * width);
    std::fprintf(stderr, "\r%s [%s%s] %3.0f%% %ld frames", label.c_str(),
                 std::string(filled, '#').c_str(), std::string(width - filled, '.').c_str(),
                 100.0 * fraction, done);
    if (done >= total) std::fprintf(stderr, "\n");
    std::fflush(stderr);
  };
}

void AddExportOption(CLI::App* cmd, report::ExportRequests* requests) {
  cmd->add_option("--export", requests->raw,
                  "Write the corrected parameters: --export ros2 FILE (diff_drive_controller "
                  "multipliers) or --export firmware FILE (the robot link's names); repeatable")
      ->type_size(2)
      ->allow_extra_args(false);
}

void AddCameraTagOptions(CLI::App* cmd, const std::string& camera_option, CameraTagArgs* args) {
  cmd->add_option(camera_option, args->camera, "A camera device (0, /dev/video0, a stream URL) or a video file")
      ->required();
  cmd->add_option("--calibration", args->calibration, "The camera's calibration (OpenCV or ROS camera_info YAML)")
      ->required();
  cmd->add_option("--tag", args->tag, "The robot's tag: FAMILY:ID:SIZE_MM[:HEIGHT_MM above the floor]")->required();
  cmd->add_option("--mount-guess", args->mount,
                  "Where the camera hangs: x,y,height,roll,pitch,yaw (mm, deg); default: level, the height "
                  "from the tag's apparent size (the tilt is then fitted to the tag)");
}

}  // namespace odocal::app
