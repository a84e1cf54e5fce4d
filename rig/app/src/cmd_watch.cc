// odocal watch CAMERA --calibration camera.yaml --tag FAMILY:ID:SIZE_MM[:HEIGHT_MM]
//     [--mount-guess x,y,height,roll,pitch,yaw] [--bind 127.0.0.1] [--port 8080]
//     [--seconds S] [--realtime] [--delay-s S] [--hold-s S]
//
// The live view (issue 13 §4, rig/live) on a camera or a video file without a
// robot: the frames go to live::TagWatch (the tag tracked, its pose on the
// tag's plane, the camera's tilt and height fitted once: live/tag_watch.h)
// and are served as a web page. Prints "live view: URL" first and a
// summary line (frames, frames/s) at the end; exit 0 when the video ended
// or Ctrl-C stopped it, 1 when a camera stopped delivering, 2 for bad input
// (an option, a camera that cannot be opened, a port in use).
#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>

#include "cli_util.h"
#include "commands.h"
#include "odocal/base/format.h"
#include "odocal/config/camera_file.h"
#include "odocal/live/live_server.h"
#include "odocal/live/live_state.h"
#include "odocal/live/tag_watch.h"
#include "odocal/media/frame_source.h"
#include "odocal/media/video.h"

namespace odocal::app {
namespace {

constexpr const char* kWatch = "watch";

std::atomic<bool> g_watch_stop{false};
void OnWatchSignal(int) { g_watch_stop = true; }

struct WatchArgs : CameraTagArgs {
  std::string bind = "127.0.0.1";
  int port = 8080;
  double seconds = 0.0;
  bool realtime = false;
  double delay_s = 0.0;
  double hold_s = 0.0;
};

using Clock = std::chrono::steady_clock;
double Since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// A video file (frames at index / fps) or a camera (its own clock), one frame at a time.
class Source {
 public:
  explicit Source(const std::string& camera) : name_(camera) {
    if (std::filesystem::is_regular_file(camera)) {
      const Status opened = video_.Open(camera);
      if (!opened.ok()) Fail(kWatch, kExitBadInput, "CAMERA " + camera + ": " + opened.message);
      fps_ = video_.fps() > 0.0 ? video_.fps() : 30.0;
      is_file_ = true;
      return;
    }
    const bool device_like = camera.find("://") != std::string::npos || camera.rfind("/dev/", 0) == 0 ||
                             camera.find_first_not_of("0123456789") == std::string::npos;
    if (!device_like) Fail(kWatch, kExitBadInput, "CAMERA " + camera + ": no such file, and not a device or URL");
    Result<std::unique_ptr<media::CaptureSource>> opened = media::CaptureSource::Open(camera);
    if (!opened) Fail(kWatch, kExitBadInput, "CAMERA " + camera + ": cannot be opened: " + opened.message);
    capture_ = std::move(*opened);
  }
  bool is_file() const { return is_file_; }
  std::string Describe() const { return is_file_ ? name_ : capture_->Describe(); }
  // The next frame, or nullopt at the end (`*error` empty) or on a failure.
  std::optional<media::CameraFrame> Next(std::string* error) {
    error->clear();
    if (is_file_) {
      cv::Mat grey;
      if (!video_.Read(&grey)) return std::nullopt;
      return media::CameraFrame{grey, index_++ / fps_};
    }
    Result<media::CameraFrame> frame = capture_->Grab();
    if (!frame) {
      *error = frame.message;
      return std::nullopt;
    }
    if (!t0_) t0_ = frame->t_s;
    frame->t_s -= *t0_;
    return std::move(frame.value);
  }

