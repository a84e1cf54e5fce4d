// Detector speed and accuracy against rendered ground truth at the issue's
// standard condition (1920x1080, fx 1400, k1 -0.12 k2 0.05, camera 2000 mm
// high at pitch 3 deg, 80 mm tag36h11 at 150 mm, noise 2, blur 0.8 px).
//
//   vision_detector_bench [frames=24] [seed=1]
//
// Prints markdown tables (docs/performance.md): time per frame and corner
// error (detected - true, OpenCV convention) for full-frame detection by
// quad_decimate / quad_sigma, for ROI detection by window size, for the
// edge refinement, and the per-frame planar pose error. Single-threaded
// (nthreads = 1): the batch runner parallelises across videos instead.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
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

struct Row {
  int found = 0, tried = 0;
  double ms = 0, sx = 0, sy = 0, sq = 0;
  int n = 0;
  void Add(const TagCorners& got, const TagCorners& truth) {
    for (int k = 0; k < 4; ++k) {
      const cv::Point2d e = got[k] - truth[k];
      sx += e.x, sy += e.y, sq += e.dot(e), ++n;
    }
  }
  void Print(const std::string& label) const {
    std::printf("| %s | %.2f | %d/%d | %+.4f | %+.4f | %.4f |\n", label.c_str(), ms / std::max(1, tried),
                found, tried, n ? sx / n : NAN, n ? sy / n : NAN, n ? std::sqrt(sq / n) : NAN);
  }
};

cv::Rect Window(const TagCorners& c, double margin_sides) {
  double x0 = 1e9, y0 = 1e9, x1 = -1e9, y1 = -1e9;
  for (const auto& p : c) x0 = std::min(x0, p.x), y0 = std::min(y0, p.y), x1 = std::max(x1, p.x), y1 = std::max(y1, p.y);
  const double m = std::max(16.0, margin_sides * cv::norm(c[0] - c[1]));
  return cv::Rect(cvFloor(x0 - m), cvFloor(y0 - m), cvCeil(x1 - x0 + 2 * m), cvCeil(y1 - y0 + 2 * m));
}

}  // namespace

