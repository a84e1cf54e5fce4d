// Text for people: printf-style formatting into a std::string (of any
// length), a number with a fixed count of decimals, text escaped for HTML. The
// one place every module formats numbers for messages and reports.
#ifndef ODOCAL_BASE_FORMAT_H_
#define ODOCAL_BASE_FORMAT_H_

#include <string>

namespace odocal {

// std::snprintf's format into a string as long as it needs. A C variadic
// function so that the compiler checks each call's arguments against its
// format (-Wformat): an int given to %f is a compile-time warning, not "0".
std::string Format(const char* format, ...) __attribute__((format(printf, 1, 2)));

// `value` with `decimals` digits after the point ("%.*f": 1.50, -0.003, nan).
std::string Fixed(double value, int decimals);

// Text made safe inside HTML or SVG, element or attribute: & < > " ' as entities.
std::string HtmlEscape(const std::string& text);

}  // namespace odocal

#endif  // ODOCAL_BASE_FORMAT_H_
