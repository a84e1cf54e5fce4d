// Planar pose and the camera-over-tag-plane estimator on rendered frames at
// the standard condition (1920x1080, fx 1400, k1 -0.12, 2000 mm high,
// pitch 3 deg, 80 mm tag at 150 mm, noise 2, blur 0.8 px).
#include <cmath>
#include <cstdio>
#include <random>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "odocal/base/units.h"
#include "odocal/test_util/test_util.h"
#include "odocal/vision/corner_refine.h"
#include "odocal/vision/detector.h"
#include "odocal/vision/planar_pose.h"
#include "odocal/vision/renderer.h"
#include "vision_fixtures.h"

namespace odocal::vision {
namespace {

using calibration::Pose2;
using calibration::WrapAngle;
using test_util::IsNearPose;

// Tracks, refines and measures one frame; nullopt if anything fails.
std::optional<TagCorners> Corners(TagTracker* tracker, const RenderedFrame& f, const CameraModel& camera) {
  const TrackResult t = tracker->Track(f.image);
  if (t.find.status != DetectStatus::kOk) return std::nullopt;
  const auto refined = RefineTagCorners(f.image, t.find.detection->corners_px, &camera);
  if (!refined.ok()) return std::nullopt;
  return refined.corners_px;
}

class PlanarPose : public ::testing::Test {
 protected:
  void SetUp() override {
    auto r = Renderer::Create(camera_, testing::StandardTag(), options_);
    ASSERT_TRUE(r.ok()) << r.message;
    renderer_ = std::move(r.renderer);
    auto d = TagDetector::Create(DetectorOptions{});
    ASSERT_TRUE(d.ok());
    detector_ = std::move(d.detector);
  }
  CameraModel camera_ = testing::StandardCamera();
  RenderOptions options_ = testing::StandardRender();
  std::unique_ptr<Renderer> renderer_;
  std::unique_ptr<TagDetector> detector_;
};

TEST_F(PlanarPose, StaticTagAveragedOverNoisyFramesIsWithinATenthOfAMillimetre) {
  // Centre, far left, bottom right: the accuracy must not depend on where.
  const Pose2 truths[] = {Pose2::FromXYHeading(0.02, -1.0, 0.4), Pose2::FromXYHeading(-1.05, -0.6, -2.0),
                          Pose2::FromXYHeading(1.0, -1.45, 2.9)};
  for (const Pose2& truth : truths) {
    TagTracker tracker(detector_.get(), 5);
    double sx = 0, sy = 0, sh = 0;
    constexpr int kFrames = 10;
    for (int i = 0; i < kFrames; ++i) {
      const RenderedFrame f = renderer_->Render(truth);
      const auto corners = Corners(&tracker, f, camera_);
      ASSERT_TRUE(corners);
      const PlanarPoseResult p = MeasureTagPose(camera_, testing::StandardTag(), *corners);
      ASSERT_TRUE(p.ok()) << p.message;
      sx += p.T_world_robot.x() - truth.x();
      sy += p.T_world_robot.y() - truth.y();
      sh += WrapAngle(p.T_world_robot.heading() - truth.heading());
    }
    const double ex_mm = sx / kFrames * 1e3, ey_mm = sy / kFrames * 1e3, eh_deg = sh / kFrames * kRadToDeg;
    std::printf("static %s: mean error (%.4f, %.4f) mm, %.5f deg over %d frames\n",
                ::testing::PrintToString(truth).c_str(), ex_mm, ey_mm, eh_deg, kFrames);
    EXPECT_LT(std::abs(ex_mm), 0.15);
    EXPECT_LT(std::abs(ey_mm), 0.15);
    EXPECT_LT(std::abs(eh_deg), 0.01);
  }
}

TEST_F(PlanarPose, MovingTagPerFramePoseWithinOneMillimetre) {
  options_.exposure_s = 0.004;
  SetUp();
  // 0.4 m/s forward while turning at 0.6 rad/s: 1.6 mm of smear per frame.
  auto trajectory = [](double t) {
    return Pose2::FromXYHeading(-0.3 + 0.4 * t, -0.9 + 0.05 * std::sin(t), 0.3 + 0.6 * t);
  };
  TagTracker tracker(detector_.get(), 5);
  double worst_mm = 0, worst_deg = 0;
  for (int i = 0; i < 15; ++i) {
    const double t = i / 30.0;
    const RenderedFrame f = renderer_->RenderExposure(trajectory, t);
    EXPECT_GT(f.motion_substeps, 1);
    const auto corners = Corners(&tracker, f, camera_);
    ASSERT_TRUE(corners) << "frame " << i;
    const PlanarPoseResult p = MeasureTagPose(camera_, testing::StandardTag(), *corners);
    ASSERT_TRUE(p.ok()) << p.message;
    EXPECT_THAT(p.T_world_robot, IsNearPose(f.T_world_robot, 1.0, 0.2)) << "frame " << i;
    worst_mm = std::max(worst_mm, 1e3 * (p.T_world_robot.translation() - f.T_world_robot.translation()).norm());
    worst_deg = std::max(worst_deg, std::abs(WrapAngle(p.T_world_robot.heading() - f.T_world_robot.heading())) * kRadToDeg);
  }
  std::printf("moving: worst per-frame error %.3f mm, %.4f deg\n", worst_mm, worst_deg);
}

TEST_F(PlanarPose, TagOffsetAndYawOnTheRobotAreUndone) {
  TagSpec tag = testing::StandardTag();
  tag.offset_x_mm = 60.0;
  tag.offset_y_mm = -25.0;
  tag.yaw_deg = 90.0;
  auto r = Renderer::Create(camera_, tag, options_);
  ASSERT_TRUE(r.ok()) << r.message;
  const Pose2 truth = Pose2::FromXYHeading(-0.4, -1.2, -0.8);
  const RenderedFrame f = r.renderer->Render(truth);
  // The tag is where the offset puts it...
  const Pose2 expected_tag = truth * Pose2::FromXYHeading(0.06, -0.025, M_PI / 2);
  EXPECT_THAT(f.T_world_tag, IsNearPose(expected_tag, 1e-9, 1e-9));
  TagTracker tracker(detector_.get(), 5);
  const auto corners = Corners(&tracker, f, camera_);
  ASSERT_TRUE(corners);
  const PlanarPoseResult p = MeasureTagPose(camera_, tag, *corners);
  ASSERT_TRUE(p.ok()) << p.message;
  // ...and the measurement gives the robot back, not the tag.
  EXPECT_THAT(p.T_world_tag, IsNearPose(expected_tag, 0.05, 0.05));
  EXPECT_THAT(p.T_world_robot, IsNearPose(truth, 0.05, 0.05));
}

TEST_F(PlanarPose, RejectsCornersThatAreNotTheTag) {
  const TagCorners skewed{cv::Point2d(100, 100), cv::Point2d(300, 100), cv::Point2d(110, 120),
                          cv::Point2d(100, 400)};
  const PlanarPoseResult p = MeasureTagPose(camera_, testing::StandardTag(), skewed);
  EXPECT_FALSE(p.ok());
  EXPECT_FALSE(p.message.empty());
  const TagCorners nan{cv::Point2d(NAN, 1), cv::Point2d(1, 1), cv::Point2d(1, 1), cv::Point2d(1, 1)};
  EXPECT_FALSE(MeasureTagPose(camera_, testing::StandardTag(), nan).ok());
}

// The operator knows intrinsics, tag size and height, not the camera's tilt
// and height: recover them from the tag's views alone.
TEST_F(PlanarPose, CameraPlaneEstimatorRecoversTiltAndHeight) {
  const CameraMount truth{0.0, -1000.0, 2000.0, -1.2, 3.0, 0.0};
  camera_ = CameraModel(testing::StandardIntrinsics(), truth);
  SetUp();
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> ux(-1.1, 1.1), uy(-1.5, -0.5), uh(-M_PI, M_PI);
  std::vector<TagCorners> views;
  std::vector<Pose2> truth_poses;
  // One noisy frame per pose, like the frames of a calibration run.
  while (views.size() < 40) {
    const RenderedFrame f = renderer_->Render(Pose2::FromXYHeading(ux(rng), uy(rng), uh(rng)));
    if (!f.tag_visible) continue;
    // A window around the truth stands in for the tracker's prediction.
    const FindResult found = detector_->Find(f.image, 5, cv::Rect(cvRound(f.corners_px[0].x) - 90,
                                                                   cvRound(f.corners_px[0].y) - 90, 180, 180));
    ASSERT_EQ(found.status, DetectStatus::kOk) << found.message;
    const auto refined = RefineTagCorners(f.image, found.detection->corners_px, &camera_);
    ASSERT_TRUE(refined.ok());
    views.push_back(refined.corners_px);
    truth_poses.push_back(f.T_world_tag);
  }
  // The operator's guess: level, 10 cm too high, and 3 cm / 1 deg off in the
  // gauge directions (x, y, yaw).
  const CameraMount nominal{30.0, -1030.0, 2100.0, 0.0, 0.0, 1.0};
  const CameraPlaneResult est =
      EstimateCameraOverTagPlane(testing::StandardIntrinsics(), testing::StandardTag(), views, nominal);
  ASSERT_TRUE(est.ok()) << est.message;
  std::printf("camera plane: %s\n", est.BriefReport().c_str());
  EXPECT_NEAR(est.mount.roll_deg, truth.roll_deg, 0.01);
  EXPECT_NEAR(est.mount.pitch_deg, truth.pitch_deg, 0.01);
  EXPECT_NEAR(est.mount.height_mm, truth.height_mm, 0.5);
  EXPECT_LT(est.rms_reprojection_px, 0.05);
  EXPECT_GT(est.sigma_height_mm, 0.0);
  EXPECT_NEAR(est.mount.yaw_deg, nominal.yaw_deg, 1e-12);  // the gauge is kept
  ASSERT_EQ(est.world_Ts_tag.size(), views.size());

  // Measured with the estimated camera, the views agree with the truth up to
  // the gauge (x, y, yaw of the camera).
  const CameraModel estimated(testing::StandardIntrinsics(), est.mount);
  std::vector<Pose2> measured;
  for (const auto& v : views) {
    const PlanarPoseResult p = MeasureTagPose(estimated, testing::StandardTag(), v);
    ASSERT_TRUE(p.ok());
    measured.push_back(p.T_world_tag);
  }
  // Gauge-free comparison: distances between all pairs of tag positions and
  // heading differences (a return error is built from exactly these).
  double worst_mm = 0, worst_deg = 0;
  for (size_t i = 0; i < views.size(); ++i) {
    for (size_t j = i + 1; j < views.size(); ++j) {
      const double d_measured = (measured[i].translation() - measured[j].translation()).norm();
      const double d_truth = (truth_poses[i].translation() - truth_poses[j].translation()).norm();
      worst_mm = std::max(worst_mm, 1e3 * std::abs(d_measured - d_truth));
      const double dh = WrapAngle((measured[j].heading() - measured[i].heading()) -
                                  (truth_poses[j].heading() - truth_poses[i].heading()));
      worst_deg = std::max(worst_deg, std::abs(dh) * kRadToDeg);
    }
  }
  std::printf("pairwise with the estimated plane: worst distance error %.4f mm, heading %.4f deg\n",
              worst_mm, worst_deg);
  // Single noisy frames per view: ~0.005 mm and ~0.01 deg of noise each, and
  // the tilt's own uncertainty over pairs up to 2.3 m apart (measured worst
  // of 780 pairs: 0.042 mm, 0.035 deg).
  EXPECT_LT(worst_mm, 0.08);
  EXPECT_LT(worst_deg, 0.05);

  // With the operator's level-camera guess instead, the same displacements
  // are centimetres off: the estimator is what makes them right.
  const CameraModel guessed(testing::StandardIntrinsics(), nominal);
  double worst_guessed_mm = 0;
  for (size_t i = 1; i < views.size(); ++i) {
    const Pose2 g0 = MeasureTagPose(guessed, testing::StandardTag(), views[0]).T_world_tag;
    const Pose2 gi = MeasureTagPose(guessed, testing::StandardTag(), views[i]).T_world_tag;
    const double d_truth = (truth_poses[0].translation() - truth_poses[i].translation()).norm();
    worst_guessed_mm = std::max(worst_guessed_mm, 1e3 * std::abs((g0.translation() - gi.translation()).norm() - d_truth));
  }
  EXPECT_GT(worst_guessed_mm, 5.0);
}

// The rolling shutter in the plane estimate, on exactly projected corners: a
// tag moving at up to 0.6 m/s, read out top to bottom over 20 ms, is seen
// sheared (each corner where it was at its row's time). Without the
// readout in the model the shear tilts the plane; with the views' corner
// velocities it comes out, and so does the readout time. (On rendered
// video, where the shear comes from the renderer's band-wise readout and
// the velocities from the tracker: tests/measure/camera_realism_test.cc.)
TEST(CameraPlane, RollingShutterShearIsTakenOut) {
  const CameraMount truth{0.0, -1000.0, 2000.0, -0.8, 3.0, 0.0};
  const CameraModel camera(testing::StandardIntrinsics(), truth);
  const TagSpec tag = testing::StandardTag();
  const double readout_s = 0.020;
  const int height = testing::StandardIntrinsics().height;
  std::mt19937 rng(21);
  std::uniform_real_distribution<double> ux(-1.0, 1.0), uy(-1.5, -0.5), uh(-M_PI, M_PI), uv(-0.6, 0.6);
  std::vector<TagCorners> sheared, still;
  std::vector<CornerVelocities> velocities;
  auto project = [&](const Pose2& robot) {
    TagCorners c;
    const Pose2 t = robot * tag.T_robot_tag();
    const auto model = TagCornersInTag(tag.size_m());
    for (int k = 0; k < 4; ++k) {
      const Eigen::Vector2d w = t * model[k];
      const auto px = camera.ProjectWorld(Eigen::Vector3d(w.x(), w.y(), tag.height_m()));
      c[k] = cv::Point2d(px->x(), px->y());
    }
    return c;
  };
  while (sheared.size() < 30) {
    const Pose2 pose = Pose2::FromXYHeading(ux(rng), uy(rng), uh(rng));
    const Eigen::Vector2d v(uv(rng), uv(rng));  // m/s
    const double w = uv(rng);                    // rad/s
    auto at = [&](double dt) {
      return Pose2::FromXYHeading(pose.x() + v.x() * dt, pose.y() + v.y() * dt, pose.heading() + w * dt);
    };
    const TagCorners mid = project(at(0.0));
    TagCorners seen, vel;
    for (int k = 0; k < 4; ++k) {
      // The row's time, found by iterating on the row it lands on.
      double dt = 0.0;
      for (int it = 0; it < 5; ++it) {
        seen[k] = project(at(dt))[k];
        dt = (seen[k].y / (height - 1) - 0.5) * readout_s;
      }
      const TagCorners a = project(at(-1e-3)), b = project(at(1e-3));
      vel[k] = (b[k] - a[k]) * (1.0 / 2e-3);
    }
    sheared.push_back(seen);
    still.push_back(mid);
    velocities.push_back(vel);
  }
  const CameraMount nominal{0.0, -1000.0, 2100.0, 0.0, 0.0, 0.0};
  const CameraPlaneResult plain = EstimateCameraOverTagPlane(testing::StandardIntrinsics(), tag, sheared, nominal);
  const CameraPlaneResult aware =
      EstimateCameraOverTagPlane(testing::StandardIntrinsics(), tag, sheared, nominal, {}, &velocities);
  ASSERT_TRUE(plain.ok() && aware.ok()) << plain.message << aware.message;
  std::printf("sheared views: without the readout roll %+.3f pitch %+.3f deg, height %+.2f mm off; with it "
              "%+.4f, %+.4f deg, %+.3f mm, readout %.3f +- %.3f ms\n",
              plain.mount.roll_deg - truth.roll_deg, plain.mount.pitch_deg - truth.pitch_deg,
              plain.mount.height_mm - truth.height_mm, aware.mount.roll_deg - truth.roll_deg,
              aware.mount.pitch_deg - truth.pitch_deg, aware.mount.height_mm - truth.height_mm,
              aware.rolling_shutter_ms, aware.sigma_rolling_shutter_ms);
  // The shear is a real error without the model...
  EXPECT_GT(std::hypot(plain.mount.roll_deg - truth.roll_deg, plain.mount.pitch_deg - truth.pitch_deg), 0.05);
  EXPECT_FALSE(plain.rolling_shutter_fitted);
  // ...and gone with it (first-order in the motion: exact corners leave
  // only the velocity's change over 10 ms).
  ASSERT_TRUE(aware.rolling_shutter_fitted);
  EXPECT_NEAR(aware.rolling_shutter_ms, 20.0, 0.05);
  EXPECT_NEAR(aware.mount.roll_deg, truth.roll_deg, 0.001);
  EXPECT_NEAR(aware.mount.pitch_deg, truth.pitch_deg, 0.001);
  EXPECT_NEAR(aware.mount.height_mm, truth.height_mm, 0.05);
  // A global shutter: still views with their (zero) velocities leave the
  // readout out of the fit, and the plane as it was.
  const std::vector<CornerVelocities> none(still.size());
  const CameraPlaneResult global =
      EstimateCameraOverTagPlane(testing::StandardIntrinsics(), tag, still, nominal, {}, &none);
  ASSERT_TRUE(global.ok());
  EXPECT_FALSE(global.rolling_shutter_fitted);
  EXPECT_NEAR(global.mount.roll_deg, truth.roll_deg, 1e-4);
  // Moving views from a global shutter: the readout comes out 0.
  const CameraPlaneResult moving_global =
      EstimateCameraOverTagPlane(testing::StandardIntrinsics(), tag, still, nominal, {}, &velocities);
  ASSERT_TRUE(moving_global.rolling_shutter_fitted);
  EXPECT_NEAR(moving_global.rolling_shutter_ms, 0.0, 0.05);
  EXPECT_NEAR(moving_global.mount.roll_deg, truth.roll_deg, 1e-3);
}

TEST(CameraPlane, TooFewViewsIsAClearFailure) {
  const CameraPlaneResult r = EstimateCameraOverTagPlane(testing::StandardIntrinsics(), testing::StandardTag(),
                                                         {}, testing::StandardMount());
  EXPECT_FALSE(r.ok());
  EXPECT_THAT(r.message, ::testing::HasSubstr("views"));
}


// The closure's error model, derived in planar_pose.h, checked by Monte
// Carlo: corners built from four edge lines, each moved along its normal by
// delta_e and turned about its middle by phi_e (the way a codec or a noisy
// band moves a fitted edge), projected into the standard camera, measured.
// The rest repeats one image (a still scene through a codec): its frames'
// spread is zero and only the closure can tell the error.
struct EdgeErrors {
  double sigma_offset_mm = 0.0, sigma_angle_rad = 0.0;
};

TagCorners CornersWithEdgeErrors(const CameraModel& camera, const TagSpec& tag, const Pose2& robot,
                                 const std::array<double, 4>& delta_mm, const std::array<double, 4>& phi) {
  const double h = 0.5 * tag.size_mm;
  // Edge k joins corner k and k + 1 of TagCornersInTag: bottom, right, top, left.
  const std::array<Eigen::Vector2d, 4> normal = {Eigen::Vector2d(0, -1), Eigen::Vector2d(1, 0),
                                                 Eigen::Vector2d(0, 1), Eigen::Vector2d(-1, 0)};
  std::array<Eigen::Vector2d, 4> point, dir;
  for (int k = 0; k < 4; ++k) {
    const Eigen::Rotation2Dd turn(phi[k]);
    point[k] = normal[k] * (h + delta_mm[k]);
    dir[k] = turn * Eigen::Vector2d(-normal[k].y(), normal[k].x());
  }
  const Pose2 T_world_tag = robot * tag.T_robot_tag();
  TagCorners px;
  for (int k = 0; k < 4; ++k) {
    // Corner k joins edge k - 1 and edge k.
    const int a = (k + 3) % 4, b = k;
    Eigen::Matrix2d m;
    m << dir[a], -dir[b];
    const Eigen::Vector2d st = m.inverse() * (point[b] - point[a]);
    const Eigen::Vector2d corner_mm = point[a] + st[0] * dir[a];
    const Eigen::Vector2d w = T_world_tag * (corner_mm * 1e-3);
    const auto p = camera.ProjectWorld(Eigen::Vector3d(w.x(), w.y(), tag.height_m()));
    px[k] = cv::Point2d(p->x(), p->y());
  }
  return px;
}

// Mean squared error of frozen rests against the closure's stated variance
// (position: x and y summed; heading), over many rests.
struct Coverage {
  double position_ratio = 0.0, heading_ratio = 0.0;  // observed / stated
};

Coverage FrozenRestCoverage(const EdgeErrors& errors, int rests, uint32_t seed, bool tag_off_centre) {
  const CameraModel camera = testing::StandardCamera();
  TagSpec tag = testing::StandardTag();
  tag.yaw_deg = 30.0;
  if (tag_off_centre) {
    tag.offset_x_mm = 60.0;
    tag.offset_y_mm = -25.0;
  }
  std::mt19937 rng(seed);
  std::normal_distribution<double> unit(0.0, 1.0);
  std::uniform_real_distribution<double> ux(-0.6, 0.6), uy(-1.3, -0.7), uh(-M_PI, M_PI);
  double err_p = 0, err_h = 0, var_p = 0, var_h = 0;
  for (int r = 0; r < rests; ++r) {
    const Pose2 robot = Pose2::FromXYHeading(ux(rng), uy(rng), uh(rng));
    std::array<double, 4> delta, phi;
    for (int k = 0; k < 4; ++k) {
      delta[k] = errors.sigma_offset_mm * unit(rng);
      phi[k] = errors.sigma_angle_rad * unit(rng);
    }
    const PlanarPoseResult m = MeasureTagPose(camera, tag, CornersWithEdgeErrors(camera, tag, robot, delta, phi));
    EXPECT_TRUE(m.ok()) << m.message;
    // Five frames of one image.
    const std::vector<std::array<Eigen::Vector2d, 4>> closures(5, m.closure_mm);
    const RestCornerError e = EstimateRestCornerError(closures, tag, m.T_world_robot.heading());
    EXPECT_NEAR(e.sigma_independent_mm, 0.0, 1e-12);
    err_p += (m.T_world_robot.translation() - robot.translation()).squaredNorm();
    err_h += std::pow(WrapAngle(m.T_world_robot.heading() - robot.heading()), 2);
    var_p += e.shared_covariance(0, 0) + e.shared_covariance(1, 1);
    var_h += e.shared_covariance(2, 2);
  }
  return {err_p / var_p, err_h / var_h};
}

TEST(RestCornerError, EdgeOffsetsAreCoveredExactly) {
  // The tag at the robot's centre: the stated heading variance (a bound
  // that holds if the same closure came from angles) adds nothing here.
  const Coverage c = FrozenRestCoverage({0.05, 0.0}, 20000, 11, false);
  EXPECT_NEAR(c.position_ratio, 1.0, 0.06);
  EXPECT_LT(c.heading_ratio, 1e-3);  // offsets do not turn the tag
  // Off the centre, the robot's position is stated with the heading's
  // lever arm: covered, not exactly.
  const Coverage off = FrozenRestCoverage({0.05, 0.0}, 20000, 11, true);
  EXPECT_LT(off.position_ratio, 1.0);
  EXPECT_GT(off.position_ratio, 0.7);
}

TEST(RestCornerError, EdgeAnglesAreCoveredExactly) {
  const Coverage c = FrozenRestCoverage({0.0, 1.5e-3}, 20000, 12, true);
  EXPECT_NEAR(c.heading_ratio, 1.0, 0.06);
  // The robot's centre is 65 mm from the tag's: it moves with the heading.
  EXPECT_LT(c.position_ratio, 1.0);
}

TEST(RestCornerError, AMixtureIsNeverUnderstated) {
  const Coverage c = FrozenRestCoverage({0.04, 1.0e-3}, 20000, 13, true);
  EXPECT_LT(c.position_ratio, 1.0);
  EXPECT_LT(c.heading_ratio, 1.0);
  EXPECT_GT(c.position_ratio, 0.2);  // a bound, not a blanket
  EXPECT_GT(c.heading_ratio, 0.2);
}

// Each corner its own error on the tag's plane (isotropic, sigma per
// coordinate, in the tag's frame), projected into `camera`.
TagCorners CornersWithOwnErrors(const CameraModel& camera, const TagSpec& tag, const Pose2& robot, double sigma_mm,
                                std::mt19937* rng) {
  std::normal_distribution<double> unit(0.0, 1.0);
  const Pose2 T_world_tag = robot * tag.T_robot_tag();
  const auto model = TagCornersInTag(tag.size_m());
  TagCorners px;
  for (int k = 0; k < 4; ++k) {
    const Eigen::Vector2d corner = model[k] + 1e-3 * sigma_mm * Eigen::Vector2d(unit(*rng), unit(*rng));
    const Eigen::Vector2d w = T_world_tag * corner;
    const auto p = camera.ProjectWorld(Eigen::Vector3d(w.x(), w.y(), tag.height_m()));
    px[k] = cv::Point2d(p->x(), p->y());
  }
  return px;
}

// The expectation (not a bound): with each corner erring on its own, the
// frozen rests' mean squared error is what expected_shared_covariance
// states, position and heading, with the tag off the robot's centre too.
TEST(RestCornerError, TheExpectationHoldsWhenEachCornerErrsOnItsOwn) {
  const CameraModel camera = testing::StandardCamera();
  for (const bool off_centre : {false, true}) {
    SCOPED_TRACE(off_centre ? "tag off the centre" : "tag at the centre");
    TagSpec tag = testing::StandardTag();
    if (off_centre) {
      tag.offset_x_mm = 60.0;
      tag.offset_y_mm = -25.0;
      tag.yaw_deg = 30.0;
    }
    std::mt19937 rng(17);
    std::uniform_real_distribution<double> ux(-0.6, 0.6), uy(-1.3, -0.7), uh(-M_PI, M_PI);
    double err_p = 0, err_h = 0, var_p = 0, var_h = 0, bound_p = 0, bound_h = 0;
    constexpr int kRests = 20000;
    for (int r = 0; r < kRests; ++r) {
      const Pose2 robot = Pose2::FromXYHeading(ux(rng), uy(rng), uh(rng));
      const PlanarPoseResult m = MeasureTagPose(camera, tag, CornersWithOwnErrors(camera, tag, robot, 0.05, &rng));
      ASSERT_TRUE(m.ok()) << m.message;
      const RestCornerError e = EstimateRestCornerError({m.closure_mm, m.closure_mm}, tag, m.T_world_robot.heading());
      err_p += (m.T_world_robot.translation() - robot.translation()).squaredNorm();
      err_h += std::pow(WrapAngle(m.T_world_robot.heading() - robot.heading()), 2);
      var_p += e.expected_shared_covariance(0, 0) + e.expected_shared_covariance(1, 1);
      var_h += e.expected_shared_covariance(2, 2);
      bound_p += e.shared_covariance(0, 0) + e.shared_covariance(1, 1);
      bound_h += e.shared_covariance(2, 2);
    }
    std::printf("  each corner its own error: error / expected %.3f (position), %.3f (heading); bounds / expected "
                "%.2f, %.2f\n", err_p / var_p, err_h / var_h, bound_p / var_p, bound_h / var_h);
    EXPECT_NEAR(err_p / var_p, 1.0, 0.05);
    EXPECT_NEAR(err_h / var_h, 1.0, 0.05);
    // The edge model's bounds state more, as bounds do.
    EXPECT_GT(bound_p, 1.2 * var_p);
    EXPECT_GT(bound_h, 1.2 * var_h);
  }
}

// setup-check fits the camera's roll and pitch to one still tag's views:
// the fit makes that tag as square as it can and takes 2 of the closure's 4
// dimensions. Counted (fitted_dof = 2), the image error read from the
// closure left over is the one the corners carry.
TEST(RestCornerError, ATiltFittedToTheSameFramesIsCounted) {
  const CameraModel camera = testing::StandardCamera();
  const TagSpec tag = testing::StandardTag();
  std::mt19937 rng(23);
  std::uniform_real_distribution<double> ux(-0.5, 0.5), uy(-1.2, -0.8), uh(-M_PI, M_PI);
  constexpr double kSigmaMm = 0.05;
  double fitted = 0.0, uncounted = 0.0;
  constexpr int kRests = 300;
  for (int r = 0; r < kRests; ++r) {
    const Pose2 robot = Pose2::FromXYHeading(ux(rng), uy(rng), uh(rng));
    // A repeated image: every view the same corners.
    const TagCorners px = CornersWithOwnErrors(camera, tag, robot, kSigmaMm, &rng);
    const CameraPlaneResult plane =
        EstimateCameraOverTagPlane(testing::StandardIntrinsics(), tag, {px, px, px}, testing::StandardMount());
    ASSERT_TRUE(plane.ok()) << plane.message;
    const PlanarPoseResult m = MeasureTagPose(CameraModel(testing::StandardIntrinsics(), plane.mount), tag, px);
    ASSERT_TRUE(m.ok());
    fitted += std::pow(EstimateRestCornerError({m.closure_mm}, tag, 0.0, 2).sigma_shared_mm, 2) / kRests;
    uncounted += std::pow(EstimateRestCornerError({m.closure_mm}, tag, 0.0).sigma_shared_mm, 2) / kRests;
  }
  std::printf("  tilt fitted to the frames: image error read %.2f (counted), %.2f (not) of the true\n",
              fitted / (kSigmaMm * kSigmaMm), uncounted / (kSigmaMm * kSigmaMm));
  // 300 rests of 2 dof: the mean square to +-8 % (1 sigma).
  EXPECT_NEAR(fitted / (kSigmaMm * kSigmaMm), 1.0, 0.25);
  EXPECT_NEAR(uncounted / (kSigmaMm * kSigmaMm), 0.5, 0.13);
}

// Frames with their own errors: the spread is the independent part, the
// shared part comes out near zero, and one repeated image has no spread.
TEST(RestCornerError, IndependentFramesAreToldFromASharedImage) {
  const CameraModel camera = testing::StandardCamera();
  const TagSpec tag = testing::StandardTag();
  const Pose2 robot = Pose2::FromXYHeading(0.1, -1.0, 0.4);
  std::mt19937 rng(5);
  std::normal_distribution<double> offset(0.0, 0.05);
  double independent_sq = 0.0, shared_sq = 0.0;
  constexpr int kRests = 400, kFrames = 10;
  for (int r = 0; r < kRests; ++r) {
    std::vector<std::array<Eigen::Vector2d, 4>> closures;
    for (int f = 0; f < kFrames; ++f) {
      const std::array<double, 4> delta = {offset(rng), offset(rng), offset(rng), offset(rng)};
      const PlanarPoseResult m = MeasureTagPose(camera, tag, CornersWithEdgeErrors(camera, tag, robot, delta, {}));
      closures.push_back(m.closure_mm);
    }
    const RestCornerError e = EstimateRestCornerError(closures, tag, robot.heading());
    independent_sq += e.sigma_independent_mm * e.sigma_independent_mm / kRests;
    shared_sq += e.sigma_shared_mm * e.sigma_shared_mm / kRests;
  }
  // Edge offsets of sigma 0.05 mm: E|r|^2 = 2 sigma^2 over 4 dof per coordinate.
  EXPECT_NEAR(std::sqrt(independent_sq), 0.05 / std::sqrt(2.0), 0.003);
  // Clamped at zero, the shared part's estimate is small and positive.
  EXPECT_LT(std::sqrt(shared_sq), 0.4 * 0.05 / std::sqrt(2.0));
  const RestCornerError none = EstimateRestCornerError({}, tag, 0.0);
  EXPECT_EQ(none.frames, 0);
  EXPECT_DOUBLE_EQ(none.shared_covariance.norm(), 0.0);
}

}  // namespace
}  // namespace odocal::vision
