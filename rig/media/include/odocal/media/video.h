// Video files: H.264 .mp4 writing (the renderer's output) and
// reading grey frames back (rendered or recorded by a real camera).
//
// Frames are 8-bit grey (CV_8UC1) in and out; timestamps are seconds from
// the start of the video.
#ifndef ODOCAL_MEDIA_VIDEO_H_
#define ODOCAL_MEDIA_VIDEO_H_

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "odocal/base/status.h"
#include "odocal/vision/image_formation.h"

namespace odocal::media {

// How Mp4Writer encodes. OpenCV 4.6's FFmpeg writer offers no quality
// setting: libx264 runs at its default CRF 23, which at the standard
// condition costs ~0.05 deg of heading per frame, and a static robot's
// frames share the same artefacts so averaging does not remove them
// (docs/vision.md). kFfmpegCli pipes raw frames to the `ffmpeg` program
// instead, still H.264 in .mp4, at the CRF asked for.
struct Mp4WriterOptions {
  enum class Backend { kOpenCv, kFfmpegCli };
  Backend backend = Backend::kOpenCv;
  int crf = 12;  // kFfmpegCli only; 0 = lossless H.264
  // kFfmpegCli only: x264 speed preset (ultrafast ... veryslow).
  std::string preset = "veryfast";
  // kFfmpegCli only: x264 tune ("" none, or e.g. "fastdecode").
  std::string tune;
  // kFfmpegCli only: the longest interval between key frames (0 = x264's
  // default of 250; 1 = every frame intra, artefacts independent per frame).
  int keyint = 0;
  bool IsValid(std::string* why) const;
};

// H.264 .mp4 (fourcc avc1) of grey frames, and each frame's timestamp for
// the timestamp list.
class Mp4Writer {
 public:
  Mp4Writer();
  ~Mp4Writer();
  // Fails with a clear message when H.264 cannot be written here (no
  // libx264 in this OpenCV/FFmpeg, no ffmpeg program, unwritable path).
  Status Open(const std::string& path, double fps, cv::Size frame_size,
                   const Mp4WriterOptions& options = {});
  Status Write(const cv::Mat& grey_frame, double timestamp_s);
  // Finishes the file (waits for ffmpeg with kFfmpegCli); safe to repeat.
  Status Close();
  const std::vector<double>& timestamps_s() const { return timestamps_s_; }
  // "frame,t_s" lines, one per written frame.
  Status WriteTimestamps(const std::string& path) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::vector<double> timestamps_s_;
  cv::Size size_;
};

// Reads grey frames back (any container/codec FFmpeg reads).
class VideoReader {
 public:
  VideoReader();
  ~VideoReader();
  // Missing, empty or corrupt files fail here with a message.
  Status Open(const std::string& path);
  // False at the end of the stream (or on a truncated file).
  bool Read(cv::Mat* grey_frame);
  double fps() const;
  int frame_count() const;  // as the container claims; may be -1

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Reads "frame,t_s" files as Mp4Writer::WriteTimestamps writes them;
// kNotFound or kBadFile (naming the file and line) otherwise.
Result<std::vector<double>> ReadTimestamps(const std::string& path);

// Codec round trip of a clip (the camera simulator's last stage): MJPEG frame
// by frame in memory, H.264 through a temporary .mp4 (ffmpeg program). The
// writer's or reader's error when the codec is unavailable; kFailed when
// frames were lost on the way. kNone returns the frames.
Result<std::vector<cv::Mat>> CodecRoundTrip(const std::vector<cv::Mat>& frames, const vision::CodecOptions& codec,
                                            double fps);

}  // namespace odocal::media

#endif  // ODOCAL_MEDIA_VIDEO_H_
