// Rest-pose accuracy on images odocal did not design:
// for each camera preset (image_formation.h) and a standard scene -- the
// issue's standard camera (1920x1080, fx 1400, k1 -0.12, 2 m high, pitch 3
// deg), the 80 mm tag at 150 mm resting at `places` places and headings,
// headings 0 and 90 deg among them (edges parallel to the pixel grid) --
// renders `frames` frames per rest, passes them through the preset's codec,
// detects, refines and measures each rest's mean planar pose with the true
// camera, and prints the error against the rendered truth per estimator:
// mean and max position error (mm), mean and max |heading error| (deg), and
// the bias over all rests (mean error) against their spread (1 sigma).
//
//   camera_profiles_bench [frames=10] [places=12] [seed=1]
//
// ODOCAL_BENCH_ONLY_PRESETS=1: the preset table alone, pipeline estimator.
// ODOCAL_BENCH_TAG_SIZES=1: machine-vision and webcam with the tag 80-240 mm
// wide, to say how many pixels a target needs.
//
// Then the PSF sweep: the webcam preset with a Gaussian, a disk and a
// disk+Gaussian PSF of equal width (per-axis sigma 0.8 px), with its noise
// and codec, and again without them (2 frames a rest), where what is left
// is each estimator's bias.
// Figures in docs/vision.md ("Images odocal did not design").
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "odocal/media/video.h"
#include "odocal/base/units.h"
#include "odocal/vision/corner_refine.h"
#include "odocal/vision/detector.h"
#include "odocal/vision/edge_quality.h"
#include "odocal/vision/image_formation.h"
#include "odocal/vision/planar_pose.h"
#include "odocal/vision/renderer.h"

using odocal::calibration::Pose2;
using odocal::calibration::WrapAngle;
using namespace odocal::vision;
namespace media = odocal::media;
using odocal::kRadToDeg;

namespace {

CameraModel StandardCamera() {
  return CameraModel(Intrinsics{1920, 1080, 1400.0, 1400.0, 960.0, 540.0, {-0.12, 0.05, 0.0, 0.0, 0.0}},
                     CameraMount{0.0, -1000.0, 2000.0, 0.0, 3.0, 0.0});
}

TagSpec StandardTag(double size_mm = 80.0) {
  TagSpec tag;
  tag.family = "tag36h11";
  tag.id = 5;
  tag.size_mm = size_mm;
  tag.height_mm = 150.0;
  return tag;
}

struct Estimator {
  std::string name;
  std::function<std::optional<TagCorners>(const cv::Mat&, const TagCorners&, const CameraModel&)> refine;
};

struct Summary {
  std::vector<double> ex, ey, eh;  // per rest: mean error, mm and deg
  // per rest: the stated sigma of the mean (frames' spread / sqrt(n), and
  // with the closure's shared error added: EstimateRestCornerError)
  std::vector<double> spread_p, spread_h, stated_p, stated_h;
  int frames_used = 0, frames_tried = 0, rests_refused = 0;
};

void Print(const std::string& label, const std::string& estimator, const Summary& s) {
  const size_t n = s.ex.size();
  if (n == 0) {
    std::printf("| %s | %s | no rest measured | | | | | |\n", label.c_str(), estimator.c_str());
    return;
  }
  double mp = 0, xp = 0, mh = 0, xh = 0, bx = 0, by = 0, bh = 0;
  for (size_t i = 0; i < n; ++i) {
    const double p = std::hypot(s.ex[i], s.ey[i]);
    mp += p / n, xp = std::max(xp, p), mh += std::abs(s.eh[i]) / n, xh = std::max(xh, std::abs(s.eh[i]));
    bx += s.ex[i] / n, by += s.ey[i] / n, bh += s.eh[i] / n;
  }
  double sx = 0, sy = 0, sh = 0;
  for (size_t i = 0; i < n; ++i) {
    sx += std::pow(s.ex[i] - bx, 2), sy += std::pow(s.ey[i] - by, 2), sh += std::pow(s.eh[i] - bh, 2);
  }
  const double dof = std::max<size_t>(1, n - 1);
  std::printf("| %s | %s | %.4f | %.4f | %.5f | %.5f | %+.4f, %+.4f ± %.4f, %.4f | %+.5f ± %.5f | %zu/%d |\n",
              label.c_str(), estimator.c_str(), mp, xp, mh, xh, bx, by, std::sqrt(sx / dof),
              std::sqrt(sy / dof), bh, std::sqrt(sh / dof), n, static_cast<int>(n) + s.rests_refused);
  // Do the stated sigmas cover the errors? RMS of error / sigma (1 when
  // honest) and the largest, with the spread alone and with the closure.
  auto z = [&](const std::vector<double>& sig_p, const std::vector<double>& sig_h) {
    double rp = 0, rh = 0, mxp = 0, mxh = 0;
    for (size_t i = 0; i < n; ++i) {
      // position: the 2-D error over the 2-D sigma
      const double zp = std::hypot(s.ex[i], s.ey[i]) / std::max(1e-9, sig_p[i]);
      const double zh = std::abs(s.eh[i]) / std::max(1e-9, sig_h[i]);
      rp += zp * zp / n, rh += zh * zh / n, mxp = std::max(mxp, zp), mxh = std::max(mxh, zh);
    }
    char buf[160];
    std::snprintf(buf, sizeof(buf), "z rms/max pos %.2f/%.2f heading %.2f/%.2f", std::sqrt(rp), mxp,
                  std::sqrt(rh), mxh);
    return std::string(buf);
  };
  auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    return v[v.size() / 2];
  };
  std::printf("|   | sigma: spread only (median %.4f mm, %.5f deg): %s; with closure (median %.4f mm, %.5f deg): %s |\n",
              median(s.spread_p), median(s.spread_h), z(s.spread_p, s.spread_h).c_str(), median(s.stated_p),
              median(s.stated_h), z(s.stated_p, s.stated_h).c_str());
}

