// Virtual robots for tests: a nominal 70 mm / 300 mm / 2048-tick robot and
// true parameters built from error factors.
#ifndef ODOCAL_TEST_UTIL_ROBOTS_H_
#define ODOCAL_TEST_UTIL_ROBOTS_H_

#include "odocal/calibration/robot_model.h"
#include "odocal/sim/virtual_robot.h"

namespace odocal::test_util {

calibration::WheelParams NominalParams(int ticks_per_rev = 2048);

// True parameters with the given Ed and Eb and Es = 1 (the sum of the true
// diameters equals the nominal sum).
calibration::WheelParams TrueParamsFor(const calibration::WheelParams& nominal, double Ed,
                                       double Eb, double Es = 1.0);

// A robot with no noise, fast control and short rests, for exact tests.
sim::RobotConfig ExactRobot(double Ed, double Eb, int ticks_per_rev = 2048);

}  // namespace odocal::test_util

#endif  // ODOCAL_TEST_UTIL_ROBOTS_H_
