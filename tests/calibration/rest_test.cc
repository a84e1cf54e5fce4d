// Rest detection on synthetic pose series with known truth.
#include "odocal/calibration/rest.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "odocal/calibration/measured_session.h"
#include "odocal/calibration/statistics.h"
#include "odocal/test_util/test_util.h"

namespace odocal::calibration {
namespace {

using test_util::IsNearPose;

// 30 fps: rest at A for 1.5 s, drive 0.5 m along x with a 0.5 m/s^2,
// 0.25 m/s trapezoid while turning 30 deg, rest at B for 1.5 s. Noise sigma.
std::vector<PoseSample> Series(const Pose2& a, double sigma_m, double sigma_rad, std::mt19937& rng,
                               Pose2* b_out) {
  std::normal_distribution<double> n(0.0, 1.0);
  std::vector<PoseSample> samples;
  const double accel = 0.5, speed = 0.25, dist = 0.5;
  const double t_acc = speed / accel, d_acc = 0.5 * speed * t_acc;
  const double t_move = 2 * t_acc + (dist - 2 * d_acc) / speed;
  auto progress = [&](double t) {
    if (t <= 0) return 0.0;
    if (t >= t_move) return dist;
    if (t < t_acc) return 0.5 * accel * t * t;
    if (t < t_move - t_acc) return d_acc + speed * (t - t_acc);
    const double td = t_move - t;
    return dist - 0.5 * accel * td * td;
  };
  const double turn = 30.0 * M_PI / 180.0;
  for (int i = 0; i < 30 * (3 + static_cast<int>(std::ceil(t_move))); ++i) {
    const double t = i / 30.0;
    const double u = progress(t - 1.5) / dist;
    const Pose2 truth = a * Pose2::FromXYHeading(u * dist, 0.0, u * turn);
    samples.push_back({t, Pose2::FromXYHeading(truth.x() + sigma_m * n(rng), truth.y() + sigma_m * n(rng),
                                               truth.heading() + sigma_rad * n(rng))});
  }
  *b_out = a * Pose2::FromXYHeading(dist, 0.0, turn);
  return samples;
}

TEST(FindRests, FindsBothRestsAndAveragesThemWithoutBias) {
  std::mt19937 rng(5);
  const Pose2 a = Pose2::FromXYHeading(0.3, -0.2, 2.0);
  Pose2 b;
  const auto samples = Series(a, 0.2e-3, 0.02 * M_PI / 180, rng, &b);
  const RestSummary s = FindRests(samples);
  ASSERT_EQ(s.rests.size(), 2u);
  EXPECT_THAT(s.rests[0].mean, IsNearPose(a, 0.1, 0.01));
  EXPECT_THAT(s.rests[1].mean, IsNearPose(b, 0.1, 0.01));
  // The first rest ends before the motion starts at 1.5 s.
  EXPECT_LT(s.rests[0].t_end_s, 1.5);
  EXPECT_GT(s.rests[0].t_end_s, 1.2);
  EXPECT_GT(s.rests[1].n, 25);
}

TEST(FindRests, BetweenIsUnbiasedAndItsSigmaIsHonest) {
  // Monte Carlo: the return error between the rests, normalised by its
  // propagated sigma, has mean 0 and standard deviation 1.
  std::mt19937 rng(11);
  const Pose2 a = Pose2::FromXYHeading(1.0, 0.5, -0.7);
  std::vector<double> zx, zy, zh;
  for (int trial = 0; trial < 200; ++trial) {
    Pose2 b;
    const auto samples = Series(a, 0.3e-3, 0.03 * M_PI / 180, rng, &b);
    const RestSummary s = FindRests(samples);
    ASSERT_EQ(s.rests.size(), 2u);
    const RelativePose r = Between(s.rests[0], s.rests[1]);
    const Pose2 truth = a.inverse() * b;
    zx.push_back((r.pose.x() - truth.x()) / r.sigma_x_m());
    zy.push_back((r.pose.y() - truth.y()) / r.sigma_y_m());
    zh.push_back(WrapAngle(r.pose.heading() - truth.heading()) / r.sigma_heading_rad());
  }
  for (const auto* z : {&zx, &zy, &zh}) {
    EXPECT_NEAR(Mean(*z), 0.0, 0.25);
    EXPECT_NEAR(*SampleStdDev(*z), 1.0, 0.2);
  }
}

TEST(FindRests, GapsSplitRestsAndShortPausesAreNotRests) {
  std::vector<PoseSample> samples;
  for (int i = 0; i < 90; ++i) {
    PoseSample s{i / 30.0, Pose2::FromXYHeading(0.1, 0.1, 0.0)};
    s.valid = !(i >= 40 && i < 55);  // half a second unseen
    samples.push_back(s);
  }
  const RestSummary s = FindRests(samples);
  ASSERT_EQ(s.rests.size(), 2u);
  EXPECT_LT(s.rests[0].t_end_s, 40 / 30.0);
  EXPECT_GT(s.rests[1].t_begin_s, 55 / 30.0);
  // A 0.3 s pause between motions is not a rest.
  std::vector<PoseSample> moving;
  for (int i = 0; i < 120; ++i) {
    const double t = i / 30.0;
    const double x = t < 1.8 ? 0.2 * t : (t < 2.1 ? 0.36 : 0.36 + 0.2 * (t - 2.1));
    moving.push_back({t, Pose2::FromXYHeading(x, 0.0, 0.0)});
  }
  EXPECT_TRUE(FindRests(moving).rests.empty());
}

}  // namespace
}  // namespace odocal::calibration

