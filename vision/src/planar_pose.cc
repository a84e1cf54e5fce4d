#include "odocal/vision/planar_pose.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <sstream>

#include <ceres/ceres.h>
#include <opencv2/calib3d.hpp>

#include "odocal/base/units.h"
#include "odocal/calibration/statistics.h"

namespace odocal::vision {

using calibration::Pose2;

namespace {

// Camera over the tag plane: roll, pitch, height above the plane (m). The
// gauge (x, y, yaw) is constant.
struct CornerResidual {
  CornerResidual(const Eigen::Vector2d& model_m, const cv::Point2d& observed_normalized,
                 const Eigen::Vector3d& gauge, double focal_px)
      : model(model_m), obs(observed_normalized), cam_x(gauge.x()), cam_y(gauge.y()),
        yaw(gauge.z()), f(focal_px) {}

  template <typename T>
  bool operator()(const T* const camera, const T* const view, T* residual) const {
    return Project(camera, view, T(0.0), residual);
  }
  // With a rolling shutter's readout `readout_s`: the corner was seen
  // shear * readout away from where it was at the frame's middle.
  template <typename T>
  bool Project(const T* const camera, const T* const view, const T& readout_s, T* residual) const {
    using std::cos;
    using std::sin;
    const T sr = sin(camera[0]), cr = cos(camera[0]);
    const T sp = sin(camera[1]), cp = cos(camera[1]);
    const double sy = std::sin(yaw), cy = std::cos(yaw);
    // Columns of Rz(yaw) Ry(pitch) Rx(roll); the camera's optical axes are
    // (col0, -col1, -col2) (see R_world_down in camera_model.h).
    const T c0[3] = {cy * cp, sy * cp, -sp};
    const T c1[3] = {cy * sp * sr - sy * cr, sy * sp * sr + cy * cr, cp * sr};
    const T c2[3] = {cy * sp * cr + sy * sr, sy * sp * cr - cy * sr, cp * cr};
    const T st = sin(view[2]), ct = cos(view[2]);
    const T d[3] = {view[0] + ct * model.x() - st * model.y() - cam_x,
                    view[1] + st * model.x() + ct * model.y() - cam_y, -camera[2]};
    const T x = c0[0] * d[0] + c0[1] * d[1] + c0[2] * d[2];
    const T y = -(c1[0] * d[0] + c1[1] * d[1] + c1[2] * d[2]);
    const T z = -(c2[0] * d[0] + c2[1] * d[1] + c2[2] * d[2]);
    residual[0] = f * (x / z - (obs.x - shear.x * readout_s));
    residual[1] = f * (y / z - (obs.y - shear.y * readout_s));
    return true;
  }

