// The live view of a camera watching a tag (tag_watch.h).
#include "odocal/live/tag_watch.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>

#include "odocal/base/units.h"
#include "odocal/measure/measure.h"
#include "odocal/vision/planar_pose.h"

namespace odocal::live {
namespace {

// The pose the page shows, with a one-frame sigma: the corners' closure of
// this frame alone (vision::EstimateRestCornerError with one frame puts the
// whole image error in the shared part).
std::optional<LivePose> PoseOf(const vision::CameraModel& camera, const vision::TagSpec& tag,
                               const vision::TagCorners& corners) {
  const vision::PlanarPoseResult m = vision::MeasureTagPose(camera, tag, corners);
  if (!m.ok()) return std::nullopt;
  const double heading = m.T_world_robot.heading();
  const vision::RestCornerError e = vision::EstimateRestCornerError({m.closure_mm}, tag, heading);
  LivePose p;
  p.x_mm = m.T_world_robot.x() * kMToMm;
  p.y_mm = m.T_world_robot.y() * kMToMm;
  p.heading_deg = heading * kRadToDeg;
  p.sigma_x_mm = std::sqrt(e.shared_covariance(0, 0)) * kMToMm;
  p.sigma_y_mm = std::sqrt(e.shared_covariance(1, 1)) * kMToMm;
  p.sigma_heading_deg = std::sqrt(e.shared_covariance(2, 2)) * kRadToDeg;
  return p;
}

double MeanSidePx(const vision::TagCorners& c) {
  double sum = 0.0;
  for (int i = 0; i < 4; ++i) sum += cv::norm(c[(i + 1) % 4] - c[i]);
  return sum / 4.0;
}

}  // namespace

Result<std::unique_ptr<TagWatch>> TagWatch::Create(const vision::TagSpec& tag, const vision::Intrinsics& intrinsics,
                                                   const std::optional<vision::CameraMount>& mount_guess,
                                                   LiveState* state) {
  vision::VideoTrackOptions track;
  track.keep_crops = false;
  auto observer = vision::TagObserver::Create(tag, intrinsics, track);
  if (!observer) return Result<std::unique_ptr<TagWatch>>::From(observer);
  return Result<std::unique_ptr<TagWatch>>::Ok(
      std::unique_ptr<TagWatch>(new TagWatch(tag, intrinsics, mount_guess, state, std::move(*observer))));
}

TagWatch::TagWatch(const vision::TagSpec& tag, const vision::Intrinsics& intrinsics,
                   const std::optional<vision::CameraMount>& mount_guess, LiveState* state,
                   std::unique_ptr<vision::TagObserver> observer)
    : tag_(tag), intrinsics_(intrinsics), mount_guess_(mount_guess), state_(state), observer_(std::move(observer)) {}

void TagWatch::OnFrame(const cv::Mat& grey, double t_s) {
  ++frames_;
  const vision::FrameObservation obs = observer_->Observe(grey, t_s);
  WarnOfOtherTags(obs);
  std::optional<LivePose> pose;
  if (obs.corners_px) {
    ++found_;
    if (!camera_) {
      mount_ =
          mount_guess_ ? *mount_guess_ : measure::LevelMountFromTagSize(intrinsics_, tag_, MeanSidePx(*obs.corners_px));
      state_->SetEstimate("camera height", mount_.height_mm, 0.0, "mm");
      camera_.emplace(intrinsics_, mount_);
    }
    if (!plane_done_) FitThePlaneOnce(*obs.corners_px);
    pose = PoseOf(*camera_, tag_, *obs.corners_px);
  }
  state_->OnFrame(grey, t_s, obs.corners_px, pose);
}

void TagWatch::WarnOfOtherTags(const vision::FrameObservation& obs) {
  if (obs.status == vision::DetectStatus::kWrongId) {
    state_->SetWarning("wrong_id",
                       "tags seen, but not id " + std::to_string(tag_.id) + " of " + tag_.family + ": check --tag");
  } else if (obs.status == vision::DetectStatus::kDuplicateId) {
    state_->SetWarning("duplicate_id", "tag id " + std::to_string(tag_.id) +
                                           " seen twice: another tag with the same id is in view; remove it");
  } else if (obs.corners_px) {
    state_->ClearWarning("wrong_id");
    state_->ClearWarning("duplicate_id");
  }
}

void TagWatch::FitThePlaneOnce(const vision::TagCorners& corners) {
  plane_views_.push_back(corners);
  if (static_cast<int>(plane_views_.size()) < kPlaneViews) return;
  plane_done_ = true;
  std::vector<vision::TagCorners> views;
  const int step = std::max(1, static_cast<int>(plane_views_.size()) / kMaxPlaneViews);
  for (size_t k = 0; k < plane_views_.size(); k += step) views.push_back(plane_views_[k]);
  const measure::CameraPlaneOrGuess fit = measure::EstimateCameraPlaneOrGuess(intrinsics_, tag_, views, mount_);
  const vision::CameraPlaneResult& plane = fit.plane;
  if (!fit.estimated()) {
    state_->SetWarning("camera_plane", "the camera's tilt could not be fitted to the tag (" + plane.message +
                                           "): poses assume a level camera");
    return;
  }
  mount_ = fit.mount;
  camera_.emplace(intrinsics_, mount_);
  // The path so far, measured again on the fitted plane.
  std::vector<cv::Point2d> path;
  for (const vision::TagCorners& c : plane_views_)
    if (const auto p = PoseOf(*camera_, tag_, c)) path.emplace_back(p->x_mm, p->y_mm);
  state_->SetTrajectory(path);
  state_->SetEstimate("camera height", mount_.height_mm, plane.sigma_height_mm, "mm");
  state_->SetEstimate("camera roll", mount_.roll_deg, plane.sigma_roll_deg, "deg");
  state_->SetEstimate("camera pitch", mount_.pitch_deg, plane.sigma_pitch_deg, "deg");
}

}  // namespace odocal::live
