#include "fisheye_fit.h"

#include <array>
#include <cmath>

#include <ceres/ceres.h>
#include <ceres/rotation.h>
#include <opencv2/calib3d.hpp>

namespace odocal::vision::internal {
namespace {

// One corner: lens (fx, fy, cx, cy, k1..k4), view pose (angle-axis, t).
// theta = atan2(rho, Z) is the ray's angle off the axis (any angle, even
// beyond 90 degrees), theta_d = theta (1 + k1 theta^2 + ... + k4 theta^8), and
// the distorted normalised point is theta_d (X, Y) / rho (camera_model.h).
struct EquidistantCorner {
  EquidistantCorner(const cv::Point3f& board, const cv::Point2f& seen, double weight = 1.0)
      : X(board), u(seen), w(weight) {}
  template <typename T>
  bool operator()(const T* const lens, const T* const pose, T* residual) const {
    const T p[3] = {T(X.x), T(X.y), T(X.z)};
    T c[3];
    ceres::AngleAxisRotatePoint(pose, p, c);
    c[0] += pose[3];
    c[1] += pose[4];
    c[2] += pose[5];
    const T rho2 = c[0] * c[0] + c[1] * c[1];
    T mx, my;
    if (rho2 < T(1e-18)) {
      mx = c[0] / c[2];
      my = c[1] / c[2];
    } else {
      using std::atan2;
      using std::sqrt;
      const T rho = sqrt(rho2);
      const T theta = atan2(rho, c[2]);
      const T t2 = theta * theta;
      const T theta_d = theta * (T(1.0) + t2 * (lens[4] + t2 * (lens[5] + t2 * (lens[6] + t2 * lens[7]))));
      mx = theta_d * c[0] / rho;
      my = theta_d * c[1] / rho;
    }
    residual[0] = T(w) * (lens[0] * mx + lens[2] - T(u.x));
    residual[1] = T(w) * (lens[1] * my + lens[3] - T(u.y));
    return true;
  }
  cv::Point3f X;
  cv::Point2f u;
  double w;
};

// The adjustment's state: the views, the lens as it stands (fx, fy, cx,
// cy, k1..k4) and each view's pose (angle-axis, t) once it has one.
struct EquidistantAdjustment {
  const std::vector<std::vector<cv::Point3f>>& objects;
  const std::vector<std::vector<cv::Point2f>>& images;
  const std::vector<std::vector<double>>& weights;
  const Intrinsics& start;
  double lens[8];
  std::vector<std::array<double, 6>> poses;
  std::vector<bool> posed;

  EquidistantAdjustment(const std::vector<std::vector<cv::Point3f>>& objects_,
                        const std::vector<std::vector<cv::Point2f>>& images_,
                        const std::vector<std::vector<double>>& weights_, const Intrinsics& start_)
      : objects(objects_),
        images(images_),
        weights(weights_),
        start(start_),
        lens{start_.fx,
             start_.fy,
             start_.cx,
             start_.cy,
             start_.distortion[0],
             start_.distortion[1],
             start_.distortion[2],
             start_.distortion[3]},
        poses(objects_.size()),
        posed(objects_.size(), false) {}

  // The lens as it stands.
  Intrinsics Current() const {
    Intrinsics in = start;
    in.fx = lens[0], in.fy = lens[1], in.cx = lens[2], in.cy = lens[3];
    in.distortion = {lens[4], lens[5], lens[6], lens[7], 0.0};
    return in;
  }