  Eigen::Vector2d model;
  cv::Point2d obs;
  double cam_x, cam_y, yaw, f;
  // Normalized-image velocity times the corner's row offset from the middle
  // row (fraction of the frame): the corner's displacement per second of
  // readout.
  cv::Point2d shear{0.0, 0.0};
};

struct RollingShutterCornerResidual {
  explicit RollingShutterCornerResidual(const CornerResidual& corner) : c(corner) {}
  template <typename T>
  bool operator()(const T* const camera, const T* const view, const T* const readout, T* residual) const {
    return c.Project(camera, view, readout[0], residual);
  }
  CornerResidual c;
};

}  // namespace

PlanarPoseResult MeasureTagPose(const CameraModel& camera, const TagSpec& tag,
                                const TagCorners& corners_px) {
  PlanarPoseResult result;
  const std::vector<cv::Point2d> px(corners_px.begin(), corners_px.end());
  for (const auto& p : px) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y)) {
      result.message = "corner is not finite";
      return result;
    }
  }
  const auto normalized = camera.UndistortToNormalized(px);
  const Eigen::Matrix3d R = camera.T_world_camera().linear();
  const Eigen::Vector3d c = camera.T_world_camera().translation();
  const double h = tag.height_m();
  std::array<Eigen::Vector2d, 4> plane;
  for (int k = 0; k < 4; ++k) {
    const Eigen::Vector3d d = R * Eigen::Vector3d(normalized[k].x, normalized[k].y, 1.0);
    const double s = (h - c.z()) / d.z();
    if (!(s > 0.0) || !std::isfinite(s)) {
      result.message = "corner ray does not meet the tag plane (camera below the tag?)";
      return result;
    }
    const Eigen::Vector3d p = c + s * d;
    plane[k] = p.head<2>();
  }
  // 2-D Procrustes: rotation from the cross-covariance of centred points.
  const auto model = TagCornersInTag(tag.size_m());
  Eigen::Vector2d mc = Eigen::Vector2d::Zero(), pc = Eigen::Vector2d::Zero();
  for (int k = 0; k < 4; ++k) {
    mc += model[k] / 4.0;
    pc += plane[k] / 4.0;
  }
  double sdot = 0.0, scross = 0.0;
  for (int k = 0; k < 4; ++k) {
    const Eigen::Vector2d a = model[k] - mc, b = plane[k] - pc;
    sdot += a.dot(b);
    scross += a.x() * b.y() - a.y() * b.x();
  }
  const double theta = std::atan2(scross, sdot);
  const Eigen::Rotation2Dd rot(theta);
  const Eigen::Vector2d t = pc - rot * mc;
  double sq = 0.0;
  for (int k = 0; k < 4; ++k) sq += (rot * model[k] + t - plane[k]).squaredNorm();
  result.rms_fit_mm = std::sqrt(sq / 4.0) * kMToMm;
  // The similarity fit: the same rotation, the least-squares scale.
  double model_sq = 0.0;
  for (int k = 0; k < 4; ++k) model_sq += (model[k] - mc).squaredNorm();
  const double scale = std::hypot(sdot, scross) / model_sq;
  for (int k = 0; k < 4; ++k) {
    const Eigen::Vector2d residual = plane[k] - (pc + scale * (rot * (model[k] - mc)));
    result.closure_mm[k] = rot.inverse() * residual * kMToMm;
  }
  result.T_world_tag = Pose2::FromXYHeading(t.x(), t.y(), theta);
  result.T_world_robot = result.T_world_tag * tag.T_robot_tag().inverse();
  // A fit residual of a quarter of the tag means these are not the tag's corners.
  if (result.rms_fit_mm > 0.25 * tag.size_mm) {
    result.message = "corners do not fit a square of the tag's size (rms " +
                     std::to_string(result.rms_fit_mm) + " mm)";
    return result;
  }
  result.status = StatusCode::kOk;
  return result;
}

