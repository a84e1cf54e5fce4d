// The lens candidate's measurement model (calibration/floor_camera.h) against
// the camera model the pipeline uses (OpenCV distortion, vision/camera_model.h):
// project a tag-plane point through the true camera (k1 + dk1, really tilted),
// unproject its pixel with the calibrated one, and compare.
#include <cmath>

#include <gtest/gtest.h>

#include "odocal/calibration/floor_camera.h"
#include "odocal/vision/camera_model.h"

namespace odocal {
namespace {

constexpr double kTagHeight = 0.15;

vision::Intrinsics Lens(double k1) {
  vision::Intrinsics in;
  in.width = 1280;
  in.height = 720;
  in.fx = in.fy = 700.0;
  in.cx = 640.0;
  in.cy = 360.0;
  in.distortion = {k1, 0.05, 0.0, 0.0, 0.0};
  return in;
}

calibration::FloorCamera FloorOf(const vision::CameraModel& camera) {
  calibration::FloorCamera f;
  f.centre_m = camera.T_world_camera().translation() - Eigen::Vector3d(0.0, 0.0, kTagHeight);
  f.R_camera_world = camera.T_camera_world().rotation();
  f.distortion = camera.intrinsics().distortion;
  return f;
}

// The worst difference over a grid of visible tag-plane points between the
// model and project-then-unproject through `truth` and `assumed`.
double WorstDifferenceM(const vision::CameraModel& truth, const vision::CameraModel& assumed,
                        double dk1, double tilt_x, double tilt_y, int* points) {
  const calibration::FloorCamera floor = FloorOf(assumed);
  double worst = 0.0;
  *points = 0;
  for (double x = -1.4; x <= 1.4; x += 0.1)
    for (double y = -1.9; y <= 0.0; y += 0.1) {
      const auto pixel = truth.ProjectWorld(Eigen::Vector3d(x, y, kTagHeight));
      if (!pixel || !truth.InImage(*pixel)) continue;
      const auto seen = assumed.UnprojectToWorldPlane(*pixel, kTagHeight);
      if (!seen) continue;
      double mx = 0.0, my = 0.0;
      calibration::SeenThroughLens(floor, x, y, dk1, tilt_x, tilt_y, &mx, &my);
      worst = std::max(worst, std::hypot(mx - seen->x(), my - seen->y()));
      ++*points;
    }
  return worst;
}

TEST(FloorCamera, K1ErrorMatchesProjectThenUnproject) {
  vision::CameraMount mount;
  mount.x_mm = 0.0;
  mount.y_mm = -1000.0;
  mount.height_mm = 2000.0;
  mount.pitch_deg = 3.0;
  mount.roll_deg = 0.5;
  const vision::CameraModel truth(Lens(-0.12 + 0.01), mount);
  const vision::CameraModel assumed(Lens(-0.12), mount);
  int points = 0;
  EXPECT_LT(WorstDifferenceM(truth, assumed, 0.01, 0.0, 0.0, &points), 1e-9);
  EXPECT_GT(points, 200);
  // And the effect is not trivially small: millimetres at the image edge.
  const double without = WorstDifferenceM(truth, assumed, 0.0, 0.0, 0.0, &points);
  EXPECT_GT(without, 2e-3);
}

TEST(FloorCamera, TiltIsARotationAboutTheCameraAxes) {
  vision::CameraMount mount;
  mount.y_mm = -1000.0;
  mount.height_mm = 2000.0;
  mount.pitch_deg = 3.0;
  const vision::CameraModel assumed(Lens(-0.12), mount);
  const double tx = 0.002, ty = -0.001;
  Eigen::Isometry3d T_camera_world = assumed.T_camera_world();
  T_camera_world.linear() =
      Eigen::AngleAxisd(std::hypot(tx, ty), Eigen::Vector3d(tx, ty, 0.0).normalized())
          .toRotationMatrix() *
      T_camera_world.linear();
  T_camera_world.translation() = -T_camera_world.linear() * assumed.T_world_camera().translation();
  const vision::CameraModel truth(
      Lens(-0.12 + 0.01), vision::CameraMount::FromTransform(T_camera_world.inverse()));
  int points = 0;
  EXPECT_LT(WorstDifferenceM(truth, assumed, 0.01, tx, ty, &points), 1e-9);
  EXPECT_GT(points, 200);
}

TEST(FloorCamera, OverheadCameraLooksDown) {
  const calibration::FloorCamera c = calibration::FloorCamera::Overhead({1.0, 0.5}, 2.5);
  EXPECT_TRUE(c.IsValid());
  EXPECT_NEAR((c.AxisPoint() - Eigen::Vector2d(1.0, 0.5)).norm(), 0.0, 1e-12);
  // Without a lens error a point is seen where it is.
  double mx = 0.0, my = 0.0;
  calibration::SeenThroughLens(c, 0.3, -0.4, 0.0, 0.0, 0.0, &mx, &my);
  EXPECT_NEAR(mx, 0.3, 1e-12);
  EXPECT_NEAR(my, -0.4, 1e-12);
}

}  // namespace
}  // namespace odocal
