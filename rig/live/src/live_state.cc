#include "odocal/live/live_state.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstdio>

#include <opencv2/imgproc.hpp>

#include "odocal/base/format.h"
#include "odocal/media/image_file.h"
#include "odocal/vision/corner_refine.h"

namespace odocal::live {
namespace {

using Clock = std::chrono::steady_clock;

double MeanSide(const TagOutline& c) {
  double sum = 0.0;
  for (int i = 0; i < 4; ++i) sum += cv::norm(c[(i + 1) % 4] - c[i]);
  return sum / 4.0;
}

// Rounded for the page: 0.1 of a unit is below anything it draws or prints
// and keeps the trajectory's JSON small.
double Round1(double v) { return std::round(v * 10.0) / 10.0; }

// OpenCV's pixel convention (centres at integers) through a scaling of the
// image by `s`: pixel edges scale, centres move by half a pixel.
cv::Point2d Scaled(const cv::Point2d& p, double s) { return {(p.x + 0.5) * s - 0.5, (p.y + 0.5) * s - 0.5}; }

// What the page says about the tag, as the state holds it (read under its lock).
struct TagStatus {
  bool framed = false;                // a frame has arrived
  std::optional<TagOutline> corners;  // in the latest frame, when the tag was found there
  int frames_without_tag = 0;
  bool ever_seen = false;
  std::optional<double> side_px, sharpness, sharpness_reference;
};

// state.json's "tag": seen or not, its corners, size and sharpness.
nlohmann::json TagJson(const TagStatus& t) {
  using nlohmann::json;
  const bool seen = t.corners.has_value();
  json tag = {{"seen", seen}, {"frames_since_seen", t.frames_without_tag}};
  if (seen) {
    json corners = json::array();
    for (const cv::Point2d& c : *t.corners) corners.push_back({c.x, c.y});
    tag["corners_px"] = corners;
  } else {
    tag["corners_px"] = nullptr;
  }
  tag["side_px"] = seen && t.side_px ? json(Round1(*t.side_px)) : json(nullptr);
  tag["sharpness"] = seen && t.sharpness ? json(*t.sharpness) : json(nullptr);
  tag["sharpness_reference"] = t.sharpness_reference ? json(*t.sharpness_reference) : json(nullptr);
  return tag;
}

// The warnings the tag's state raises: lost (or never found), too small, blurred.
nlohmann::json TagWarnings(const TagStatus& t, const LiveOptions& options) {
  using nlohmann::json;
  const bool seen = t.corners.has_value();
  json warnings = json::array();
  auto warn = [&](const char* key, const std::string& text) { warnings.push_back({{"key", key}, {"text", text}}); };
  if (t.framed && t.frames_without_tag >= options.lost_after_frames) {
    warn("tag_lost", t.ever_seen
                         ? Format("tag lost: not in the last %d frames (out of view, covered, or too blurred)",
                                  t.frames_without_tag)
                         : Format("tag not found in %d frames: is it in view, lit, and the family and id given?",
                                  t.frames_without_tag));
  }
  if (seen && t.side_px && *t.side_px < options.min_side_px) {
    warn("too_small", Format("tag too small: %.0f px across, under %.0f px its corners cannot be refined (hang the "
                             "camera lower or print the tag larger)",
                             *t.side_px, options.min_side_px));
  }
  if (seen && t.sharpness && t.sharpness_reference && *t.sharpness < options.blur_ratio * *t.sharpness_reference) {
    warn("blur", Format("image blurred: the tag is %.0f %% as sharp as this session's sharp frames (motion blur: a "
                        "shorter exposure or a slower robot; or the focus)",
                        100.0 * *t.sharpness / *t.sharpness_reference));
  }
  return warnings;
}

}  // namespace

double DefaultMinSidePx() {
  const vision::CornerRefineOptions refine;
  return refine.min_cell_px * refine.width_at_border;
}

bool LiveOptions::IsValid(std::string* why) const {
  auto fail = [&](const std::string& w) {
    if (why) *why = w;
    return false;
  };
  if (lost_after_frames < 1) return fail("lost_after_frames must be at least 1");
  if (!(min_side_px >= 0.0)) return fail("min_side_px must be >= 0");
  if (!(blur_ratio >= 0.0 && blur_ratio < 1.0)) return fail("blur_ratio must be in [0, 1)");
  if (blur_reference_frames < 1) return fail("blur_reference_frames must be at least 1");
  if (blur_min_frames < 1) return fail("blur_min_frames must be at least 1");
  if (!(trajectory_step_mm >= 0.0)) return fail("trajectory_step_mm must be >= 0");
  if (max_trajectory_points < 4) return fail("max_trajectory_points must be at least 4");
  if (image_max_width_px < 16) return fail("image_max_width_px must be at least 16");
  if (jpeg_quality < 1 || jpeg_quality > 100) return fail("jpeg_quality must be in 1..100");
  return true;
}

std::optional<double> TagSharpness(const cv::Mat& image, const TagOutline& corners_px) {
  if (image.empty()) return std::nullopt;
  std::vector<cv::Point2f> pts;
  for (const cv::Point2d& p : corners_px) pts.emplace_back(static_cast<float>(p.x), static_cast<float>(p.y));
  const cv::Rect box = cv::boundingRect(pts);
  // One cell of margin (side / 8 for tag36h11): the outer edge and its quiet zone.
  const int margin = std::max(2, static_cast<int>(std::lround(MeanSide(corners_px) / 8.0)));
  const cv::Rect grown(box.x - margin, box.y - margin, box.width + 2 * margin, box.height + 2 * margin);
  const cv::Rect roi = grown & cv::Rect(0, 0, image.cols, image.rows);
  if (roi.width < 8 || roi.height < 8 || roi.area() < grown.area() / 2) return std::nullopt;
  cv::Mat grey;
  if (image.channels() == 1) {
    grey = image(roi);
  } else {
    cv::cvtColor(image(roi), grey, cv::COLOR_BGR2GRAY);
  }
  int histogram[256] = {0};
  for (int r = 0; r < grey.rows; ++r) {
    const unsigned char* row = grey.ptr<unsigned char>(r);
    for (int c = 0; c < grey.cols; ++c) ++histogram[row[c]];
  }
  const long n = static_cast<long>(grey.total());
  auto percentile = [&](double q) {
    long seen = 0;
    for (int v = 0; v < 256; ++v) {
      seen += histogram[v];
      if (seen > q * n) return v;
    }
    return 255;
  };
  const int contrast = percentile(0.95) - percentile(0.05);
  if (contrast < 10) return std::nullopt;
  cv::Mat laplacian;
  cv::Laplacian(grey, laplacian, CV_32F, 1);
  cv::Scalar mean, sd;
  cv::meanStdDev(laplacian, mean, sd);
  return sd[0] * sd[0] / (static_cast<double>(contrast) * contrast);
}

LiveState::LiveState(const LiveOptions& options) : options_(options) {
  [[maybe_unused]] std::string why;
  assert(options_.IsValid(&why) && "LiveOptions");
  trajectory_step_now_mm_ = options_.trajectory_step_mm;
}

void LiveState::OnFrame(const cv::Mat& image, double t_s, const std::optional<TagOutline>& tag_corners_px,
                        const std::optional<LivePose>& pose_world) {
  assert(!image.empty() && image.depth() == CV_8U && (image.channels() == 1 || image.channels() == 3));
  auto frame = std::make_shared<Frame>();
  frame->image = image.clone();
  frame->corners = tag_corners_px;
  // The tag's statistics outside the lock: the server never waits for them.
  std::optional<double> side, sharpness;
  if (tag_corners_px) {
    side = MeanSide(*tag_corners_px);
    sharpness = TagSharpness(image, *tag_corners_px);
  }
  const Clock::time_point now = Clock::now();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    frame->seq = (frame_ ? frame_->seq : 0) + 1;
    if (frame_) {
      const double dt = std::chrono::duration<double>(now - frame_wall_).count();
      if (dt > 0.0) {
        // Smoothed over about a second, whatever the rate.
        const double alpha = 1.0 - std::exp(-dt / 1.0);
        fps_ = fps_ > 0.0 ? fps_ + alpha * (1.0 / dt - fps_) : 1.0 / dt;
      }
    }
    frame_ = std::move(frame);
    frame_t_s_ = t_s;
    frame_wall_ = now;
    side_px_ = side;
    sharpness_ = sharpness;
    if (tag_corners_px) {
      frames_without_tag_ = 0;
      tag_ever_seen_ = true;
    } else {
      ++frames_without_tag_;
    }
    if (sharpness) {
      sharpness_history_.push_back(*sharpness);
      while (static_cast<int>(sharpness_history_.size()) > options_.blur_reference_frames)
        sharpness_history_.pop_front();
      if (static_cast<int>(sharpness_history_.size()) >= options_.blur_min_frames) {
        std::vector<double> v(sharpness_history_.begin(), sharpness_history_.end());
        const size_t k = std::min(v.size() - 1, static_cast<size_t>(0.9 * v.size()));
        std::nth_element(v.begin(), v.begin() + k, v.end());
        sharpness_reference_ = v[k];
      }
    }
    if (pose_world) {
      pose_ = pose_world;
      pose_t_s_ = t_s;
      AddTrajectoryPoint(pose_world->x_mm, pose_world->y_mm);
    }
  }
  frame_arrived_.notify_all();
}

