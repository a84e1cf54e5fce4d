// EstimateSession on sessions built by hand (no video): return errors of a
// virtual robot with known error factors, put where the camera's would be.
#include "odocal/measure/estimate_session.h"

#include <cmath>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "odocal/calibration/corrections.h"
#include "odocal/calibration/cvra.h"
#include "odocal/sim/virtual_robot.h"
#include "odocal/test_util/robots.h"

namespace odocal::measure {
namespace {

using calibration::Direction;
using calibration::Pose2;
using calibration::RunFlag;
using calibration::RunFlagKind;
using calibration::RunSpec;

constexpr double kSide = 2.0;
constexpr double kEd = 0.996;
constexpr double kEb = 1.025;

RunMeasurement RunOf(const std::string& name, const RunSpec& spec, const Pose2& return_error,
                   std::vector<RunFlag> flags = {}) {
  RunMeasurement rm;
  rm.measured.name = name;
  rm.measured.spec = spec;
  calibration::RelativePose r;
  r.pose = return_error;
  r.covariance = Eigen::Matrix3d::Identity() * 1e-8;
  rm.measured.return_error = r;
  rm.measured.flags = std::move(flags);
  return rm;
}

// The run's return error on an exact robot with no telemetry: the robot's
// plan closes, so true - odometry is the true end in the start frame.
Pose2 SquareError(sim::VirtualRobot& robot, Direction d, double side = kSide) {
  return robot.Execute(RunSpec::Umbmark(d, side)).TrueEndInStartFrame();
}

SessionMeasurement Session(std::vector<RunMeasurement> runs) {
  SessionMeasurement sm;
  sm.session.path = "session.yaml";
  sm.session.nominal = test_util::NominalParams();
  sm.runs = std::move(runs);
  return sm;
}

class EstimateSessionUmbmark : public testing::Test {
 protected:
  EstimateSessionUmbmark() : robot_(test_util::ExactRobot(kEd, kEb)) {
    cw_ = SquareError(robot_, Direction::kCw);
    ccw_ = SquareError(robot_, Direction::kCcw);
  }
  sim::VirtualRobot robot_;
  Pose2 cw_, ccw_;
};

TEST_F(EstimateSessionUmbmark, RecoversEdAndEbFromACwAndACcwSquare) {
  const std::vector<SessionMeasurement> sessions = {
      Session({RunOf("cw1", RunSpec::Umbmark(Direction::kCw, kSide), cw_),
               RunOf("ccw1", RunSpec::Umbmark(Direction::kCcw, kSide), ccw_)})};
  const SessionEstimate e = EstimateSession(sessions);
  ASSERT_TRUE(e.umbmark.has_value()) << testing::PrintToString(e.notes);
  EXPECT_TRUE(e.any());
  EXPECT_TRUE(e.notes.empty()) << testing::PrintToString(e.notes);
  // The same bounds as UMBMark's own test on this robot (umbmark_test.cc).
  EXPECT_NEAR(e.umbmark->coupled.Ed, kEd, 1e-5);
  EXPECT_NEAR(e.umbmark->coupled.Eb, kEb, 1e-4);
  ASSERT_TRUE(e.umbmark_input.has_value());
  EXPECT_NEAR(e.umbmark_input->side_m, kSide, 1e-12);
  EXPECT_NEAR(e.umbmark_input->track_m, test_util::NominalParams().track_m, 1e-12);
  ASSERT_EQ(e.umbmark_input->cw.size(), 1u);
  ASSERT_EQ(e.umbmark_input->ccw.size(), 1u);
  EXPECT_NEAR(e.umbmark_input->cw[0].x_m, cw_.x(), 1e-12);
  EXPECT_NEAR(e.umbmark_input->ccw[0].y_m, ccw_.y(), 1e-12);
  EXPECT_FALSE(e.ratio || e.scale || e.track) << "no CVRA runs";
  EXPECT_EQ(CountUsableRuns(sessions), 2);

  // The corrected parameters are the true ones (equal nominal wheels: the
  // correction keeps their sum, which Es = 1 keeps too).
  const calibration::WheelParams nominal = test_util::NominalParams();
  const calibration::WheelParams truth = test_util::TrueParamsFor(nominal, kEd, kEb);
  const calibration::WheelParams corrected = CorrectedParams(nominal, e);
  EXPECT_NEAR(corrected.left_wheel_diameter_m, truth.left_wheel_diameter_m, 1e-5 * truth.left_wheel_diameter_m);
  EXPECT_NEAR(corrected.right_wheel_diameter_m, truth.right_wheel_diameter_m,
              1e-5 * truth.right_wheel_diameter_m);
  EXPECT_NEAR(corrected.track_m, truth.track_m, 1e-4 * truth.track_m);
  EXPECT_NEAR(corrected.ticks_per_rev, nominal.ticks_per_rev, 1e-9);
}

TEST_F(EstimateSessionUmbmark, FatallyFlaggedRunsAreNotUsed) {
  // A garbage ccw square with a fatal flag would wreck the estimate if pooled;
  // one with a benign flag is a normal run.
  const Pose2 garbage = Pose2::FromXYHeading(0.5, -0.4, 0.3);
  std::vector<RunMeasurement> runs = {
      RunOf("cw1", RunSpec::Umbmark(Direction::kCw, kSide), cw_,
          {RunFlag::Of(RunFlagKind::kShortStartRest)}),
      RunOf("ccw_bad", RunSpec::Umbmark(Direction::kCcw, kSide), garbage,
          {RunFlag::Of(RunFlagKind::kShortEndRest), RunFlag::Of(RunFlagKind::kNoEndRest)}),
      RunOf("ccw1", RunSpec::Umbmark(Direction::kCcw, kSide), ccw_,
          {RunFlag::Of(RunFlagKind::kTagOutOfViewMidRun, "0.3s")})};
  // A run without a return error at all.
  RunMeasurement missing = RunOf("cw_missing", RunSpec::Umbmark(Direction::kCw, kSide), garbage);
  missing.measured.return_error.reset();
  runs.push_back(missing);
  const std::vector<SessionMeasurement> sessions = {Session(runs)};

  EXPECT_EQ(CountUsableRuns(sessions), 2);
  const SessionEstimate e = EstimateSession(sessions);
  ASSERT_TRUE(e.umbmark.has_value()) << testing::PrintToString(e.notes);
  EXPECT_TRUE(e.notes.empty()) << "both directions have one usable square: "
                               << testing::PrintToString(e.notes);
  ASSERT_EQ(e.umbmark_input->ccw.size(), 1u);
  EXPECT_NEAR(e.umbmark_input->ccw[0].x_m, ccw_.x(), 1e-12) << "the garbage run was pooled";
  EXPECT_NEAR(e.umbmark->coupled.Ed, kEd, 1e-5);
  EXPECT_NEAR(e.umbmark->coupled.Eb, kEb, 1e-4);
}

TEST_F(EstimateSessionUmbmark, UnequalCountsAfterAFatalFlagPairTheFirstOfEach) {
  const Pose2 cw2 = SquareError(robot_, Direction::kCw);
  const std::vector<SessionMeasurement> sessions = {
      Session({RunOf("cw1", RunSpec::Umbmark(Direction::kCw, kSide), cw_),
               RunOf("ccw1", RunSpec::Umbmark(Direction::kCcw, kSide), ccw_),
               RunOf("cw2", RunSpec::Umbmark(Direction::kCw, kSide), cw2),
               RunOf("ccw2", RunSpec::Umbmark(Direction::kCcw, kSide), ccw_,
                   {RunFlag::Of(RunFlagKind::kVideoUnreadable, "moov atom not found")})})};
  EXPECT_EQ(CountUsableRuns(sessions), 3);
  const SessionEstimate e = EstimateSession(sessions);
  ASSERT_TRUE(e.umbmark.has_value()) << testing::PrintToString(e.notes);
  EXPECT_THAT(e.notes, testing::ElementsAre("umbmark: 2 cw and 1 ccw usable runs; using 1 of each"));
  ASSERT_EQ(e.umbmark_input->cw.size(), 1u);
  ASSERT_EQ(e.umbmark_input->ccw.size(), 1u);
  EXPECT_NEAR(e.umbmark_input->cw[0].x_m, cw_.x(), 1e-12) << "the first cw square";
  EXPECT_NEAR(e.umbmark->coupled.Ed, kEd, 1e-5);
}

TEST_F(EstimateSessionUmbmark, SquaresOfAnotherSideAreNotedAndNotPooled) {
  // The 1 m squares come from a robot with other errors: pooled, they would
  // move the estimate away from (kEd, kEb).
  sim::VirtualRobot other(test_util::ExactRobot(1.01, 0.97));
  const Pose2 small_cw = SquareError(other, Direction::kCw, 1.0);
  const Pose2 small_ccw = SquareError(other, Direction::kCcw, 1.0);
  // Across two sessions: the first square sets the side.
  const std::vector<SessionMeasurement> sessions = {
      Session({RunOf("cw1", RunSpec::Umbmark(Direction::kCw, kSide), cw_),
               RunOf("small_cw", RunSpec::Umbmark(Direction::kCw, 1.0), small_cw)}),
      Session({RunOf("small_ccw", RunSpec::Umbmark(Direction::kCcw, 1.0), small_ccw),
               RunOf("ccw1", RunSpec::Umbmark(Direction::kCcw, kSide), ccw_)})};
  EXPECT_EQ(CountUsableRuns(sessions), 4) << "usable, just not poolable";
  const SessionEstimate e = EstimateSession(sessions);
  ASSERT_TRUE(e.umbmark.has_value()) << testing::PrintToString(e.notes);
  EXPECT_THAT(e.notes, testing::ElementsAre("small_cw: square of another side, not pooled",
                                            "small_ccw: square of another side, not pooled"));
  EXPECT_NEAR(e.umbmark_input->side_m, kSide, 1e-12);
  EXPECT_EQ(e.umbmark_input->cw.size(), 1u);
  EXPECT_EQ(e.umbmark_input->ccw.size(), 1u);
  EXPECT_NEAR(e.umbmark->coupled.Ed, kEd, 1e-5);
  EXPECT_NEAR(e.umbmark->coupled.Eb, kEb, 1e-4);
}

TEST(EstimateSession, OnlyFatalRunsGiveNoEstimate) {
  const std::vector<SessionMeasurement> sessions = {
      Session({RunOf("cw1", RunSpec::Umbmark(Direction::kCw, kSide), Pose2::Identity(),
                   {RunFlag::Of(RunFlagKind::kTagNeverSeen)}),
               RunOf("ccw1", RunSpec::Umbmark(Direction::kCcw, kSide), Pose2::Identity(),
                   {RunFlag::Of(RunFlagKind::kImageQuality, "end_rest:blurred")})})};
  EXPECT_EQ(CountUsableRuns(sessions), 0);
  const SessionEstimate e = EstimateSession(sessions);
  EXPECT_FALSE(e.any());
  EXPECT_FALSE(e.umbmark_input.has_value());
}

TEST(EstimateSession, OutAndBacksGiveTheWheelRatioAsWheelRatioFromCamera) {
  const double track = test_util::NominalParams().track_m;
  const RunSpec spec = RunSpec::OutAndBack(1.5, 2, Direction::kCcw);
  const double travel = 2.0 * 1.5 * 2;  // out and back, twice
  const double h1 = 0.0123, h2 = 0.0131;
  const std::vector<SessionMeasurement> sessions = {
      Session({RunOf("oab1", spec, Pose2::FromXYHeading(0.004, -0.002, h1)),
               RunOf("oab2", spec, Pose2::FromXYHeading(0.003, -0.001, h2)),
               RunOf("oab_fatal", spec, Pose2::FromXYHeading(0.0, 0.0, 0.2),
                   {RunFlag::Of(RunFlagKind::kNoStartRest)})})};
  const SessionEstimate e = EstimateSession(sessions);
  ASSERT_TRUE(e.ratio.has_value()) << testing::PrintToString(e.notes);
  EXPECT_FALSE(e.umbmark.has_value());
  EXPECT_FALSE(e.scale || e.track);
  const calibration::CvraResult r1 = calibration::WheelRatioFromCamera(travel, h1, track);
  const calibration::CvraResult r2 = calibration::WheelRatioFromCamera(travel, h2, track);
  ASSERT_TRUE(r1.ok() && r2.ok());
  ASSERT_EQ(e.ratio->values.size(), 2u);
  EXPECT_NEAR(e.ratio->values[0], r1.value, 1e-12);
  EXPECT_NEAR(e.ratio->values[1], r2.value, 1e-12);
  EXPECT_THAT(e.ratio->runs, testing::ElementsAre("oab1", "oab2"));
  EXPECT_NEAR(e.ratio->mean, 0.5 * (r1.value + r2.value), 1e-12);
  // Two values: the standard error of their mean is |a - b| / 2.
  ASSERT_TRUE(e.ratio->standard_error.has_value());
  EXPECT_NEAR(*e.ratio->standard_error, 0.5 * std::abs(r1.value - r2.value), 1e-12);
  // A heading gained ccw means the right wheel is the larger one: Ed > 1.
  EXPECT_GT(e.ratio->mean, 1.0);

  // Without UMBMark the CVRA ratio sets the wheels.
  const calibration::WheelParams nominal = test_util::NominalParams();
  const calibration::WheelParams corrected = CorrectedParams(nominal, e);
  EXPECT_NEAR(corrected.right_wheel_diameter_m / corrected.left_wheel_diameter_m,
              e.ratio->mean * nominal.right_wheel_diameter_m / nominal.left_wheel_diameter_m, 1e-9);
  EXPECT_NEAR(corrected.track_m, nominal.track_m, 1e-12);
}

TEST(EstimateSession, OneOutAndBackHasNoStandardError) {
  const RunSpec spec = RunSpec::OutAndBack(1.0, 1, Direction::kCcw);
  const SessionEstimate e =
      EstimateSession({Session({RunOf("oab1", spec, Pose2::FromXYHeading(0.0, 0.0, 0.01))})});
  ASSERT_TRUE(e.ratio.has_value());
  EXPECT_FALSE(e.ratio->standard_error.has_value());
}

TEST(EstimateSession, OutAndBackOnAnExactRobotRecoversItsEd) {
  // Independent truth: the virtual robot's true Ed, seen through the camera's
  // heading error (true - odometry) as EstimateSession reads it.
  constexpr double kRobotEd = 1.0025;
  sim::VirtualRobot robot(test_util::ExactRobot(kRobotEd, 1.0));
  const RunSpec spec = RunSpec::OutAndBack(1.0, 2, Direction::kCcw);
  const sim::RunRecord run = robot.Execute(spec);
  const Pose2 error = Pose2::FromXYHeading(
      0.0, 0.0, calibration::WrapAngle(run.TrueEndInStartFrame().heading() - run.odometry_end.heading()));
  const SessionEstimate e = EstimateSession({Session({RunOf("oab", spec, error)})});
  ASSERT_TRUE(e.ratio.has_value()) << testing::PrintToString(e.notes);
  EXPECT_NEAR(e.ratio->mean, kRobotEd, 1e-4);
}

TEST(EstimateSession, WallReferencedOutAndBacksAreNoted) {
  RunSpec spec = RunSpec::OutAndBack(1.0, 1, Direction::kCcw);
  spec.reference = calibration::Reference::kWall;
  const SessionEstimate e =
      EstimateSession({Session({RunOf("wall1", spec, Pose2::FromXYHeading(0.0, 0.0, 0.01))})});
  EXPECT_FALSE(e.ratio.has_value());
  EXPECT_FALSE(e.any());
  ASSERT_EQ(e.notes.size(), 1u);
  EXPECT_THAT(e.notes[0], testing::StartsWith("wall1: wall-referenced"));
}

}  // namespace
}  // namespace odocal::measure
