#include "odocal/vision/camera_model.h"

#include <cmath>
#include <limits>
#include <ostream>

#include <opencv2/calib3d.hpp>

#include "odocal/base/units.h"

namespace odocal::vision {
namespace {

// Optical axes of a camera looking straight down, image x along world x.
Eigen::Matrix3d RWorldDown() {
  Eigen::Matrix3d r;
  r.col(0) = Eigen::Vector3d(1, 0, 0);
  r.col(1) = Eigen::Vector3d(0, -1, 0);
  r.col(2) = Eigen::Vector3d(0, 0, -1);
  return r;
}

// Tight enough that the inverse matches projectPoints to ~1e-9 px.
const cv::TermCriteria kUndistortCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 200,
                                          1e-14);

// The equidistant model's theta_d(theta) and its derivative.
double ThetaD(const std::array<double, 5>& k, double theta, double* derivative) {
  const double t2 = theta * theta;
  const double poly = 1.0 + t2 * (k[0] + t2 * (k[1] + t2 * (k[2] + t2 * k[3])));
  if (derivative) *derivative = 1.0 + t2 * (3.0 * k[0] + t2 * (5.0 * k[1] + t2 * (7.0 * k[2] + t2 * 9.0 * k[3])));
  return theta * poly;
}

}  // namespace

const char* LensModelName(LensModel lens) {
  return lens == LensModel::kEquidistant ? "equidistant" : "plumb_bob";
}

std::optional<LensModel> ParseLensModel(const std::string& name) {
  if (name == "plumb_bob" || name == "radtan" || name == "pinhole-radtan" || name == "radial-tangential")
    return LensModel::kPlumbBob;
  if (name == "equidistant" || name == "fisheye" || name == "equi" || name == "pinhole-equi")
    return LensModel::kEquidistant;
  return std::nullopt;
}

bool Intrinsics::IsValid(std::string* why) const {
  auto fail = [&](const char* msg) {
    if (why) *why = msg;
    return false;
  };
  if (width <= 0 || height <= 0) return fail("image width and height must be positive");
  if (!(fx > 0.0) || !(fy > 0.0)) return fail("focal lengths fx, fy must be positive");
  if (!std::isfinite(cx) || !std::isfinite(cy)) return fail("principal point must be finite");
  for (double d : distortion) {
    if (!std::isfinite(d)) return fail("distortion coefficients must be finite");
  }
  if (lens == LensModel::kEquidistant && distortion[4] != 0.0)
    return fail("an equidistant lens has four coefficients k1..k4");
  return true;
}

cv::Mat Intrinsics::CameraMatrix() const {
  return (cv::Mat_<double>(3, 3) << fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0);
}

cv::Mat Intrinsics::DistortionCoeffs() const {
  if (lens == LensModel::kEquidistant)
    return (cv::Mat_<double>(1, 4) << distortion[0], distortion[1], distortion[2], distortion[3]);
  return (cv::Mat_<double>(1, 5) << distortion[0], distortion[1], distortion[2], distortion[3],
          distortion[4]);
}

