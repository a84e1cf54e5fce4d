// Batch throughput and accuracy on one recorded session.
//
//   ./build/odocal simulate --scenario sample_data/scenarios/standard_1080p.yaml --out /tmp/std
//   ./build/bench/batch_bench /tmp/std
//
// Throughput, on the longest video of the session, single file:
//   decode only            frames/s of VideoReader alone
//   batch pipeline         frames/s of TrackTagInVideo (decode thread + ROI
//                          tracking + refinement), what batch runs per video
//   full-frame apriltag    frames/s of decode + libapriltag with the
//                          library's default detector settings on every frame
// Accuracy: the whole session through MeasureSessions (what `odocal batch`
// does), each run's return error against truth.json.
#include <apriltag/apriltag.h>
#include <apriltag/tag36h11.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <thread>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "odocal/config/session.h"
#include "odocal/measure/measure.h"
#include "odocal/measure/video_track.h"
#include "odocal/media/video.h"
#include "odocal/report/measurement_json.h"

namespace {

using Clock = std::chrono::steady_clock;
double Since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

double DecodeOnlyFps(const std::string& video, int* frames) {
  odocal::media::VideoReader reader;
  if (!reader.Open(video).ok()) return 0.0;
  cv::Mat grey;
  const auto t0 = Clock::now();
  *frames = 0;
  while (reader.Read(&grey)) ++*frames;
  return *frames / Since(t0);
}

double FullFrameApriltagFps(const std::string& video) {
  odocal::media::VideoReader reader;
  if (!reader.Open(video).ok()) return 0.0;
  apriltag_detector_t* detector = apriltag_detector_create();  // library defaults
  apriltag_family_t* family = tag36h11_create();
  apriltag_detector_add_family(detector, family);
  cv::Mat grey;
  int frames = 0;
  const auto t0 = Clock::now();
  while (reader.Read(&grey)) {
    image_u8_t image = {grey.cols, grey.rows, static_cast<int32_t>(grey.step), grey.data};
    zarray_t* detections = apriltag_detector_detect(detector, &image);
    apriltag_detections_destroy(detections);
    ++frames;
  }
  const double fps = frames / Since(t0);
  apriltag_detector_destroy(detector);
  tag36h11_destroy(family);
  return fps;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s SIMULATION_DIR (from odocal simulate)\n", argv[0]);
    return 2;
  }
  const std::string dir = argv[1];
  std::string error;
  const auto session = odocal::config::LoadSession(dir + "/session.yaml");
  if (!session) {
    std::fprintf(stderr, "%s\n", session.message.c_str());
    return 1;
  }
  // The longest video.
  const odocal::config::SessionRun* longest = &session->runs.front();
  for (const auto& run : session->runs)
    if (std::filesystem::file_size(run.video) > std::filesystem::file_size(longest->video)) longest = &run;
  std::printf("session %s: %zu runs, %dx%d; throughput on %s\n", dir.c_str(), session->runs.size(),
              session->intrinsics.width, session->intrinsics.height, longest->name.c_str());

  int frames = 0;
  const double decode_fps = DecodeOnlyFps(longest->video, &frames);
  const auto t0 = Clock::now();
  const odocal::measure::VideoTrack track = odocal::measure::TrackTagInVideo(
      longest->video, {}, session->tag, session->intrinsics);
  const double batch_fps = track.frames.size() / Since(t0);
  const double apriltag_fps = FullFrameApriltagFps(longest->video);
  std::printf("  frames                   %d\n", frames);
  std::printf("  decode only              %7.1f frames/s\n", decode_fps);
  std::printf("  batch pipeline           %7.1f frames/s  (%.2f of decode; goal >= 0.8)\n", batch_fps,
              batch_fps / decode_fps);
  std::printf("  full-frame apriltag      %7.1f frames/s  (batch is %.1fx faster; goal >= 10x)\n",
              apriltag_fps, batch_fps / apriltag_fps);
  std::printf("  tracker thread busy      %.2f ms/frame (decode thread %.2f ms/frame)\n",
              1e3 * track.track_s / track.frames.size(), 1e3 * track.decode_s / track.frames.size());

  // Accuracy: the whole session, as batch measures it.
  const auto t1 = Clock::now();
  const auto measured = odocal::measure::MeasureSessions({*session}, {}, {});
  if (!measured) {
    std::fprintf(stderr, "%s\n", measured.message.c_str());
    return 1;
  }
  const double session_s = Since(t1);
  std::ifstream truth_in(dir + "/truth.json");
  const nlohmann::json truth = nlohmann::json::parse(truth_in);
  long total_frames = 0;
  double worst_xy = 0.0, worst_theta = 0.0;
  std::printf("  session measured in %.1f s (all runs, all cores)\n", session_s);
  std::printf("  %-24s %10s %10s %12s\n", "run", "dx [mm]", "dy [mm]", "dtheta [deg]");
  for (size_t i = 0; i < measured->front().runs.size(); ++i) {
    const auto& rm = measured->front().runs[i];
    total_frames += static_cast<long>(rm.track.frames.size());
    const nlohmann::json j = odocal::report::RunJson(rm);
    const nlohmann::json& t = truth["runs"][i]["true_return_error"];
    if (j["return_error"].is_null()) {
      std::printf("  %-24s not measured: %s\n", rm.run.name.c_str(), j["flags"].dump().c_str());
      continue;
    }
    const double dx = j["return_error"]["x_mm"].get<double>() - t["x_mm"].get<double>();
    const double dy = j["return_error"]["y_mm"].get<double>() - t["y_mm"].get<double>();
    const double dth = j["return_error"]["theta_deg"].get<double>() - t["theta_deg"].get<double>();
    worst_xy = std::max({worst_xy, std::abs(dx), std::abs(dy)});
    worst_theta = std::max(worst_theta, std::abs(dth));
    std::printf("  %-24s %+10.4f %+10.4f %+12.5f\n", rm.run.name.c_str(), dx, dy, dth);
  }
  std::printf("  worst |dx|,|dy| %.4f mm (goal <= 0.15), |dtheta| %.5f deg (goal <= 0.01)\n", worst_xy,
              worst_theta);
  std::printf("  session throughput %.1f frames/s on %u cores\n", total_frames / session_s,
              std::thread::hardware_concurrency());
  return 0;
}
