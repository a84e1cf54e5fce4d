// Writing files so that a failure never leaves half of one: every file odocal
// writes (reports, exports, camera and session files, simulations) goes
// through here.
#ifndef ODOCAL_CONFIG_FILES_H_
#define ODOCAL_CONFIG_FILES_H_

#include <optional>
#include <string>

namespace odocal::config {

// Creates `dir` (and parents); nullopt on success, else the error line.
std::optional<std::string> EnsureDirectory(const std::string& dir);
// Writes `contents` to a temporary file beside `path` and renames it into
// place: readers see the old file or the new one, never a partial one.
std::optional<std::string> WriteFileAtomically(const std::string& path,
                                               const std::string& contents);

}  // namespace odocal::config

#endif  // ODOCAL_CONFIG_FILES_H_
