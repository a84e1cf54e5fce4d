#include "odocal/config/files.h"

#include <filesystem>
#include <fstream>

namespace odocal::config {

std::optional<std::string> EnsureDirectory(const std::string& dir) {
  std::error_code ec;
  if (std::filesystem::exists(dir, ec) && !std::filesystem::is_directory(dir, ec))
    return dir + ": exists and is not a directory";
  std::filesystem::create_directories(dir, ec);
  if (ec) return dir + ": cannot create directory: " + ec.message();
  return std::nullopt;
}

std::optional<std::string> WriteFileAtomically(const std::string& path,
                                               const std::string& contents) {
  const std::string temp = path + ".partial";
  {
    std::ofstream out(temp, std::ios::binary | std::ios::trunc);
    if (!out) return path + ": cannot write";
    out << contents;
    out.flush();
    if (!out) {
      std::filesystem::remove(temp);
      return path + ": write failed (disk full?)";
    }
  }
  std::error_code ec;
  std::filesystem::rename(temp, path, ec);
  if (ec) return path + ": cannot move into place: " + ec.message();
  return std::nullopt;
}

}  // namespace odocal::config