RestCornerError EstimateRestCornerError(const std::vector<std::array<Eigen::Vector2d, 4>>& closures,
                                        const TagSpec& tag, double heading_rad, int fitted_dof) {
  assert(fitted_dof >= 0 && fitted_dof < 4);
  RestCornerError e;
  e.frames = static_cast<int>(closures.size());
  if (closures.empty()) return e;
  const double n = static_cast<double>(closures.size());
  std::array<Eigen::Vector2d, 4> mean{};
  for (auto& m : mean) m.setZero();
  for (const auto& c : closures)
    for (int k = 0; k < 4; ++k) mean[k] += c[k] / n;
  double mean_sq = 0.0;
  for (const auto& m : mean) mean_sq += m.squaredNorm();
  // Four degrees of freedom in the closure (docs in the header); a camera
  // fitted to these frames has taken `fitted_dof` of them from their mean.
  constexpr double kDof = 4.0;
  const double mean_dof = kDof - fitted_dof;
  double independent_var = 0.0, shared_var = mean_sq / mean_dof;
  if (closures.size() >= 2) {
    double within = 0.0;
    for (const auto& c : closures)
      for (int k = 0; k < 4; ++k) within += (c[k] - mean[k]).squaredNorm();
    independent_var = within / (n - 1.0) / kDof;
    shared_var = std::max(0.0, mean_sq / mean_dof - independent_var / n);
  }
  e.sigma_independent_mm = std::sqrt(independent_var);
  e.sigma_shared_mm = std::sqrt(shared_var);
  // Corner variance (m^2) to the tag's pose, then to the robot's centre.
  const double var_m2 = shared_var * 1e-6;
  const double size_m = tag.size_m();
  // Edge model (header): all of it edge offsets gives var_t = sigma_c^2,
  // all of it edge angles gives var_h = sigma_c^2 / (1.5 L^2); a mixture
  // gives less of each, so both bounds hold.
  const double var_t = var_m2;
  const double var_h = var_m2 / (1.5 * size_m * size_m);
  // Robot = tag * T_tag_robot: its position moves by d(R(h) o)/dh = J o.
  const Eigen::Vector2d o = tag.T_robot_tag().inverse().translation();
  // The tag's heading is the robot's heading plus the tag's yaw on it.
  const double th = heading_rad + tag.T_robot_tag().heading();
  const double ct = std::cos(th), st = std::sin(th);
  const Eigen::Vector2d lever(-st * o.x() - ct * o.y(), ct * o.x() - st * o.y());
  Eigen::Matrix3d J = Eigen::Matrix3d::Identity();  // (tx, ty, h) -> (x, y, h)
  J(0, 2) = lever.x();
  J(1, 2) = lever.y();
  const Eigen::Matrix3d tag_cov = Eigen::Vector3d(var_t, var_t, var_h).asDiagonal();
  e.shared_covariance = J * tag_cov * J.transpose();
  // Each corner its own error (every one of the 8 modes alike): the centre,
  // a mean of four corners, var / 4 per axis; the heading, the corners'
  // tangential errors at L / sqrt(2) from the centre, var / (2 L^2).
  const Eigen::Matrix3d even_cov =
      Eigen::Vector3d(var_m2 / 4.0, var_m2 / 4.0, var_m2 / (2.0 * size_m * size_m)).asDiagonal();
  e.expected_shared_covariance = J * even_cov * J.transpose();
  return e;
}

bool CameraPlaneOptions::IsValid(std::string* why) const {
  const auto fail = [why](const std::string& what) {
    if (why) *why = "camera-plane options: " + what;
    return false;
  };
  std::string solver_why;
  if (!solver.IsValid(&solver_why)) return fail("solver: " + solver_why);
  if (!(huber_px >= 0.0)) return fail("huber_px must not be negative");
  if (min_views < 1) return fail("min_views must be at least 1");
  if (!(rolling_shutter_probe_s > 0.0)) return fail("rolling_shutter_probe_s must be positive");
  if (!(rolling_shutter_min_shear_px > 0.0)) return fail("rolling_shutter_min_shear_px must be positive");
  return true;
}

std::string CameraPlaneResult::BriefReport() const {
  std::ostringstream os;
  os << (ok() ? "ok" : "FAILED") << ": " << views_used << " views, rms " << rms_reprojection_px << " px; roll "
     << mount.roll_deg << " +- " << sigma_roll_deg << " deg, pitch " << mount.pitch_deg << " +- " << sigma_pitch_deg
     << " deg, height " << mount.height_mm << " +- " << sigma_height_mm << " mm";
  if (rolling_shutter_fitted)
    os << ", rolling shutter " << rolling_shutter_ms << " +- " << sigma_rolling_shutter_ms << " ms";
  if (!message.empty()) os << " (" << message << ")";
  return os.str();
}

