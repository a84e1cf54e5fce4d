// Text helpers the file readers share (config's CSV and YAML-side readers,
// the pose logs, the records' limits): one Trim, one field splitter.
#ifndef ODOCAL_BASE_TEXT_H_
#define ODOCAL_BASE_TEXT_H_

#include <string>
#include <string_view>
#include <vector>

namespace odocal {

// `s` without leading and trailing white space (std::isspace).
std::string_view Trim(std::string_view s);

// The fields of `line` between `separator`s, each trimmed: "a, b," is
// {"a", "b", ""}; an empty line has no field.
std::vector<std::string> SplitFields(std::string_view line, char separator = ',');

}  // namespace odocal

#endif  // ODOCAL_BASE_TEXT_H_
