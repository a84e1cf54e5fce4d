// The board's shape from a calibration's views (board_shape.h).
#include "odocal/vision/board_shape.h"

#include <algorithm>
#include <cmath>
#include <map>

#include <Eigen/Dense>

#include "odocal/vision/tag_survey.h"

namespace odocal::vision {

bool BoardShapeOptions::IsValid(std::string* why) const {
  if (min_sightings < 4) {
    if (why) *why = "board shape: min_sightings must be at least 4";
    return false;
  }
  if (!(flat_mm >= 0.0)) {
    if (why) *why = "board shape: flat_mm must not be negative";
    return false;
  }
  return true;
}

namespace {

// Per tag, over its corner sightings: sum J.r, sum J.J, and the sightings.
struct LiftSums {
  double jr = 0.0, jj = 0.0;
  int n = 0;
};

}  // namespace

BoardShape MeasureBoardShape(const std::vector<BoardDetection>& views, const CalibrationBoard& board,
                             const Intrinsics& intrinsics, const BoardShapeOptions& options) {
  BoardShape shape;
  if (!options.IsValid(&shape.message)) return shape;
  if (board.type != CalibrationBoard::Type::kAprilgrid) {
    shape.message = "the board's shape is measured on aprilgrids only";
    return shape;
  }
  const CameraModel camera(intrinsics, CameraMount{});
  constexpr double kStepM = 1e-3;  // central differences over +-1 mm of lift
  // Each sighting's residual and J, kept to measure what the lifts leave.
  struct Sighting {
    int id;
    Eigen::Vector2d r, J;
  };
  std::map<int, LiftSums> sums;
  std::vector<Sighting> sightings;
  std::map<int, double> lift_m;
  int poses = 0;
  // Poses and lifts in turn: each view's pose solved with the corners moved
  // back by the lifts so far (where the flat board would show them), then
  // the lifts from what is left. The pose of a flat board fitted to a
  // lifted one takes part of the lifts; three rounds give them back.
  for (int round = 0; round < 3; ++round) {
    sums.clear();
    sightings.clear();
    poses = 0;
    for (const BoardDetection& view : views) {
      if (!view.found || view.tag_ids.empty() || view.object_points.size() != 4 * view.tag_ids.size() ||
          view.image_points.size() != view.object_points.size())
        continue;
      const std::vector<cv::Point3d> object(view.object_points.begin(), view.object_points.end());
      const std::vector<cv::Point2d> image(view.image_points.begin(), view.image_points.end());
      auto lift_of = [&](size_t i) {
        const auto it = lift_m.find(view.tag_ids[i / 4]);
        return it == lift_m.end() ? 0.0 : it->second;
      };
      // The flat board's pose fitted to `points`, and each corner's J under it.
      auto solve = [&](const std::vector<cv::Point2d>& points, std::vector<Eigen::Vector2d>* J) {
        ObjectPose pose = EstimateObjectPose(intrinsics, object, points, view.point_sigma_px);
        if (!pose.ok) return pose;
        const Eigen::Vector3d normal = pose.T_camera_object.linear().col(2);
        J->assign(object.size(), Eigen::Vector2d::Zero());
        for (size_t i = 0; i < object.size(); ++i) {
          const Eigen::Vector3d p = pose.T_camera_object * Eigen::Vector3d(object[i].x, object[i].y, object[i].z);
          const auto up = camera.ProjectCamera(p + kStepM * normal);
          const auto down = camera.ProjectCamera(p - kStepM * normal);
          if (!up || !down) {
            pose.ok = false;
            break;
          }
          (*J)[i] = (*up - *down) / (2.0 * kStepM);
        }
        return pose;
      };
      std::vector<Eigen::Vector2d> J;
      ObjectPose pose = solve(image, &J);
      if (!pose.ok) continue;
      if (!lift_m.empty()) {
        // The corners moved back by the lifts so far: where the flat board
        // would show them.
        std::vector<cv::Point2d> flat = image;
        for (size_t i = 0; i < flat.size(); ++i) flat[i] -= cv::Point2d(lift_of(i) * J[i].x(), lift_of(i) * J[i].y());
        pose = solve(flat, &J);
        if (!pose.ok) continue;
      }
      ++poses;
      for (size_t i = 0; i < object.size(); ++i) {
        // The flat board's residual with the lifts so far put back in.
        const int id = view.tag_ids[i / 4];
        const Eigen::Vector2d r = Eigen::Vector2d(pose.residuals_px[i].x, pose.residuals_px[i].y) + lift_of(i) * J[i];
        sums[id].jr += J[i].dot(r);
        sums[id].jj += J[i].dot(J[i]);
        ++sums[id].n;
        sightings.push_back({id, r, J[i]});
      }
    }
    lift_m.clear();
    for (const auto& [id, s] : sums)
      if (s.n >= options.min_sightings && s.jj > 0.0) lift_m[id] = s.jr / s.jj;
    if (lift_m.size() < 4) break;
  }
  if (lift_m.size() < 4) {
    shape.message = "fewer than 4 tags seen in " + std::to_string(options.min_sightings) + " corners or more";
    return shape;
  }
  // The residual per coordinate once the lifts are out; the degrees of
  // freedom less each view's pose and each lift.
  double total = 0.0, left = 0.0;
  int used = 0;
  for (const Sighting& s : sightings) {
    const auto it = lift_m.find(s.id);
    if (it == lift_m.end()) continue;
    total += s.r.squaredNorm();
    left += (s.r - it->second * s.J).squaredNorm();
    ++used;
  }
  const int dof_px = 2 * used - 6 * poses - static_cast<int>(lift_m.size());
  if (dof_px < 1) {
    shape.message = "too few corners for the board's poses and lifts";
    return shape;
  }
  const double sigma_px = std::sqrt(left / dof_px);
  shape.explained_fraction = total > 0.0 ? 1.0 - left / total : 0.0;
  // The plane a + b x + c y over the board is the poses' (weighted least
  // squares over the tags' centres), not the board's shape.
  std::vector<int> ids;
  std::vector<double> h, sigma;
  Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  std::vector<Eigen::Vector3d> rows;
  for (const auto& [id, value] : lift_m) {
    const auto c0 = board.AprilgridCorner(id, 0), c2 = board.AprilgridCorner(id, 2);
    if (!c0 || !c2) continue;
    const double s = sigma_px / std::sqrt(sums[id].jj);
    const Eigen::Vector3d row(1.0, 0.5 * (c0->x + c2->x), 0.5 * (c0->y + c2->y));
    A += row * row.transpose() / (s * s);
    b += row * value / (s * s);
    ids.push_back(id);
    h.push_back(value);
    sigma.push_back(s);
    rows.push_back(row);
  }
  const Eigen::Vector3d plane = A.ldlt().solve(b);
  double chi2 = 0.0, sq = 0.0;
  for (size_t k = 0; k < ids.size(); ++k) {
    TagLift t;
    t.id = ids[k];
    t.lift_mm = 1e3 * (h[k] - rows[k].dot(plane));
    t.sigma_mm = 1e3 * sigma[k];
    t.corners = sums[ids[k]].n;
    chi2 += std::pow(t.lift_mm / t.sigma_mm, 2);
    sq += t.lift_mm * t.lift_mm;
    if (std::abs(t.lift_mm) > shape.max_abs_lift_mm) {
      shape.max_abs_lift_mm = std::abs(t.lift_mm);
      shape.max_lift_id = t.id;
    }
    shape.tags.push_back(t);
  }
  shape.dof = static_cast<int>(shape.tags.size()) - 3;
  shape.chi2_per_dof = shape.dof > 0 ? chi2 / shape.dof : 0.0;
  shape.rms_lift_mm = std::sqrt(sq / shape.tags.size());
  // The 99.9 % quantile of chi2 / dof for a flat board (Wilson-Hilferty).
  const double k = std::max(1, shape.dof);
  const double q = std::pow(1.0 - 2.0 / (9.0 * k) + 3.09 * std::sqrt(2.0 / (9.0 * k)), 3);
  shape.flat = shape.chi2_per_dof <= q || shape.rms_lift_mm < options.flat_mm;
  shape.ok = true;
  return shape;
}

}  // namespace odocal::vision