Result<Intrinsics> Intrinsics::FromCv(const cv::Mat& camera_matrix, const cv::Mat& dist_coeffs, int width, int height,
                                      LensModel lens) {
  using R = Result<Intrinsics>;
  if (camera_matrix.rows != 3 || camera_matrix.cols != 3) {
    return R::Error(StatusCode::kInvalidArgument, "camera matrix must be 3x3");
  }
  cv::Mat k;
  camera_matrix.convertTo(k, CV_64F);
  if (std::abs(k.at<double>(0, 1)) > 1e-9 || std::abs(k.at<double>(1, 0)) > 1e-9 ||
      std::abs(k.at<double>(2, 0)) > 1e-9 || std::abs(k.at<double>(2, 1)) > 1e-9 ||
      std::abs(k.at<double>(2, 2) - 1.0) > 1e-9) {
    return R::Error(StatusCode::kInvalidArgument, "camera matrix must be [fx 0 cx; 0 fy cy; 0 0 1] (no skew)");
  }
  Intrinsics in;
  in.width = width;
  in.height = height;
  in.fx = k.at<double>(0, 0);
  in.fy = k.at<double>(1, 1);
  in.cx = k.at<double>(0, 2);
  in.cy = k.at<double>(1, 2);
  in.lens = lens;
  if (lens == LensModel::kEquidistant && !dist_coeffs.empty()) {
    cv::Mat d;
    dist_coeffs.reshape(1, 1).convertTo(d, CV_64F);
    if (d.cols != 4) {
      return R::Error(
          StatusCode::kInvalidArgument,
          "an equidistant (fisheye) lens has exactly 4 coefficients k1 k2 k3 k4, got " + std::to_string(d.cols));
    }
    for (int i = 0; i < 4; ++i) in.distortion[i] = d.at<double>(0, i);
  } else if (!dist_coeffs.empty()) {
    cv::Mat d;
    dist_coeffs.reshape(1, 1).convertTo(d, CV_64F);
    const int n = d.cols;
    if (n != 4 && n < 5) {
      return R::Error(StatusCode::kInvalidArgument, "distortion must have 4, 5 or more coefficients");
    }
    for (int i = 0; i < std::min(n, 5); ++i) in.distortion[i] = d.at<double>(0, i);
    for (int i = 5; i < n; ++i) {
      if (std::abs(d.at<double>(0, i)) > 1e-12) {
        return R::Error(StatusCode::kInvalidArgument,
                        "only k1 k2 p1 p2 k3 are modelled; higher coefficients must be zero");
      }
    }
  }
  std::string reason;
  if (!in.IsValid(&reason)) return R::Error(StatusCode::kInvalidArgument, reason);
  return R::Ok(in);
}

Eigen::Isometry3d CameraMount::T_world_camera() const {
  const Eigen::Matrix3d r =
      (Eigen::AngleAxisd(yaw_deg * kDegToRad, Eigen::Vector3d::UnitZ()) *
       Eigen::AngleAxisd(pitch_deg * kDegToRad, Eigen::Vector3d::UnitY()) *
       Eigen::AngleAxisd(roll_deg * kDegToRad, Eigen::Vector3d::UnitX()))
          .toRotationMatrix() *
      RWorldDown();
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = r;
  t.translation() = Eigen::Vector3d(x_mm, y_mm, height_mm) * kMmToM;
  return t;
}

CameraMount CameraMount::FromTransform(const Eigen::Isometry3d& T_world_camera) {
  // Undo R_world_down, then read Z-Y-X angles off R = Rz Ry Rx.
  const Eigen::Matrix3d r = T_world_camera.linear() * RWorldDown().transpose();
  CameraMount m;
  m.yaw_deg = std::atan2(r(1, 0), r(0, 0)) / kDegToRad;
  m.pitch_deg = std::asin(std::clamp(-r(2, 0), -1.0, 1.0)) / kDegToRad;
  m.roll_deg = std::atan2(r(2, 1), r(2, 2)) / kDegToRad;
  m.x_mm = T_world_camera.translation().x() * kMToMm;
  m.y_mm = T_world_camera.translation().y() * kMToMm;
  m.height_mm = T_world_camera.translation().z() * kMToMm;
  return m;
}

CameraModel::CameraModel(const Intrinsics& intrinsics, const CameraMount& mount)
    : intrinsics_(intrinsics),
      mount_(mount),
      T_world_camera_(mount.T_world_camera()),
      T_camera_world_(T_world_camera_.inverse()),
      K_(intrinsics.CameraMatrix()),
      D_(intrinsics.DistortionCoeffs()) {}

