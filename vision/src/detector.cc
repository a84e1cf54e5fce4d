#include "odocal/vision/detector.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include <apriltag/common/homography.h>

#include "apriltag_util.h"

namespace odocal::vision {
namespace {

// Bilinear grey level at OpenCV pixel (x, y); nullopt outside the image.
std::optional<double> Sample(const cv::Mat& grey, double x, double y) {
  const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
  if (x0 < 0 || y0 < 0 || x0 + 1 >= grey.cols || y0 + 1 >= grey.rows) return std::nullopt;
  const double fx = x - x0, fy = y - y0;
  const auto at = [&](int r, int c) { return static_cast<double>(grey.at<uint8_t>(r, c)); };
  return (1 - fy) * ((1 - fx) * at(y0, x0) + fx * at(y0, x0 + 1)) +
         fy * ((1 - fx) * at(y0 + 1, x0) + fx * at(y0 + 1, x0 + 1));
}

// The border's width, checked where libapriltag does not look: the fraction
// of the cells of ring 1 (the ring just inside the outer black ring, in the
// family's own grid of `width` cells across the black square) that are dark,
// dark meaning below the midpoint of the outer black ring (ring 0) and the
// white quiet zone (ring -1). A 2-bit border makes ring 1 black all round;
// with a 1-bit border ring 1 is the outer data ring, and no code of
// tag36h11, tag25h9 or tag16h5 has fewer than 4 light bits there (at most
// 80 % dark). `H` maps tag coordinates ([-1, 1] at the black corners) to
// the window's pixels in libapriltag's convention.
std::optional<double> RingOneDarkFraction(const cv::Mat& window, const matd_t* H, int width) {
  const auto ring = [&](int r, std::vector<double>* out) {
    for (int i = r; i <= width - 1 - r; ++i) {
      const int cells[4][2] = {{i, r}, {i, width - 1 - r}, {r, i}, {width - 1 - r, i}};
      for (int k = 0; k < 4; ++k) {
        if ((k >= 2) && (i == r || i == width - 1 - r)) continue;  // corners once
        double px = 0, py = 0;
        homography_project(H, 2.0 * (cells[k][0] + 0.5) / width - 1.0, 2.0 * (cells[k][1] + 0.5) / width - 1.0,
                           &px, &py);
        const auto v = Sample(window, px + kApriltagToOpenCvPx, py + kApriltagToOpenCvPx);
        if (!v) return false;
        out->push_back(*v);
      }
    }
    return true;
  };
  std::vector<double> white, black, inner;
  if (!ring(-1, &white) || !ring(0, &black) || !ring(1, &inner)) return std::nullopt;
  std::sort(white.begin(), white.end());
  std::sort(black.begin(), black.end());
  const double threshold = 0.5 * (white[white.size() / 2] + black[black.size() / 2]);
  if (!(white[white.size() / 2] > black[black.size() / 2])) return std::nullopt;
  int dark = 0;
  for (double v : inner) dark += v < threshold;
  return static_cast<double>(dark) / inner.size();
}

// Ring 1 at least this dark: a 2-bit border. Between the 81 % a 1-bit
// tag36h11 can reach there (read on either grid) and the 100 % of a 2-bit
// border, with room for a few cells blurred by a tiny tag or JPEG.
constexpr double kTwoBitRingDark = 0.85;

// Families whose border width the wrapper checks: the classic ones and
// their 2-bit variants (apriltag_util.cc).
std::optional<bool> ExpectsTwoBitBorder(const std::string& family) {
  for (const char* base : {"tag36h11", "tag25h9", "tag16h5"}) {
    if (family == base) return false;
    if (family == std::string(base) + "b2") return true;
  }
  return std::nullopt;
}

}  // namespace

bool DetectorOptions::IsValid(std::string* why) const {
  auto fail = [&](const std::string& msg) {
    if (why) *why = msg;
    return false;
  };
  if (!internal::CreateFamily(family)) return fail("unknown tag family '" + family + "'");
  if (!(quad_decimate >= 1.0f)) return fail("quad_decimate must be >= 1");
  if (!(quad_sigma >= 0.0f)) return fail("quad_sigma must be >= 0");
  if (!(decode_sharpening >= 0.0)) return fail("decode_sharpening must be >= 0");
  if (nthreads < 1) return fail("nthreads must be >= 1");
  if (max_hamming < 0 || max_hamming > 3) return fail("max_hamming must be in [0, 3]");
  return true;
}

bool TrackerOptions::IsValid(std::string* why) const {
  if (!(roi_margin_sides >= 0.0) || roi_min_margin_px < 0) {
    if (why) *why = "tracker ROI margins must be >= 0";
    return false;
  }
  if (!(small_tag_px >= 0.0) || full_resolution_every < 0) {
    if (why) *why = "tracker small_tag_px and full_resolution_every must be >= 0";
    return false;
  }
  return true;
}

const char* ToString(DetectStatus status) {
  switch (status) {
    case DetectStatus::kOk: return "ok";
    case DetectStatus::kNotFound: return "not found";
    case DetectStatus::kWrongId: return "wrong id";
    case DetectStatus::kDuplicateId: return "duplicate id";
    case DetectStatus::kBadInput: return "bad input";
  }
  return "?";
}

struct TagDetector::Impl {
  DetectorOptions options;
  internal::FamilyPtr family;
  internal::DetectorPtr detector;
};

TagDetector::TagDetector(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
TagDetector::~TagDetector() {
  // The detector references the family: destroy it first.
  if (impl_) impl_->detector.reset();
}

TagDetectorResult TagDetector::Create(const DetectorOptions& options) {
  TagDetectorResult result;
  std::string why;
  if (!options.IsValid(&why)) {
    result.status = StatusCode::kInvalidArgument;
    result.message = why;
    return result;
  }
  auto impl = std::make_unique<Impl>();
  impl->options = options;
  impl->family = internal::CreateFamily(options.family);
  impl->detector.reset(apriltag_detector_create());
  apriltag_detector_t* td = impl->detector.get();
  apriltag_detector_add_family_bits(td, impl->family.get(), options.max_hamming);
  td->quad_decimate = options.quad_decimate;
  td->quad_sigma = options.quad_sigma;
  td->refine_edges = options.refine_edges;
  td->decode_sharpening = options.decode_sharpening;
  td->nthreads = options.nthreads;
  td->debug = false;
  result.detector.reset(new TagDetector(std::move(impl)));
  result.status = StatusCode::kOk;
  return result;
}

const DetectorOptions& TagDetector::options() const { return impl_->options; }

DetectResult TagDetector::Detect(const cv::Mat& grey, const std::optional<cv::Rect>& roi,
                                 std::optional<float> quad_decimate) {
  DetectResult result;
  if (grey.empty() || grey.type() != CV_8UC1) {
    result.status = DetectStatus::kBadInput;
    result.message = "detector needs a non-empty 8-bit grey image";
    return result;
  }
  cv::Rect window(0, 0, grey.cols, grey.rows);
  if (roi) {
    // Snap the window's origin to the decimation grid: libapriltag decimates
    // from the window's first pixel, so an origin of another parity sees a
    // different decimated image, and window and full-frame detections would
    // differ by a few hundredths of a pixel.
    const float decimate = quad_decimate.value_or(impl_->options.quad_decimate);
    const int step = std::max(1, static_cast<int>(std::lround(decimate)));
    cv::Rect snapped = *roi;
    const int dx = ((snapped.x % step) + step) % step, dy = ((snapped.y % step) + step) % step;
    snapped.x -= dx;
    snapped.y -= dy;
    snapped.width += dx;
    snapped.height += dy;
    window = snapped & window;
    if (window.width < 8 || window.height < 8) {
      result.status = DetectStatus::kBadInput;
      result.message = "region of interest lies (almost) outside the image";
      return result;
    }
  }
  // libapriltag reads the pixels in place (it copies before blurring or
  // decimating), so a view into the caller's image is enough.
  const cv::Mat view = grey(window);
  image_u8_t im{view.cols, view.rows, static_cast<int32_t>(view.step[0]),
                const_cast<uint8_t*>(view.ptr<uint8_t>(0))};
  // The detector is this object's alone (one per tracked video): its
  // decimation may be set for one call and put back.
  impl_->detector->quad_decimate = quad_decimate.value_or(impl_->options.quad_decimate);
  internal::DetectionsPtr detections(apriltag_detector_detect(impl_->detector.get(), &im));
  impl_->detector->quad_decimate = impl_->options.quad_decimate;
  const double dx = window.x + kApriltagToOpenCvPx;
  const double dy = window.y + kApriltagToOpenCvPx;
  const std::optional<bool> two_bit = ExpectsTwoBitBorder(impl_->options.family);
  for (int i = 0; i < zarray_size(detections.get()); ++i) {
    apriltag_detection_t* det = nullptr;
    zarray_get(detections.get(), i, &det);
    TagDetection d;
    d.id = det->id;
    d.hamming = det->hamming;
    d.decision_margin = det->decision_margin;
    for (int k = 0; k < 4; ++k) d.corners_px[k] = cv::Point2d(det->p[k][0] + dx, det->p[k][1] + dy);
    d.center_px = cv::Point2d(det->c[0] + dx, det->c[1] + dy);
    if (two_bit) {
      const auto dark = RingOneDarkFraction(view, det->H, impl_->family->width_at_border);
      if (dark && (*dark >= kTwoBitRingDark) != *two_bit) {
        std::ostringstream why;
        why << "id " << d.id << " decoded, but its black border is " << (*two_bit ? "1 bit" : "2 bits")
            << " wide, not " << (*two_bit ? "2" : "1") << " (" << static_cast<int>(std::lround(100 * *dark))
            << " % of the ring inside the border is dark): "
            << (*two_bit ? "an AprilTag 3 tag? use the family without b2" : "a Kalibr tag? use " +
                                                                                 impl_->options.family + "b2");
        result.refused.push_back({d, why.str()});
        continue;
      }
    }
    result.detections.push_back(d);
  }
  if (result.detections.empty()) {
    result.status = DetectStatus::kNotFound;
    result.message = "no " + impl_->options.family + " tag found";
    if (!result.refused.empty()) result.message += "; refused " + result.refused.front().reason;
  } else {
    result.status = DetectStatus::kOk;
  }
  return result;
}

FindResult TagDetector::Find(const cv::Mat& grey, int id, const std::optional<cv::Rect>& roi,
                             std::optional<float> quad_decimate) {
  FindResult result;
  DetectResult all = Detect(grey, roi, quad_decimate);
  result.status = all.status;
  result.message = all.message;
  if (all.status != DetectStatus::kOk) return result;
  std::vector<TagDetection> hits;
  std::ostringstream others;
  for (const auto& d : all.detections) {
    if (d.id == id) {
      hits.push_back(d);
    } else {
      others << (others.tellp() > 0 ? ", " : "") << d.id;
    }
  }
  if (hits.empty()) {
    result.status = DetectStatus::kWrongId;
    result.message = "tag " + std::to_string(id) + " not found; saw " + impl_->options.family +
                     " id(s) " + others.str();
  } else if (hits.size() > 1) {
    result.status = DetectStatus::kDuplicateId;
    result.message = "tag " + std::to_string(id) + " seen " + std::to_string(hits.size()) +
                     " times in one frame: ambiguous";
  } else {
    result.status = DetectStatus::kOk;
    result.message.clear();
    result.detection = hits.front();
  }
  return result;
}

// ---------------------------------------------------------------------------

TagTracker::TagTracker(TagDetector* detector, int id, const TrackerOptions& options)
    : detector_(detector), id_(id), options_(options) {}

void TagTracker::Reset() {
  last_.reset();
  before_last_.reset();
  last_small_ = false;
}

std::optional<cv::Rect> TagTracker::PredictRoi(cv::Size image_size) const {
  if (!last_) return std::nullopt;
  std::array<cv::Point2d, 4> predicted = *last_;
  if (before_last_) {
    for (int k = 0; k < 4; ++k) predicted[k] += (*last_)[k] - (*before_last_)[k];
  }
  double x0 = 1e18, y0 = 1e18, x1 = -1e18, y1 = -1e18;
  for (const auto& p : predicted) {
    x0 = std::min(x0, p.x);
    y0 = std::min(y0, p.y);
    x1 = std::max(x1, p.x);
    y1 = std::max(y1, p.y);
  }
  const double side = cv::norm(predicted[0] - predicted[1]);
  const double margin = std::max<double>(options_.roi_min_margin_px, options_.roi_margin_sides * side);
  const cv::Rect roi(static_cast<int>(std::floor(x0 - margin)), static_cast<int>(std::floor(y0 - margin)),
                     static_cast<int>(std::ceil(x1 - x0 + 2 * margin)),
                     static_cast<int>(std::ceil(y1 - y0 + 2 * margin)));
  const cv::Rect clipped = roi & cv::Rect(0, 0, image_size.width, image_size.height);
  if (clipped.width < 8 || clipped.height < 8) return std::nullopt;
  return clipped;
}

TrackResult TagTracker::Track(const cv::Mat& grey) {
  TrackResult result;
  if (grey.empty()) {
    result.find.status = DetectStatus::kBadInput;
    result.find.message = "empty frame";
    return result;
  }
  const std::optional<float> full_resolution = 1.0f;
  bool at_full_resolution = false;
  if (const auto roi = PredictRoi(grey.size())) {
    result.used_roi = true;
    result.roi = *roi;
    at_full_resolution = last_small_;
    result.find = detector_->Find(grey, id_, roi, last_small_ ? full_resolution : std::nullopt);
  }
  if (!result.used_roi || result.find.status != DetectStatus::kOk) {
    // Acquire or reacquire on the whole frame; now and then at full
    // resolution when the decimated search misses (a small tag).
    result.used_roi = false;
    result.roi = cv::Rect(0, 0, grey.cols, grey.rows);
    at_full_resolution = false;
    result.find = detector_->Find(grey, id_);
    // Only while the tag has not been seen yet, or was small when it was
    // lost: a tag the decimated search found before is found by it again,
    // and a whole frame at full resolution costs 5-10 times as much (a
    // noisy 1080p frame: 412 ms against 34, docs/performance.md).
    const bool may_be_small = !ever_found_ || lost_small_;
    if (result.find.status == DetectStatus::kNotFound && may_be_small && options_.full_resolution_every > 0 &&
        detector_->options().quad_decimate > 1.0f && whole_frame_misses_++ % options_.full_resolution_every == 0) {
      at_full_resolution = true;
      result.find = detector_->Find(grey, id_, std::nullopt, full_resolution);
    }
  }
  if (result.find.status == DetectStatus::kOk) {
    before_last_ = last_;
    last_ = result.find.detection->corners_px;
    const auto& c = *last_;
    double shorter = 1e18;
    for (int k = 0; k < 4; ++k) shorter = std::min(shorter, cv::norm(c[k] - c[(k + 1) % 4]));
    // With some hysteresis: the decimated and the full-resolution searches
    // place a small tag's corners a few tenths of a pixel apart, and a tag
    // near the threshold must not alternate between them from frame to frame.
    last_small_ = shorter < options_.small_tag_px * (at_full_resolution ? 1.5 : 1.0);
    whole_frame_misses_ = 0;
    ever_found_ = true;
    lost_small_ = false;
  } else {
    lost_small_ = lost_small_ || last_small_;
    Reset();
  }
  return result;
}

}  // namespace odocal::vision
