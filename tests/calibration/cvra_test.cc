// CVRA update rules on the virtual robot: each converges in one step.
#include "odocal/calibration/cvra.h"

#include <cmath>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "odocal/calibration/corrections.h"
#include "odocal/calibration/umbmark.h"
#include "odocal/sim/virtual_robot.h"
#include "odocal/test_util/robots.h"

namespace odocal::calibration {

// GoogleTest prints a reference by its name (found by argument-dependent
// lookup: here, not in the unnamed namespace).
void PrintTo(Reference reference, std::ostream* os) { *os << ToString(reference); }

namespace {

// Total believed travel of each wheel over a run, from the telemetry ticks.
struct Travel {
  double left_m;
  double right_m;
  double mean() const { return 0.5 * (left_m + right_m); }
};

Travel BelievedTravel(const sim::RunRecord& run, const WheelParams& believed) {
  const auto& first = run.telemetry.front();
  const auto& last = run.telemetry.back();
  return {(last.left_ticks - first.left_ticks) * believed.LeftMetresPerTick(),
          (last.right_ticks - first.right_ticks) * believed.RightMetresPerTick()};
}

RunSpec WallOutAndBack() {
  RunSpec spec = RunSpec::OutAndBack(1.0, 3, Direction::kCcw);
  spec.reference = Reference::kWall;
  return spec;
}

// The robot's remaining wheel-ratio error after its firmware got `params`.
double ResidualEd(const sim::RobotConfig& config, const WheelParams& params) {
  return ErrorFactorsFrom(params, config.truth).Ed;
}

TEST(CvraWheelRatio, WallReferencedConvergesInOneStep) {
  sim::RobotConfig config = test_util::ExactRobot(1.003, 1.02, 1 << 14);
  sim::VirtualRobot robot(config);
  WheelParams params = config.nominal;
  double previous_error = std::abs(ResidualEd(config, params) - 1.0);
  for (int iteration = 0; iteration < 2; ++iteration) {
    robot.SetBelievedParams(params);
    const sim::RunRecord run = robot.Execute(WallOutAndBack());
    const Travel travel = BelievedTravel(run, params);
    const CvraResult r = WheelRatioFromWall(travel.mean(), run.odometry_end.heading(), params.track_m);
    ASSERT_TRUE(r.ok()) << r.message;
    // Exact: Ed = T_L / T_R.
    EXPECT_NEAR(r.value, travel.left_m / travel.right_m, 1e-9);
    // The seed's gain update is the same correction.
    const double f = WheelGainFactor(r.value);
    EXPECT_NEAR(1.0 + f, CorrectionLeft(r.value), 1e-12);
    EXPECT_NEAR(1.0 - f, CorrectionRight(r.value), 1e-12);
    params = ApplyCvra(params, r.value, std::nullopt, std::nullopt);
    const double error = std::abs(ResidualEd(config, params) - 1.0);
    if (iteration == 0) {
      EXPECT_LT(error, 1e-3 * previous_error) << "one step, not an oscillation";
    }
    previous_error = error;
  }
  EXPECT_LT(previous_error, 2e-6);
}

// Erratum E1: the seed's comment defines delta_angle as "the difference
// between the pulse count of the left wheel and the right wheel". Read that
// way (left - right, whole difference), the update has the wrong sign and
// twice the size: the error triples. With the right sign but the whole
// difference it flips sign every step: the oscillation the seed reports.
// The exact rule uses half the right - left difference (the "angle" of the
// robot_system the CVRA code uses), and converges in one step (above).
double ResidualAfterSeedUpdate(double sign, double size) {
  sim::RobotConfig config = test_util::ExactRobot(1.002, 1.0, 1 << 14);
  sim::VirtualRobot robot(config);
  WheelParams params = config.nominal;
  const sim::RunRecord run = robot.Execute(WallOutAndBack());
  const Travel travel = BelievedTravel(run, params);
  const double factor = sign * size * (travel.right_m - travel.left_m) / 2.0 / travel.mean();
  params.left_wheel_diameter_m *= 1.0 + factor;
  params.right_wheel_diameter_m *= 1.0 - factor;
  return ResidualEd(config, params) - 1.0;
}

TEST(CvraWheelRatio, TheSeedsLiteralReadingDivergesOrOscillates) {
  const double initial = 1.002 - 1.0;
  EXPECT_NEAR(ResidualAfterSeedUpdate(-1.0, 2.0), 3.0 * initial, 0.01 * initial) << "diverges";
  EXPECT_NEAR(ResidualAfterSeedUpdate(+1.0, 2.0), -initial, 0.01 * initial) << "oscillates";
  EXPECT_NEAR(ResidualAfterSeedUpdate(+1.0, 1.0), 0.0, 0.001 * initial) << "converges";
}

TEST(CvraWheelRatio, CameraReferencedConvergesInOneStep) {
  sim::RobotConfig config = test_util::ExactRobot(0.9975, 1.0, 1 << 14);
  sim::VirtualRobot robot(config);
  WheelParams params = config.nominal;
  const RunSpec spec = RunSpec::OutAndBack(1.0, 2, Direction::kCcw);
  const sim::RunRecord run = robot.Execute(spec);
  // The camera's heading error: true - odometry.
  const double heading_error =
      WrapAngle(run.TrueEndInStartFrame().heading() - run.odometry_end.heading());
  const Travel travel = BelievedTravel(run, params);
  const CvraResult r = WheelRatioFromCamera(travel.mean(), heading_error, params.track_m);
  ASSERT_TRUE(r.ok()) << r.message;
  params = ApplyCvra(params, r.value, std::nullopt, std::nullopt);
  // First order in the track (the formula uses the believed track): 1e-6 of
  // a 2.5e-3 error.
  EXPECT_LT(std::abs(ResidualEd(config, params) - 1.0), 1e-6);
}

TEST(CvraScale, StraightRunConvergesInOneStepAndTheSeedRatioIsUpsideDown) {
  sim::RobotConfig config = test_util::ExactRobot(1.001, 1.0, 1 << 14);
  config.truth = test_util::TrueParamsFor(config.nominal, 1.001, 1.0, 1.004);
  sim::VirtualRobot robot(config);
  const double asked = 2.0;
  const sim::RunRecord run = robot.Execute(RunSpec::Straight(asked));
  const Pose2 end = run.TrueEndInStartFrame();
  const CvraResult r = ScaleFromStraight(asked, end.x(), end.y(), end.heading());
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_NEAR(r.value, 1.004, 1e-6);
  const WheelParams fixed = ApplyCvra(config.nominal, std::nullopt, r.value, std::nullopt);
  EXPECT_NEAR(ErrorFactorsFrom(fixed, config.truth).Es, 1.0, 1e-6);
  // Ticks per mm go the other way: new = old * asked / real.
  const double ticks_per_mm_old = config.nominal.ticks_per_rev / (M_PI * 70.0);
  const double ticks_per_mm_new = fixed.ticks_per_rev / (M_PI * fixed.left_wheel_diameter_m * 1e3);
  EXPECT_NEAR(ticks_per_mm_new, ticks_per_mm_old / r.value, 1e-9);
  // Erratum E2: the seed's new = old * real / asked doubles the error.
  WheelParams seed = config.nominal;
  seed.left_wheel_diameter_m /= r.value;
  seed.right_wheel_diameter_m /= r.value;
  EXPECT_NEAR(ErrorFactorsFrom(seed, config.truth).Es - 1.0, 2.0 * 0.004, 1e-4);
}

class CvraTrack : public ::testing::TestWithParam<Reference> {};

TEST_P(CvraTrack, SpinConvergesInOneStep) {
  const double Eb = 1.015;
  sim::RobotConfig config = test_util::ExactRobot(1.0, Eb, 1 << 14);
  sim::VirtualRobot robot(config);
  WheelParams params = config.nominal;
  for (int iteration = 0; iteration < 2; ++iteration) {
    robot.SetBelievedParams(params);
    RunSpec spec = RunSpec::Spin(5, Direction::kCw);
    spec.reference = GetParam();
    const sim::RunRecord run = robot.Execute(spec);
    const double believed = -10.0 * M_PI;
    CvraResult r;
    if (GetParam() == Reference::kWall) {
      r = TrackFromWall(believed, run.odometry_end.heading());
    } else {
      r = TrackFromCamera(believed, WrapAngle(run.TrueEndInStartFrame().heading() -
                                              run.odometry_end.heading()));
    }
    ASSERT_TRUE(r.ok()) << r.message;
    params = ApplyCvra(params, std::nullopt, std::nullopt, r.value);
    if (iteration == 0) {
      EXPECT_NEAR(params.track_m / config.truth.track_m, 1.0, 2e-5);
    } else {
      EXPECT_NEAR(r.value, 1.0, 2e-5) << "nothing left to correct";
    }
  }
}

INSTANTIATE_TEST_SUITE_P(BothReferences, CvraTrack, ::testing::Values(Reference::kWall, Reference::kCamera),
                         [](const ::testing::TestParamInfo<Reference>& info) {
                           return std::string(ToString(info.param));
                         });

TEST(CvraAll, ThreeProceduresThenUmbmarkShowsACalibratedRobot) {
  // Ratio, scale and track measured with the old parameters, applied at once.
  sim::RobotConfig config = test_util::ExactRobot(1.0, 1.0, 1 << 14);
  config.truth = test_util::TrueParamsFor(config.nominal, 1.0025, 0.985, 1.003);
  sim::VirtualRobot robot(config);
  const WheelParams& p = config.nominal;
  const sim::RunRecord ratio_run = robot.Execute(WallOutAndBack());
  const CvraResult ratio = WheelRatioFromWall(BelievedTravel(ratio_run, p).mean(),
                                              ratio_run.odometry_end.heading(), p.track_m);
  const sim::RunRecord straight = robot.Execute(RunSpec::Straight(2.0));
  const Pose2 e = straight.TrueEndInStartFrame();
  const CvraResult scale = ScaleFromStraight(2.0, e.x(), e.y(), e.heading());
  RunSpec spin = RunSpec::Spin(5, Direction::kCcw);
  spin.reference = Reference::kWall;
  const sim::RunRecord spin_run = robot.Execute(spin);
  const CvraResult track = TrackFromWall(10.0 * M_PI, spin_run.odometry_end.heading());
  ASSERT_TRUE(ratio.ok() && scale.ok() && track.ok());
  const WheelParams fixed = ApplyCvra(p, ratio.value, scale.value, track.value);
  const ErrorFactors left = ErrorFactorsFrom(fixed, config.truth);
  EXPECT_NEAR(left.Ed, 1.0, 2e-6);
  EXPECT_NEAR(left.Es, 1.0, 2e-5);
  EXPECT_NEAR(left.Eb, 1.0, 5e-5);
}

TEST(CvraInput, BadNumbersAreRejectedWithTheirName) {
  EXPECT_FALSE(WheelRatioFromWall(0.0, 0.01, 0.3).ok());
  EXPECT_THAT(WheelRatioFromWall(0.0, 0.01, 0.3).message, ::testing::HasSubstr("distance-mm"));
  EXPECT_FALSE(WheelRatioFromWall(2.0, 0.01, -0.3).ok());
  EXPECT_FALSE(WheelRatioFromCamera(2.0, std::nan(""), 0.3).ok());
  EXPECT_FALSE(WheelRatioFromCamera(0.1, 3.0, 0.3).ok()) << "ratio would be negative";
  EXPECT_FALSE(ScaleFromStraight(0.0, 1.0, 0.0, 0.0).ok());
  // Backwards (a negative distance asked) measures the same scale.
  ASSERT_TRUE(ScaleFromStraight(-1.0, -1.002, 0.0, 0.0).ok());
  EXPECT_NEAR(ScaleFromStraight(-1.0, -1.002, 0.0, 0.0).value, 1.002, 1e-12);
  EXPECT_FALSE(TrackFromWall(0.5, 0.0).ok());
  EXPECT_FALSE(TrackFromCamera(2.0 * M_PI, 4.0).ok());
}

}  // namespace
}  // namespace odocal::calibration
