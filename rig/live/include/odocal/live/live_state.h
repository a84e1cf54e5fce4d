// The live view's state (issue 13 §4): what a producer (`odocal watch`, the
// station loop) saw last, kept for a web page to show while it runs. The
// producer calls OnFrame() once per camera frame and the Set*() methods when
// something changes; the server (live_server.h) reads StateJson() and
// FrameJpeg() from its own threads. Every method may be called from any
// thread; OnFrame() costs a copy of the frame and a few small image
// statistics on the tag's pixels (the JPEG is made only when a page asks).
//
// Frames and units: poses are planar world poses (REP-103 on the floor: x
// forward, y left, heading counter-clockwise from x) in millimetres and
// degrees, as the rest of odocal prints them; tag corners are distorted image
// pixels in OpenCV's convention (pixel centres at integers), in the order
// vision::TagDetector reports them. Times are the producer's (t_s of its
// frames). The JSON keys are documented in docs/formats.md ("Live view").
//
// Warnings the state computes itself from the frames (keys in the JSON):
//   tag_lost   the tag was in none of the last `lost_after_frames` frames
//              (or has not been seen yet);
//   too_small  the tag's mean side is below `min_side_px`: by default the
//              size under which vision's edge refinement refuses a tag
//              (CornerRefineOptions: min_cell_px x width_at_border = 16 px),
//              so the pose falls back to libapriltag's corners;
//   blur       the tag's sharpness is below `blur_ratio` x the reference.
//              Sharpness = variance of the Laplacian (3x3) over the tag's
//              bounding box / (its 95th - 5th grey percentile)^2, so that a
//              change of exposure or light does not count as blur; the
//              reference is the 90th percentile of the last
//              `blur_reference_frames` frames with the tag (the sharpest
//              ones, usually the rests). Relative by design: it catches
//              motion blur and a focus that drifts during a session, not a
//              camera that was never in focus (setup-check's quality gate is
//              for that: vision/edge_quality.h).
// A producer adds its own with SetWarning() (a video that ended, a robot
// link that dropped).
#ifndef ODOCAL_LIVE_LIVE_STATE_H_
#define ODOCAL_LIVE_LIVE_STATE_H_

#include <array>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

namespace odocal::live {

// The tag's four outer corners (the same type as vision::TagCorners).
using TagOutline = std::array<cv::Point2d, 4>;

// A planar pose in the world frame with its 1-sigma uncertainty (0 = not known).
struct LivePose {
  double x_mm = 0.0;
  double y_mm = 0.0;
  double heading_deg = 0.0;
  double sigma_x_mm = 0.0;
  double sigma_y_mm = 0.0;
  double sigma_heading_deg = 0.0;
};

// vision::CornerRefineOptions' min_cell_px x width_at_border (24 px).
double DefaultMinSidePx();

struct LiveOptions {
  // tag_lost after this many frames in a row without the tag.
  int lost_after_frames = 10;
  // too_small below this mean side (px); default: CornerRefineOptions'
  // min_cell_px x width_at_border (see the top of this header).
  double min_side_px = DefaultMinSidePx();
  // blur when the sharpness is below this fraction of the reference...
  double blur_ratio = 0.5;
  // ... the 90th percentile of this many last frames with the tag ...
  int blur_reference_frames = 300;
  // ... once at least this many have been seen.
  int blur_min_frames = 15;
  // The trajectory keeps a point when it is this far from the last kept one;
  // when it holds `max_trajectory_points`, every other point is dropped (the
  // whole path stays, more coarsely).
  double trajectory_step_mm = 2.0;
  int max_trajectory_points = 2000;
  // Frames wider than this are scaled down for the page (bytes, phones).
  int image_max_width_px = 960;
  int jpeg_quality = 80;

