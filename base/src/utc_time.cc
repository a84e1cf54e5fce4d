#include "odocal/base/utc_time.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>

namespace odocal {

std::string NowUtc() {
  return FormatUtc(std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count());
}

std::string FormatUtc(double seconds) {
  const std::time_t t = static_cast<std::time_t>(std::floor(seconds));
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof(buf), "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

std::optional<double> ParseUtc(std::string_view text) {
  std::tm tm{};
  int y = 0, mo = 0, d = 0, h = 0, mi = 0;
  double s = 0.0;
  const std::string str(text);
  char tail[16] = {0};
  int n = std::sscanf(str.c_str(), "%4d-%2d-%2dT%2d:%2d:%lf%15s", &y, &mo, &d, &h, &mi, &s, tail);
  if (n < 5) {
    char rest = 0;
    if (std::sscanf(str.c_str(), "%4d-%2d-%2d%c", &y, &mo, &d, &rest) != 3) return std::nullopt;
    h = mi = 0;
    s = 0;
    tail[0] = 0;
  } else if (n == 5) {
    return std::nullopt;
  }
  if (mo < 1 || mo > 12 || d < 1 || d > 31 || h < 0 || h > 23 || mi < 0 || mi > 59 || s < 0 || s >= 61) return std::nullopt;
  double offset = 0.0;
  const std::string zone(tail);
  if (zone == "Z" || zone.empty()) {
    offset = 0.0;
  } else {
    int oh = 0, om = 0;
    char sign = 0;
    if (std::sscanf(zone.c_str(), "%c%2d:%2d", &sign, &oh, &om) != 3 || (sign != '+' && sign != '-')) return std::nullopt;
    offset = (sign == '+' ? 1 : -1) * (oh * 3600.0 + om * 60.0);
  }
  tm.tm_year = y - 1900;
  tm.tm_mon = mo - 1;
  tm.tm_mday = d;
  tm.tm_hour = h;
  tm.tm_min = mi;
  tm.tm_sec = 0;
  return static_cast<double>(timegm(&tm)) + s - offset;
}

}  // namespace odocal
