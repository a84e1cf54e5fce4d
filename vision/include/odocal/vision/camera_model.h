// CameraModel: the overhead camera — pinhole intrinsics, OpenCV lens
// distortion and the camera's pose over the floor.
//
// Frames:
//   world   REP-103: x forward, y left, z up; the floor is z = 0.
//   camera  OpenCV optical frame: x right, y down, z forward (along the view).
// Pixels: OpenCV convention everywhere, pixel centres at integer coordinates,
//   so pixel (u, v) covers [u - 0.5, u + 0.5] x [v - 0.5, v + 0.5].
// Units: SI inside (metres, radians); the `_mm` / `_deg` fields of
//   CameraMount are the edge format the config files use.
//
// Mount rotation (documented once, used everywhere):
//   R_world_camera = Rz(yaw) * Ry(pitch) * Rx(roll) * R_world_down
// where R_world_down is the camera looking straight down with image x along
// world x (optical x = world +x, optical y = world -y, optical z = world -z),
// and Rx, Ry, Rz are rotations about the fixed world axes (REP-103 roll,
// pitch, yaw, counter-clockwise positive). All zero = looking straight down,
// image x along world x, image up = world +y. A positive pitch tips the view
// direction towards world -x.
//
// Lens models (LensModel), on normalised coordinates (x, y) = (X/Z, Y/Z),
// r = |(x, y)|:
//   plumb_bob    OpenCV's default (ROS plumb_bob, Kalibr radtan):
//                D = [k1 k2 p1 p2 k3], radial 1 + k1 r^2 + k2 r^4 + k3 r^6 and
//                tangential p1, p2.
//   equidistant  Kannala-Brandt as cv::fisheye (ROS equidistant, Kalibr
//                pinhole-equi), for fisheye lenses: D = [k1 k2 k3 k4];
//                theta = atan(r), theta_d = theta (1 + k1 theta^2 + k2 theta^4
//                + k3 theta^6 + k4 theta^8), distorted point (x, y) theta_d / r.
// The conversions to and from cv::Mat let `rig/` read OpenCV FileStorage and
// ROS camera_info files (K row-major 3x3, D as above).
#ifndef ODOCAL_VISION_CAMERA_MODEL_H_
#define ODOCAL_VISION_CAMERA_MODEL_H_

#include <array>
#include <iosfwd>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "odocal/base/status.h"

namespace odocal::vision {

enum class LensModel { kPlumbBob, kEquidistant };
// "plumb_bob", "equidistant": the names camera files and scenarios use.
const char* LensModelName(LensModel lens);
// Also the other programs' spellings: radtan (Kalibr), radial-tangential
// (ASL/EuRoC sensor.yaml), fisheye, equi.
std::optional<LensModel> ParseLensModel(const std::string& name);

struct Intrinsics {
  int width = 0;
  int height = 0;
  double fx = 0.0;
  double fy = 0.0;
  double cx = 0.0;
  double cy = 0.0;
  // plumb_bob: k1, k2, p1, p2, k3 (OpenCV's order); equidistant: k1..k4 and 0.
  std::array<double, 5> distortion{0.0, 0.0, 0.0, 0.0, 0.0};
  LensModel lens = LensModel::kPlumbBob;  // after `distortion`: {w, h, fx, fy, cx, cy, {d}} still reads

  bool IsValid(std::string* why) const;
  // 3x3 CV_64F camera matrix K.
  cv::Mat CameraMatrix() const;
  // CV_64F distortion vector: 1x5 (plumb_bob), 1x4 (equidistant, as cv::fisheye takes it).
  cv::Mat DistortionCoeffs() const;
  // From K (3x3) and D: plumb_bob 4, 5 or more coefficients (extra ones must
  // be zero since only k1..k3 are modelled), equidistant exactly 4.
  // kInvalidArgument saying what is wrong otherwise.
  static Result<Intrinsics> FromCv(const cv::Mat& camera_matrix, const cv::Mat& dist_coeffs, int width, int height,
                                   LensModel lens = LensModel::kPlumbBob);
};

// The camera's pose over the floor, in the config-file units.
struct CameraMount {
  double x_mm = 0.0;
  double y_mm = 0.0;
  double height_mm = 2000.0;
  double roll_deg = 0.0;
  double pitch_deg = 0.0;
  double yaw_deg = 0.0;

  // Rotation and position of the camera in the world frame (see top).
  Eigen::Isometry3d T_world_camera() const;
  // The inverse of T_world_camera(); nullopt-free: any rotation is valid.
  static CameraMount FromTransform(const Eigen::Isometry3d& T_world_camera);
};

class CameraModel {
 public:
  CameraModel() = default;
  CameraModel(const Intrinsics& intrinsics, const CameraMount& mount);

  const Intrinsics& intrinsics() const { return intrinsics_; }
  const CameraMount& mount() const { return mount_; }
  const Eigen::Isometry3d& T_world_camera() const { return T_world_camera_; }
  const Eigen::Isometry3d& T_camera_world() const { return T_camera_world_; }

  // Distorted pixel of a point in the camera frame; nullopt behind the camera.
  std::optional<Eigen::Vector2d> ProjectCamera(const Eigen::Vector3d& p_camera) const;
  // Distorted pixel of a world point; nullopt behind the camera.
  std::optional<Eigen::Vector2d> ProjectWorld(const Eigen::Vector3d& p_world) const;
  // Many world points at once (OpenCV projectPoints); points behind the camera
  // come out as NaN.
  std::vector<cv::Point2d> ProjectWorld(const std::vector<Eigen::Vector3d>& ps_world) const;

  // Distorted pixels -> undistorted normalised image coordinates (x/z, y/z),
  // solved to machine precision by Newton's method (OpenCV's default 5
  // fixed-point iterations leave ~0.01 px at the image corners with
  // k1 = -0.12, too much for ground truth); OpenCV's iteration is the fallback.
  std::vector<cv::Point2d> UndistortToNormalized(const std::vector<cv::Point2d>& pixels) const;
  // Distorted pixels -> undistorted pixels of the same pinhole (K, no distortion).
  std::vector<cv::Point2d> UndistortPixels(const std::vector<cv::Point2d>& pixels) const;
  // Unit-depth ray (x, y, 1) in the camera frame through a distorted pixel.
  Eigen::Vector3d UnprojectToRay(const Eigen::Vector2d& pixel) const;
  // Where the ray through `pixel` meets the horizontal plane z = plane_height_m
  // of the world; nullopt if it points away from it.
  std::optional<Eigen::Vector3d> UnprojectToWorldPlane(const Eigen::Vector2d& pixel,
                                                       double plane_height_m) const;
  bool InImage(const Eigen::Vector2d& pixel, double margin_px = 0.0) const;

 private:
  std::vector<cv::Point2d> UndistortEquidistant(const std::vector<cv::Point2d>& pixels) const;

  Intrinsics intrinsics_;
  CameraMount mount_;
  Eigen::Isometry3d T_world_camera_ = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d T_camera_world_ = Eigen::Isometry3d::Identity();
  cv::Mat K_;
  cv::Mat D_;
};

std::ostream& operator<<(std::ostream& os, const Intrinsics& intrinsics);
std::ostream& operator<<(std::ostream& os, const CameraMount& mount);

}  // namespace odocal::vision

#endif  // ODOCAL_VISION_CAMERA_MODEL_H_
