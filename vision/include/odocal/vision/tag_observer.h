// Following the robot's tag from frame to frame: window-of-interest tracking,
// full-frame search only to (re)acquire, and edge-based corner refinement.
// Frames come from anywhere (a decoded video: measure/video_track.h; a live
// camera: the station).
//
// Pixels: OpenCV convention (corners as TagDetector returns them, refined).
#ifndef ODOCAL_VISION_TAG_OBSERVER_H_
#define ODOCAL_VISION_TAG_OBSERVER_H_

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "odocal/base/status.h"
#include "odocal/vision/camera_model.h"
#include "odocal/vision/corner_refine.h"
#include "odocal/vision/detector.h"
#include "odocal/vision/planar_pose.h"
#include "odocal/vision/tag.h"

namespace odocal::vision {

struct VideoTrackOptions {
  DetectorOptions detector;  // family is taken from the tag spec
  TrackerOptions tracker;
  CornerRefineOptions refine;
  bool refine_corners = true;
  // While the tag is lost, search the whole frame only every this many frames
  // (a full 1080p search costs ~20 ms, a tracked window ~0.4 ms).
  int reacquire_every = 3;
  // Every this many frames, search the whole frame for a second tag with the
  // same id (the window never sees one); 0 = never.
  int duplicate_check_every = 60;
  // Decoded frames waiting for the tracker.
  int queue_frames = 8;
  // Keep the pixels around each found tag (a few kB a frame), so that the
  // frames that end up averaged can be refined again, exactly, afterwards.
  bool keep_crops = true;

  bool IsValid(std::string* why) const;
};

struct FrameObservation {
  int index = 0;
  double t_s = 0.0;
  DetectStatus status = DetectStatus::kNotFound;
  bool searched = false;  // false: skipped while lost (see reacquire_every)
  bool used_roi = false;
  bool refined = false;
  std::optional<TagCorners> corners_px;  // when status == kOk
  // With keep_crops: the tag and its surroundings; crop pixel (0, 0) is image
  // pixel crop_origin.
  cv::Mat crop;
  cv::Point crop_origin;
  // Cells across the tag's black border (CornerRefineOptions::width_at_border)
  // for refining this frame again from its crop: the family's (10 for
  // Kalibr's tag36h11b2), as the observer refined it.
  int width_at_border = CornerRefineOptions{}.width_at_border;
};

// The per-frame half of TrackTagInVideo, for frames that arrive one at a time
// (a live camera, the station): window tracking, a full-frame search only to
// (re)acquire, the periodic duplicate-id check, refinement and the kept crop,
// exactly as the video path does them.
class TagObserver {
 public:
  // kInvalidArgument naming what is wrong when the options or the detector
  // are invalid.
  static Result<std::unique_ptr<TagObserver>> Create(const TagSpec& tag, const Intrinsics& intrinsics,
                                                     const VideoTrackOptions& options);
  ~TagObserver();
  TagObserver(const TagObserver&) = delete;
  TagObserver& operator=(const TagObserver&) = delete;

  // Observes the next frame (CV_8UC1) taken at t_s; frames are numbered in
  // the order they are observed.
  FrameObservation Observe(const cv::Mat& grey, double t_s);
  // Forget the track (the next frame is searched in full).
  void Reset();

 private:
  TagObserver(const TagSpec& tag, const Intrinsics& intrinsics, const VideoTrackOptions& options,
              std::unique_ptr<TagDetector> detector);
  TagSpec tag_;
  VideoTrackOptions options_;
  std::unique_ptr<TagDetector> detector_;
  TagTracker tracker_;
  CameraModel camera_;
  int index_ = 0;
  int lost_for_ = 0;
  bool lost_ = true;
};

// The refinement options a frame's crop is refined again with (its family's
// border width; the rest CornerRefineOptions' defaults).
CornerRefineOptions RefineOptionsFor(const FrameObservation& observation);

// The exact refinement (RefineTagCornersByEdgeModel) of a frame's corners
// from its kept crop; nullopt without a crop or when the fit fails.
std::optional<TagCorners> RefineObservationExactly(const FrameObservation& observation,
                                                   const CameraModel& camera);

}  // namespace odocal::vision

#endif  // ODOCAL_VISION_TAG_OBSERVER_H_
