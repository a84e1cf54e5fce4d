#include "odocal/measure/setup_check.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>

#include <opencv2/imgproc.hpp>

#include "odocal/base/format.h"
#include "odocal/base/units.h"
#include "odocal/calibration/statistics.h"
#include "odocal/calibration/umbmark.h"
#include "odocal/measure/measure.h"
#include "odocal/vision/corner_refine.h"
#include "odocal/vision/detector.h"
#include "odocal/vision/planar_pose.h"
#include "odocal/vision/tag.h"

namespace odocal::measure {
namespace {

using calibration::Pose2;

// The image border inset by `inset_px`, walked around in steps, met with the
// plane at `height_m`: the floor the camera sees there.
std::vector<Eigen::Vector2d> ViewPolygon(const vision::CameraModel& camera, double height_m, double inset_px) {
  const vision::Intrinsics& in = camera.intrinsics();
  const double x0 = inset_px, y0 = inset_px, x1 = in.width - 1 - inset_px, y1 = in.height - 1 - inset_px;
  std::vector<Eigen::Vector2d> pixels;
  constexpr int kSteps = 16;
  for (int k = 0; k < kSteps; ++k) pixels.emplace_back(x0 + (x1 - x0) * k / kSteps, y0);
  for (int k = 0; k < kSteps; ++k) pixels.emplace_back(x1, y0 + (y1 - y0) * k / kSteps);
  for (int k = 0; k < kSteps; ++k) pixels.emplace_back(x1 - (x1 - x0) * k / kSteps, y1);
  for (int k = 0; k < kSteps; ++k) pixels.emplace_back(x0, y1 - (y1 - y0) * k / kSteps);
  std::vector<Eigen::Vector2d> polygon;
  for (const Eigen::Vector2d& p : pixels)
    if (const auto w = camera.UnprojectToWorldPlane(p, height_m)) polygon.push_back(w->head<2>());
  return polygon;
}

bool Inside(const std::vector<Eigen::Vector2d>& polygon, const Eigen::Vector2d& p) {
  if (polygon.size() < 3) return false;
  std::vector<cv::Point2f> contour;
  for (const auto& q : polygon) contour.emplace_back(static_cast<float>(q.x()), static_cast<float>(q.y()));
  return cv::pointPolygonTest(contour, cv::Point2f(static_cast<float>(p.x()), static_cast<float>(p.y())), false) >= 0;
}

// CheckSetup's steps, in order. Each fills its part of the result `r`; a
// step that ends the check says why in r->message and returns false.

// The still tag's frames where it is found and refined (through the lens
// alone: the mount is not known yet), with their image quality.
struct StillFrames {
  std::vector<vision::TagCorners> corners;
  std::vector<vision::TagImageQuality> qualities;
  std::vector<size_t> frame_of;  // corners[k] is frames[frame_of[k]]'s
};

bool RefineStillFrames(const std::vector<SetupFrame>& frames, const SetupCheckOptions& options,
                       const vision::CameraModel& camera, StillFrames* still, SetupCheckResult* r) {
  auto detector = vision::TagDetector::Create(vision::DetectorOptions{});
  if (!detector.ok()) {
    r->message = detector.message;
    return false;
  }
  std::vector<vision::TagCorners>& corners = still->corners;
  std::vector<vision::TagImageQuality>& qualities = still->qualities;
  std::vector<size_t>& frame_of = still->frame_of;
  int wrong_id = 0, duplicate = 0;
  for (size_t i = 0; i < frames.size(); ++i) {
    const vision::FindResult found = detector.detector->Find(frames[i].grey, options.tag.id);
    if (found.status == vision::DetectStatus::kWrongId) ++wrong_id;
    if (found.status == vision::DetectStatus::kDuplicateId) ++duplicate;
    if (found.status != vision::DetectStatus::kOk) continue;
    ++r->frames_found;
    const vision::CornerRefineResult half = vision::RefineTagCorners(frames[i].grey, found.detection->corners_px, &camera);
    if (!half.ok()) continue;
    const vision::ModelFreeRefineResult exact = vision::RefineTagCornersModelFree(frames[i].grey, half.corners_px, &camera);
    if (!exact.ok()) continue;
    corners.push_back(exact.corners_px);
    qualities.push_back(exact.quality);
    frame_of.push_back(i);
  }
  r->frames_refined = static_cast<int>(corners.size());
  if (duplicate > 0)
    r->warnings.push_back("tag id " + std::to_string(options.tag.id) + " seen twice in " + std::to_string(duplicate) +
                          " frames: another tag with the same id is in view; remove it");
  if (r->frames_found == 0) {
    r->message = wrong_id > 0 ? "tags seen, but never id " + std::to_string(options.tag.id) + " of " +
                                    options.tag.family + ": check --tag"
                              : "the tag was not found in any of " + std::to_string(r->frames) +
                                    " frames: is it in view, in focus, lit, and " + options.tag.family + "?";
    return false;
  }
  if (corners.size() < 2) {
    r->message = "the tag was found but its edges could not be refined (" + std::to_string(r->frames_found) +
                 " frames): too small, blurred or occluded";
    return false;
  }
  return true;
}

// The median frame's image quality, and the gate's flags on it.
void MedianQuality(const std::vector<vision::TagImageQuality>& qualities, SetupCheckResult* r) {
  {
    auto med = [&](auto field) {
      std::vector<double> v;
      for (const auto& q : qualities) v.push_back(q.*field);
      return calibration::Median(v);
    };
    r->quality.side_px = med(&vision::TagImageQuality::side_px);
    r->quality.cell_px = med(&vision::TagImageQuality::cell_px);
    r->quality.contrast_grey = med(&vision::TagImageQuality::contrast_grey);
    r->quality.blur_sigma_px = med(&vision::TagImageQuality::blur_sigma_px);
    r->quality.gamma = med(&vision::TagImageQuality::gamma);
    r->quality.saturated_fraction = med(&vision::TagImageQuality::saturated_fraction);
    r->quality.rms_residual_grey = med(&vision::TagImageQuality::rms_residual_grey);
    r->quality.relative_residual = med(&vision::TagImageQuality::relative_residual);
    r->quality_flags = vision::QualityFlags(r->quality);
    for (const vision::ObservationFlag flag : r->quality_flags)
      r->warnings.push_back(std::string("image quality: ") + vision::ToString(flag));
    if (r->quality.side_px < 60.0)
      r->warnings.push_back(
          Format("the tag is %.0f px across: below ~60 px the heading error grows (docs/vision.md, "
                 "\"How many pixels the heading targets need\"); print it larger or hang the "
                 "camera lower",
                 r->quality.side_px));
  }
}

// The tag's edge shift (a tone curve, blur or ink that makes its black look
// larger or smaller), measured in every (n / 8)-th frame and taken out of
// every frame's corners. Returns the tag's printed side in the image [px]:
// the height below is the tag's apparent size.
double RemoveTheEdgeShift(const std::vector<SetupFrame>& frames, const SetupCheckOptions& options,
                          const vision::CameraModel& camera, StillFrames* still, SetupCheckResult* r) {
  std::vector<vision::TagCorners>& corners = still->corners;
  const std::vector<size_t>& frame_of = still->frame_of;
  double print_side_px = r->quality.side_px;
  {
    if (const auto cells = vision::TagCells::Of(options.tag.family, options.tag.id)) {
      std::vector<vision::EdgeShiftResult> shifts;
      const size_t step = std::max<size_t>(1, corners.size() / 8);
      for (size_t k = 0; k < corners.size(); k += step)
        shifts.push_back(vision::MeasureEdgeShift(frames[frame_of[k]].grey, corners[k], *cells, &camera));
      r->edge_shift = vision::PoolEdgeShifts(shifts);
      if (r->edge_shift.ok()) {
        for (vision::TagCorners& c : corners) c = vision::RemoveEdgeShift(c, r->edge_shift.shift_px, &camera);
        print_side_px -= 2.0 * r->edge_shift.shift_px;
      }
    }
  }
  return print_side_px;
}

// The mount: the operator's, or a level camera at the height the tag's
// apparent size implies (f x size / side, plus the tag's height); then the
// tilt the still tag's own perspective tells.
void MountAndTilt(const SetupCheckOptions& options, double print_side_px,
                  const std::vector<vision::TagCorners>& corners, SetupCheckResult* r) {
  if (options.mount_guess) {
    r->mount = *options.mount_guess;
  } else {
    r->mount = LevelMountFromTagSize(options.intrinsics, options.tag, print_side_px);
    r->mount_from_tag_size = true;
  }
  // The tilt: a still tag's own perspective tells it (the bundle adjustment
  // of the camera plane on its views). Without it the tag's corners, put on
  // the floor with a wrong tilt, are not a square, and the closure would
  // count that as image error (a 3 deg tilt: 0.07 mm at 2 m).
  {
    const int step = std::max<int>(1, static_cast<int>(corners.size()) / 20);
    std::vector<vision::TagCorners> views;
    for (size_t k = 0; k < corners.size(); k += step) views.push_back(corners[k]);
    const CameraPlaneOrGuess fit = EstimateCameraPlaneOrGuess(options.intrinsics, options.tag, views, r->mount);
    r->mount = fit.mount;
    r->plane_from_tag = fit.estimated();
    if (!fit.estimated())
      r->warnings.push_back("the camera's tilt could not be estimated from the still tag (" + fit.plane.message +
                            "): the noise below may be overstated");
  }
}

// The still tag's poses through the mount: their spread (per frame), the
// error the frames share (the closure), and what that makes of a rest and a
// return error. `mean_pose` is the mean pose (x, y, heading), `posed_frames`
// the frames posed.
bool StillTagNoise(const vision::CameraModel& camera, const SetupCheckOptions& options,
                   const std::vector<vision::TagCorners>& corners, Eigen::Vector3d* mean_pose,
                   std::vector<size_t>* posed_frames, SetupCheckResult* r) {
  std::vector<Eigen::Vector3d> poses;
  std::vector<std::array<Eigen::Vector2d, 4>> closures;
  std::vector<size_t> posed;
  for (size_t k = 0; k < corners.size(); ++k) {
    const vision::PlanarPoseResult m = vision::MeasureTagPose(camera, options.tag, corners[k]);
    if (!m.ok()) continue;
    poses.emplace_back(m.T_world_robot.x(), m.T_world_robot.y(), m.T_world_robot.heading());
    closures.push_back(m.closure_mm);
    posed.push_back(k);
  }
  if (poses.size() < 2) {
    r->message = "the tag's pose could not be measured from the refined frames";
    return false;
  }
  const size_t n = poses.size();
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& p : poses) mean += p / n;
  double var_p = 0.0, var_h = 0.0;
  for (const auto& p : poses) {
    var_p += 0.5 * ((p.head<2>() - mean.head<2>()).squaredNorm()) / (n - 1);
    var_h += std::pow(calibration::WrapAngle(p.z() - mean.z()), 2) / (n - 1);
  }
  // Still? A robot that moved makes the spread meaningless.
  for (const auto& p : poses)
    if ((p.head<2>() - mean.head<2>()).norm() > 0.005) {
      r->warnings.push_back("the tag moved by more than 5 mm during the check: keep the robot still");
      break;
    }
  r->frame_sigma_position_m = std::sqrt(var_p);
  r->frame_sigma_heading_rad = std::sqrt(var_h);
  // What the frames share, as expected (each corner its own error), not the
  // edge model's bound that batch states: a prediction is compared with the
  // error then made (docs/vision.md, "What a rest's error is made of").
  // The tilt fitted to these very frames (above) has made the tag as square
  // as roll and pitch can: 2 of the closure's 4 dimensions.
  const vision::RestCornerError shared =
      vision::EstimateRestCornerError(closures, options.tag, mean.z(), r->plane_from_tag ? 2 : 0);
  const Eigen::Matrix3d& shared_cov = shared.expected_shared_covariance;
  r->shared_sigma_position_m = std::sqrt(0.5 * (shared_cov(0, 0) + shared_cov(1, 1)));
  r->shared_sigma_heading_rad = std::sqrt(shared_cov(2, 2));
  const double rest_frames = std::max(1.0, (r->fps > 0.0 ? r->fps : 30.0) * options.rest_s);
  r->rest_sigma_position_m =
      std::hypot(std::sqrt(var_p / rest_frames), options.session_position_factor * r->shared_sigma_position_m);
  r->rest_sigma_heading_rad =
      std::hypot(std::sqrt(var_h / rest_frames), options.session_heading_factor * r->shared_sigma_heading_rad);
  r->return_sigma_position_m = std::sqrt(2.0) * r->rest_sigma_position_m;
  r->return_sigma_heading_rad = std::sqrt(2.0) * r->rest_sigma_heading_rad;

