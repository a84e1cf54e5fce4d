// Following the robot's tag through a whole video file: decoding in its own
// thread (pipelined with detection, so the measurement keeps up with the
// decoder), each frame observed by vision::TagObserver.
//
// Time: the video's timestamps (seconds), from its timestamp list when given,
// else frame index / fps.
#ifndef ODOCAL_MEASURE_VIDEO_TRACK_H_
#define ODOCAL_MEASURE_VIDEO_TRACK_H_

#include <functional>
#include <string>
#include <vector>

#include "odocal/base/status.h"
#include "odocal/vision/camera_model.h"
#include "odocal/vision/tag.h"
#include "odocal/vision/tag_observer.h"

namespace odocal::measure {

struct VideoTrack {
  StatusCode status = StatusCode::kFailed;
  bool ok() const { return status == StatusCode::kOk; }
  std::string message;
  std::vector<vision::FrameObservation> frames;
  int found = 0;
  int duplicate_frames = 0;
  int wrong_id_frames = 0;  // other tags seen, not ours
  double decode_s = 0.0;    // time in the decoder thread
  double track_s = 0.0;     // time in detection, refinement
  double wall_s = 0.0;
};

// `timestamps_s` may be empty (then index / fps); `camera` undistorts edge
// samples for refinement. `on_frame(index)` is called after each frame.
VideoTrack TrackTagInVideo(const std::string& video_path, const std::vector<double>& timestamps_s,
                           const vision::TagSpec& tag, const vision::Intrinsics& intrinsics,
                           const vision::VideoTrackOptions& options = {},
                           const std::function<void(int)>& on_frame = {});

}  // namespace odocal::measure

#endif  // ODOCAL_MEASURE_VIDEO_TRACK_H_