namespace {

// EstimateCameraOverTagPlane's steps, in order.

// Each view's corners undistorted (`normalized`), and the camera's start:
// roll, pitch and distance to the tag plane, the medians of the views' IPPE
// planes; nullopt when fewer than `min_views` give a pose.
std::optional<std::array<double, 3>> StartingPlane(const CameraModel& nominal, const std::vector<cv::Point3d>& model3d,
                                                   const std::vector<TagCorners>& views_corners_px, int min_views,
                                                   std::vector<std::vector<cv::Point2d>>* normalized) {
  std::vector<double> nx, ny, nz, dist;
  for (const auto& corners : views_corners_px) {
    normalized->push_back(nominal.UndistortToNormalized({corners.begin(), corners.end()}));
    cv::Mat rvec, tvec;
    if (!cv::solvePnP(model3d, normalized->back(), cv::Mat::eye(3, 3, CV_64F), cv::noArray(), rvec, tvec, false,
                      cv::SOLVEPNP_IPPE)) {
      continue;
    }
    cv::Mat rmat;
    cv::Rodrigues(rvec, rmat);
    Eigen::Vector3d n(rmat.at<double>(0, 2), rmat.at<double>(1, 2), rmat.at<double>(2, 2));
    const Eigen::Vector3d t(tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2));
    if (n.z() > 0) n = -n;  // the plane's up normal points back at the camera
    nx.push_back(n.x());
    ny.push_back(n.y());
    nz.push_back(n.z());
    dist.push_back(std::abs(n.dot(t)));
  }
  if (static_cast<int>(nx.size()) < min_views) return std::nullopt;
  const Eigen::Vector3d n0 =
      Eigen::Vector3d(calibration::Median(nx), calibration::Median(ny), calibration::Median(nz)).normalized();
  return std::array<double, 3>{std::atan2(-n0.y(), -n0.z()), std::asin(std::clamp(-n0.x(), -1.0, 1.0)),
                               calibration::Median(dist)};
}

// The rolling shutter: each used view's corners' shear (normalized velocity
// times its row's offset from the middle row); `fit_readout` when the views
// move enough for the readout to be fitted.
std::vector<std::array<cv::Point2d, 4>> CornerShears(const Intrinsics& intrinsics, const CameraModel& nominal,
                                                     const std::vector<TagCorners>& views_corners_px,
                                                     const std::vector<size_t>& view_index,
                                                     const std::vector<CornerVelocities>* views_velocities,
                                                     const CameraPlaneOptions& options, bool* fit_readout) {
  const double f = std::sqrt(intrinsics.fx * intrinsics.fy);
  const bool have_velocities = views_velocities && views_velocities->size() == views_corners_px.size();
  std::vector<std::array<cv::Point2d, 4>> shear(view_index.size());
  double shear_sq = 0.0;
  for (size_t v = 0; v < view_index.size() && have_velocities; ++v) {
    const TagCorners& c = views_corners_px[view_index[v]];
    const CornerVelocities& vel = (*views_velocities)[view_index[v]];
    // The velocity in normalized coordinates through the lens (a central
    // difference over 1 ms of motion).
    constexpr double kDt = 1e-3;
    std::vector<cv::Point2d> ahead, behind;
    for (int k = 0; k < 4; ++k) {
      ahead.push_back(c[k] + vel[k] * kDt);
      behind.push_back(c[k] - vel[k] * kDt);
    }
    const auto na = nominal.UndistortToNormalized(ahead), nb = nominal.UndistortToNormalized(behind);
    for (int k = 0; k < 4; ++k) {
      const double row = c[k].y / std::max(1, intrinsics.height - 1) - 0.5;
      shear[v][k] = (na[k] - nb[k]) * (row / (2.0 * kDt));
      shear_sq += std::pow(f * cv::norm(shear[v][k]) * options.rolling_shutter_probe_s, 2);
    }
  }
  *fit_readout =
      have_velocities && std::sqrt(shear_sq / (4.0 * view_index.size())) > options.rolling_shutter_min_shear_px;
  return shear;
}

