// The board's shape from a calibration's views (board_shape.h).
#include "odocal/vision/board_shape.h"

#include <algorithm>
#include <cmath>
#include <map>

#include <Eigen/Dense>

#include "odocal/base/units.h"
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

// One corner seen: the flat board's residual with the lifts put back in, and
// J, its image motion per metre of lift along the board's normal.
struct Sighting {
  int id;
  Eigen::Vector2d r, J;
};

// The lifts (m, by tag id) and what they were fitted to.
struct LiftFit {
  std::map<int, LiftSums> sums;
  std::vector<Sighting> sightings;
  std::map<int, double> lift_m;
  int poses = 0;
};

// The flat board's pose fitted to `points`, and each corner's J under it
// (central differences over +-1 mm of lift); not ok where a lifted corner
// does not project.
ObjectPose SolveFlat(const BoardDetection& view, const std::vector<cv::Point3d>& object,
                     const std::vector<cv::Point2d>& points, const Intrinsics& intrinsics, const CameraModel& camera,
                     std::vector<Eigen::Vector2d>* J) {
  constexpr double kStepM = 1e-3;
  ObjectPose pose = EstimateObjectPose(intrinsics, object, points, view.point_sigma_px);
  if (!pose.ok()) return pose;
  const Eigen::Vector3d normal = pose.T_camera_object.linear().col(2);
  J->assign(object.size(), Eigen::Vector2d::Zero());
  for (size_t i = 0; i < object.size(); ++i) {
    const Eigen::Vector3d p = pose.T_camera_object * Eigen::Vector3d(object[i].x, object[i].y, object[i].z);
    const auto up = camera.ProjectCamera(p + kStepM * normal);
    const auto down = camera.ProjectCamera(p - kStepM * normal);
    if (!up || !down) {
      pose.status = StatusCode::kFailed;
      break;
    }
    (*J)[i] = (*up - *down) / (2.0 * kStepM);
  }
  return pose;
}

// One view's sightings under the lifts so far (`lifts`), into `fit`.
void AddView(const BoardDetection& view, const Intrinsics& intrinsics, const CameraModel& camera,
             const std::map<int, double>& lifts, LiftFit* fit) {
  if (!view.found || view.tag_ids.empty() || view.object_points.size() != 4 * view.tag_ids.size() ||
      view.image_points.size() != view.object_points.size())
    return;
  const std::vector<cv::Point3d> object(view.object_points.begin(), view.object_points.end());
  const std::vector<cv::Point2d> image(view.image_points.begin(), view.image_points.end());
  auto lift_of = [&](size_t i) {
    const auto it = lifts.find(view.tag_ids[i / 4]);
    return it == lifts.end() ? 0.0 : it->second;
  };
  std::vector<Eigen::Vector2d> J;
  ObjectPose pose = SolveFlat(view, object, image, intrinsics, camera, &J);
  if (!pose.ok()) return;
  if (!lifts.empty()) {
    // The corners moved back by the lifts so far: where the flat board
    // would show them.
    std::vector<cv::Point2d> flat = image;
    for (size_t i = 0; i < flat.size(); ++i) flat[i] -= cv::Point2d(lift_of(i) * J[i].x(), lift_of(i) * J[i].y());
    pose = SolveFlat(view, object, flat, intrinsics, camera, &J);
    if (!pose.ok()) return;
  }
  ++fit->poses;
  for (size_t i = 0; i < object.size(); ++i) {
    // The flat board's residual with the lifts so far put back in.
    const int id = view.tag_ids[i / 4];
    const Eigen::Vector2d r = Eigen::Vector2d(pose.residuals_px[i].x, pose.residuals_px[i].y) + lift_of(i) * J[i];
    fit->sums[id].jr += J[i].dot(r);
    fit->sums[id].jj += J[i].dot(J[i]);
    ++fit->sums[id].n;
    fit->sightings.push_back({id, r, J[i]});
  }
}

