#include "odocal/media/video.h"

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <opencv2/imgproc.hpp>

#include "codecs.h"

extern "C" char** environ;

namespace odocal::media {

bool Mp4WriterOptions::IsValid(std::string* why) const {
  if (crf < 0 || crf > 51) {
    if (why) *why = "H.264 crf must be in [0, 51]";
    return false;
  }
  static const char* kPresets[] = {"ultrafast", "superfast", "veryfast", "faster", "fast",
                                   "medium",    "slow",      "slower",   "veryslow"};
  bool known = false;
  for (const char* p : kPresets) known = known || preset == p;
  if (!known) {
    if (why) *why = "unknown x264 preset '" + preset + "'";
    return false;
  }
  static const char* kTunes[] = {"", "film", "animation", "grain", "stillimage", "psnr", "ssim", "fastdecode",
                                 "zerolatency"};
  known = false;
  for (const char* t : kTunes) known = known || tune == t;
  if (!known) {
    if (why) *why = "unknown x264 tune '" + tune + "'";
    return false;
  }
  if (keyint < 0) {
    if (why) *why = "H.264 keyint must not be negative";
    return false;
  }
  return true;
}

struct Mp4Writer::Impl {
  Mp4WriterOptions options;
  std::unique_ptr<internal::VideoOutput> writer;  // kOpenCv
  cv::Mat bgr;
  // kFfmpegCli: the child process and the pipe to its stdin.
  pid_t child = -1;
  int pipe_fd = -1;
  bool IsOpen() const { return writer || pipe_fd >= 0; }
};

Mp4Writer::Mp4Writer() : impl_(std::make_unique<Impl>()) {}
Mp4Writer::~Mp4Writer() { Close(); }

Status Mp4Writer::Open(const std::string& path, double fps, cv::Size frame_size,
                       const Mp4WriterOptions& options) {
  Close();
  std::string why;
  if (!options.IsValid(&why)) return Status::Error(StatusCode::kInvalidArgument, why);
  if (!(fps > 0.0) || frame_size.width <= 0 || frame_size.height <= 0) {
    return Status::Error(StatusCode::kInvalidArgument, "video fps and frame size must be positive");
  }
  if (frame_size.width % 2 || frame_size.height % 2) {
    return Status::Error(StatusCode::kInvalidArgument,
                         "H.264 (yuv420p) needs an even frame width and height");
  }
  impl_->options = options;
  size_ = frame_size;
  timestamps_s_.clear();
  if (options.backend == Mp4WriterOptions::Backend::kOpenCv) {
    std::string why;
    const internal::Codecs* codecs = internal::LoadCodecs(&why);
    if (!codecs) return Status::Error(StatusCode::kFailed, "cannot write '" + path + "': " + why);
    impl_->writer = codecs->OpenH264File(path, fps, frame_size);
    if (!impl_->writer) {
      return Status::Error(
          StatusCode::kIoError,
          "cannot open '" + path +
              "' for H.264 (avc1) writing through OpenCV's FFmpeg backend: this OpenCV "
              "build or FFmpeg lacks an H.264 encoder (libx264), or the path is not writable");
    }
    return Status::Ok();
  }
  // kFfmpegCli. The output must be creatable (ffmpeg would only say so later).
  {
    std::ofstream probe(path, std::ios::binary);
    if (!probe)
      return Status::Error(StatusCode::kIoError, "cannot create video file '" + path + "'");
  }
  // A socket rather than a pipe: send(MSG_NOSIGNAL) reports a dead ffmpeg as
  // an error instead of raising SIGPIPE in the caller's process.
  // Close-on-exec: writers opened at once from several threads would
  // otherwise hand each other's socket to their ffmpeg children, and no
  // ffmpeg would see the end of its input (a deadlock at Close). The child's
  // dup2 onto its stdin makes a descriptor without the flag.
  int fds[2];
  if (socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, fds) != 0)
    return Status::Error(StatusCode::kIoError, "cannot create a socket to ffmpeg");
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, fds[0], STDIN_FILENO);
  posix_spawn_file_actions_addclose(&actions, fds[1]);
  const std::string size = std::to_string(frame_size.width) + "x" + std::to_string(frame_size.height);
  char rate[32];
  std::snprintf(rate, sizeof rate, "%.9g", fps);
  const std::string crf = std::to_string(options.crf);
  std::vector<std::string> args = {"ffmpeg", "-nostdin", "-y", "-loglevel", "error", "-f", "rawvideo",
                                   "-pix_fmt", "gray", "-s", size, "-r", rate, "-i", "pipe:0",
                                   "-c:v", "libx264", "-preset", options.preset, "-crf", crf};
  if (!options.tune.empty()) args.insert(args.end(), {"-tune", options.tune});
  if (options.keyint > 0) args.insert(args.end(), {"-g", std::to_string(options.keyint)});
  args.insert(args.end(), {"-pix_fmt", "yuv420p", "-movflags", "+faststart", path});
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = -1;
  const int rc = posix_spawnp(&pid, "ffmpeg", &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  close(fds[0]);
  if (rc != 0) {
    close(fds[1]);
    return Status::Error(StatusCode::kFailed,
                         "cannot run the ffmpeg program for H.264 writing (is it installed?)");
  }
  impl_->child = pid;
  impl_->pipe_fd = fds[1];
  return Status::Ok();
}

