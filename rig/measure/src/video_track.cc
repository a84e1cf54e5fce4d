#include "odocal/measure/video_track.h"

#include <chrono>
#include <condition_variable>
#include <deque>
#include <mutex>
#include <thread>

#include "odocal/media/video.h"

namespace odocal::measure {
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

VideoTrack TrackTagInVideo(const std::string& video_path, const std::vector<double>& timestamps_s,
                           const vision::TagSpec& tag, const vision::Intrinsics& intrinsics,
                           const vision::VideoTrackOptions& options,
                           const std::function<void(int)>& on_frame) {
  VideoTrack track;
  std::string why;
  if (!options.IsValid(&why)) {
    track.status = StatusCode::kInvalidArgument;
    track.message = "options: " + why;
    return track;
  }
  media::VideoReader reader;
  const odocal::Status opened = reader.Open(video_path);
  if (!opened.ok()) {
    track.message = opened.message;
    return track;
  }
  auto created = vision::TagObserver::Create(tag, intrinsics, options);
  if (!created) {
    track.message = created.message;
    return track;
  }
  std::unique_ptr<vision::TagObserver> observer = std::move(*created);
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
    vision::FrameObservation obs = observer->Observe(grey, t_s);
    track.found += obs.corners_px ? 1 : 0;
    track.duplicate_frames += obs.status == vision::DetectStatus::kDuplicateId ? 1 : 0;
    track.wrong_id_frames += obs.status == vision::DetectStatus::kWrongId ? 1 : 0;
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
  track.status = StatusCode::kOk;
  track.message = "ok";
  return track;
}

}  // namespace odocal::measure