// Poses and lifts in turn: each view's pose solved with the corners moved
// back by the lifts so far (where the flat board would show them), then the
// lifts from what is left. The pose of a flat board fitted to a lifted one
// takes part of the lifts; three rounds give them back.
LiftFit FitLifts(const std::vector<BoardDetection>& views, const Intrinsics& intrinsics,
                 const BoardShapeOptions& options) {
  const CameraModel camera(intrinsics, CameraMount{});
  LiftFit fit;
  for (int round = 0; round < 3; ++round) {
    const std::map<int, double> lifts = fit.lift_m;
    fit = LiftFit{};
    for (const BoardDetection& view : views) AddView(view, intrinsics, camera, lifts, &fit);
    for (const auto& [id, s] : fit.sums)
      if (s.n >= options.min_sightings && s.jj > 0.0) fit.lift_m[id] = s.jr / s.jj;
    if (fit.lift_m.size() < 4) break;
  }
  return fit;
}

// Each tag's lift less the plane a + b x + c y over the board (weighted least
// squares over the tags' centres): the poses', not the board's shape. Into
// `shape`: the tags, their chi2 and RMS, flat or not.
void ReportLifts(const LiftFit& fit, const CalibrationBoard& board, double sigma_px, const BoardShapeOptions& options,
                 BoardShape* shape) {
  std::vector<int> ids;
  std::vector<double> h, sigma;
  Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  std::vector<Eigen::Vector3d> rows;
  for (const auto& [id, value] : fit.lift_m) {
    const auto c0 = board.AprilgridCorner(id, 0), c2 = board.AprilgridCorner(id, 2);
    if (!c0 || !c2) continue;
    const double s = sigma_px / std::sqrt(fit.sums.at(id).jj);
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
    t.lift_mm = kMToMm * (h[k] - rows[k].dot(plane));
    t.sigma_mm = kMToMm * sigma[k];
    t.corners = fit.sums.at(ids[k]).n;
    chi2 += std::pow(t.lift_mm / t.sigma_mm, 2);
    sq += t.lift_mm * t.lift_mm;
    if (std::abs(t.lift_mm) > shape->max_abs_lift_mm) {
      shape->max_abs_lift_mm = std::abs(t.lift_mm);
      shape->max_lift_id = t.id;
    }
    shape->tags.push_back(t);
  }
  shape->dof = static_cast<int>(shape->tags.size()) - 3;
  shape->chi2_per_dof = shape->dof > 0 ? chi2 / shape->dof : 0.0;
  shape->rms_lift_mm = std::sqrt(sq / shape->tags.size());
  // The 99.9 % quantile of chi2 / dof for a flat board (Wilson-Hilferty).
  const double k = std::max(1, shape->dof);
  const double q = std::pow(1.0 - 2.0 / (9.0 * k) + 3.09 * std::sqrt(2.0 / (9.0 * k)), 3);
  shape->flat = shape->chi2_per_dof <= q || shape->rms_lift_mm < options.flat_mm;
}

}  // namespace

BoardShape MeasureBoardShape(const std::vector<BoardDetection>& views, const CalibrationBoard& board,
                             const Intrinsics& intrinsics, const BoardShapeOptions& options) {
  BoardShape shape;
  if (!options.IsValid(&shape.message)) {
    shape.status = StatusCode::kInvalidArgument;
    return shape;
  }
  if (board.type != CalibrationBoard::Type::kAprilgrid) {
    shape.status = StatusCode::kInvalidArgument;
    shape.message = "the board's shape is measured on aprilgrids only";
    return shape;
  }
  const LiftFit fit = FitLifts(views, intrinsics, options);
  if (fit.lift_m.size() < 4) {
    shape.message = "fewer than 4 tags seen in " + std::to_string(options.min_sightings) + " corners or more";
    return shape;
  }
  // The residual per coordinate once the lifts are out; the degrees of
  // freedom less each view's pose and each lift.
  double total = 0.0, left = 0.0;
  int used = 0;
  for (const Sighting& s : fit.sightings) {
    const auto it = fit.lift_m.find(s.id);
    if (it == fit.lift_m.end()) continue;
    total += s.r.squaredNorm();
    left += (s.r - it->second * s.J).squaredNorm();
    ++used;
  }
  const int dof_px = 2 * used - 6 * fit.poses - static_cast<int>(fit.lift_m.size());
  if (dof_px < 1) {
    shape.message = "too few corners for the board's poses and lifts";
    return shape;
  }
  shape.explained_fraction = total > 0.0 ? 1.0 - left / total : 0.0;
  ReportLifts(fit, board, std::sqrt(left / dof_px), options, &shape);
  shape.status = StatusCode::kOk;
  return shape;
}

}  // namespace odocal::vision