void LiveState::AddTrajectoryPoint(double x_mm, double y_mm) {
  const cv::Point2d p(x_mm, y_mm);
  if (!trajectory_mm_.empty() && cv::norm(p - trajectory_mm_.back()) < trajectory_step_now_mm_) return;
  trajectory_mm_.push_back(p);
  if (static_cast<int>(trajectory_mm_.size()) <= options_.max_trajectory_points) return;
  // Every other point goes, the last one stays; new points then come at
  // twice the spacing, so the path keeps one density.
  std::vector<cv::Point2d> kept;
  kept.reserve(trajectory_mm_.size() / 2 + 1);
  for (size_t i = 0; i < trajectory_mm_.size(); i += 2) kept.push_back(trajectory_mm_[i]);
  if (trajectory_mm_.size() % 2 == 0) kept.push_back(trajectory_mm_.back());
  trajectory_mm_ = std::move(kept);
  trajectory_step_now_mm_ = std::max(2.0 * trajectory_step_now_mm_, 1.0);
}

void LiveState::SetProgress(int run_index, int run_total, const std::string& run_label,
                            const std::string& plan_label) {
  std::lock_guard<std::mutex> lock(mutex_);
  progress_ = Progress{run_index, run_total, run_label, plan_label};
}

void LiveState::SetEstimate(const std::string& name, double value, double sigma, const std::string& unit) {
  std::lock_guard<std::mutex> lock(mutex_);
  for (LiveEstimate& e : estimates_) {
    if (e.name == name) {
      e = {name, value, sigma, unit};
      return;
    }
  }
  estimates_.push_back({name, value, sigma, unit});
}

