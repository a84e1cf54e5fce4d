// The default plan's sizing, the turn-slip analysis and the command
// templates, on analytic cases.
#include <cmath>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "odocal/station/driver.h"
#include "odocal/station/plan.h"

namespace odocal::station {
namespace {

using calibration::Pose2;
using calibration::Procedure;

// A rectangular view 2.0 m x 1.2 m centred on the origin.
// (A nanometre of slack: the corners are computed by rotations.)
bool InBox(const Eigen::Vector2d& p) { return std::abs(p.x()) <= 1.0 + 1e-9 && std::abs(p.y()) <= 0.6 + 1e-9; }

TEST(DefaultPlan, SizesTheSquareAndTheStraightToTheView) {
  std::string summary;
  // From (-0.7, 0) heading +x: a square turning either way must fit within
  // y in [-0.6, 0.6] (0.6 m), the straight within x <= 1.0 (1.7 m: 1.5 m).
  const auto plan = DefaultPlan(InBox, Pose2::FromXYHeading(-0.7, 0.0, 0.0), Pose2::Identity(), {}, &summary);
  ASSERT_FALSE(plan.empty()) << summary;
  int squares = 0, straights = 0, spins = 0;
  for (const calibration::RunSpec& s : plan) {
    if (s.procedure == Procedure::kUmbmark) {
      ++squares;
      EXPECT_NEAR(s.side_m, 0.6, 1e-12);
    } else if (s.procedure == Procedure::kStraight) {
      ++straights;
      EXPECT_NEAR(std::abs(s.distance_m), 1.5, 1e-12);
    } else if (s.procedure == Procedure::kSpin) {
      ++spins;
      EXPECT_TRUE(s.turn_rate_rad_s.has_value());
    }
  }
  EXPECT_EQ(squares, 4);
  EXPECT_EQ(straights, 4);
  EXPECT_EQ(spins, 4);
  EXPECT_THAT(summary, ::testing::HasSubstr("squares of 600 mm"));
  // A tag mounted 0.3 m ahead of the axle needs that much more room ahead:
  // 1.5 m would take it to x = 1.1.
  const auto offset = DefaultPlan(InBox, Pose2::FromXYHeading(-0.7, 0.0, 0.0), Pose2::FromXYHeading(0.3, 0.0, 0.0),
                                  {}, &summary);
  for (const calibration::RunSpec& s : offset) {
    if (s.procedure == Procedure::kStraight) {
      EXPECT_NEAR(std::abs(s.distance_m), 1.2, 1e-12);
    }
  }
  // Standing at the view's edge: nothing fits, said.
  EXPECT_TRUE(DefaultPlan(InBox, Pose2::FromXYHeading(0.95, 0.55, 0.0), Pose2::Identity(), {}, &summary).empty());
  EXPECT_THAT(summary, ::testing::HasSubstr("keeps the tag in view"));
}

TEST(TurnRates, RecoversASlipFromTwoRatesAndItsUncertainty) {
  // Eb0 = 1.01, f = 0.03 per rad/s: Eb(w) = Eb0 / (1 - f w), two spins at
  // each rate with a spread of +-1e-4.
  const double Eb0 = 1.01, f = 0.03, w1 = 0.5, w2 = 2.0;
  auto eb = [&](double w) { return Eb0 / (1.0 - f * w); };
  const std::vector<SpinTrack> spins = {
      {w1, eb(w1) + 1e-4}, {w1, eb(w1) - 1e-4}, {w2, eb(w2) + 1e-4}, {w2 * 1.005, eb(w2) - 1e-4}};
  const TurnSlipResult r = AnalyzeTurnRates(spins);
  ASSERT_EQ(r.groups.size(), 2u) << "rates within 1 % are one group";
  ASSERT_TRUE(r.slip_per_rad_s && r.track_factor_at_rest);
  // The group means are exact here (the spreads cancel), up to the 0.5 % rate jitter.
  EXPECT_NEAR(*r.slip_per_rad_s, f, 2e-4);
  EXPECT_NEAR(*r.track_factor_at_rest, Eb0, 2e-4);
  // Standard error of a group: 1e-4 (sample sd 1.41e-4 over sqrt 2).
  EXPECT_NEAR(*r.groups[0].standard_error, 1e-4, 1e-9);
  EXPECT_GT(*r.slip_sigma, 0.0);
  EXPECT_TRUE(r.significant);
  EXPECT_THAT(r.advice, ::testing::HasSubstr("calibrate at your operating turn rate"));
  // No slip: the same factor at both rates is not significant.
  const TurnSlipResult none = AnalyzeTurnRates({{w1, 1.01 + 1e-4}, {w1, 1.01 - 1e-4}, {w2, 1.01 + 1e-4}, {w2, 1.01 - 1e-4}});
  ASSERT_TRUE(none.slip_per_rad_s);
  EXPECT_NEAR(*none.slip_per_rad_s, 0.0, 1e-12);
  EXPECT_FALSE(none.significant);
  // One rate: nothing to compare.
  EXPECT_FALSE(AnalyzeTurnRates({{w1, 1.0}, {w1, 1.0}}).slip_per_rad_s.has_value());
}

TEST(CommandTemplate, ExpandsKnownPlaceholdersAndNamesUnknownOnes) {
  const Result<std::string> drive =
      ExpandTemplate("drive --side {side_mm} --dir {direction}", {{"side_mm", "500"}, {"direction", "cw"}});
  ASSERT_TRUE(drive) << drive.message;
  EXPECT_EQ(*drive, "drive --side 500 --dir cw");
  const Result<std::string> unknown = ExpandTemplate("drive {side}", {{"side_mm", "500"}});
  EXPECT_EQ(unknown.status, StatusCode::kInvalidArgument);
  EXPECT_THAT(unknown.message, ::testing::HasSubstr("unknown placeholder {side}"));
  EXPECT_THAT(ExpandTemplate("drive {side_mm", {{"side_mm", "500"}}).message, ::testing::HasSubstr("'{' without '}'"));
  EXPECT_FALSE(ExpandTemplate("drive }", {}));
  const Status run = CheckTemplate("x {procedure} {turn_rate_deg_s} {log}", "run");
  EXPECT_TRUE(run) << run.message;
  EXPECT_FALSE(CheckTemplate("x {file}", "run"));
  const Status apply = CheckTemplate("push {file} {track_mm}", "apply");
  EXPECT_TRUE(apply) << apply.message;
}

}  // namespace
}  // namespace odocal::station
