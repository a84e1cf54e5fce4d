// Time as records and sessions write it: ISO 8601 in UTC, to the second.
#ifndef ODOCAL_BASE_UTC_TIME_H_
#define ODOCAL_BASE_UTC_TIME_H_

#include <optional>
#include <string>
#include <string_view>

namespace odocal {

// Now, as ISO 8601 UTC ("2026-11-27T18:40:00Z").
std::string NowUtc();
// Seconds since the epoch -> "2026-11-27T18:40:00Z" (the second's fraction dropped).
std::string FormatUtc(double seconds_since_epoch);
// "2026-11-27T18:40:00Z", "2026-11-27T19:40:00+01:00", "2026-11-27T18:40:00.25Z" or a date alone
// ("2026-11-27", midnight UTC) -> seconds since the epoch; nullopt for anything else.
std::optional<double> ParseUtc(std::string_view text);

}  // namespace odocal

#endif  // ODOCAL_BASE_UTC_TIME_H_