void LiveState::SetWarning(const std::string& key, const std::string& text) {
  std::lock_guard<std::mutex> lock(mutex_);
  for (Warning& w : producer_warnings_) {
    if (w.key == key) {
      w.text = text;
      return;
    }
  }
  producer_warnings_.push_back({key, text});
}

void LiveState::ClearWarning(const std::string& key) {
  std::lock_guard<std::mutex> lock(mutex_);
  std::erase_if(producer_warnings_, [&](const Warning& w) { return w.key == key; });
}

void LiveState::ClearTrajectory() {
  std::lock_guard<std::mutex> lock(mutex_);
  trajectory_mm_.clear();
  trajectory_step_now_mm_ = options_.trajectory_step_mm;
}

void LiveState::SetTrajectory(const std::vector<cv::Point2d>& points_mm) {
  std::lock_guard<std::mutex> lock(mutex_);
  trajectory_mm_.clear();
  trajectory_step_now_mm_ = options_.trajectory_step_mm;
  for (const cv::Point2d& p : points_mm) AddTrajectoryPoint(p.x, p.y);
}

void LiveState::SetSource(const std::string& label) {
  std::lock_guard<std::mutex> lock(mutex_);
  source_ = label;
}

nlohmann::json LiveState::StateJson() const {
  using nlohmann::json;
  std::lock_guard<std::mutex> lock(mutex_);
  json j;
  j["version"] = 1;
  j["source"] = source_;
  if (frame_) {
    const double scale = std::min(1.0, static_cast<double>(options_.image_max_width_px) / frame_->image.cols);
    j["frame"] = {{"seq", frame_->seq},
                  {"t_s", frame_t_s_},
                  {"width", frame_->image.cols},
                  {"height", frame_->image.rows},
                  {"jpeg_width", static_cast<int>(std::lround(frame_->image.cols * scale))},
                  {"jpeg_height", static_cast<int>(std::lround(frame_->image.rows * scale))},
                  {"fps", Round1(fps_)},
                  {"age_s", Round1(std::chrono::duration<double>(Clock::now() - frame_wall_).count())}};
  } else {
    j["frame"] = nullptr;
  }
  TagStatus t;
  t.framed = frame_ != nullptr;
  if (frame_) t.corners = frame_->corners;
  t.frames_without_tag = frames_without_tag_;
  t.ever_seen = tag_ever_seen_;
  t.side_px = side_px_;
  t.sharpness = sharpness_;
  t.sharpness_reference = sharpness_reference_;
  const bool seen = t.corners.has_value();
  j["tag"] = TagJson(t);
  if (pose_) {
    j["pose"] = {{"t_s", pose_t_s_},
                 {"current", seen && pose_t_s_ == frame_t_s_},
                 {"x_mm", pose_->x_mm},
                 {"y_mm", pose_->y_mm},
                 {"heading_deg", pose_->heading_deg},
                 {"sigma_x_mm", pose_->sigma_x_mm},
                 {"sigma_y_mm", pose_->sigma_y_mm},
                 {"sigma_heading_deg", pose_->sigma_heading_deg}};
  } else {
    j["pose"] = nullptr;
  }
  json trajectory = json::array();
  for (const cv::Point2d& p : trajectory_mm_) trajectory.push_back({Round1(p.x), Round1(p.y)});
  j["trajectory_mm"] = trajectory;
  if (progress_) {
    j["progress"] = {{"run_index", progress_->run_index},
                     {"run_total", progress_->run_total},
                     {"run_label", progress_->run_label},
                     {"plan_label", progress_->plan_label}};
  } else {
    j["progress"] = nullptr;
  }
  json estimates = json::array();
  for (const LiveEstimate& e : estimates_)
    estimates.push_back({{"name", e.name}, {"value", e.value}, {"sigma", e.sigma}, {"unit", e.unit}});
  j["estimates"] = estimates;

  json warnings = TagWarnings(t, options_);
  for (const Warning& w : producer_warnings_) warnings.push_back({{"key", w.key}, {"text", w.text}});
  j["warnings"] = warnings;
  return j;
}