std::optional<Eigen::Vector2d> CameraModel::ProjectCamera(const Eigen::Vector3d& p_camera) const {
  if (!(p_camera.z() > 1e-9)) return std::nullopt;
  const double x = p_camera.x() / p_camera.z();
  const double y = p_camera.y() / p_camera.z();
  // The OpenCV model written out (it is what cv::projectPoints computes) so
  // single points avoid cv::Mat allocations.
  const auto& d = intrinsics_.distortion;
  const double r2 = x * x + y * y;
  if (intrinsics_.lens == LensModel::kEquidistant) {
    const double r = std::sqrt(r2);
    // theta_d / r -> 1 on the axis.
    const double scale = r > 1e-12 ? ThetaD(d, std::atan(r), nullptr) / r : 1.0;
    return Eigen::Vector2d(intrinsics_.fx * x * scale + intrinsics_.cx, intrinsics_.fy * y * scale + intrinsics_.cy);
  }
  const double radial = 1.0 + d[0] * r2 + d[1] * r2 * r2 + d[4] * r2 * r2 * r2;
  const double xd = x * radial + 2.0 * d[2] * x * y + d[3] * (r2 + 2.0 * x * x);
  const double yd = y * radial + d[2] * (r2 + 2.0 * y * y) + 2.0 * d[3] * x * y;
  return Eigen::Vector2d(intrinsics_.fx * xd + intrinsics_.cx, intrinsics_.fy * yd + intrinsics_.cy);
}

std::optional<Eigen::Vector2d> CameraModel::ProjectWorld(const Eigen::Vector3d& p_world) const {
  return ProjectCamera(T_camera_world_ * p_world);
}

std::vector<cv::Point2d> CameraModel::ProjectWorld(
    const std::vector<Eigen::Vector3d>& ps_world) const {
  std::vector<cv::Point2d> out;
  out.reserve(ps_world.size());
  for (const auto& p : ps_world) {
    const auto px = ProjectWorld(p);
    if (px) {
      out.emplace_back(px->x(), px->y());
    } else {
      const double nan = std::numeric_limits<double>::quiet_NaN();
      out.emplace_back(nan, nan);
    }
  }
  return out;
}

std::vector<cv::Point2d> CameraModel::UndistortToNormalized(
    const std::vector<cv::Point2d>& pixels) const {
  // Newton on the distortion model (analytic 2x2 Jacobian): converges to
  // machine precision in 3-4 steps, where OpenCV's fixed-point iteration
  // needs ~20 at the image corners; the renderer undistorts every pixel corner.
  const auto& d = intrinsics_.distortion;
  if (intrinsics_.lens == LensModel::kEquidistant) return UndistortEquidistant(pixels);
  const double k1 = d[0], k2 = d[1], p1 = d[2], p2 = d[3], k3 = d[4];
  std::vector<cv::Point2d> out(pixels.size());
  std::vector<cv::Point2d> fallback_in;
  std::vector<size_t> fallback_index;
  for (size_t i = 0; i < pixels.size(); ++i) {
    const double tx = (pixels[i].x - intrinsics_.cx) / intrinsics_.fx;
    const double ty = (pixels[i].y - intrinsics_.cy) / intrinsics_.fy;
    double x = tx, y = ty;
    bool converged = false;
    for (int it = 0; it < 30; ++it) {
      const double r2 = x * x + y * y;
      const double radial = 1.0 + k1 * r2 + k2 * r2 * r2 + k3 * r2 * r2 * r2;
      const double dradial = k1 + 2.0 * k2 * r2 + 3.0 * k3 * r2 * r2;
      const double fx = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x) - tx;
      const double fy = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y - ty;
      const double a = radial + 2.0 * x * x * dradial + 2.0 * p1 * y + 6.0 * p2 * x;
      const double b = 2.0 * x * y * dradial + 2.0 * p1 * x + 2.0 * p2 * y;
      const double c = b;
      const double e = radial + 2.0 * y * y * dradial + 6.0 * p1 * y + 2.0 * p2 * x;
      const double det = a * e - b * c;
      if (!(std::abs(det) > 1e-12)) break;
      const double dx = (e * fx - b * fy) / det;
      const double dy = (a * fy - c * fx) / det;
      x -= dx;
      y -= dy;
      if (std::abs(dx) + std::abs(dy) < 1e-15) {
        converged = true;
        break;
      }
    }
    if (converged && std::isfinite(x) && std::isfinite(y)) {
      out[i] = cv::Point2d(x, y);
    } else {
      fallback_in.push_back(pixels[i]);
      fallback_index.push_back(i);
    }
  }
  if (!fallback_in.empty()) {
    std::vector<cv::Point2d> fb;
    cv::undistortPoints(fallback_in, fb, K_, D_, cv::noArray(), cv::noArray(), kUndistortCriteria);
    for (size_t j = 0; j < fb.size(); ++j) out[fallback_index[j]] = fb[j];
  }
  return out;
}

