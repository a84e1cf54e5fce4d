// The virtual robot is the referee of every estimator, so it is tested
// against analytic truth that does not share its code path.
#include "odocal/sim/virtual_robot.h"

#include <cmath>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "odocal/calibration/statistics.h"
#include "odocal/test_util/robots.h"
#include "odocal/test_util/test_util.h"

namespace odocal::sim {
namespace {

using calibration::Direction;
using calibration::Pose2;
using calibration::RunSpec;
using test_util::IsNearPose;

// Seed (CVRA) worked example: 0.1 % wheel-diameter difference, 300 mm track,
// 3 m straight: "R = 300 m ... the positioning error is 1.5 cm".
TEST(VirtualRobot, ReproducesTheCvraWorkedExample) {
  const double Ed = 1.001;
  VirtualRobot robot(test_util::ExactRobot(Ed, 1.0));
  const RunRecord run = robot.Execute(RunSpec::Straight(3.0));
  const Pose2 end = run.TrueEndInStartFrame();
  // Independent truth: an arc of length L turning by theta = L (r_R - r_L) / b
  // ends R (1 - cos theta) to the side, R = L / theta.
  const double r_left = 2.0 / (1.0 + Ed), r_right = 2.0 * Ed / (1.0 + Ed);
  const double theta = 3.0 * (r_right - r_left) / 0.3;
  const double lateral = 3.0 / theta * (1.0 - std::cos(theta));
  EXPECT_NEAR(end.y(), lateral, 1e-6);
  EXPECT_NEAR(end.y(), 0.015, 0.0002) << "the seed's 1.5 cm";
  EXPECT_GT(end.y(), 0.0) << "a larger right wheel veers left";
  EXPECT_NEAR(end.heading(), theta, 1e-9);
}

TEST(VirtualRobot, FirmwareBelievesItClosedTheSquare) {
  VirtualRobot robot(test_util::ExactRobot(1.002, 1.02));
  for (Direction d : {Direction::kCw, Direction::kCcw}) {
    const RunRecord run = robot.Execute(RunSpec::Umbmark(d, 2.0));
    // Odometry only differs from the setpoint by encoder quantization: a tick
    // is 0.107 mm of travel, 0.036 deg of heading here.
    EXPECT_THAT(run.odometry_end, IsNearPose(Pose2::Identity(), 0.2, 0.05)) << ToString(d);
    // ...while the robot really ended far away.
    EXPECT_GT(run.TrueEndInStartFrame().translation().norm(), 0.02);
  }
}

TEST(VirtualRobot, AgreesWithTheClosedFormModel) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> ed(0.99, 1.01), eb(0.95, 1.05);
  for (int i = 0; i < 10; ++i) {
    const double Ed = ed(rng), Eb = eb(rng);
    VirtualRobot robot(test_util::ExactRobot(Ed, Eb));
    const calibration::WheelScales scales = calibration::WheelScalesFromFactors(Ed, Eb);
    for (const RunSpec& spec :
         {RunSpec::Umbmark(Direction::kCw, 1.5), RunSpec::Umbmark(Direction::kCcw, 1.5),
          RunSpec::Straight(2.0), RunSpec::Spin(2, Direction::kCw),
          RunSpec::OutAndBack(1.0, 2, Direction::kCcw)}) {
      const RunRecord run = robot.Execute(spec);
      const Pose2 predicted = calibration::PredictReturnError(spec, scales, 0.3);
      const Pose2 planned = calibration::PlannedEnd(calibration::PlanPrimitives(spec));
      const Pose2 simulated = run.TrueEndInStartFrame();
      const calibration::ReturnError simulated_error{simulated.x() - planned.x(), simulated.y() - planned.y(),
                                                     simulated.heading() - planned.heading()};
      // 1e-9 m and 1e-9 rad.
      EXPECT_THAT(simulated_error, test_util::IsNearReturnError(predicted, 1e-6, 1e-9 * 180.0 / M_PI))
          << ToString(spec.procedure);
    }
  }
}

TEST(VirtualRobot, TelemetryTicksExplainTheOdometry) {
  VirtualRobot robot(test_util::ExactRobot(1.003, 0.98));
  const RunRecord run = robot.Execute(RunSpec::Straight(1.0));
  ASSERT_GE(run.telemetry.size(), 10u);
  const TelemetrySample& first = run.telemetry.front();
  const TelemetrySample& last = run.telemetry.back();
  const calibration::WheelParams nominal = test_util::NominalParams();
  const double left = (last.left_ticks - first.left_ticks) * nominal.LeftMetresPerTick();
  const double right = (last.right_ticks - first.right_ticks) * nominal.RightMetresPerTick();
  EXPECT_NEAR(last.odometry.heading(), (right - left) / nominal.track_m, 1e-9);
  EXPECT_NEAR(last.odometry.x(), 1.0, nominal.LeftMetresPerTick());
  // The telemetry rate is the configured 50 Hz.
  EXPECT_NEAR(run.telemetry[1].t_s - run.telemetry[0].t_s, 0.02, 1e-9);
}

TEST(VirtualRobot, SameSeedSameRunDifferentSeedDifferentNoise) {
  RobotConfig config = test_util::ExactRobot(1.0, 1.0);
  config.noise.wheel_sigma_m_per_sqrt_m = 1e-3;
  config.noise.random_encoder_phase = true;
  const RunSpec spec = RunSpec::Umbmark(Direction::kCw, 1.0);
  VirtualRobot a(config), b(config);
  config.seed = 2;
  VirtualRobot c(config);
  const Pose2 ea = a.Execute(spec).TrueEndInStartFrame();
  const Pose2 eb = b.Execute(spec).TrueEndInStartFrame();
  const Pose2 ec = c.Execute(spec).TrueEndInStartFrame();
  EXPECT_THAT(ea, IsNearPose(eb, 1e-12, 1e-12));
  EXPECT_GT((ea.translation() - ec.translation()).norm(), 1e-5);
}

TEST(VirtualRobot, WheelNoiseIsARandomWalkOfTheConfiguredSize) {
  // Heading after a straight of length L: (n_R - n_L) / b, each n ~ sigma sqrt(L).
  RobotConfig config = test_util::ExactRobot(1.0, 1.0);
  const double sigma = 2e-3, L = 1.0;
  config.noise.wheel_sigma_m_per_sqrt_m = sigma;
  VirtualRobot robot(config);
  std::vector<double> headings;
  for (int i = 0; i < 300; ++i)
    headings.push_back(robot.Execute(RunSpec::Straight(L)).TrueEndInStartFrame().heading());
  const double expected = sigma * std::sqrt(2.0 * L) / config.truth.track_m;
  EXPECT_NEAR(*calibration::SampleStdDev(headings), expected, 0.12 * expected);
  EXPECT_NEAR(calibration::Mean(headings), 0.0, 4.0 * expected / std::sqrt(300.0));
}

TEST(VirtualRobot, WallRestoresTheTrueHeadingAndOdometryRecordsIt) {
  const double Eb = 1.02;
  VirtualRobot robot(test_util::ExactRobot(1.0, Eb, 1 << 16));
  RunSpec spec = RunSpec::Spin(3, Direction::kCcw);
  spec.reference = calibration::Reference::kWall;
  const RunRecord run = robot.Execute(spec);
  EXPECT_NEAR(run.TrueEndInStartFrame().heading(), 0.0, 1e-9);
  // Odometry turned a = 6 pi, the robot a / Eb; the wall's correction of
  // a (1 - 1/Eb), read through the believed track, shows as a (Eb - 1).
  const double a = 6.0 * M_PI;
  EXPECT_NEAR(run.odometry_end.heading(), calibration::WrapAngle(a * (Eb - 1.0)), 1e-4);
}

TEST(VirtualRobot, StopEndsTheRunWhereTheRobotIs) {
  VirtualRobot robot(test_util::ExactRobot(1.0, 1.0));
  robot.StartRun(RunSpec::Straight(2.0));
  for (int i = 0; i < 500; ++i) ASSERT_TRUE(robot.Step());
  const Pose2 at_stop = robot.true_pose();
  robot.Stop();
  EXPECT_FALSE(robot.running());
  EXPECT_FALSE(robot.Step());
  EXPECT_THAT(robot.true_pose(), IsNearPose(at_stop, 1e-12, 1e-12));
  EXPECT_GT(at_stop.x(), 0.05);
}

}  // namespace
}  // namespace odocal::sim