std::optional<LiveJpeg> LiveState::FrameJpeg() const {
  std::shared_ptr<const Frame> frame;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    frame = frame_;
  }
  if (!frame) return std::nullopt;
  std::lock_guard<std::mutex> lock(jpeg_mutex_);
  if (jpeg_ && jpeg_->seq >= frame->seq) return jpeg_;
  const double scale = std::min(1.0, static_cast<double>(options_.image_max_width_px) / frame->image.cols);
  cv::Mat shown;
  if (scale < 1.0) {
    cv::resize(frame->image, shown, cv::Size(static_cast<int>(std::lround(frame->image.cols * scale)),
                                             static_cast<int>(std::lround(frame->image.rows * scale))),
               0, 0, cv::INTER_AREA);
  } else {
    shown = frame->image;
  }
  cv::Mat bgr;
  if (shown.channels() == 1) {
    cv::cvtColor(shown, bgr, cv::COLOR_GRAY2BGR);
  } else {
    bgr = shown.clone();
  }
  if (frame->corners) {
    // Drawn with 4 fractional bits: the outline sits where the corners are.
    constexpr int kShift = 4;
    std::vector<cv::Point> outline;
    for (const cv::Point2d& c : *frame->corners) {
      const cv::Point2d p = Scaled(c, scale);
      outline.emplace_back(static_cast<int>(std::lround(p.x * (1 << kShift))),
                           static_cast<int>(std::lround(p.y * (1 << kShift))));
    }
    const int thickness = std::max(2, static_cast<int>(std::lround(bgr.cols / 320.0)));
    cv::polylines(bgr, std::vector<std::vector<cv::Point>>{outline}, true, kOutlineBgr, thickness, cv::LINE_AA,
                  kShift);
    // The first corner (the printed bitmap's bottom left) shows which way the tag is turned.
    cv::circle(bgr, outline[0], (2 * thickness) << kShift, kOutlineBgr, cv::FILLED, cv::LINE_AA, kShift);
  }
  // The codecs not loaded: an empty picture, which the page shows as none.
  std::vector<unsigned char> bytes =
      media::EncodeJpeg(bgr, options_.jpeg_quality).value.value_or(std::vector<unsigned char>());
  jpeg_ = LiveJpeg{std::make_shared<const std::vector<unsigned char>>(std::move(bytes)), frame->seq, bgr.cols,
                   bgr.rows};
  return jpeg_;
}

int64_t LiveState::frame_seq() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return frame_ ? frame_->seq : 0;
}

bool LiveState::WaitForFrame(int64_t after_seq, std::chrono::milliseconds timeout) const {
  std::unique_lock<std::mutex> lock(mutex_);
  return frame_arrived_.wait_for(lock, timeout, [&] { return frame_ && frame_->seq > after_seq; });
}

}  // namespace odocal::live
