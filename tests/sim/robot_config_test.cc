// RobotConfig::IsValid (sim/virtual_robot.h): the test robot passes; each field out of range
// fails, and `why` names it as a scenario file spells it (robot.nominal.track_mm, ...).
#include <limits>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "odocal/sim/virtual_robot.h"
#include "odocal/test_util/options_checks.h"
#include "odocal/test_util/robots.h"

namespace odocal::sim {
namespace {

using test_util::ExpectValidAndEachEditRejected;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

TEST(RobotConfig, TheTestRobotIsValidAndEachBadFieldIsNamedAsTheScenarioSpellsIt) {
  std::string why;
  EXPECT_FALSE(RobotConfig{}.IsValid(&why)) << "no wheels";
  EXPECT_THAT(why, ::testing::HasSubstr("robot.nominal."));
  RobotConfig robot = test_util::ExactRobot(1.003, 1.015);
  // The truth's ticks are the nominal's (the encoder is what it is): not checked on their own.
  robot.truth.ticks_per_rev = 0.0;
  ExpectValidAndEachEditRejected<RobotConfig>(
      robot, {{[](RobotConfig* r) { r->nominal.track_m = 0.0; }, "robot.nominal.track_mm"},
              {[](RobotConfig* r) { r->nominal.ticks_per_rev = 0.0; }, "robot.nominal.ticks_per_rev"},
              {[](RobotConfig* r) { r->truth.left_wheel_diameter_m = kNaN; }, "robot.true.left_wheel_diameter_mm"},
              {[](RobotConfig* r) { r->limits.speed_m_s = 0.0; }, "robot.speed_mm_s"},
              {[](RobotConfig* r) { r->limits.accel_m_s2 = -1.0; }, "robot.accel_mm_s2"},
              {[](RobotConfig* r) { r->limits.turn_rate_rad_s = kNaN; }, "robot.turn_rate_deg_s"},
              {[](RobotConfig* r) { r->limits.turn_accel_rad_s2 = 0.0; }, "robot.turn_accel_deg_s2"},
              {[](RobotConfig* r) { r->noise.wheel_sigma_m_per_sqrt_m = -1e-4; }, "robot.noise.wheel_mm_per_sqrt_m"},
              {[](RobotConfig* r) { r->control_rate_hz = 0.0; }, "robot.control_rate_hz"},
              {[](RobotConfig* r) { r->telemetry_rate_hz = 2.0 * r->control_rate_hz; }, "robot.telemetry_rate_hz"},
              {[](RobotConfig* r) { r->rest_s = -1.0; }, "robot.rest_s"},
              {[](RobotConfig* r) { r->pause_s = kNaN; }, "robot.pause_s"}});
}

}  // namespace
}  // namespace odocal::sim
