#include "odocal/vision/tag_observer.h"

#include <opencv2/imgproc.hpp>

#include "odocal/vision/edge_shift.h"
#include "odocal/vision/tag.h"


namespace odocal::vision {

bool VideoTrackOptions::IsValid(std::string* why) const {
  auto fail = [why](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (!detector.IsValid(why) || !tracker.IsValid(why) || !refine.IsValid(why)) return false;
  if (reacquire_every < 1) return fail("reacquire_every must be at least 1");
  if (duplicate_check_every < 0) return fail("duplicate_check_every must not be negative");
  if (queue_frames < 1) return fail("queue_frames must be at least 1");
  return true;
}

Result<std::unique_ptr<TagObserver>> TagObserver::Create(const TagSpec& tag, const Intrinsics& intrinsics,
                                                         const VideoTrackOptions& options) {
  using R = Result<std::unique_ptr<TagObserver>>;
  std::string why;
  if (!options.IsValid(&why)) return R::Error(StatusCode::kInvalidArgument, "options: " + why);
  DetectorOptions detector_options = options.detector;
  detector_options.family = tag.family;
  TagDetectorResult created = TagDetector::Create(detector_options);
  if (!created.ok()) return R::Error(StatusCode::kInvalidArgument, created.message);
  // The refinement sized for the family's black border (a cell is the side
  // over it), unless the caller chose a width; families with the border
  // inside the data (tagStandard41h12) keep the default.
  VideoTrackOptions sized = options;
  if (options.refine.width_at_border == CornerRefineOptions{}.width_at_border && TagCells::Of(tag.family, tag.id))
    sized.refine.width_at_border = TagWidthAtBorder(tag.family);
  return R::Ok(std::unique_ptr<TagObserver>(new TagObserver(tag, intrinsics, sized, std::move(created.detector))));
}

TagObserver::TagObserver(const TagSpec& tag, const Intrinsics& intrinsics,
                         const VideoTrackOptions& options, std::unique_ptr<TagDetector> detector)
    : tag_(tag),
      options_(options),
      detector_(std::move(detector)),
      tracker_(detector_.get(), tag.id, options.tracker),
      camera_(intrinsics, CameraMount{}) {}

TagObserver::~TagObserver() = default;

void TagObserver::Reset() {
  tracker_.Reset();
  lost_ = true;
  lost_for_ = 0;
}

FrameObservation TagObserver::Observe(const cv::Mat& grey, double t_s) {
  FrameObservation obs;
  obs.index = index_;
  obs.t_s = t_s;
  obs.width_at_border = options_.refine.width_at_border;
  // While lost, a full-frame search only every few frames.
  obs.searched = !lost_ || lost_for_ % options_.reacquire_every == 0;
  if (obs.searched) {
    const TrackResult r = tracker_.Track(grey);
    obs.status = r.find.status;
    obs.used_roi = r.used_roi;
    if (r.find.status == DetectStatus::kOk) obs.corners_px = r.find.detection->corners_px;
  }
  if (obs.corners_px && options_.duplicate_check_every > 0 && obs.used_roi &&
      index_ % options_.duplicate_check_every == 0) {
    const FindResult full = detector_->Find(grey, tag_.id);
    if (full.status == DetectStatus::kDuplicateId) {
      obs.status = DetectStatus::kDuplicateId;
      obs.corners_px.reset();
    }
  }
  if (obs.corners_px && options_.refine_corners) {
    const CornerRefineResult refined = RefineTagCorners(grey, *obs.corners_px, &camera_, options_.refine);
    if (refined.ok()) {
      obs.corners_px = refined.corners_px;
      obs.refined = true;
    }
  }
  if (obs.corners_px && options_.keep_crops) {
    cv::Rect box = cv::boundingRect(std::vector<cv::Point2f>(
        {cv::Point2f((*obs.corners_px)[0]), cv::Point2f((*obs.corners_px)[1]),
         cv::Point2f((*obs.corners_px)[2]), cv::Point2f((*obs.corners_px)[3])}));
    const int margin = 8;
    box = cv::Rect(box.x - margin, box.y - margin, box.width + 2 * margin, box.height + 2 * margin) &
          cv::Rect(0, 0, grey.cols, grey.rows);
    obs.crop = grey(box).clone();
    obs.crop_origin = box.tl();
  }
  lost_ = !obs.corners_px.has_value();
  lost_for_ = lost_ ? lost_for_ + 1 : 0;
  ++index_;
  return obs;
}

CornerRefineOptions RefineOptionsFor(const FrameObservation& observation) {
  CornerRefineOptions o;
  o.width_at_border = observation.width_at_border;
  return o;
}

std::optional<TagCorners> RefineObservationExactly(const FrameObservation& observation,
                                                   const CameraModel& camera) {
  if (!observation.corners_px || observation.crop.empty()) return std::nullopt;
  const CornerRefineResult r = RefineTagCornersByEdgeModel(
      observation.crop, *observation.corners_px, &camera, RefineOptionsFor(observation), observation.crop_origin);
  if (!r.ok()) return std::nullopt;
  return r.corners_px;
}

}  // namespace odocal::vision
