#include "odocal/vision/video_track.h"

#include <chrono>
#include <condition_variable>
#include <deque>
#include <fstream>
#include <mutex>
#include <sstream>
#include <thread>

#include <opencv2/imgproc.hpp>

#include "odocal/vision/video.h"

namespace odocal::vision {
namespace {

using Clock = std::chrono::steady_clock;

double Seconds(Clock::duration d) { return std::chrono::duration<double>(d).count(); }

// A bounded queue between the decoder thread and the tracker.
class FrameQueue {
 public:
  explicit FrameQueue(size_t capacity) : capacity_(capacity) {}
  void Push(cv::Mat frame) {
    std::unique_lock<std::mutex> lock(mutex_);
    not_full_.wait(lock, [&] { return frames_.size() < capacity_; });
    frames_.push_back(std::move(frame));
    not_empty_.notify_one();
  }
  void Finish() {
    std::lock_guard<std::mutex> lock(mutex_);
    finished_ = true;
    not_empty_.notify_all();
  }
  // False when the decoder is done and the queue is empty.
  bool Pop(cv::Mat* frame) {
    std::unique_lock<std::mutex> lock(mutex_);
    not_empty_.wait(lock, [&] { return !frames_.empty() || finished_; });
    if (frames_.empty()) return false;
    *frame = std::move(frames_.front());
    frames_.pop_front();
    not_full_.notify_one();
    return true;
  }

 private:
  size_t capacity_;
  std::deque<cv::Mat> frames_;
  bool finished_ = false;
  std::mutex mutex_;
  std::condition_variable not_empty_, not_full_;
};

}  // namespace

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

std::unique_ptr<TagObserver> TagObserver::Create(const TagSpec& tag, const Intrinsics& intrinsics,
                                                 const VideoTrackOptions& options, std::string* error) {
  std::string why;
  if (!options.IsValid(&why)) {
    if (error) *error = "options: " + why;
    return nullptr;
  }
  DetectorOptions detector_options = options.detector;
  detector_options.family = tag.family;
  TagDetectorResult created = TagDetector::Create(detector_options);
  if (!created.ok) {
    if (error) *error = created.message;
    return nullptr;
  }
  return std::unique_ptr<TagObserver>(
      new TagObserver(tag, intrinsics, options, std::move(created.detector)));
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
    if (refined.ok) {
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

std::optional<TagCorners> RefineObservationExactly(const FrameObservation& observation,
                                                   const CameraModel& camera) {
  if (!observation.corners_px || observation.crop.empty()) return std::nullopt;
  const CornerRefineResult r = RefineTagCornersByEdgeModel(
      observation.crop, *observation.corners_px, &camera, CornerRefineOptions{}, observation.crop_origin);
  if (!r.ok) return std::nullopt;
  return r.corners_px;
}

std::optional<std::vector<double>> ReadTimestamps(const std::string& path, std::string* error) {
  std::ifstream in(path);
  if (!in) {
    if (error) *error = path + ": cannot read";
    return std::nullopt;
  }
  std::vector<double> stamps;
  std::string line;
  int line_number = 0;
  while (std::getline(in, line)) {
    ++line_number;
    if (line.empty() || line.rfind("frame", 0) == 0) continue;
    std::istringstream fields(line);
    std::string index, t;
    if (!std::getline(fields, index, ',') || !std::getline(fields, t)) {
      if (error) *error = path + ":" + std::to_string(line_number) + ": expected frame,t_s";
      return std::nullopt;
    }
    try {
      stamps.push_back(std::stod(t));
    } catch (const std::exception&) {
      if (error) *error = path + ":" + std::to_string(line_number) + ": t_s is not a number";
      return std::nullopt;
    }
  }
  return stamps;
}

VideoTrack TrackTagInVideo(const std::string& video_path, const std::vector<double>& timestamps_s,
                           const TagSpec& tag, const Intrinsics& intrinsics,
                           const VideoTrackOptions& options,
                           const std::function<void(int)>& on_frame) {
  VideoTrack track;
  std::string why;
  if (!options.IsValid(&why)) {
    track.message = "options: " + why;
    return track;
  }
  VideoReader reader;
  const Status opened = reader.Open(video_path);
  if (!opened.ok()) {
    track.message = opened.message;
    return track;
  }
  std::unique_ptr<TagObserver> observer = TagObserver::Create(tag, intrinsics, options, &why);
  if (!observer) {
    track.message = why;
    return track;
  }
  const double fps = reader.fps() > 0.0 ? reader.fps() : 30.0;

  const Clock::time_point start = Clock::now();
  FrameQueue queue(static_cast<size_t>(options.queue_frames));
  double decode_s = 0.0;
  std::thread decoder([&]() {
    for (;;) {
      const Clock::time_point t0 = Clock::now();
      cv::Mat frame;
      const bool got = reader.Read(&frame);
      decode_s += Seconds(Clock::now() - t0);
      if (!got) break;
      queue.Push(std::move(frame));
    }
    queue.Finish();
  });

  cv::Mat grey;
  int index = 0;
  while (queue.Pop(&grey)) {
    const Clock::time_point t0 = Clock::now();
    const double t_s =
        index < static_cast<int>(timestamps_s.size()) ? timestamps_s[index] : index / fps;
    FrameObservation obs = observer->Observe(grey, t_s);
    track.found += obs.corners_px ? 1 : 0;
    track.duplicate_frames += obs.status == DetectStatus::kDuplicateId ? 1 : 0;
    track.wrong_id_frames += obs.status == DetectStatus::kWrongId ? 1 : 0;
    track.frames.push_back(std::move(obs));
    track.track_s += Seconds(Clock::now() - t0);
    if (on_frame) on_frame(index);
    ++index;
  }
  decoder.join();
  track.decode_s = decode_s;
  track.wall_s = Seconds(Clock::now() - start);
  if (track.frames.empty()) {
    track.message = video_path + ": no frame could be decoded (empty or corrupt video)";
    return track;
  }
  track.ok = true;
  track.message = "ok";
  return track;
}

}  // namespace odocal::vision
