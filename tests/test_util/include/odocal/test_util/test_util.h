// Shared test helpers: matchers on odocal value types and paths to the
// binary and the source tree.
#ifndef ODOCAL_TEST_UTIL_TEST_UTIL_H_
#define ODOCAL_TEST_UTIL_TEST_UTIL_H_

#include <cmath>
#include <optional>
#include <string>

#include <gmock/gmock.h>
#include <nlohmann/json.hpp>

#include "odocal/base/status.h"
#include "odocal/calibration/pose2.h"
#include "odocal/calibration/robot_model.h"
#include "odocal/calibration/umbmark.h"

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

namespace internal {
// A return error as UMBMark takes it, from either of the forms tests hold.
inline calibration::ReturnError AsReturnError(const calibration::ReturnError& e) { return e; }
inline calibration::ReturnError AsReturnError(const calibration::Pose2& p) {
  return {p.x(), p.y(), p.heading()};
}
}  // namespace internal

// Matches a return error (calibration::ReturnError or a Pose2 holding one)
// whose x and y are each within tol_mm of the expected ones and whose heading
// is within tol_deg. A heading present on one side only does not match.
MATCHER_P3(IsNearReturnError, expected, tol_mm, tol_deg,
           "has x and y each within " + ::testing::PrintToString(tol_mm) + " mm and heading within " +
               ::testing::PrintToString(tol_deg) + " deg of " +
               ::testing::PrintToString(internal::AsReturnError(expected))) {
  const calibration::ReturnError a = internal::AsReturnError(arg);
  const calibration::ReturnError e = internal::AsReturnError(expected);
  const double dx_mm = (a.x_m - e.x_m) * 1e3;
  const double dy_mm = (a.y_m - e.y_m) * 1e3;
  *result_listener << "off by (" << dx_mm << ", " << dy_mm << ") mm";
  bool near = std::abs(dx_mm) <= tol_mm && std::abs(dy_mm) <= tol_mm;
  if (a.heading_rad && e.heading_rad) {
    const double dh_deg =
        calibration::WrapAngle(*a.heading_rad - *e.heading_rad) * 180.0 / M_PI;
    *result_listener << ", " << dh_deg << " deg";
    near = near && std::abs(dh_deg) <= tol_deg;
  } else if (a.heading_rad.has_value() != e.heading_rad.has_value()) {
    *result_listener << ", heading " << (a.heading_rad ? "given" : "missing") << " where "
                     << (e.heading_rad ? "one is" : "none is") << " expected";
    near = false;
  }
  return near;
}

// Matches calibration::WheelParams whose wheel diameters and track are each
// within tol_mm of the expected ones (ticks_per_rev is not compared).
MATCHER_P2(IsNearWheelParams, expected, tol_mm,
           "has diameters and track each within " + ::testing::PrintToString(tol_mm) + " mm of " +
               ::testing::PrintToString(expected)) {
  const double dl_mm = (arg.left_wheel_diameter_m - expected.left_wheel_diameter_m) * 1e3;
  const double dr_mm = (arg.right_wheel_diameter_m - expected.right_wheel_diameter_m) * 1e3;
  const double db_mm = (arg.track_m - expected.track_m) * 1e3;
  *result_listener << "off by " << dl_mm << " mm (left D), " << dr_mm << " mm (right D), "
                   << db_mm << " mm (track)";
  return std::abs(dl_mm) <= tol_mm && std::abs(dr_mm) <= tol_mm && std::abs(db_mm) <= tol_mm;
}

// The message of a result that must be an error (the test fails if it is not).
template <typename T>
std::string ErrorOf(const Result<T>& result) {
  EXPECT_FALSE(result.ok()) << "expected an error";
  return result.message;
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
