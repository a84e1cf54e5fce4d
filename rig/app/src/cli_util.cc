#include "cli_util.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstdio>
#include <iostream>
#include <memory>
#include <mutex>

#include <unistd.h>

#include <CLI/CLI.hpp>

namespace odocal::app {

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

}  // namespace odocal::app
