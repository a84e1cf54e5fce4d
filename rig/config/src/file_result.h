// The one place a config reader's error line becomes a Result: kNotFound when
// the file is not there, kBadFile when it is but does not parse.
#ifndef ODOCAL_CONFIG_FILE_RESULT_H_
#define ODOCAL_CONFIG_FILE_RESULT_H_

#include <filesystem>
#include <optional>
#include <string>
#include <utility>

#include "odocal/base/status.h"

namespace odocal::config {

// `parse(&error)` returns the value, or nullopt with one error line.
template <typename T, typename Parse>
Result<T> ReadFileAs(const std::string& path, Parse&& parse) {
  std::string error;
  std::optional<T> parsed = parse(&error);
  if (!parsed) {
    return Result<T>::Error(
        std::filesystem::exists(path) ? StatusCode::kBadFile : StatusCode::kNotFound, error);
  }
  return Result<T>::Ok(std::move(*parsed));
}

}  // namespace odocal::config

#endif  // ODOCAL_CONFIG_FILE_RESULT_H_
