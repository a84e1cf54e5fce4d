// CameraModel: frames, projection round trips, OpenCV conversions.
#include <cmath>
#include <random>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>

#include "odocal/vision/camera_model.h"
#include "vision_fixtures.h"

namespace odocal::vision {
namespace {

TEST(CameraModel, AllZeroMountLooksStraightDownImageXAlongWorldX) {
  const CameraModel cam(testing::StandardIntrinsics(), CameraMount{0, 0, 2000, 0, 0, 0});
  const auto centre = cam.ProjectWorld(Eigen::Vector3d(0, 0, 0));
  ASSERT_TRUE(centre);
  EXPECT_NEAR(centre->x(), 960.0, 1e-9);
  EXPECT_NEAR(centre->y(), 540.0, 1e-9);
  const auto ahead = cam.ProjectWorld(Eigen::Vector3d(0.1, 0, 0));
  const auto left = cam.ProjectWorld(Eigen::Vector3d(0, 0.1, 0));
  EXPECT_GT(ahead->x(), centre->x() + 60);  // world x -> image right
  EXPECT_NEAR(ahead->y(), centre->y(), 1e-9);
  EXPECT_LT(left->y(), centre->y() - 60);   // world y (left) -> image up
  EXPECT_NEAR(left->x(), centre->x(), 1e-9);
}

TEST(CameraModel, PitchTipsViewTowardsMinusX) {
  // Documented in camera_model.h: positive pitch looks towards world -x, so the
  // point under the camera moves to the image's right (+x).
  const CameraModel cam(testing::StandardIntrinsics(), CameraMount{0, 0, 2000, 0, 3, 0});
  const auto below = cam.ProjectWorld(Eigen::Vector3d(0, 0, 0));
  EXPECT_NEAR(below->x() - 960.0, 1400.0 * std::tan(3.0 * M_PI / 180.0), 2.0);
  // Roll about world x moves it vertically; yaw turns the image.
  const CameraModel rolled(testing::StandardIntrinsics(), CameraMount{0, 0, 2000, 2, 0, 0});
  EXPECT_GT(std::abs(rolled.ProjectWorld(Eigen::Vector3d(0, 0, 0))->y() - 540.0), 40.0);
}

TEST(CameraModel, MountTransformRoundTrip) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> angle(-20.0, 20.0), pos(-2000.0, 2000.0);
  for (int i = 0; i < 50; ++i) {
    const CameraMount m{pos(rng), pos(rng), 1500 + pos(rng) / 4, angle(rng), angle(rng), 8 * angle(rng)};
    const CameraMount back = CameraMount::FromTransform(m.T_world_camera());
    EXPECT_NEAR(back.x_mm, m.x_mm, 1e-9);
    EXPECT_NEAR(back.y_mm, m.y_mm, 1e-9);
    EXPECT_NEAR(back.height_mm, m.height_mm, 1e-9);
    EXPECT_NEAR(back.roll_deg, m.roll_deg, 1e-9);
    EXPECT_NEAR(back.pitch_deg, m.pitch_deg, 1e-9);
    EXPECT_NEAR(back.yaw_deg, m.yaw_deg, 1e-9);
  }
}

TEST(CameraModel, ProjectMatchesOpenCvAndUnprojectInvertsIt) {
  const CameraModel cam = testing::StandardCamera();
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-0.5, 1919.5), v(-0.5, 1079.5);
  std::vector<cv::Point2d> pixels;
  for (int i = 0; i < 200; ++i) pixels.emplace_back(u(rng), v(rng));
  pixels.emplace_back(-0.5, -0.5);  // the worst corner for distortion
  const auto normalized = cam.UndistortToNormalized(pixels);
  std::vector<cv::Point3d> rays;
  for (const auto& n : normalized) rays.emplace_back(n.x, n.y, 1.0);
  std::vector<cv::Point2d> reprojected;
  cv::projectPoints(rays, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), cam.intrinsics().CameraMatrix(),
                    cam.intrinsics().DistortionCoeffs(), reprojected);
  for (size_t i = 0; i < pixels.size(); ++i) {
    EXPECT_NEAR(reprojected[i].x, pixels[i].x, 1e-8);
    EXPECT_NEAR(reprojected[i].y, pixels[i].y, 1e-8);
    const auto mine = cam.ProjectCamera(Eigen::Vector3d(rays[i].x, rays[i].y, 1.0));
    EXPECT_NEAR(mine->x(), pixels[i].x, 1e-8);
    EXPECT_NEAR(mine->y(), pixels[i].y, 1e-8);
  }
  // World round trip through the floor plane.
  const auto p = cam.UnprojectToWorldPlane(Eigen::Vector2d(300.25, 700.75), 0.15);
  ASSERT_TRUE(p);
  EXPECT_NEAR(p->z(), 0.15, 1e-12);
  const auto back = cam.ProjectWorld(*p);
  EXPECT_NEAR(back->x(), 300.25, 1e-8);
  EXPECT_NEAR(back->y(), 700.75, 1e-8);
}

TEST(CameraModel, BehindTheCameraIsNotProjected) {
  const CameraModel cam = testing::StandardCamera();
  EXPECT_FALSE(cam.ProjectWorld(Eigen::Vector3d(0, -1, 3.0)));
  // A horizontal ray never meets the floor.
  const CameraModel level(testing::StandardIntrinsics(), CameraMount{0, 0, 2000, 0, 90, 0});
  EXPECT_FALSE(level.UnprojectToWorldPlane(Eigen::Vector2d(960, 100), 0.0));
}

TEST(Intrinsics, OpenCvMatrixRoundTripAndValidation) {
  const Intrinsics in = testing::StandardIntrinsics();
  std::string why;
  const auto back = Intrinsics::FromCv(in.CameraMatrix(), in.DistortionCoeffs(), 1920, 1080);
  ASSERT_TRUE(back) << back.message;
  EXPECT_NEAR(back->fx, 1400.0, 1e-12);
  EXPECT_NEAR(back->cy, 540.0, 1e-12);
  EXPECT_NEAR(back->distortion[0], -0.12, 1e-12);
  EXPECT_NEAR(back->distortion[1], 0.05, 1e-12);
  // ROS camera_info "plumb_bob" D has 5 entries; 8-entry rational models
  // with non-zero k4..k6 are not representable and must be refused.
  cv::Mat d8 = (cv::Mat_<double>(1, 8) << -0.1, 0.01, 0, 0, 0, 0.2, 0, 0);
  const auto higher = Intrinsics::FromCv(in.CameraMatrix(), d8, 1920, 1080);
  EXPECT_FALSE(higher);
  EXPECT_EQ(higher.status, StatusCode::kInvalidArgument);
  EXPECT_THAT(higher.message, ::testing::HasSubstr("higher"));
  cv::Mat k_bad = in.CameraMatrix();
  k_bad.at<double>(0, 0) = -5;
  EXPECT_FALSE(Intrinsics::FromCv(k_bad, cv::Mat(), 1920, 1080));
  Intrinsics zero;
  EXPECT_FALSE(zero.IsValid(&why));
  EXPECT_FALSE(why.empty());
}

}  // namespace
}  // namespace odocal::vision