// One preset: every rest rendered, coded, measured by every estimator.
void RunPreset(const std::string& label, const ImageFormationOptions& formation, int frames,
               int places, uint64_t seed, const std::vector<Estimator>& estimators,
               double tag_size_mm = 80.0) {
  const CameraModel camera = StandardCamera();
  const TagSpec tag = StandardTag(tag_size_mm);
  RenderOptions ro;
  ro.noise_sigma = 2.0;
  ro.blur_sigma_px = 0.8;
  ro.seed = seed;
  ro.formation = formation;
  auto created = Renderer::Create(camera, tag, ro);
  if (!created.ok()) {
    std::printf("cannot render: %s\n", created.message.c_str());
    return;
  }
  auto detector = TagDetector::Create(DetectorOptions{}).detector;
  std::mt19937 rng(static_cast<uint32_t>(seed * 7 + 1));
  std::uniform_real_distribution<double> ux(-0.75, 0.75), uy(-1.35, -0.65), uh(-M_PI, M_PI);
  std::vector<Summary> summaries(estimators.size());
  for (int p = 0; p < places; ++p) {
    // Every third rest at a heading that puts the edges parallel to the
    // pixel rows and columns (the hard case of docs/vision.md).
    const double heading = p % 3 == 0 ? (p % 2 ? M_PI / 2 : 0.0) + 0.002 * p : uh(rng);
    const Pose2 pose = Pose2::FromXYHeading(ux(rng), uy(rng), heading);
    std::vector<cv::Mat> images;
    RenderedFrame truth;
    for (int k = 0; k < frames; ++k) {
      truth = created.renderer->Render(pose);
      images.push_back(truth.image);
    }
    const auto coded = media::CodecRoundTrip(images, formation.codec, 30.0);
    if (!coded) {
      std::printf("codec: %s\n", coded.message.c_str());
      return;
    }
    for (size_t e = 0; e < estimators.size(); ++e) {
      std::vector<std::array<Eigen::Vector2d, 4>> closures;
      std::vector<Eigen::Vector3d> errors;  // per frame: x, y (mm), heading (deg)
      for (const cv::Mat& image : *coded) {
        ++summaries[e].frames_tried;
        const FindResult found = detector->Find(image, tag.id);
        if (found.status != DetectStatus::kOk) continue;
        const auto corners = estimators[e].refine(image, found.detection->corners_px, camera);
        if (!corners) continue;
        const PlanarPoseResult m = MeasureTagPose(camera, tag, *corners);
        if (!m.ok()) continue;
        closures.push_back(m.closure_mm);
        errors.emplace_back((m.T_world_robot.x() - pose.x()) * 1e3, (m.T_world_robot.y() - pose.y()) * 1e3,
                            WrapAngle(m.T_world_robot.heading() - pose.heading()) * kRadToDeg);
      }
      const int n = static_cast<int>(errors.size());
      summaries[e].frames_used += n;
      if (2 * n < frames) {
        ++summaries[e].rests_refused;
        continue;
      }
      Eigen::Vector3d mean = Eigen::Vector3d::Zero(), var = Eigen::Vector3d::Zero();
      for (const auto& v : errors) mean += v / n;
      for (const auto& v : errors) var += (v - mean).cwiseAbs2() / std::max(1, n - 1);
      summaries[e].ex.push_back(mean.x());
      summaries[e].ey.push_back(mean.y());
      summaries[e].eh.push_back(mean.z());
      const RestCornerError shared = EstimateRestCornerError(closures, tag, pose.heading());
      const double spread_p = std::sqrt((var.x() + var.y()) / n);
      const double spread_h = std::sqrt(var.z() / n);
      summaries[e].spread_p.push_back(spread_p);
      summaries[e].spread_h.push_back(spread_h);
      summaries[e].stated_p.push_back(std::sqrt(spread_p * spread_p + 1e6 * (shared.shared_covariance(0, 0) +
                                                                               shared.shared_covariance(1, 1))));
      summaries[e].stated_h.push_back(
          std::hypot(spread_h, std::sqrt(shared.shared_covariance(2, 2)) * kRadToDeg));
    }
  }
  for (size_t e = 0; e < estimators.size(); ++e) Print(label, estimators[e].name, summaries[e]);
}

