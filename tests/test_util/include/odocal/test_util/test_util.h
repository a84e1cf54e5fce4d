// Shared test helpers: matchers on odocal value types and paths to the
// binary and the source tree.
#ifndef ODOCAL_TEST_UTIL_TEST_UTIL_H_
#define ODOCAL_TEST_UTIL_TEST_UTIL_H_

#include <cmath>
#include <string>

#include <gmock/gmock.h>
#include <nlohmann/json.hpp>

#include "odocal/calibration/pose2.h"

namespace odocal::test_util {

// Matches a Pose2 within tol_mm in position and tol_deg in heading.
MATCHER_P3(IsNearPose, expected, tol_mm, tol_deg,
           "is within " + ::testing::PrintToString(tol_mm) + " mm and " +
               ::testing::PrintToString(tol_deg) + " deg of " +
               ::testing::PrintToString(expected)) {
  const double dx_mm = (arg.x() - expected.x()) * 1e3;
  const double dy_mm = (arg.y() - expected.y()) * 1e3;
  const double dh_deg =
      odocal::calibration::WrapAngle(arg.heading() - expected.heading()) * 180.0 / M_PI;
  *result_listener << "off by (" << dx_mm << ", " << dy_mm << ") mm, " << dh_deg << " deg";
  return std::hypot(dx_mm, dy_mm) <= tol_mm && std::abs(dh_deg) <= tol_deg;
}

// The odocal binary under test ($ODOCAL_BINARY, set by odocal_test()).
std::string OdocalBinary();
// A command line running it with `args`.
std::string Odocal(const std::string& args);
// The source tree ($ODOCAL_SOURCE_DIR).
std::string SourceDir();
// A fresh empty directory under the system temp dir.
std::string MakeTempDir(const std::string& prefix);

struct CommandResult {
  int exit_code = -1;
  std::string out;
  std::string err;
};
// Runs a shell command line, capturing stdout and stderr.
CommandResult RunCommand(const std::string& command_line);

// A file's whole text ("" when it cannot be read), and a JSON file parsed
// (throws on a missing file or bad JSON: the test fails with the message).
std::string Slurp(const std::string& path);
nlohmann::json ReadJson(const std::string& path);

}  // namespace odocal::test_util

#endif  // ODOCAL_TEST_UTIL_TEST_UTIL_H_
