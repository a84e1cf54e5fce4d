// The live view of a camera watching a tag, without a robot (`odocal watch`):
// each frame's tag found and tracked (vision::TagObserver), its pose measured
// on the tag's plane, both given to a LiveState. The camera's mount starts as
// the guess, or a level camera at the height the tag's apparent size implies
// (as setup-check does); its tilt and height are fitted once to the first
// kPlaneViews views of the tag (thinned to kMaxPlaneViews), and the path so
// far is measured again on the fitted plane.
//
//   auto watch = live::TagWatch::Create(tag, intrinsics, mount_guess, &state);
//   if (!watch) return watch.message;
//   for (each frame) (*watch)->OnFrame(grey, t_s);
#ifndef ODOCAL_LIVE_TAG_WATCH_H_
#define ODOCAL_LIVE_TAG_WATCH_H_

#include <memory>
#include <optional>
#include <vector>

#include <opencv2/core.hpp>

#include "odocal/base/status.h"
#include "odocal/live/live_state.h"
#include "odocal/vision/camera_model.h"
#include "odocal/vision/tag_observer.h"

namespace odocal::live {

class TagWatch {
 public:
  // Views of the tag the camera's tilt and height are fitted to (evenly
  // thinned to kMaxPlaneViews): about a second of a 30 fps camera.
  static constexpr int kPlaneViews = 30;
  static constexpr int kMaxPlaneViews = 15;

  // kInvalidArgument when the tag or the intrinsics cannot be tracked
  // (the message says why). `state` must outlive the watch.
  static Result<std::unique_ptr<TagWatch>> Create(const vision::TagSpec& tag, const vision::Intrinsics& intrinsics,
                                                  const std::optional<vision::CameraMount>& mount_guess,
                                                  LiveState* state);
  // One frame (CV_8UC1, the intrinsics' size) taken at t_s.
  void OnFrame(const cv::Mat& grey, double t_s);

  long frames() const { return frames_; }
  long found() const { return found_; }

 private:
  TagWatch(const vision::TagSpec& tag, const vision::Intrinsics& intrinsics,
           const std::optional<vision::CameraMount>& mount_guess, LiveState* state,
           std::unique_ptr<vision::TagObserver> observer);
  void WarnOfOtherTags(const vision::FrameObservation& obs);
  void FitThePlaneOnce(const vision::TagCorners& corners);

  vision::TagSpec tag_;
  vision::Intrinsics intrinsics_;
  std::optional<vision::CameraMount> mount_guess_;
  LiveState* state_;
  std::unique_ptr<vision::TagObserver> observer_;
  std::optional<vision::CameraModel> camera_;
  vision::CameraMount mount_;
  std::vector<vision::TagCorners> plane_views_;
  bool plane_done_ = false;
  long frames_ = 0, found_ = 0;
};

}  // namespace odocal::live

#endif  // ODOCAL_LIVE_TAG_WATCH_H_
