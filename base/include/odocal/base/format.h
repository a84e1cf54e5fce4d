// Text for people: printf-style formatting into a std::string (of any
// length), a number with a fixed count of decimals, text escaped for HTML, a
// list of flags as their stable texts. The one place every module formats
// numbers for messages and reports.
#ifndef ODOCAL_BASE_FORMAT_H_
#define ODOCAL_BASE_FORMAT_H_

#include <string>
#include <vector>

namespace odocal {

// std::snprintf's format into a string as long as it needs. A C variadic
// function so that the compiler checks each call's arguments against its
// format (-Wformat): an int given to %f is a compile-time warning, not "0".
std::string Format(const char* format, ...) __attribute__((format(printf, 1, 2)));

// `value` with `decimals` digits after the point ("%.*f": 1.50, -0.003, nan).
std::string Fixed(double value, int decimals);

// Text made safe inside HTML or SVG, element or attribute: & < > " ' as entities.
std::string HtmlEscape(const std::string& text);

// Each item's stable text, in order: its `ToString()` member when it has one,
// else the `ToString(item)` of its own namespace (found by argument-dependent
// lookup). The flags' lists in report.json: calibration::RunFlag,
// vision::ObservationFlag, measure::SessionFlag (each namespace brings this
// in with `using odocal::ToStrings`).
template <typename T>
std::vector<std::string> ToStrings(const std::vector<T>& items) {
  std::vector<std::string> out;
  out.reserve(items.size());
  for (const T& item : items) {
    if constexpr (requires { item.ToString(); }) {
      out.emplace_back(item.ToString());
    } else {
      out.emplace_back(ToString(item));
    }
  }
  return out;
}

}  // namespace odocal

#endif  // ODOCAL_BASE_FORMAT_H_