// The camera's sigmas (and the readout's), the covariance scaled by the
// residual variance over `n_res` residuals.
void PlaneSigmas(ceres::Problem& problem, double* camera, double* readout_s, bool fit_readout, double final_cost,
                 int n_res, CameraPlaneResult* result) {
  ceres::Covariance::Options cov_options;
  ceres::Covariance covariance(cov_options);
  std::vector<std::pair<const double*, const double*>> blocks = {{camera, camera}};
  if (fit_readout) blocks.push_back({readout_s, readout_s});
  if (!covariance.Compute(blocks, &problem)) return;
  double cov[9];
  covariance.GetCovarianceBlock(camera, camera, cov);
  const int dof = std::max(1, n_res - 3 - 3 * result->views_used - (fit_readout ? 1 : 0));
  const double s2 = 2.0 * final_cost / dof;
  result->sigma_roll_deg = std::sqrt(cov[0] * s2) * kRadToDeg;
  result->sigma_pitch_deg = std::sqrt(cov[4] * s2) * kRadToDeg;
  result->sigma_height_mm = std::sqrt(cov[8] * s2) * kMToMm;
  if (fit_readout) {
    double t_cov = 0.0;
    covariance.GetCovarianceBlock(readout_s, readout_s, &t_cov);
    result->sigma_rolling_shutter_ms = std::sqrt(t_cov * s2) * kSToMs;
  }
}

// `mount` with the camera over the tag plane (roll, pitch, height above the
// plane in m) put in: roll, pitch and height above the floor.
CameraMount MountOf(const CameraMount& mount, const double* camera, const TagSpec& tag) {
  CameraMount out = mount;
  out.roll_deg = camera[0] * kRadToDeg;
  out.pitch_deg = camera[1] * kRadToDeg;
  out.height_mm = (camera[2] + tag.height_m()) * kMToMm;
  return out;
}

// The adjustment's unknowns as Ceres holds them: the rolling shutter's
// readout (s), fitted when `fit_readout`, the camera over the tag plane
// (roll, pitch, height m), and each used view's tag pose (x, y, heading) with
// its index among the views. The readout lies before the camera in memory
// on purpose: ceres::Covariance orders the parameter blocks by their
// addresses, and this order gives the sigmas the bits they have always had.
struct PlaneUnknowns {
  double readout_s[1] = {0.0};
  double camera[3] = {0.0, 0.0, 0.0};
  bool fit_readout = false;
  std::vector<std::array<double, 3>> views;
  std::vector<size_t> view_index;
};

// What the corner residuals compare: the tag's corners in its frame, every
// view's undistorted corners, each used view's corners' shear, the gauge
// (x, y, yaw) and the focal length (px) that scales them.
struct PlaneObservations {
  const std::array<Eigen::Vector2d, 4>& model;
  const std::vector<std::vector<cv::Point2d>>& normalized;
  const std::vector<std::array<cv::Point2d, 4>>& shear;
  const Eigen::Vector3d& gauge;
  double f;
};

// One residual per corner of each used view (with the readout when it is
// fitted, bounded to +-0.1 s) into `problem`.
void AddCornerResiduals(const PlaneObservations& obs, double huber_px, PlaneUnknowns* x, ceres::Problem* problem) {
  for (size_t v = 0; v < x->views.size(); ++v) {
    for (int k = 0; k < 4; ++k) {
      CornerResidual corner(obs.model[k], obs.normalized[x->view_index[v]][k], obs.gauge, obs.f);
      ceres::LossFunction* loss = huber_px > 0 ? new ceres::HuberLoss(huber_px) : nullptr;
      if (x->fit_readout) {
        corner.shear = obs.shear[v][k];
        problem->AddResidualBlock(new ceres::AutoDiffCostFunction<RollingShutterCornerResidual, 2, 3, 3, 1>(
                                      new RollingShutterCornerResidual(corner)),
                                  loss, x->camera, x->views[v].data(), x->readout_s);
      } else {
        problem->AddResidualBlock(new ceres::AutoDiffCostFunction<CornerResidual, 2, 3, 3>(new CornerResidual(corner)),
                                  loss, x->camera, x->views[v].data());
      }
    }
  }
  if (x->fit_readout) {
    // Either direction of readout; longer than any camera's frame is not one.
    problem->SetParameterLowerBound(x->readout_s, 0, -0.1);
    problem->SetParameterUpperBound(x->readout_s, 0, 0.1);
  }
}

}  // namespace