// Every camera preset and the webcam with MJPEG q80 instead of H.264.
void RunPresetTable(int frames, int places, uint64_t seed, const std::vector<Estimator>& estimators) {
  RunPreset("odocal renderer", ImageFormationOptions{}, frames, places, seed, estimators);
  for (const std::string& name : ImageFormationPresetNames())
    RunPreset(name, *ImageFormationPreset(name), frames, places, seed, estimators);
  ImageFormationOptions mjpeg = *ImageFormationPreset("webcam");
  mjpeg.codec = {CodecOptions::Kind::kMjpeg, 23, 80};
  RunPreset("webcam, MJPEG q80", mjpeg, frames, places, seed, estimators);
}

}  // namespace

int main(int argc, char** argv) {
  const int frames = argc > 1 ? std::atoi(argv[1]) : 10;
  const int places = argc > 2 ? std::atoi(argv[2]) : 12;
  const uint64_t seed = argc > 3 ? std::strtoull(argv[3], nullptr, 10) : 1;
  const std::vector<Estimator> estimators = {
      {"half-level (per frame)",
       [](const cv::Mat& im, const TagCorners& c, const CameraModel& cam) -> std::optional<TagCorners> {
         const auto r = RefineTagCorners(im, c, &cam);
         if (!r.ok()) return std::nullopt;
         return r.corners_px;
       }},
      {"exact Gaussian model",
       [](const cv::Mat& im, const TagCorners& c, const CameraModel& cam) -> std::optional<TagCorners> {
         const auto r0 = RefineTagCorners(im, c, &cam);
         if (!r0.ok()) return std::nullopt;
         const auto r = RefineTagCornersByEdgeModel(im, r0.corners_px, &cam);
         if (!r.ok()) return std::nullopt;
         return r.corners_px;
       }},
      {"PSF/tone-free (symmetric ESF)",
       [](const cv::Mat& im, const TagCorners& c, const CameraModel& cam) -> std::optional<TagCorners> {
         const auto r0 = RefineTagCorners(im, c, &cam);
         if (!r0.ok()) return std::nullopt;
         const auto r = RefineTagCornersModelFree(im, r0.corners_px, &cam);
         if (!r.ok()) return std::nullopt;
         return r.corners_px;
       }},
  };
  std::printf("%d frames a rest, %d rests, seed %llu; errors against rendered truth, true camera\n\n",
              frames, places, static_cast<unsigned long long>(seed));
  std::printf("| preset | estimator | pos mean mm | pos max mm | |heading| mean deg | max deg | bias x, y ± spread mm | bias heading ± spread deg | rests |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|\n");
  if (std::getenv("ODOCAL_BENCH_TAG_SIZES")) {
    // How large must the tag be in the image for a target? The lossy
    // presets with the tag printed 80, 120, 160 and 240 mm wide (about 60,
    // 90, 120 and 180 px in this camera), the pipeline's estimator only.
    for (const std::string name : {"machine-vision", "webcam"}) {
      for (const double size : {80.0, 120.0, 160.0, 240.0}) {
        char label[96];
        std::snprintf(label, sizeof(label), "%s, tag %.0f mm (%.0f px)", name.c_str(), size,
                      size * 1400.0 / (2000.0 - 150.0));
        RunPreset(label, *ImageFormationPreset(name), frames, places, seed, {estimators.back()}, size);
      }
    }
    return 0;
  }
  if (std::getenv("ODOCAL_BENCH_ONLY_PRESETS")) {
    // Quick look: the presets only, the pipeline's estimator only.
    RunPresetTable(frames, places, seed, {estimators.back()});
    return 0;
  }
  RunPresetTable(frames, places, seed, estimators);
  std::printf("\nPSF sweep: webcam preset, equal per-axis width 0.8 px\n\n");
  std::printf("| PSF | estimator | pos mean mm | pos max mm | |heading| mean deg | max deg | bias x, y ± spread mm | bias heading ± spread deg | rests |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|\n");
  for (const PsfOptions& psf : {PsfOptions{PsfOptions::Model::kGaussian, 0.0, 0.8},
                                PsfOptions{PsfOptions::Model::kDisk, 1.6, 0.0},
                                PsfOptions{PsfOptions::Model::kDiskGaussian, 1.2, std::sqrt(0.64 - 0.36)}}) {
    ImageFormationOptions f = *ImageFormationPreset("webcam");
    f.psf = psf;
    RunPreset(ToString(psf.model), f, frames, places, seed, estimators);
  }
  // The same without noise and codec: what is left is the estimators' bias.
  std::printf("\nPSF sweep without noise and codec (webcam optics and tone: gamma 2.2, Bayer, shading)\n\n");
  std::printf("| PSF | estimator | pos mean mm | pos max mm | |heading| mean deg | max deg | bias x, y ± spread mm | bias heading ± spread deg | rests |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|\n");
  for (const PsfOptions& psf : {PsfOptions{PsfOptions::Model::kGaussian, 0.0, 0.8},
                                PsfOptions{PsfOptions::Model::kDisk, 1.6, 0.0},
                                PsfOptions{PsfOptions::Model::kDiskGaussian, 1.2, std::sqrt(0.64 - 0.36)}}) {
    ImageFormationOptions f = *ImageFormationPreset("webcam");
    f.psf = psf;
    f.noise = SensorNoiseOptions{0.0, 1e9};
    f.codec = CodecOptions{};
    RunPreset(ToString(psf.model), f, 2, places, seed, estimators);
  }
  return 0;
}
