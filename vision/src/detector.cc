#include "odocal/vision/detector.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "apriltag_util.h"

namespace odocal::vision {

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
  result.ok = true;
  return result;
}

const DetectorOptions& TagDetector::options() const { return impl_->options; }

DetectResult TagDetector::Detect(const cv::Mat& grey, const std::optional<cv::Rect>& roi) {
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
    const int step = std::max(1, static_cast<int>(std::lround(impl_->options.quad_decimate)));
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
  internal::DetectionsPtr detections(apriltag_detector_detect(impl_->detector.get(), &im));
  const double dx = window.x + kApriltagToOpenCvPx;
  const double dy = window.y + kApriltagToOpenCvPx;
  for (int i = 0; i < zarray_size(detections.get()); ++i) {
    apriltag_detection_t* det = nullptr;
    zarray_get(detections.get(), i, &det);
    TagDetection d;
    d.id = det->id;
    d.hamming = det->hamming;
    d.decision_margin = det->decision_margin;
    for (int k = 0; k < 4; ++k) d.corners_px[k] = cv::Point2d(det->p[k][0] + dx, det->p[k][1] + dy);
    d.center_px = cv::Point2d(det->c[0] + dx, det->c[1] + dy);
    result.detections.push_back(d);
  }
  if (result.detections.empty()) {
    result.status = DetectStatus::kNotFound;
    result.message = "no " + impl_->options.family + " tag found";
  } else {
    result.status = DetectStatus::kOk;
  }
  return result;
}

FindResult TagDetector::Find(const cv::Mat& grey, int id, const std::optional<cv::Rect>& roi) {
  FindResult result;
  DetectResult all = Detect(grey, roi);
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
  if (const auto roi = PredictRoi(grey.size())) {
    result.used_roi = true;
    result.roi = *roi;
    result.find = detector_->Find(grey, id_, roi);
  }
  if (!result.used_roi || result.find.status != DetectStatus::kOk) {
    // Acquire or reacquire on the whole frame.
    result.used_roi = false;
    result.roi = cv::Rect(0, 0, grey.cols, grey.rows);
    result.find = detector_->Find(grey, id_);
  }
  if (result.find.status == DetectStatus::kOk) {
    before_last_ = last_;
    last_ = result.find.detection->corners_px;
  } else {
    Reset();
  }
  return result;
}

}  // namespace odocal::vision
