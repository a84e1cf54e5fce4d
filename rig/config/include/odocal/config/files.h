// Writing files so that a failure never leaves half of one: every file odocal
// writes (reports, exports, camera and session files, simulations) goes
// through here.
#ifndef ODOCAL_CONFIG_FILES_H_
#define ODOCAL_CONFIG_FILES_H_

#include <string>

#include "odocal/base/status.h"

namespace odocal::config {

// Creates `dir` (and parents). kInvalidArgument when `dir` is a file, kIoError when it
// cannot be made; the message names the directory.
Status EnsureDirectory(const std::string& dir);
// Writes `contents` to a temporary file beside `path` and renames it into
// place: readers see the old file or the new one, never a partial one. kIoError naming
// the file when it cannot be written.
Status WriteFileAtomically(const std::string& path, const std::string& contents);

}  // namespace odocal::config

#endif  // ODOCAL_CONFIG_FILES_H_
