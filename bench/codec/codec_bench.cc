// What the H.264 settings of `simulate` cost and what they change in the
// measurement: the same rendered clips (the standard condition: fx 1400,
// k1 -0.12 k2 0.05, camera 2000 mm high at pitch 3 deg, 80 mm tag36h11 at
// 150 mm, noise 2, blur 0.8 px) encoded with each x264 setting, decoded and
// measured (track, edge refinement, planar pose) against rendered truth.
//
//   codec_bench [WIDTH HEIGHT [SETTING...]]
//
// SETTING is preset:crf[:tune[:keyint]] (tune "-" for none), e.g.
// veryfast:6 ultrafast:6 ultrafast:18:-:1; lossless (ultrafast:0) always runs
// first, as the reference of the "mean − lossless's" columns. Default 1920 1080 and a list of
// settings. Per setting: bit rate at 30 fps, encode and decode time per frame
// (wall, ffmpeg on every core it likes), the worst static-clip mean error
// (8 clips: 4 places, two of them grid-aligned, x 2 noise seeds, 30 frames
// each: is the codec biased where a rest is averaged?) and the per-frame rms error of a moving robot
// (90 frames at 0.3 m/s). CRF 0 is x264's lossless mode: the reference.
#include <sys/stat.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "odocal/media/video.h"
#include "odocal/vision/corner_refine.h"
#include "odocal/vision/detector.h"
#include "odocal/vision/planar_pose.h"
#include "odocal/vision/renderer.h"

using odocal::calibration::Pose2;
using odocal::calibration::WrapAngle;
using namespace odocal::vision;
namespace media = odocal::media;