Status Mp4Writer::Write(const cv::Mat& grey_frame, double timestamp_s) {
  if (!impl_->IsOpen())
    return Status::Error(StatusCode::kInvalidArgument, "video writer is not open");
  if (grey_frame.type() != CV_8UC1 || grey_frame.size() != size_) {
    return Status::Error(StatusCode::kInvalidArgument,
                         "frame must be 8-bit grey of the size the writer was opened with");
  }
  if (impl_->pipe_fd >= 0) {
    const cv::Mat frame = grey_frame.isContinuous() ? grey_frame : grey_frame.clone();
    const auto* data = frame.ptr<uint8_t>(0);
    size_t left = frame.total();
    while (left > 0) {
      const ssize_t n = ::send(impl_->pipe_fd, data, left, MSG_NOSIGNAL);
      if (n <= 0) {
        if (n < 0 && errno == EINTR) continue;
        return Status::Error(StatusCode::kIoError, "ffmpeg stopped accepting frames");
      }
      data += n;
      left -= static_cast<size_t>(n);
    }
  } else {
    cv::cvtColor(grey_frame, impl_->bgr, cv::COLOR_GRAY2BGR);
    impl_->writer->Write(impl_->bgr);
  }
  timestamps_s_.push_back(timestamp_s);
  return Status::Ok();
}

Status Mp4Writer::Close() {
  if (!impl_) return Status::Ok();
  impl_->writer.reset();  // finishes the file
  if (impl_->pipe_fd >= 0) {
    close(impl_->pipe_fd);
    impl_->pipe_fd = -1;
    int status = 0;
    while (waitpid(impl_->child, &status, 0) < 0 && errno == EINTR) {
    }
    impl_->child = -1;
    if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
      return Status::Error(StatusCode::kFailed, "ffmpeg failed to finish the video");
    }
  }
  return Status::Ok();
}

Status Mp4Writer::WriteTimestamps(const std::string& path) const {
  std::ofstream out(path);
  if (!out)
    return Status::Error(StatusCode::kIoError, "cannot write timestamp list '" + path + "'");
  out << "frame,t_s\n";
  out.precision(9);
  for (size_t i = 0; i < timestamps_s_.size(); ++i) out << i << ',' << timestamps_s_[i] << '\n';
  return out ? Status::Ok() : Status::Error(StatusCode::kIoError, "write error on '" + path + "'");
}

struct VideoReader::Impl {
  std::unique_ptr<internal::VideoInput> capture;
  cv::Mat pending;  // the first frame, decoded by Open() to prove the file is readable
  cv::Mat bgr;
};

VideoReader::VideoReader() : impl_(std::make_unique<Impl>()) {}
VideoReader::~VideoReader() = default;

Status VideoReader::Open(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec))
    return Status::Error(StatusCode::kNotFound, "video file '" + path + "' does not exist");
  if (std::filesystem::is_directory(path, ec))
    return Status::Error(StatusCode::kBadFile, "'" + path + "' is a directory, not a video file");
  if (std::filesystem::file_size(path, ec) == 0 || ec) {
    return Status::Error(StatusCode::kBadFile, "video file '" + path + "' is empty");
  }
  std::string why;
  const internal::Codecs* codecs = internal::LoadCodecs(&why);
  if (!codecs) return Status::Error(StatusCode::kFailed, "cannot read video '" + path + "': " + why);
  impl_->capture = codecs->OpenVideoFile(path);
  if (!impl_->capture) {
    return Status::Error(StatusCode::kBadFile, "cannot open video '" + path +
                                                   "': not a video FFmpeg can read (corrupt?)");
  }
  cv::Mat first;
  if (!impl_->capture->Read(&first) || first.empty()) {
    impl_->capture.reset();
    return Status::Error(StatusCode::kBadFile,
                         "video '" + path + "' has no decodable frame (corrupt or truncated?)");
  }
  impl_->pending = first;
  return Status::Ok();
}

