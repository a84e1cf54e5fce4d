#include "odocal/config/files.h"

#include <filesystem>
#include <fstream>

namespace odocal::config {

Status EnsureDirectory(const std::string& dir) {
  std::error_code ec;
  if (std::filesystem::exists(dir, ec) && !std::filesystem::is_directory(dir, ec))
    return Status::Error(StatusCode::kInvalidArgument, dir + ": exists and is not a directory");
  std::filesystem::create_directories(dir, ec);
  if (ec) return Status::Error(StatusCode::kIoError, dir + ": cannot create directory: " + ec.message());
  return Status::Ok();
}

Status WriteFileAtomically(const std::string& path, const std::string& contents) {
  const std::string temp = path + ".partial";
  {
    std::ofstream out(temp, std::ios::binary | std::ios::trunc);
    if (!out) return Status::Error(StatusCode::kIoError, path + ": cannot write");
    out << contents;
    out.flush();
    if (!out) {
      std::filesystem::remove(temp);
      return Status::Error(StatusCode::kIoError, path + ": write failed (disk full?)");
    }
  }
  std::error_code ec;
  std::filesystem::rename(temp, path, ec);
  if (ec) return Status::Error(StatusCode::kIoError, path + ": cannot move into place: " + ec.message());
  return Status::Ok();
}

}  // namespace odocal::config
