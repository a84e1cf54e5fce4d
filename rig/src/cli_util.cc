#include "odocal/rig/cli_util.h"

#include <cmath>
#include <cstdlib>
#include <iostream>

#include <CLI/CLI.hpp>

namespace odocal::rig {

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

}  // namespace odocal::rig