CameraPlaneResult EstimateCameraOverTagPlane(const Intrinsics& intrinsics, const TagSpec& tag,
                                             const std::vector<TagCorners>& views_corners_px,
                                             const CameraMount& nominal_mount,
                                             const CameraPlaneOptions& options,
                                             const std::vector<CornerVelocities>* views_velocities) {
  CameraPlaneResult result;
  result.mount = nominal_mount;
  std::string why;
  if (!intrinsics.IsValid(&why) || !tag.IsValid(&why) || !options.IsValid(&why)) {
    result.status = StatusCode::kInvalidArgument;
    result.message = why;
    return result;
  }
  if (static_cast<int>(views_corners_px.size()) < options.min_views) {
    result.message = "need at least " + std::to_string(options.min_views) + " views of the tag, got " +
                     std::to_string(views_corners_px.size());
    return result;
  }
  const CameraModel nominal(intrinsics, nominal_mount);
  const auto model = TagCornersInTag(tag.size_m());
  std::vector<cv::Point3d> model3d;
  for (const auto& m : model) model3d.emplace_back(m.x(), m.y(), 0.0);

  // Undistorted observations, and the views' IPPE planes for the start.
  std::vector<std::vector<cv::Point2d>> normalized;
  const auto plane = StartingPlane(nominal, model3d, views_corners_px, options.min_views, &normalized);
  if (!plane) {
    result.message = "too few views gave a pose for the starting estimate";
    return result;
  }
  PlaneUnknowns x;
  x.camera[0] = (*plane)[0];
  x.camera[1] = (*plane)[1];
  x.camera[2] = (*plane)[2];
  const CameraModel start_model(intrinsics, MountOf(nominal_mount, x.camera, tag));

  const Eigen::Vector3d gauge(nominal_mount.x_mm * kMmToM, nominal_mount.y_mm * kMmToM,
                              nominal_mount.yaw_deg / kRadToDeg);
  ceres::Problem problem;
  const double f = std::sqrt(intrinsics.fx * intrinsics.fy);
  for (size_t i = 0; i < views_corners_px.size(); ++i) {
    const auto pose = MeasureTagPose(start_model, tag, views_corners_px[i]);
    if (!pose.ok()) continue;
    x.views.push_back({pose.T_world_tag.x(), pose.T_world_tag.y(), pose.T_world_tag.heading()});
    x.view_index.push_back(i);
  }
  if (static_cast<int>(x.views.size()) < options.min_views) {
    result.message = "too few views fit the tag model";
    return result;
  }
  const std::vector<std::array<cv::Point2d, 4>> shear =
      CornerShears(intrinsics, nominal, views_corners_px, x.view_index, views_velocities, options, &x.fit_readout);
  AddCornerResiduals(PlaneObservations{model, normalized, shear, gauge, f}, options.huber_px, &x, &problem);
  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::DENSE_SCHUR;
  ApplyTo(options.solver, &solver_options);
  ceres::Solver::Summary summary;
  ceres::Solve(solver_options, &problem, &summary);
  if (!summary.IsSolutionUsable()) {
    result.message = "camera-plane adjustment failed: " + summary.message;
    return result;
  }
  result.mount = MountOf(result.mount, x.camera, tag);
  result.views_used = static_cast<int>(x.views.size());
  const int n_res = 8 * result.views_used;
  result.rms_reprojection_px = std::sqrt(2.0 * summary.final_cost / n_res);
  for (const auto& v : x.views) result.world_Ts_tag.push_back(Pose2::FromXYHeading(v[0], v[1], v[2]));

  result.rolling_shutter_fitted = x.fit_readout;
  result.rolling_shutter_ms = x.readout_s[0] * kSToMs;

  PlaneSigmas(problem, x.camera, x.readout_s, x.fit_readout, summary.final_cost, n_res, &result);
  result.status = StatusCode::kOk;
  return result;
}

}  // namespace odocal::vision
