// Small helpers shared by the commands: failing with one clear line, and
// parsing number lists from the command line.
#ifndef ODOCAL_RIG_CLI_UTIL_H_
#define ODOCAL_RIG_CLI_UTIL_H_

#include <optional>
#include <string>
#include <vector>

namespace odocal::rig {

// Exit codes: 1 = the work failed (no valid result), 2 = bad input.
inline constexpr int kExitFailure = 1;
inline constexpr int kExitBadInput = 2;

// Prints "odocal <command>: <message>" on stderr and ends the command with
// `exit_code` (through CLI11, so main returns it).
[[noreturn]] void Fail(const std::string& command, int exit_code, const std::string& message);

// "1.5,-2,0.25" -> {1.5, -2, 0.25}; nullopt unless every field is a finite number.
std::optional<std::vector<double>> ParseNumberList(const std::string& text);

}  // namespace odocal::rig

#endif  // ODOCAL_RIG_CLI_UTIL_H_
