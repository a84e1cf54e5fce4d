// TagDetector: libapriltag behind an odocal interface, with its pixel
// convention converted once, here, to OpenCV's (pixel centres at integers).
// TagTracker: region-of-interest detection around the predicted tag, with a
// full-frame search only to (re)acquire.
//
// Pixels: every corner this header returns is in OpenCV's convention, with
// lens distortion still in it (undistort with CameraModel). Corner order is
// libapriltag's (p[0..3]), which matches TagCornersInTag() in tag.h.
// One TagDetector must not be used from two threads at once (libapriltag's
// detector owns a worker pool and scratch state); make one per thread.
#ifndef ODOCAL_VISION_DETECTOR_H_
#define ODOCAL_VISION_DETECTOR_H_

#include <array>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "odocal/base/status.h"

namespace odocal::vision {

// libapriltag reports corners with the top-left corner of the top-left pixel
// at (0, 0), i.e. a pixel centre at (u + 0.5, v + 0.5). Add this to get
// OpenCV's convention. Measured on rendered frames: after adding it the mean
// corner error is below 0.01 px (it would be +0.5 px without), at
// quad_decimate 1 and 2 alike as long as refine_edges is on (docs/vision.md,
// tests/vision/detector_test.cc). With decimation and refine_edges off the
// library's own up-scaling leaves a further ~-0.1 px bias: keep it on.
inline constexpr double kApriltagToOpenCvPx = -0.5;

struct DetectorOptions {
  std::string family = "tag36h11";
  // Defaults chosen by measurement (docs/performance.md, standard condition):
  // decimate 2 is 4x faster than 1 in a tracking window and 10x on a full
  // frame, finds every tag, and its corners are no worse (0.060 vs 0.071 px
  // rms); RefineTagCorners then brings either to 0.02 px. quad_sigma blurs
  // away no useful noise after decimation; refine_edges halves the corner
  // error for free; decode_sharpening does not matter here (kept at the
  // library default).
  float quad_decimate = 2.0f;
  float quad_sigma = 0.0f;
  bool refine_edges = true;
  double decode_sharpening = 0.25;
  int nthreads = 1;
  // Bit errors corrected when decoding (libapriltag default 2). More costs
  // memory and raises the false-positive rate.
  int max_hamming = 1;

  bool IsValid(std::string* why) const;
};

struct TagDetection {
  int id = -1;
  int hamming = 0;
  double decision_margin = 0.0;
  std::array<cv::Point2d, 4> corners_px{};  // OpenCV convention
  cv::Point2d center_px;                    // OpenCV convention
};

enum class DetectStatus {
  kOk,            // at least one tag found (or, for Find, exactly the wanted one)
  kNotFound,      // no tag of the family
  kWrongId,       // tags seen, but not the wanted id
  kDuplicateId,   // the wanted id seen more than once: ambiguous, not used
  kBadInput,      // empty or non-8-bit image, ROI outside the image
};

const char* ToString(DetectStatus status);

// A tag libapriltag decoded but the wrapper refused: its black border is not
// the family's width (a Kalibr 2-bit tag decoded with tag36h11's 1-bit layout
// or the reverse; libapriltag checks only the outermost ring).
struct RefusedDetection {
  TagDetection detection;
  std::string reason;
};

struct DetectResult {
  DetectStatus status = DetectStatus::kNotFound;
  std::string message;
  std::vector<TagDetection> detections;
  std::vector<RefusedDetection> refused;
};

struct FindResult {
  DetectStatus status = DetectStatus::kNotFound;
  std::string message;
  std::optional<TagDetection> detection;  // set only when status == kOk
};

class TagDetector;
struct TagDetectorResult {
  StatusCode status = StatusCode::kFailed;
  bool ok() const { return status == StatusCode::kOk; }
  std::string message;
  std::unique_ptr<TagDetector> detector;
};

class TagDetector {
 public:
  static TagDetectorResult Create(const DetectorOptions& options);
  ~TagDetector();
  TagDetector(const TagDetector&) = delete;
  TagDetector& operator=(const TagDetector&) = delete;

  // All tags of the family in `grey` (CV_8UC1), or inside `roi` of it; the
  // corners come back in full-image coordinates either way. `quad_decimate`,
  // when given, replaces the options' for this call only.
  DetectResult Detect(const cv::Mat& grey, const std::optional<cv::Rect>& roi = std::nullopt,
                      std::optional<float> quad_decimate = std::nullopt);
  // Exactly tag `id`: kWrongId / kDuplicateId say why not.
  FindResult Find(const cv::Mat& grey, int id, const std::optional<cv::Rect>& roi = std::nullopt,
                  std::optional<float> quad_decimate = std::nullopt);

  const DetectorOptions& options() const;

 private:
  struct Impl;
  explicit TagDetector(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

struct TrackerOptions {
  // The ROI is the predicted tag's bounding box grown by this many tag sides
  // on each side (covers the motion between frames and the prediction error).
  double roi_margin_sides = 1.0;
  // ... and by at least this many pixels.
  int roi_min_margin_px = 16;
  // Small tags are looked for at full resolution (quad_decimate 1): a tag
  // whose shorter side was under `small_tag_px` in the last frame (in its
  // window), and, before the tag is first found or while it is lost after
  // being small, every `full_resolution_every`-th whole-frame search that the
  // decimated one missed (a whole frame costs 5-10 times as much at full
  // resolution, so not for a tag lost while large). At decimate 2 a tag's
  // cells under ~2 px fall apart in libapriltag's quad finder: an 80 mm tag
  // 1.3-1.5 m off the axis of a fisheye 1.05 m above it is 14-18 px across
  // the view's radius, found in the full image and not in the decimated one
  // (FisheyeLens.ASmallTagAtTheRimIsFoundAtFullResolutionAndMeasured).
  double small_tag_px = 32.0;
  int full_resolution_every = 4;  // 0: never

  bool IsValid(std::string* why) const;
};

struct TrackResult {
  FindResult find;
  bool used_roi = false;   // false: a full-frame search (acquiring or reacquiring)
  cv::Rect roi;            // the window searched (the whole image when !used_roi)
};

// Follows one tag through a video: detects in a window around the position
// predicted from the last two detections (constant velocity), and searches
// the whole frame only when there is no prediction or the window misses.
class TagTracker {
 public:
  TagTracker(TagDetector* detector, int id, const TrackerOptions& options = {});
  TrackResult Track(const cv::Mat& grey);
  // Forget the track (next Track() searches the whole frame).
  void Reset();

 private:
  std::optional<cv::Rect> PredictRoi(cv::Size image_size) const;
  TagDetector* detector_;
  int id_;
  TrackerOptions options_;
  std::optional<std::array<cv::Point2d, 4>> last_, before_last_;
  bool last_small_ = false;    // the last detection's shorter side under small_tag_px
  bool ever_found_ = false;    // the tag was found in some frame since the tracker was made
  bool lost_small_ = false;    // the tag is lost, and was small when it was
  int whole_frame_misses_ = 0;  // full-resolution-eligible whole-frame misses since the last detection
};

}  // namespace odocal::vision

#endif  // ODOCAL_VISION_DETECTOR_H_