int main(int argc, char** argv) {
  const int frames = argc > 1 ? std::atoi(argv[1]) : 24;
  const unsigned seed = argc > 2 ? static_cast<unsigned>(std::atoi(argv[2])) : 1;
  const Intrinsics intrinsics{1920, 1080, 1400, 1400, 960, 540, {-0.12, 0.05, 0, 0, 0}};
  const CameraModel camera(intrinsics, CameraMount{0, -1000, 2000, 0, 3, 0});
  TagSpec tag;
  tag.id = 5;
  RenderOptions ro;
  ro.seed = seed;
  auto created = Renderer::Create(camera, tag, ro);
  if (!created.ok()) {
    std::fprintf(stderr, "renderer: %s\n", created.message.c_str());
    return 1;
  }
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> ux(-1.15, 1.15), uy(-1.55, -0.45), uh(-M_PI, M_PI);
  std::vector<RenderedFrame> shots;
  double render_ms = 0;
  while (static_cast<int>(shots.size()) < frames) {
    const double t0 = NowMs();
    RenderedFrame f = created.renderer->Render(Pose2::FromXYHeading(ux(rng), uy(rng), uh(rng)));
    render_ms += NowMs() - t0;
    if (f.tag_visible) shots.push_back(std::move(f));
  }
  std::printf("Rendered %d 1920x1080 frames, %.1f ms each (static robot).\n\n", frames, render_ms / frames);

  auto run = [&](const DetectorOptions& o, double margin_sides, int max_frames, const std::string& label) {
    auto d = TagDetector::Create(o);
    Row row;
    for (int i = 0; i < std::min<int>(max_frames, shots.size()); ++i) {
      const auto& f = shots[i];
      std::optional<cv::Rect> roi;
      if (margin_sides > 0) roi = Window(f.corners_px, margin_sides);
      const double t0 = NowMs();
      const FindResult r = d.detector->Find(f.image, tag.id, roi);
      row.ms += NowMs() - t0;
      ++row.tried;
      if (r.status == DetectStatus::kOk) {
        ++row.found;
        row.Add(r.detection->corners_px, f.corners_px);
      }
    }
    row.Print(label);
  };

  std::printf("### Full frame (1920x1080), by quad_decimate / quad_sigma\n\n");
  std::printf("| options | ms/frame | found | mean dx px | mean dy px | rms px |\n|---|---|---|---|---|---|\n");
  const int full_frames = std::min(frames, 8);
  {
    DetectorOptions lib;  // libapriltag's own defaults
    lib.quad_decimate = 2.0f;
    lib.max_hamming = 2;
    run(lib, 0, full_frames, "library defaults (decimate 2, sigma 0, hamming 2)");
  }
  for (float dec : {1.0f, 1.5f, 2.0f, 3.0f, 4.0f}) {
    for (float sigma : {0.0f, 0.8f}) {
      DetectorOptions o;
      o.quad_decimate = dec;
      o.quad_sigma = sigma;
      char label[80];
      std::snprintf(label, sizeof label, "decimate %.1f, sigma %.1f", dec, sigma);
      run(o, 0, full_frames, label);
    }
  }

  std::printf("\n### Region of interest (tag bounding box + margin), by margin and decimate\n\n");
  std::printf("| options | ms/frame | found | mean dx px | mean dy px | rms px |\n|---|---|---|---|---|---|\n");
  for (double margin : {0.5, 1.0, 2.0, 4.0}) {
    for (float dec : {1.0f, 2.0f}) {
      DetectorOptions o;
      o.quad_decimate = dec;
      const cv::Rect w = Window(shots[0].corners_px, margin);
      char label[96];
      std::snprintf(label, sizeof label, "margin %.1f sides (~%dx%d px), decimate %.0f", margin, w.width, w.height, dec);
      run(o, margin, frames, label);
    }
  }
  {
    for (float dec : {1.0f, 2.0f}) {
      DetectorOptions o;
      o.quad_decimate = dec;
      o.refine_edges = false;
      run(o, 1.0, frames, "margin 1.0, decimate " + std::to_string(static_cast<int>(dec)) + ", refine_edges off");
      o.refine_edges = true;
      o.decode_sharpening = 0.0;
      run(o, 1.0, frames, "margin 1.0, decimate " + std::to_string(static_cast<int>(dec)) + ", decode_sharpening 0");
    }
  }

  for (float dec : {1.0f, 2.0f}) {
  std::printf("\n### Corner refinement (after ROI detection, margin 1, decimate %.0f)\n\n", dec);
  std::printf("| corners | ms/frame (refine only) | found | mean dx px | mean dy px | rms px |\n|---|---|---|---|---|---|\n");
  DetectorOptions refine_opts;
  refine_opts.quad_decimate = dec;
  auto detector = TagDetector::Create(refine_opts);
  Row lib_row, plain_row, cam_row;
  struct PoseErr { double sq_mm = 0, sq_deg = 0, max_mm = 0; int n = 0; };
  PoseErr pose_lib, pose_ref;
  for (const auto& f : shots) {
    const FindResult r = detector.detector->Find(f.image, tag.id, Window(f.corners_px, 1.0));
    ++lib_row.tried, ++plain_row.tried, ++cam_row.tried;
    if (r.status != DetectStatus::kOk) continue;
    ++lib_row.found;
    lib_row.Add(r.detection->corners_px, f.corners_px);
    double t0 = NowMs();
    const auto plain = RefineTagCorners(f.image, r.detection->corners_px, nullptr);
    plain_row.ms += NowMs() - t0;
    if (plain.ok()) ++plain_row.found, plain_row.Add(plain.corners_px, f.corners_px);
    t0 = NowMs();
    const auto withcam = RefineTagCorners(f.image, r.detection->corners_px, &camera);
    cam_row.ms += NowMs() - t0;
    if (withcam.ok()) ++cam_row.found, cam_row.Add(withcam.corners_px, f.corners_px);
    for (auto [corners, acc] : {std::pair{r.detection->corners_px, &pose_lib}, std::pair{withcam.corners_px, &pose_ref}}) {
      const auto p = MeasureTagPose(camera, tag, corners);
      if (!p.ok()) continue;
      const double e_mm = 1e3 * (p.T_world_tag.translation() - f.T_world_tag.translation()).norm();
      const double e_deg = WrapAngle(p.T_world_tag.heading() - f.T_world_tag.heading()) * 180 / M_PI;
      acc->sq_mm += e_mm * e_mm, acc->sq_deg += e_deg * e_deg, acc->max_mm = std::max(acc->max_mm, e_mm), ++acc->n;
    }
  }
  lib_row.Print("libapriltag (refine_edges on)");
  plain_row.Print("+ edge refinement, distorted image");
  cam_row.Print("+ edge refinement, undistorted lines");
  std::printf("\n### Planar pose per single frame (true camera mount, decimate %.0f)\n\n", dec);
  std::printf("| corners | rms position mm | max position mm | rms heading deg |\n|---|---|---|---|\n");
  for (auto [label, acc] : {std::pair{"libapriltag", &pose_lib}, std::pair{"refined", &pose_ref}}) {
    std::printf("| %s | %.4f | %.4f | %.4f |\n", label, std::sqrt(acc->sq_mm / acc->n), acc->max_mm,
                std::sqrt(acc->sq_deg / acc->n));
  }
  }

  // H.264 round trip: a moving robot (0.3 m/s, 4 ms exposure) written with
  // Mp4Writer, decoded back; decode-only vs decode + track + refine + pose.
  const std::string path = "/tmp/odocal_vision_bench.mp4";
  {
    RenderOptions mo = ro;
    mo.exposure_s = 0.004;
    auto moving_renderer = Renderer::Create(camera, tag, mo);
    media::Mp4Writer writer;
    const auto st = writer.Open(path, 30.0, cv::Size(1920, 1080));
    if (!st.ok()) {
      std::printf("\nH.264: %s\n", st.message.c_str());
      return 0;
    }
    std::vector<Pose2> truth;
    auto traj = [](double t) { return Pose2::FromXYHeading(-0.9 + 0.3 * t, -1.0 + 0.02 * t, 0.2 * t); };
    const int n_video = 90;
    for (int i = 0; i < n_video; ++i) {
      const RenderedFrame f = moving_renderer.renderer->RenderExposure(traj, i / 30.0);
      writer.Write(f.image, i / 30.0);
      truth.push_back(f.T_world_tag);
    }
    writer.Close();
    media::VideoReader reader;
    reader.Open(path);
    cv::Mat grey;
    double t0 = NowMs();
    int decoded = 0;
    while (reader.Read(&grey)) ++decoded;
    const double decode_ms = (NowMs() - t0) / decoded;
    media::VideoReader reader2;
    reader2.Open(path);
    auto det = TagDetector::Create(DetectorOptions{});
    TagTracker tracker(det.detector.get(), tag.id);
    double sq_mm = 0, max_mm = 0, sq_deg = 0;
    int measured = 0, i = 0;
    t0 = NowMs();
    while (reader2.Read(&grey)) {
      const TrackResult tr = tracker.Track(grey);
      if (tr.find.status == DetectStatus::kOk) {
        const auto ref = RefineTagCorners(grey, tr.find.detection->corners_px, &camera);
        const auto p = MeasureTagPose(camera, tag, ref.corners_px);
        if (p.ok() && i < static_cast<int>(truth.size())) {
          const double e = 1e3 * (p.T_world_tag.translation() - truth[i].translation()).norm();
          const double h = WrapAngle(p.T_world_tag.heading() - truth[i].heading()) * 180 / M_PI;
          sq_mm += e * e, max_mm = std::max(max_mm, e), sq_deg += h * h, ++measured;
        }
      }
      ++i;
    }
    const double full_ms = (NowMs() - t0) / i;
    std::printf("\n### H.264 1080p clip (%d frames, moving robot, Mp4Writer defaults)\n\n", decoded);
    std::printf("| path | ms/frame | frames/s |\n|---|---|---|\n");
    std::printf("| decode only | %.2f | %.1f |\n", decode_ms, 1000.0 / decode_ms);
    std::printf("| decode + track + refine + planar pose | %.2f | %.1f |\n", full_ms, 1000.0 / full_ms);
    std::printf("\nPose from decoded H.264 frames vs truth: %d/%d measured, rms %.4f mm, max %.4f mm, "
                "rms heading %.4f deg\n", measured, i, std::sqrt(sq_mm / std::max(1, measured)), max_mm,
                std::sqrt(sq_deg / std::max(1, measured)));
    if (!std::getenv("ODOCAL_KEEP_VIDEO")) std::remove(path.c_str());
  }

  // Static robot through H.264: the mean of a rest window's poses vs truth
  // (is the compression biased?). 30 frames (1 s) per position.
  for (int crf : {-1, 18, 12, 6}) {
  double encode_ms = 0;
  int encode_clips = 0;
  media::Mp4WriterOptions wo;
  if (crf >= 0) wo.backend = media::Mp4WriterOptions::Backend::kFfmpegCli, wo.crf = crf;
  std::printf("\n### H.264 (%s), static robot, mean of 30 frames vs truth\n\n",
              crf < 0 ? "OpenCV VideoWriter, x264 default CRF 23" : ("ffmpeg CLI, CRF " + std::to_string(crf)).c_str());
  std::printf("| position | mean error x mm | mean error y mm | mean error heading deg |\n|---|---|---|---|\n");
  for (const Pose2& truth : {Pose2::FromXYHeading(0.02, -1.0, 0.4), Pose2::FromXYHeading(-1.05, -0.6, -2.0),
                             Pose2::FromXYHeading(1.0, -1.45, 2.9), Pose2::FromXYHeading(0.5, -0.7, 1.3)}) {
    media::Mp4Writer writer;
    if (const auto st = writer.Open(path, 30.0, cv::Size(1920, 1080), wo); !st.ok()) {
      std::printf("| %s |\n", st.message.c_str());
      break;
    }
    std::vector<cv::Mat> clip;
    for (int i = 0; i < 30; ++i) clip.push_back(created.renderer->Render(truth).image);
    const double e0 = NowMs();
    for (int i = 0; i < 30; ++i) writer.Write(clip[i], i / 30.0);
    writer.Close();
    encode_ms += (NowMs() - e0) / 30.0;
    ++encode_clips;
    media::VideoReader reader;
    reader.Open(path);
    auto det = TagDetector::Create(DetectorOptions{});
    TagTracker tracker(det.detector.get(), tag.id);
    cv::Mat grey;
    double sx = 0, sy = 0, sh = 0;
    int n = 0;
    while (reader.Read(&grey)) {
      const TrackResult tr = tracker.Track(grey);
      if (tr.find.status != DetectStatus::kOk) continue;
      const auto ref = RefineTagCorners(grey, tr.find.detection->corners_px, &camera);
      const auto p = MeasureTagPose(camera, tag, ref.corners_px);
      if (!p.ok()) continue;
      sx += p.T_world_robot.x() - truth.x(), sy += p.T_world_robot.y() - truth.y();
      sh += WrapAngle(p.T_world_robot.heading() - truth.heading()), ++n;
    }
    std::printf("| (%.2f, %.2f) m, %.1f deg | %+.4f | %+.4f | %+.5f |\n", truth.x(), truth.y(),
                truth.heading() * 180 / M_PI, 1e3 * sx / n, 1e3 * sy / n, sh / n * 180 / M_PI);
  }
  std::printf("\nEncoding: %.1f ms per 1080p frame.\n", encode_ms / std::max(1, encode_clips));
  }
  std::remove(path.c_str());
  return 0;
}