// Newton on theta_d(theta) = |distorted|: monotone over the lens's field
// for any physical calibration, so from theta = theta_d it converges in a few
// steps; a lens that folds back (theta_d' <= 0) or a ray at or past 90 deg
// gives NaN rather than a wrong point.
std::vector<cv::Point2d> CameraModel::UndistortEquidistant(const std::vector<cv::Point2d>& pixels) const {
  const auto& d = intrinsics_.distortion;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::vector<cv::Point2d> out(pixels.size());
  for (size_t i = 0; i < pixels.size(); ++i) {
    const double xd = (pixels[i].x - intrinsics_.cx) / intrinsics_.fx;
    const double yd = (pixels[i].y - intrinsics_.cy) / intrinsics_.fy;
    const double theta_d = std::hypot(xd, yd);
    if (theta_d < 1e-12) {
      out[i] = cv::Point2d(xd, yd);
      continue;
    }
    double theta = std::min(theta_d, 1.5);
    bool converged = false;
    for (int it = 0; it < 50; ++it) {
      double slope = 0.0;
      const double f = ThetaD(d, theta, &slope) - theta_d;
      if (!(slope > 1e-9)) break;
      const double step = f / slope;
      theta -= step;
      if (std::abs(step) < 1e-15) {
        converged = true;
        break;
      }
    }
    if (!converged || !(theta >= 0.0 && theta < M_PI / 2.0)) {
      out[i] = cv::Point2d(nan, nan);
      continue;
    }
    const double scale = std::tan(theta) / theta_d;
    out[i] = cv::Point2d(xd * scale, yd * scale);
  }
  return out;
}

std::vector<cv::Point2d> CameraModel::UndistortPixels(const std::vector<cv::Point2d>& pixels) const {
  auto out = UndistortToNormalized(pixels);
  for (auto& p : out) {
    p = cv::Point2d(p.x * intrinsics_.fx + intrinsics_.cx, p.y * intrinsics_.fy + intrinsics_.cy);
  }
  return out;
}

Eigen::Vector3d CameraModel::UnprojectToRay(const Eigen::Vector2d& pixel) const {
  const auto n = UndistortToNormalized({cv::Point2d(pixel.x(), pixel.y())});
  return Eigen::Vector3d(n[0].x, n[0].y, 1.0);
}

std::optional<Eigen::Vector3d> CameraModel::UnprojectToWorldPlane(const Eigen::Vector2d& pixel,
                                                                  double plane_height_m) const {
  const Eigen::Vector3d dir = T_world_camera_.linear() * UnprojectToRay(pixel);
  const Eigen::Vector3d origin = T_world_camera_.translation();
  if (std::abs(dir.z()) < 1e-12) return std::nullopt;
  const double s = (plane_height_m - origin.z()) / dir.z();
  if (!(s > 0.0)) return std::nullopt;
  return origin + s * dir;
}

bool CameraModel::InImage(const Eigen::Vector2d& pixel, double margin_px) const {
  return pixel.x() >= -0.5 + margin_px && pixel.y() >= -0.5 + margin_px &&
         pixel.x() <= intrinsics_.width - 0.5 - margin_px &&
         pixel.y() <= intrinsics_.height - 0.5 - margin_px;
}

std::ostream& operator<<(std::ostream& os, const Intrinsics& in) {
  return os << "Intrinsics{" << in.width << "x" << in.height << " fx=" << in.fx << " fy=" << in.fy
            << " cx=" << in.cx << " cy=" << in.cy << " " << LensModelName(in.lens) << "=["
            << in.distortion[0] << ", "
            << in.distortion[1] << ", " << in.distortion[2] << ", " << in.distortion[3] << ", "
            << in.distortion[4] << "]}";
}

std::ostream& operator<<(std::ostream& os, const CameraMount& m) {
  return os << "CameraMount{x_mm=" << m.x_mm << " y_mm=" << m.y_mm << " height_mm=" << m.height_mm
            << " roll_deg=" << m.roll_deg << " pitch_deg=" << m.pitch_deg
            << " yaw_deg=" << m.yaw_deg << "}";
}

}  // namespace odocal::vision