bool VideoReader::Read(cv::Mat* grey_frame) {
  cv::Mat frame;
  if (!impl_->pending.empty()) {
    frame = impl_->pending;
    impl_->pending.release();
  } else if (!impl_->capture || !impl_->capture->Read(&frame) || frame.empty()) {
    return false;
  }
  if (frame.channels() == 3) {
    cv::cvtColor(frame, *grey_frame, cv::COLOR_BGR2GRAY);
  } else if (frame.channels() == 4) {
    cv::cvtColor(frame, *grey_frame, cv::COLOR_BGRA2GRAY);
  } else {
    frame.copyTo(*grey_frame);
  }
  return true;
}

double VideoReader::fps() const { return impl_->capture ? impl_->capture->Fps() : 0.0; }
int VideoReader::frame_count() const { return impl_->capture ? static_cast<int>(impl_->capture->FrameCount()) : -1; }

Result<std::vector<double>> ReadTimestamps(const std::string& path) {
  using Stamps = Result<std::vector<double>>;
  std::ifstream in(path);
  if (!in) return Stamps::Error(StatusCode::kNotFound, path + ": cannot read");
  std::vector<double> stamps;
  std::string line;
  int line_number = 0;
  while (std::getline(in, line)) {
    ++line_number;
    if (line.empty() || line.rfind("frame", 0) == 0) continue;
    std::istringstream fields(line);
    std::string index, t;
    if (!std::getline(fields, index, ',') || !std::getline(fields, t)) {
      return Stamps::Error(StatusCode::kBadFile,
                           path + ":" + std::to_string(line_number) + ": expected frame,t_s");
    }
    try {
      stamps.push_back(std::stod(t));
    } catch (const std::exception&) {
      return Stamps::Error(StatusCode::kBadFile,
                           path + ":" + std::to_string(line_number) + ": t_s is not a number");
    }
  }
  return Stamps::Ok(std::move(stamps));
}

Result<std::vector<cv::Mat>> CodecRoundTrip(const std::vector<cv::Mat>& frames, const vision::CodecOptions& codec,
                                            double fps) {
  using Frames = Result<std::vector<cv::Mat>>;
  if (codec.kind != vision::CodecOptions::Kind::kH264 || frames.empty()) {
    if (codec.kind == vision::CodecOptions::Kind::kMjpeg) {
      std::vector<cv::Mat> out;
      for (const cv::Mat& f : frames) out.push_back(vision::JpegRoundTrip(f, codec.quality));
      return Frames::Ok(std::move(out));
    }
    return Frames::Ok(frames);
  }
  static std::atomic<int> counter{0};
  const std::string path = (std::filesystem::temp_directory_path() /
                            ("odocal_codec_" + std::to_string(getpid()) + "_" +
                             std::to_string(counter++) + ".mp4"))
                               .string();
  Mp4Writer writer;
  Mp4WriterOptions wo;
  wo.backend = Mp4WriterOptions::Backend::kFfmpegCli;
  wo.crf = codec.crf;
  Status s = writer.Open(path, fps, frames.front().size(), wo);
  for (size_t k = 0; s.ok() && k < frames.size(); ++k) s = writer.Write(frames[k], k / fps);
  if (s.ok()) s = writer.Close();
  std::vector<cv::Mat> out;
  if (s.ok()) {
    VideoReader reader;
    s = reader.Open(path);
    cv::Mat f;
    while (s.ok() && reader.Read(&f)) out.push_back(f.clone());
  }
  std::error_code ignored;
  std::filesystem::remove(path, ignored);
  if (!s.ok()) return Frames::From(s);
  if (out.size() != frames.size()) return Frames::Error(StatusCode::kFailed, "H.264 round trip lost frames");
  return Frames::Ok(std::move(out));
}

}  // namespace odocal::media