  // Each view's pose through the lens as it stands: its corners undistorted
  // to the normalised plane, where the board is a homography away. A view
  // the start lens cannot pose (its corners beyond where a lens fitted
  // without it undistorts) is tried again through the adjusted lens.
  // Returns how many views gained a pose.
  int PoseViews(const CameraModel& camera) {
    int added = 0;
    for (size_t v = 0; v < objects.size(); ++v) {
      if (posed[v]) continue;
      std::vector<cv::Point2d> px(images[v].begin(), images[v].end());
      const std::vector<cv::Point2d> normalised = camera.UndistortToNormalized(px);
      std::vector<cv::Point3f> o;
      std::vector<cv::Point2d> n;
      for (size_t i = 0; i < normalised.size(); ++i)
        if (std::isfinite(normalised[i].x) && std::isfinite(normalised[i].y))
          o.push_back(objects[v][i]), n.push_back(normalised[i]);
      cv::Vec3d rvec, tvec;
      bool ok = o.size() >= 4;
      try {
        ok = ok && cv::solvePnP(o, n, cv::Matx33d::eye(), cv::noArray(), rvec, tvec);
      } catch (const cv::Exception&) {
        ok = false;
      }
      if (!ok || !std::isfinite(rvec[0]) || !std::isfinite(tvec[2]) || !(tvec[2] > 0.0)) continue;
      poses[v] = {rvec[0], rvec[1], rvec[2], tvec[0], tvec[1], tvec[2]};
      posed[v] = true;
      ++added;
    }
    return added;
  }

  // A weighted residual for every corner of every posed view into
  // `problem`; returns the number of views, `n_points` the corners.
  int AddResiduals(ceres::Problem* problem, size_t* n_points) {
    int n_views = 0;
    for (size_t v = 0; v < objects.size(); ++v) {
      if (!posed[v]) continue;
      ++n_views;
      for (size_t i = 0; i < objects[v].size(); ++i) {
        const double w = weights.empty() ? 1.0 : weights[v][i];
        problem->AddResidualBlock(new ceres::AutoDiffCostFunction<EquidistantCorner, 2, 8, 6>(
                                      new EquidistantCorner(objects[v][i], images[v][i], w)),
                                  nullptr, lens, poses[v].data());
        ++*n_points;
      }
    }
    return n_views;
  }

  // The unweighted sum of squared residuals over the posed views (px^2).
  double UnweightedSquares() const {
    double sq = 0.0;
    for (size_t v = 0; v < objects.size(); ++v) {
      if (!posed[v]) continue;
      for (size_t i = 0; i < objects[v].size(); ++i) {
        double r[2];
        EquidistantCorner(objects[v][i], images[v][i])(lens, poses[v].data(), r);
        sq += r[0] * r[0] + r[1] * r[1];
      }
    }
    return sq;
  }
};

}  // namespace

std::optional<EquidistantFit> FitEquidistant(const std::vector<std::vector<cv::Point3f>>& objects,
                                             const std::vector<std::vector<cv::Point2f>>& images,
                                             const std::vector<std::vector<double>>& weights, const Intrinsics& start,
                                             std::string* why) {
  EquidistantAdjustment fit(objects, images, weights, start);
  EquidistantFit out;
  for (int round = 0; round < 3; ++round) {
    if (fit.PoseViews(CameraModel(fit.Current(), CameraMount{})) == 0 && round > 0) break;
    ceres::Problem problem;
    size_t n_points = 0;
    const int n_views = fit.AddResiduals(&problem, &n_points);
    if (n_views < 3) {
      if (why) *why = "fewer than 3 views with a pose through the first lens";
      return std::nullopt;
    }
    ceres::Solver::Options options;
    options.linear_solver_type = ceres::DENSE_SCHUR;
    options.max_num_iterations = 200;
    options.function_tolerance = 1e-12;
    options.parameter_tolerance = 1e-12;
    options.gradient_tolerance = 1e-14;
    options.logging_type = ceres::SILENT;
    ceres::Solver::Summary summary;
    ceres::Solve(options, &problem, &summary);
    if (!summary.IsSolutionUsable() || !std::isfinite(summary.final_cost)) {
      if (why) *why = "the fisheye adjustment failed: " + summary.message;
      return std::nullopt;
    }
    // The unweighted RMS, the figure every calibration reports.
    out.rms_px = std::sqrt(fit.UnweightedSquares() / static_cast<double>(n_points));
    out.weighted_rms_px = std::sqrt(2.0 * summary.final_cost / static_cast<double>(n_points));
  }
  out.views_left_out.clear();
  for (size_t v = 0; v < objects.size(); ++v)
    if (!fit.posed[v]) out.views_left_out.push_back(static_cast<int>(v));
  out.intrinsics = fit.Current();
  if (!out.intrinsics.IsValid(why)) return std::nullopt;
  return out;
}

}  // namespace odocal::vision::internal