 private:
  std::string name_;
  bool is_file_ = false;
  media::VideoReader video_;
  double fps_ = 30.0;
  long index_ = 0;
  std::unique_ptr<media::CaptureSource> capture_;
  std::optional<double> t0_;
};

// The options, checked (a bad one exits 2): the tag, the mount guess, where to
// serve, the camera's intrinsics.
struct WatchInputs {
  vision::TagSpec tag;
  std::optional<vision::CameraMount> mount_guess;
  live::LiveServerOptions server_options;
  vision::Intrinsics intrinsics;
};
WatchInputs CheckWatchInputs(const WatchArgs& args) {
  WatchInputs in;
  in.tag = ParseTagOption(kWatch, "--tag", args.tag);
  std::string why;
  if (!vision::IsKnownTagFamily(in.tag.family))
    Fail(kWatch, kExitBadInput, "--tag " + args.tag + ": unknown family '" + in.tag.family + "'");
  if (!args.mount.empty()) in.mount_guess = ParseMountOption(kWatch, "--mount-guess", args.mount);
  if (args.port < 0 || args.port > 65535)
    Fail(kWatch, kExitBadInput, "--port " + std::to_string(args.port) + ": not in 0..65535 (0: any free port)");
  in.server_options.bind_address = args.bind;
  in.server_options.port = args.port;
  if (!in.server_options.IsValid(&why)) Fail(kWatch, kExitBadInput, "--bind " + args.bind + ": " + why);
  if (args.seconds < 0.0) Fail(kWatch, kExitBadInput, "--seconds must be >= 0 (0: until the source ends)");
  if (args.hold_s < 0.0) Fail(kWatch, kExitBadInput, "--hold-s must be >= 0");
  if (args.delay_s < 0.0) Fail(kWatch, kExitBadInput, "--delay-s must be >= 0");
  const auto file = config::ReadCameraFile(args.calibration);
  if (!file) Fail(kWatch, kExitBadInput, "--calibration: " + file.message);
  in.intrinsics = file->intrinsics;
  return in;
}

// How the frames ended: `ended` says why a source stopped delivering (empty
// at the video's end, --seconds or Ctrl-C), after elapsed_s.
struct WatchedFrames {
  std::string ended;
  double elapsed_s = 0.0;
};

// Each frame to the tag watch until the source ends, --seconds pass or Ctrl-C
// (with --realtime, a video at its frame rate).
WatchedFrames WatchFrames(const WatchArgs& args, const vision::Intrinsics& intrinsics, Source& source,
                          live::TagWatch& watch) {
  std::string error;
  WatchedFrames watched;
  const Clock::time_point t0 = Clock::now();
  while (!g_watch_stop) {
    std::optional<media::CameraFrame> frame = source.Next(&error);
    if (!frame) {
      watched.ended = error;
      break;
    }
    if (args.seconds > 0.0 && frame->t_s > args.seconds) break;
    if (frame->grey.cols != intrinsics.width || frame->grey.rows != intrinsics.height) {
      Fail(kWatch, kExitBadInput,
           source.Describe() + " delivers " + std::to_string(frame->grey.cols) + "x" +
               std::to_string(frame->grey.rows) + " frames, --calibration " + args.calibration + " is for " +
               std::to_string(intrinsics.width) + "x" + std::to_string(intrinsics.height));
    }
    if (args.realtime && source.is_file()) {
      const double ahead = frame->t_s - Since(t0);
      if (ahead > 0.0) std::this_thread::sleep_for(std::chrono::duration<double>(ahead));
    }
    watch.OnFrame(frame->grey, frame->t_s);
  }
  watched.elapsed_s = Since(t0);
  return watched;
}

void RunWatch(const WatchArgs& args) {
  const WatchInputs in = CheckWatchInputs(args);
  const vision::TagSpec& tag = in.tag;
  const vision::Intrinsics& intrinsics = in.intrinsics;

  Source source(args.camera);
  live::LiveState state;
  auto watch = live::TagWatch::Create(tag, intrinsics, in.mount_guess, &state);
  if (!watch) Fail(kWatch, kExitBadInput, "--tag " + args.tag + ": " + watch.message);

  state.SetSource(source.Describe());
  state.SetProgress(0, 0, "", "watch: no plan, the camera only");
  auto server = live::LiveServer::Start(state, in.server_options);
  if (!server)
    Fail(kWatch, kExitBadInput, "--bind " + args.bind + " --port " + std::to_string(args.port) + ": " + server.message);
  const std::string url = (*server)->url();
  std::printf("live view: %s%s\n", url.c_str(),
              args.bind == "0.0.0.0" ? " (every interface: open this machine's address on the phone)" : "");
  std::fflush(stdout);
  g_watch_stop = false;
  std::signal(SIGINT, OnWatchSignal);
  std::signal(SIGTERM, OnWatchSignal);

  // Time to open the page before a video starts.
  const Clock::time_point delay_from = Clock::now();
  while (!g_watch_stop && Since(delay_from) < args.delay_s) std::this_thread::sleep_for(std::chrono::milliseconds(20));

  const WatchedFrames watched = WatchFrames(args, intrinsics, source, **watch);
  const double elapsed = watched.elapsed_s;
  const std::string& ended = watched.ended;
  const long frames = (*watch)->frames(), found = (*watch)->found();
  std::printf("watched %ld frames in %.2f s (%.1f frames/s), tag found in %ld\n", frames, elapsed,
              elapsed > 0.0 ? frames / elapsed : 0.0, found);
  if (g_watch_stop) {
    std::printf("stopped (Ctrl-C)\n");
    return;
  }
  const bool failed = !ended.empty();
  const std::string end_text = failed ? source.Describe() + " stopped delivering frames: " + ended
                               : source.is_file() ? Format("the video ended after %ld frames", frames)
                                                  : Format("stopped after %ld frames (--seconds)", frames);
  if (args.hold_s > 0.0) {
    state.SetWarning("source_ended", end_text + "; the page stays for " + Format("%.0f s", args.hold_s));
    std::fflush(stdout);
    const Clock::time_point hold_from = Clock::now();
    while (!g_watch_stop && Since(hold_from) < args.hold_s) std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  (*server)->Stop();
  if (failed) Fail(kWatch, kExitFailure, end_text);
}

}  // namespace

void RegisterWatchCommand(CLI::App& app) {
  auto args = std::make_shared<WatchArgs>();
  CLI::App* cmd = app.add_subcommand(
      "watch",
      "The live view without a robot: a camera or a video watched frame by frame, the tag's outline, pose\n"
      "and trajectory served as a web page (bound to 127.0.0.1 unless --bind says otherwise; keys of\n"
      "/state.json in docs/formats.md). Prints \"live view: URL\"; Ctrl-C stops");
  AddCameraTagOptions(cmd, "camera", args.get());
  cmd->add_option("--bind", args->bind, "Address to serve on; 0.0.0.0 for a phone on the same network")
      ->default_val("127.0.0.1");
  cmd->add_option("--port", args->port, "Port to serve on; 0 for any free one (the URL printed says which)")
      ->default_val(8080);
  cmd->add_option("--seconds", args->seconds, "Stop after this much of the camera or video (0: until it ends)")
      ->default_val(0.0);
  cmd->add_flag("--realtime", args->realtime, "Play a video file at its frame rate (default: as fast as possible)");
  cmd->add_option("--delay-s", args->delay_s,
                  "Wait this long after printing the URL before reading the source (to open the page first)")
      ->default_val(0.0);
  cmd->add_option("--hold-s", args->hold_s, "Keep serving the page this long after the video ends")
      ->default_val(0.0);
  cmd->callback([args]() { RunWatch(*args); });
}

}  // namespace odocal::app