  bool IsValid(std::string* why) const;
};

struct LiveEstimate {
  std::string name;  // "Ed", "Eb", "E_max,syst", "camera height"
  double value = 0.0;
  double sigma = 0.0;  // 1 sigma, in `unit`; 0 = not known
  std::string unit;    // "", "mm", "deg", "%"
};

// The latest frame as the page shows it: scaled to image_max_width_px, the
// tag's outline drawn in kOutlineBgr, JPEG.
struct LiveJpeg {
  std::shared_ptr<const std::vector<unsigned char>> bytes;
  int64_t seq = 0;  // the frame's number (1 = the first OnFrame)
  int width = 0, height = 0;
};

// The outline's colour in the JPEG (magenta: absent from a grey image).
inline const cv::Scalar kOutlineBgr(255, 0, 255);

class LiveState {
 public:
  // `options` must be valid (IsValid); a programming error otherwise.
  explicit LiveState(const LiveOptions& options = {});
  LiveState(const LiveState&) = delete;
  LiveState& operator=(const LiveState&) = delete;

  // --- The producer's side.
  // One camera frame (CV_8UC1 or CV_8UC3), taken at t_s; the tag's corners
  // when it was found, its world pose when it could be measured (the pose is
  // added to the trajectory).
  void OnFrame(const cv::Mat& image, double t_s, const std::optional<TagOutline>& tag_corners_px,
               const std::optional<LivePose>& pose_world);
  // What runs: run `run_index` (1-based; 0 = none yet) of `run_total`.
  void SetProgress(int run_index, int run_total, const std::string& run_label, const std::string& plan_label);
  // Adds or replaces the estimate called `name` (the page keeps the order of first appearance).
  void SetEstimate(const std::string& name, double value, double sigma, const std::string& unit);
  // A warning of the producer's own under `key` (replaces one with the same key).
  void SetWarning(const std::string& key, const std::string& text);
  void ClearWarning(const std::string& key);
  // Starts the trajectory afresh (a new run).
  void ClearTrajectory();
  // Replaces the trajectory (world mm, oldest first; thinned as OnFrame's
  // poses are): the path measured again with a new camera model.
  void SetTrajectory(const std::vector<cv::Point2d>& points_mm);
  // What is being watched, for the page's title line ("camera 0", a file).
  void SetSource(const std::string& label);

  // --- The server's side.
  // The documented state (docs/formats.md, "Live view").
  nlohmann::json StateJson() const;
  // The latest frame annotated and encoded (made once per frame, on demand);
  // nullopt before the first frame.
  std::optional<LiveJpeg> FrameJpeg() const;
  // The number of the latest frame (0 before the first).
  int64_t frame_seq() const;
  // Waits until a frame newer than `after_seq` has arrived or `timeout` passed;
  // whether one has.
  bool WaitForFrame(int64_t after_seq, std::chrono::milliseconds timeout) const;
  const LiveOptions& options() const { return options_; }

 private:
  struct Frame {
    cv::Mat image;
    std::optional<TagOutline> corners;
    int64_t seq = 0;
  };
  struct Warning {
    std::string key, text;
  };
  void AddTrajectoryPoint(double x_mm, double y_mm);

  const LiveOptions options_;
  mutable std::mutex mutex_;
  mutable std::condition_variable frame_arrived_;
  std::shared_ptr<const Frame> frame_;
  double frame_t_s_ = 0.0;
  std::chrono::steady_clock::time_point frame_wall_;
  double fps_ = 0.0;  // producer's frame rate (wall clock, smoothed)
  std::string source_;
  int frames_without_tag_ = 0;
  bool tag_ever_seen_ = false;
  std::optional<double> side_px_, sharpness_;
  std::deque<double> sharpness_history_;
  std::optional<double> sharpness_reference_;
  std::optional<LivePose> pose_;
  double pose_t_s_ = 0.0;
  std::vector<cv::Point2d> trajectory_mm_;
  double trajectory_step_now_mm_ = 0.0;  // doubles each time the trajectory is thinned
  struct Progress {
    int run_index = 0, run_total = 0;
    std::string run_label, plan_label;
  };
  std::optional<Progress> progress_;
  std::vector<LiveEstimate> estimates_;
  std::vector<Warning> producer_warnings_;

  // The JPEG cache: one encoding per frame, whoever asks first.
  mutable std::mutex jpeg_mutex_;
  mutable std::optional<LiveJpeg> jpeg_;
};

// Sharpness of the tag's pixels as the blur rule above defines it; nullopt
// when the box is (nearly) outside the image or has no contrast.
std::optional<double> TagSharpness(const cv::Mat& grey, const TagOutline& corners_px);

}  // namespace odocal::live

#endif  // ODOCAL_LIVE_LIVE_STATE_H_
