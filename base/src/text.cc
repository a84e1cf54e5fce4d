#include "odocal/base/text.h"

#include <cctype>

namespace odocal {

std::string_view Trim(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  return s;
}

std::vector<std::string> SplitFields(std::string_view line, char separator) {
  std::vector<std::string> fields;
  if (line.empty()) return fields;
  size_t start = 0;
  while (true) {
    const size_t at = line.find(separator, start);
    fields.emplace_back(Trim(line.substr(start, at == std::string_view::npos ? std::string_view::npos : at - start)));
    if (at == std::string_view::npos) break;
    start = at + 1;
  }
  return fields;
}

}  // namespace odocal
