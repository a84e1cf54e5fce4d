// Unit conversions. odocal computes in SI (metres, radians, seconds); files and the terminal
// speak millimetres, degrees and milliseconds. Convert at the boundary, with these names.
#ifndef ODOCAL_BASE_UNITS_H_
#define ODOCAL_BASE_UNITS_H_

#include <numbers>

namespace odocal {

inline constexpr double kDegToRad = std::numbers::pi / 180.0;
inline constexpr double kRadToDeg = 180.0 / std::numbers::pi;
inline constexpr double kMmToM = 1e-3;
inline constexpr double kMToMm = 1e3;
// Times: files and the terminal speak milliseconds, odocal computes in seconds.
inline constexpr double kSToMs = 1e3;
inline constexpr double kMsToS = 1e-3;

// Angles one value at a time: x * 180 / pi and x * pi / 180 in that order, as
// the code wrote them inline (x * kRadToDeg rounds 180 / pi first and may
// differ from these in the last bit).
constexpr double RadToDeg(double rad) { return rad * 180.0 / std::numbers::pi; }
constexpr double DegToRad(double deg) { return deg * std::numbers::pi / 180.0; }

}  // namespace odocal

#endif  // ODOCAL_BASE_UNITS_H_