namespace {

double NowMs() {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

struct Clip {
  std::vector<cv::Mat> frames;
  std::vector<Pose2> truth;  // T_world_tag per frame
};

struct Setting {
  std::string label;
  media::Mp4WriterOptions options;
};

Setting Parse(const std::string& text) {
  Setting s;
  s.label = text;
  s.options.backend = media::Mp4WriterOptions::Backend::kFfmpegCli;
  std::vector<std::string> parts;
  size_t at = 0;
  while (true) {
    const size_t colon = text.find(':', at);
    parts.push_back(text.substr(at, colon - at));
    if (colon == std::string::npos) break;
    at = colon + 1;
  }
  s.options.preset = parts[0];
  if (parts.size() > 1) s.options.crf = std::atoi(parts[1].c_str());
  if (parts.size() > 2 && parts[2] != "-") s.options.tune = parts[2];
  if (parts.size() > 3) s.options.keyint = std::atoi(parts[3].c_str());
  return s;
}

struct Measured {
  double mean_x_mm = 0, mean_y_mm = 0, mean_deg = 0, rms_mm = 0, rms_deg = 0;
  int n = 0, frames = 0;
};

// Encodes, decodes and measures one clip; adds the costs to the totals.
bool RoundTrip(const Clip& clip, const Setting& s, const CameraModel& camera, const TagSpec& tag,
               const std::string& path, double* encode_ms, double* decode_ms, double* bytes,
               Measured* m) {
  media::Mp4Writer writer;
  if (const auto st = writer.Open(path, 30.0, clip.frames[0].size(), s.options); !st.ok()) {
    std::fprintf(stderr, "%s: %s\n", s.label.c_str(), st.message.c_str());
    return false;
  }
  double t0 = NowMs();
  for (size_t i = 0; i < clip.frames.size(); ++i) writer.Write(clip.frames[i], i / 30.0);
  writer.Close();
  *encode_ms += NowMs() - t0;
  struct stat st {};
  stat(path.c_str(), &st);
  *bytes += static_cast<double>(st.st_size);
  media::VideoReader reader;
  if (!reader.Open(path).ok()) return false;
  std::vector<cv::Mat> decoded;
  cv::Mat grey;
  t0 = NowMs();
  while (reader.Read(&grey)) decoded.push_back(grey.clone());
  *decode_ms += NowMs() - t0;
  auto det = TagDetector::Create(DetectorOptions{});
  TagTracker tracker(det.detector.get(), tag.id);
  double sx = 0, sy = 0, sh = 0, sq = 0, sqh = 0;
  for (size_t i = 0; i < decoded.size() && i < clip.truth.size(); ++i) {
    const TrackResult tr = tracker.Track(decoded[i]);
    if (tr.find.status != DetectStatus::kOk) continue;
    const auto ref = RefineTagCorners(decoded[i], tr.find.detection->corners_px, &camera);
    const auto p = MeasureTagPose(camera, tag, ref.corners_px);
    if (!p.ok()) continue;
    const Eigen::Vector2d e = p.T_world_tag.translation() - clip.truth[i].translation();
    const double h = WrapAngle(p.T_world_tag.heading() - clip.truth[i].heading()) * 180 / M_PI;
    sx += e.x() * 1e3, sy += e.y() * 1e3, sh += h, sq += e.squaredNorm() * 1e6, sqh += h * h, ++m->n;
  }
  m->frames = static_cast<int>(decoded.size());
  if (m->n == 0) return false;
  m->mean_x_mm = sx / m->n, m->mean_y_mm = sy / m->n, m->mean_deg = sh / m->n;
  m->rms_mm = std::sqrt(sq / m->n), m->rms_deg = std::sqrt(sqh / m->n);
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  const int width = argc > 2 ? std::atoi(argv[1]) : 1920;
  const int height = argc > 2 ? std::atoi(argv[2]) : 1080;
  std::vector<Setting> settings;
  settings.push_back(Parse("ultrafast:0"));  // the reference: x264's lossless mode
  for (int i = 3; i < argc; ++i) settings.push_back(Parse(argv[i]));
  if (settings.size() == 1) {
    for (const char* s : {"veryfast:6", "ultrafast:6", "ultrafast:10", "veryfast:6:fastdecode",
                          "veryfast:12", "ultrafast:18:-:1", "veryfast:18"}) {
      settings.push_back(Parse(s));
    }
  }
  // The standard camera on this sensor, centred on the same optical axis.
  const Intrinsics intrinsics{width, height, 1400, 1400, width / 2.0, height / 2.0, {-0.12, 0.05, 0, 0, 0}};
  const CameraModel camera(intrinsics, CameraMount{0, -1000, 2000, 0, 3, 0});
  TagSpec tag;
  tag.id = 5;

  // Static clips: 4 places x 2 noise seeds, 30 frames each (within a
  // 960x540 sensor's view too). Two of the places rest with the tag's edges
  // along the pixel rows and columns (heading 0.1 deg and 90 deg, camera yaw
  // 0), where every pixel of an edge shares one phase and a codec's
  // artefacts do not average (docs/vision.md, "Edges parallel to the pixel grid").
  std::vector<Clip> still;
  for (unsigned seed : {1u, 2u}) {
    RenderOptions ro;
    ro.seed = seed;
    auto r = Renderer::Create(camera, tag, ro);
    if (!r.ok()) {
      std::fprintf(stderr, "renderer: %s\n", r.message.c_str());
      return 1;
    }
    for (const Pose2& place : {Pose2::FromXYHeading(0.02, -1.0, 0.4), Pose2::FromXYHeading(-0.15, -0.95, 0.002),
                               Pose2::FromXYHeading(0.2, -1.1, M_PI / 2), Pose2::FromXYHeading(0.1, -0.9, 1.3)}) {
      Clip c;
      for (int i = 0; i < 30; ++i) {
        RenderedFrame f = r.renderer->Render(place);
        c.frames.push_back(f.image);
        c.truth.push_back(f.T_world_tag);
      }
      still.push_back(std::move(c));
    }
  }
  // A moving robot: 0.3 m/s, turning, 4 ms exposure.
  Clip moving;
  {
    RenderOptions ro;
    ro.seed = 3;
    ro.exposure_s = 0.004;
    auto r = Renderer::Create(camera, tag, ro);
    auto traj = [](double t) { return Pose2::FromXYHeading(-0.3 + 0.3 * t, -1.0 + 0.02 * t, 0.2 * t); };
    for (int i = 0; i < 90; ++i) {
      const RenderedFrame f = r.renderer->RenderExposure(traj, i / 30.0);
      moving.frames.push_back(f.image);
      moving.truth.push_back(f.T_world_tag);
    }
  }

  const std::string path = "/tmp/odocal_codec_bench.mp4";
  std::printf("%dx%d, 30 fps. Static: worst |mean error| of 8 clips of 30 frames. Moving: 90 frames at 0.3 m/s.\n\n",
              width, height);
  std::printf("| x264 setting (preset:crf[:tune[:keyint]]) | Mbit/s | encode ms/frame | decode ms/frame | "
              "static worst mean x,y mm | static worst mean heading deg | worst mean − lossless's, x,y mm | "
              "worst mean − lossless's, heading deg | moving rms mm | moving rms deg |\n"
              "|---|---|---|---|---|---|---|---|---|---|\n");
  std::vector<Measured> lossless;  // per static clip, the reference's means
  for (const Setting& s : settings) {
    double encode_ms = 0, decode_ms = 0, bytes = 0, worst_xy = 0, worst_deg = 0, off_xy = 0, off_deg = 0;
    int frames = 0;
    bool ok = true;
    const bool reference = lossless.empty();
    for (size_t k = 0; k < still.size(); ++k) {
      Measured m;
      ok = ok && RoundTrip(still[k], s, camera, tag, path, &encode_ms, &decode_ms, &bytes, &m);
      worst_xy = std::max({worst_xy, std::abs(m.mean_x_mm), std::abs(m.mean_y_mm)});
      worst_deg = std::max(worst_deg, std::abs(m.mean_deg));
      if (reference) lossless.push_back(m);
      off_xy = std::max({off_xy, std::abs(m.mean_x_mm - lossless[k].mean_x_mm),
                         std::abs(m.mean_y_mm - lossless[k].mean_y_mm)});
      off_deg = std::max(off_deg, std::abs(m.mean_deg - lossless[k].mean_deg));
      frames += static_cast<int>(still[k].frames.size());
    }
    Measured mv;
    ok = ok && RoundTrip(moving, s, camera, tag, path, &encode_ms, &decode_ms, &bytes, &mv);
    frames += static_cast<int>(moving.frames.size());
    if (!ok) {
      std::printf("| %s | failed |\n", s.label.c_str());
      continue;
    }
    std::printf("| %s | %.1f | %.1f | %.1f | %.4f | %.4f | %.4f | %.4f | %.4f | %.4f |\n", s.label.c_str(),
                bytes * 8 / frames * 30 / 1e6, encode_ms / frames, decode_ms / frames, worst_xy, worst_deg,
                off_xy, off_deg, mv.rms_mm, mv.rms_deg);
    std::fflush(stdout);
  }
  std::remove(path.c_str());
  return 0;
}