namespace odocal::calibration {
namespace {

// The pooled rest scatter recovers a known frame noise from many short
// rests, and ignores the frames in motion, invalid frames and rests too short
// to have a spread.
TEST(PooledRestScatter, RecoversTheFrameNoiseFromTheRests) {
  std::mt19937 rng(17);
  std::normal_distribution<double> n(0.0, 1.0);
  const double sigma_m = 0.2e-3, sigma_rad = 0.05 * M_PI / 180.0;
  std::vector<MeasuredRun> runs(20);
  for (size_t r = 0; r < runs.size(); ++r) {
    MeasuredRun& run = runs[r];
    const Pose2 start = Pose2::FromXYHeading(0.1 * r, -0.2, M_PI - 1e-4);  // noise wraps it
    const Pose2 end = Pose2::FromXYHeading(1.0, 0.3 * r, -3.1);
    for (int k = 0; k < 60; ++k) {
      CameraRecord c;
      c.t_s = 0.1 * k;
      c.valid = k != 5;
      const Pose2& truth = k < 20 ? start : k < 40 ? Pose2::FromXYHeading(5.0 * k, 0.0, 0.0) : end;
      c.T_world_robot = Pose2::FromXYHeading(truth.x() + sigma_m * n(rng), truth.y() + sigma_m * n(rng),
                                             truth.heading() + sigma_rad * n(rng));
      if (!c.valid) c.T_world_robot = Pose2::FromXYHeading(99.0, 99.0, 0.0);  // ignored
      run.camera.push_back(c);
    }
    run.start_rest = RestWindow{0.0, 1.95, 19, start, Eigen::Matrix3d::Zero()};
    run.end_rest = RestWindow{4.0, 5.95, 20, end, Eigen::Matrix3d::Zero()};
  }
  MeasuredRun too_short;  // a rest of two frames says nothing of the spread
  too_short.camera = {CameraRecord{0.0, true, Pose2::FromXYHeading(0, 0, 0), 0, 0},
                      CameraRecord{0.1, true, Pose2::FromXYHeading(1.0, 0, 0), 0, 0}};
  too_short.start_rest = RestWindow{0.0, 0.15, 2, Pose2::Identity(), Eigen::Matrix3d::Zero()};
  std::vector<const MeasuredRun*> pointers = {&too_short};
  for (const MeasuredRun& run : runs) pointers.push_back(&run);
  const RestScatter s = PooledRestScatter(pointers);
  EXPECT_EQ(s.dof, 20 * (18 + 19));
  // 740 degrees of freedom: the sample sigma is within ~3 % (1 sigma) of the truth.
  EXPECT_NEAR(s.sigma_position_m, sigma_m, 0.1 * sigma_m);
  EXPECT_NEAR(s.sigma_heading_rad, sigma_rad, 0.1 * sigma_rad);
  EXPECT_EQ(PooledRestScatter({}).dof, 0);
}

}  // namespace
}  // namespace odocal::calibration
