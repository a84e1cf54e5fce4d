#include "odocal/calibration/pose2.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "odocal/test_util/test_util.h"

namespace odocal::calibration {
namespace {

using test_util::IsNearPose;

Pose2 RandomPose(std::mt19937& rng) {
  std::uniform_real_distribution<double> pos(-5.0, 5.0);
  std::uniform_real_distribution<double> angle(-M_PI, M_PI);
  return Pose2::FromXYHeading(pos(rng), pos(rng), angle(rng));
}

TEST(WrapAngle, MapsIntoHalfOpenInterval) {
  EXPECT_NEAR(WrapAngle(3.0 * M_PI), M_PI, 1e-12);
  EXPECT_NEAR(WrapAngle(-M_PI), M_PI, 1e-12);
  EXPECT_NEAR(WrapAngle(2.0 * M_PI + 0.1), 0.1, 1e-12);
  EXPECT_NEAR(WrapAngle(-0.1), -0.1, 1e-12);
}

TEST(Pose2, InverseComposesToIdentity) {
  std::mt19937 rng(42);
  for (int i = 0; i < 100; ++i) {
    const Pose2 T = RandomPose(rng);
    EXPECT_THAT(T * T.inverse(), IsNearPose(Pose2::Identity(), 1e-9, 1e-9));
    EXPECT_THAT(T.inverse() * T, IsNearPose(Pose2::Identity(), 1e-9, 1e-9));
  }
}

TEST(Pose2, CompositionIsAssociativeAndActsOnPoints) {
  std::mt19937 rng(7);
  for (int i = 0; i < 100; ++i) {
    const Pose2 a = RandomPose(rng), b = RandomPose(rng), c = RandomPose(rng);
    EXPECT_THAT((a * b) * c, IsNearPose(a * (b * c), 1e-9, 1e-9));
    const Eigen::Vector2d p(0.3, -1.2);
    EXPECT_TRUE(((a * b) * p).isApprox(a * (b * p), 1e-12));
  }
}

TEST(Pose2, QuarterTurnMovesForwardToLeft) {
  const Pose2 T_world_robot = Pose2::FromXYHeading(1.0, 2.0, M_PI / 2.0);
  const Eigen::Vector2d p_world = T_world_robot * Eigen::Vector2d(1.0, 0.0);
  EXPECT_NEAR(p_world.x(), 1.0, 1e-12);
  EXPECT_NEAR(p_world.y(), 3.0, 1e-12);
}

TEST(ArcStep, StraightAndInPlaceTurn) {
  EXPECT_THAT(ArcStep(Pose2::Identity(), 1.0, 1.0, 0.3),
              IsNearPose(Pose2::FromXYHeading(1.0, 0.0, 0.0), 1e-9, 1e-9));
  const double quarter = M_PI / 2.0 * 0.15;
  EXPECT_THAT(ArcStep(Pose2::Identity(), -quarter, quarter, 0.3),
              IsNearPose(Pose2::FromXYHeading(0.0, 0.0, M_PI / 2.0), 1e-9, 1e-9));
}

TEST(ArcStep, OneArcEqualsManySmallArcs) {
  // Constant curvature: splitting the arc must not change its end.
  const Pose2 one = ArcStep(Pose2::Identity(), 1.9, 2.1, 0.3);
  Pose2 many = Pose2::Identity();
  for (int i = 0; i < 1000; ++i) many = ArcStep(many, 1.9e-3, 2.1e-3, 0.3);
  EXPECT_THAT(many, IsNearPose(one, 1e-9, 1e-9));
  // And the end lies on the circle of radius R = b (l + r) / (2 (r - l)).
  const double R = 0.3 * 4.0 / (2.0 * 0.2);
  EXPECT_NEAR(std::hypot(one.x(), one.y() - R), R, 1e-12);
}

}  // namespace
}  // namespace odocal::calibration