  *mean_pose = mean;
  *posed_frames = posed;
  return true;
}

// The floor the camera sees, and the planned squares from where the robot
// stands: the tag in view at every corner, and how small it gets there.
void SquaresInView(const vision::CameraModel& camera, const SetupCheckOptions& options, const Eigen::Vector3d& mean,
                   SetupCheckResult* r) {
  const double inset = options.border_margin_px + r->quality.side_px / std::sqrt(2.0);
  r->view_polygon = ViewPolygon(camera, options.tag.height_m(), inset);
  if (!r->view_polygon.empty()) {
    Eigen::Vector2d lo = r->view_polygon.front(), hi = lo;
    for (const auto& p : r->view_polygon) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
    r->view_width_m = hi.x() - lo.x();
    r->view_depth_m = hi.y() - lo.y();
  }
  // The squares from where the robot stands: the tag's centre at every
  // corner, with the heading it arrives and leaves with, must stay in view.
  const Pose2 start = Pose2::FromXYHeading(mean.x(), mean.y(), mean.z());
  const Pose2 T_robot_tag = Pose2::FromXYHeading(options.tag.offset_x_mm * kMmToM, options.tag.offset_y_mm * kMmToM, 0.0);
  const double L = options.square_side_m;
  // The tag's shortest side in the image with the robot at `robot`.
  const Pose2 T_robot_tag_turned = T_robot_tag * Pose2::FromXYHeading(0.0, 0.0, DegToRad(options.tag.yaw_deg));
  const auto tag_side_px = [&](const Pose2& robot) {
    const Pose2 tag = robot * T_robot_tag_turned;
    std::array<Eigen::Vector2d, 4> px;
    for (int k = 0; k < 4; ++k) {
      const Eigen::Vector2d w = tag * vision::TagCornersInTag(options.tag.size_m())[k];
      const auto p = camera.ProjectWorld(Eigen::Vector3d(w.x(), w.y(), options.tag.height_m()));
      if (!p) return 0.0;
      px[k] = *p;
    }
    double side = std::numeric_limits<double>::infinity();
    for (int k = 0; k < 4; ++k) side = std::min(side, (px[(k + 1) % 4] - px[k]).norm());
    return side;
  };
  r->squares_fit = true;
  r->squares_min_tag_side_px = std::numeric_limits<double>::infinity();
  for (int d = 0; d < 2; ++d) {
    const double turn = d == 0 ? -M_PI / 2 : M_PI / 2;  // cw turns right
    Pose2 pose = start;
    for (int side = 0; side < 4; ++side) {
      r->squares[d].push_back(pose.translation());
      pose = pose * Pose2::FromXYHeading(L, 0.0, 0.0);
      for (const Pose2& at : {pose, pose * Pose2::FromXYHeading(0.0, 0.0, turn)}) {
        if (!Inside(r->view_polygon, (at * T_robot_tag).translation())) {
          r->squares_fit = false;
          continue;
        }
        const double px = tag_side_px(at);
        if (px > 0.0 && px < r->squares_min_tag_side_px) {
          r->squares_min_tag_side_px = px;
          r->squares_min_tag_side_at = at.translation();
        }
      }
      pose = pose * Pose2::FromXYHeading(0.0, 0.0, turn);
    }
  }
  if (!std::isfinite(r->squares_min_tag_side_px)) r->squares_min_tag_side_px = 0.0;
  if (!r->squares_fit)
    r->warnings.push_back(
        Format("the planned %.0f mm squares (cw and ccw from where the robot stands) leave the "
               "camera's view: move the robot, shrink the square, or raise the camera",
               L * kMToMm));
  const double cells = vision::TagWidthAtBorder(options.tag.family);
  if (r->squares_min_tag_side_px > 0.0 && r->squares_min_tag_side_px < kSmallTagCellPx * cells) {
    r->squares_tag_too_small = r->squares_min_tag_side_px < kTooSmallTagCellPx * cells;
    r->warnings.push_back(Format(
        "at the squares' corner at (%.0f, %.0f) mm the tag is %.0f px across (%.0f px where it stands): %s; "
        "keep the squares nearer the middle of the view, or use a larger tag",
        r->squares_min_tag_side_at.x() * kMToMm, r->squares_min_tag_side_at.y() * kMToMm, r->squares_min_tag_side_px,
        r->quality.side_px,
        r->squares_tag_too_small ? "too small to be measured there (its cells under 2 px)"
                                 : "with cells under 4 px its corners carry several times the error (a wide lens "
                                   "shrinks a tag towards the rim of its view)"));
  }
}

// Ed and Eb: UMBMark's coupled fit on return errors drawn with the
// predicted sigmas, as often as the plan repeats the squares.
void PredictEdAndEb(const SetupCheckOptions& options, SetupCheckResult* r) {
  const double L = options.square_side_m;
  std::mt19937_64 rng(options.seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::vector<double> eds, ebs;
  for (int draw = 0; draw < options.monte_carlo_draws; ++draw) {
    calibration::UmbmarkInput input;
    input.side_m = L;
    input.track_m = options.track_m;
    for (int k = 0; k < options.runs_per_direction; ++k)
      for (auto* list : {&input.cw, &input.ccw})
        list->push_back({r->return_sigma_position_m * normal(rng), r->return_sigma_position_m * normal(rng),
                         r->return_sigma_heading_rad * normal(rng)});
    const calibration::UmbmarkSummary s = calibration::EstimateUmbmark(input);
    if (!s.ok()) continue;
    eds.push_back(s.coupled.Ed);
    ebs.push_back(s.coupled.Eb);
  }
  auto spread = [](const std::vector<double>& v) {
    if (v.size() < 2) return 0.0;
    double m = 0.0, q = 0.0;
    for (double x : v) m += x / v.size();
    for (double x : v) q += (x - m) * (x - m) / (v.size() - 1);
    return std::sqrt(q);
  };
  r->sigma_Ed = spread(eds);
  r->sigma_Eb = spread(ebs);
}

// The edges' angle to the pixel grid, from a frame's corners `c`.
void GridAngle(const vision::TagCorners& c, SetupCheckResult* r) {
  {
    const double edge_deg = RadToDeg(std::atan2(c[1].y - c[0].y, c[1].x - c[0].x));
    const double off = std::fmod(std::fmod(edge_deg, 90.0) + 90.0, 90.0);
    r->grid_angle_deg = std::min(off, 90.0 - off);
    if (r->grid_angle_deg < 5.0)
      r->warnings.push_back(
          Format("the tag's edges run %.1f deg off the pixel rows: a lossy video codec (H.264 at CRF "
                 "23, a webcam's) turns such edges toward the rows, a heading error no still image "
                 "shows (up to 2x the predicted; docs/vision.md). Start the robot turned 15-45 deg to "
                 "the camera's rows, or record with less compression",
                 r->grid_angle_deg));
  }
}

}  // namespace

SetupCheckResult CheckSetup(const std::vector<SetupFrame>& frames, const SetupCheckOptions& options) {
  SetupCheckResult r;
  r.frames = static_cast<int>(frames.size());
  if (frames.size() >= 2) r.fps = (frames.size() - 1) / std::max(1e-9, frames.back().t_s - frames.front().t_s);
  // The lens alone first (the refinement undistorts edge samples); the mount
  // follows from the first tag seen when the operator gave none.
  vision::CameraModel camera(options.intrinsics, options.mount_guess.value_or(vision::CameraMount{}));
  StillFrames still;
  if (!RefineStillFrames(frames, options, camera, &still, &r)) return r;
  MedianQuality(still.qualities, &r);
  const double print_side_px = RemoveTheEdgeShift(frames, options, camera, &still, &r);
  MountAndTilt(options, print_side_px, still.corners, &r);
  camera = vision::CameraModel(options.intrinsics, r.mount);
  Eigen::Vector3d mean;
  std::vector<size_t> posed;
  if (!StillTagNoise(camera, options, still.corners, &mean, &posed, &r)) return r;
  SquaresInView(camera, options, mean, &r);
  PredictEdAndEb(options, &r);
  GridAngle(still.corners[posed.back()], &r);
  r.last_frame = frames[still.frame_of[posed.back()]].grey;
  r.last_corners = still.corners[posed.back()];
  r.status = StatusCode::kOk;
  return r;
}

}  // namespace odocal::measure
