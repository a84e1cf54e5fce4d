// What a rest's error is made of, and which statement of it is honest:
// rests at random places and headings on the segment-video test's camera
// (640x360, fx 933, k1 -0.12, 2 m, pitch 3 deg; the 80 mm tag at 150 mm is
// 40 px wide) or the standard 1080p camera of docs/vision.md, `frames` frames
// each through the camera's codec, measured with the pipeline's refinement
// (half-level, then PSF/tone-free) and the true camera. Per rest: the mean
// pose's error against the rendered truth; the mean corner error on the
// tag's plane split into its 8 orthonormal modes (translation x, y,
// rotation, scale, the closure's rectangle mode and its three others);
// and the rest's sigma as stated four ways:
//   spread       the frames' spread / sqrt(n) alone;
//   bounds       + vision::EstimateRestCornerError's shared_covariance (the
//                edge model's bounds: what batch states);
//   expected     + its expected_shared_covariance (each corner its own
//                error: what setup-check predicts with);
//   edge split   + the edge model with the closure split into its offset
//                mode (position) and angle modes (heading) (a diagnostic).
// Pooled over the rests: RMS error / RMS stated (1 = honest), with the 95 %
// interval the rests' number allows (chi-square on the errors).
//
//   rest_error_bench [frames=12] [rests=60] [seed=1] [camera=all] [1080]
//   rest_error_bench --videos SIM_DIR...   (the rests of rendered sessions)
//
// camera: renderer (the tests' renderer: noise 0.5, blur 0.8, H.264 CRF 12),
// renderer-nocodec, machine-vision, webcam, webcam-mjpeg, phone, or all.
// ODOCAL_BENCH_VERBOSE=1 prints every rest. Figures in docs/vision.md
// ("What a rest's error is made of").
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "odocal/base/units.h"
#include "odocal/media/video.h"
#include "odocal/vision/corner_refine.h"
#include "odocal/vision/detector.h"
#include "odocal/vision/edge_quality.h"
#include "odocal/vision/image_formation.h"
#include "odocal/vision/planar_pose.h"
#include "odocal/vision/renderer.h"

using odocal::calibration::Pose2;
using odocal::calibration::WrapAngle;
using namespace odocal::vision;
using odocal::kRadToDeg;

namespace {

// Wilson-Hilferty: the q quantile (0.025 or 0.975) of chi-square, k dof.
double Chi2Quantile(double q, double k) {
  const double z = q < 0.5 ? -1.959964 : 1.959964;
  return k * std::pow(1.0 - 2.0 / (9.0 * k) + z * std::sqrt(2.0 / (9.0 * k)), 3);
}

struct Sums {
  double err = 0.0;  // squared errors (per axis for position)
  double spread = 0.0, bounds = 0.0, expected = 0.0, split = 0.0;  // stated variances
};

void RunCamera(const std::string& name, int frames, int rests, uint64_t seed, bool standard, bool verbose) {
  const CameraModel camera =
      standard ? CameraModel(Intrinsics{1920, 1080, 1400.0, 1400.0, 960.0, 540.0, {-0.12, 0.05, 0.0, 0.0, 0.0}},
                             CameraMount{0.0, 0.0, 2000.0, 0.0, 3.0, 0.0})
               : CameraModel(Intrinsics{640, 360, 933.3, 933.3, 320.0, 180.0, {-0.12, 0.05, 0.0, 0.0, 0.0}},
                             CameraMount{0.0, 0.0, 2000.0, 0.0, 3.0, 0.0});
  TagSpec tag;
  tag.family = "tag36h11";
  tag.id = 5;
  tag.size_mm = 80.0;
  tag.height_mm = 150.0;
  RenderOptions ro;
  ro.noise_sigma = 0.5;
  ro.blur_sigma_px = 0.8;
  ro.seed = seed;
  if (name == "renderer") {
    ro.formation.codec = {CodecOptions::Kind::kH264, 12, 80};
  } else if (name == "renderer-nocodec") {
  } else if (name == "webcam-mjpeg") {
    ro.formation = *ImageFormationPreset("webcam");
    ro.formation.codec = {CodecOptions::Kind::kMjpeg, 23, 80};
  } else if (const auto preset = ImageFormationPreset(name)) {
    ro.formation = *preset;
  } else {
    std::printf("unknown camera %s\n", name.c_str());
    return;
  }
  auto created = Renderer::Create(camera, tag, ro);
  if (!created.ok()) {
    std::printf("cannot render: %s\n", created.message.c_str());
    return;
  }
  auto detector = TagDetector::Create(DetectorOptions{}).detector;
  const double grid_deg = std::getenv("ODOCAL_BENCH_GRID") ? std::atof(std::getenv("ODOCAL_BENCH_GRID")) : 0.0;
  const double grid_min_deg =
      std::getenv("ODOCAL_BENCH_GRID_MIN") ? std::atof(std::getenv("ODOCAL_BENCH_GRID_MIN")) : 0.0;
  std::mt19937 rng(static_cast<uint32_t>(seed * 7 + 1));
  const double half_x = standard ? 0.75 : 0.4, half_y = standard ? 0.35 : 0.18;
  std::uniform_real_distribution<double> ux(-half_x, half_x), uy(-half_y, half_y), uh(-M_PI, M_PI);
  const double L = tag.size_mm, h = 0.5 * L;  // mm
  const double cx[4] = {-h, h, h, -h}, cy[4] = {-h, -h, h, h};  // TagCornersInTag
  Sums pos, head;
  double modes[6] = {0, 0, 0, 0, 0, 0};  // tx, ty, rotation, scale, rectangle, each other closure mode
  int used = 0;
  for (int r = 0; r < rests; ++r) {
    // ODOCAL_BENCH_GRID=D (and ODOCAL_BENCH_GRID_MIN=M): headings M to D deg
    // off the pixel grid (a multiple of 90 deg: a square plan aligned with
    // the camera).
    double heading = uh(rng);
    if (grid_deg > 0.0) {
      // |angle to the grid| uniform in [grid_min_deg, grid_deg], either sign.
      const double u = std::abs(std::fmod(heading * 1e3, 1.0));
      const double off = grid_min_deg + u * (grid_deg - grid_min_deg);
      heading = std::round(heading / (M_PI / 2)) * (M_PI / 2) + (std::fmod(heading * 1e4, 2.0) < 0 ? -off : off) / kRadToDeg;
    }
    const Pose2 pose = Pose2::FromXYHeading(ux(rng), uy(rng), heading);
    std::vector<cv::Mat> images;
    RenderedFrame truth;
    for (int k = 0; k < frames; ++k) {
      truth = created.renderer->Render(pose);
      images.push_back(truth.image);
    }
    const auto coded = odocal::media::CodecRoundTrip(images, ro.formation.codec, 15.0);
    if (!coded) {
      std::printf("codec: %s\n", coded.message.c_str());
      return;
    }
    // The true corners on the tag's plane; the measured ones' mean error
    // there, in the tag's frame (mm).
    std::array<Eigen::Vector2d, 4> true_plane{}, corner_err{};
    for (int k = 0; k < 4; ++k) {
      true_plane[k] = camera.UnprojectToWorldPlane({truth.corners_px[k].x, truth.corners_px[k].y}, tag.height_m())
                          ->head<2>();
      corner_err[k].setZero();
    }
    const Eigen::Rotation2Dd to_tag(-truth.T_world_tag.heading());
    std::vector<Eigen::Vector3d> errs;
    std::vector<std::array<Eigen::Vector2d, 4>> closures;
    for (const cv::Mat& image : *coded) {
      const FindResult found = detector->Find(image, tag.id);
      if (found.status != DetectStatus::kOk) continue;
      const auto half = RefineTagCorners(image, found.detection->corners_px, &camera);
      if (!half.ok()) continue;
      const auto exact = RefineTagCornersModelFree(image, half.corners_px, &camera);
      if (!exact.ok()) continue;
      const PlanarPoseResult m = MeasureTagPose(camera, tag, exact.corners_px);
      if (!m.ok()) continue;
      for (int k = 0; k < 4; ++k)
        corner_err[k] += to_tag * (camera.UnprojectToWorldPlane({exact.corners_px[k].x, exact.corners_px[k].y},
                                                                tag.height_m())->head<2>() - true_plane[k]) * 1e3;
      errs.emplace_back((m.T_world_robot.x() - pose.x()) * 1e3, (m.T_world_robot.y() - pose.y()) * 1e3,
                        WrapAngle(m.T_world_robot.heading() - pose.heading()) * kRadToDeg);
      closures.push_back(m.closure_mm);
    }
    const int n = static_cast<int>(errs.size());
    if (2 * n < frames || n < 2) continue;
    ++used;
    for (auto& c : corner_err) c /= n;
    Eigen::Vector3d mean = Eigen::Vector3d::Zero(), var = Eigen::Vector3d::Zero();
    for (const auto& e : errs) mean += e / n;
    for (const auto& e : errs) var += (e - mean).cwiseAbs2() / (n - 1);
    // The mean corner error's energy per orthonormal mode.
    auto energy = [&](auto fx, auto fy) {
      double dot = 0, norm = 0;
      for (int k = 0; k < 4; ++k) {
        dot += corner_err[k].x() * fx(k) + corner_err[k].y() * fy(k);
        norm += fx(k) * fx(k) + fy(k) * fy(k);
      }
      return dot * dot / norm;
    };
    const double e_tx = energy([](int) { return 1.0; }, [](int) { return 0.0; });
    const double e_ty = energy([](int) { return 0.0; }, [](int) { return 1.0; });
    const double e_rot = energy([&](int k) { return -cy[k]; }, [&](int k) { return cx[k]; });
    const double e_sc = energy([&](int k) { return cx[k]; }, [&](int k) { return cy[k]; });
    const double e_re = energy([&](int k) { return cx[k]; }, [&](int k) { return -cy[k]; });
    double all = 0;
    for (const auto& c : corner_err) all += c.squaredNorm();
    const double each[6] = {e_tx, e_ty, e_rot, e_sc, e_re, (all - e_tx - e_ty - e_rot - e_sc - e_re) / 3.0};
    for (int k = 0; k < 6; ++k) modes[k] += each[k];
    // The closure's rectangle mode against the rest (the edge model's split):
    // shared part = mean closure less the frames' own share.
    std::array<Eigen::Vector2d, 4> mc{};
    for (auto& m : mc) m.setZero();
    for (const auto& c : closures)
      for (int k = 0; k < 4; ++k) mc[k] += c[k] / n;
    auto rect_and_rest = [&](const std::array<Eigen::Vector2d, 4>& c) {
      double dot = 0, sq = 0;
      for (int k = 0; k < 4; ++k) dot += (c[k].x() * cx[k] - c[k].y() * cy[k]) / (2.0 * std::sqrt(2.0) * h), sq += c[k].squaredNorm();
      return std::make_pair(dot * dot, sq - dot * dot);
    };
    const auto [mean_rect, mean_angle] = rect_and_rest(mc);
    double own_rect = 0, own_angle = 0;
    for (const auto& c : closures) {
      std::array<Eigen::Vector2d, 4> d;
      for (int k = 0; k < 4; ++k) d[k] = c[k] - mc[k];
      const auto [a, b] = rect_and_rest(d);
      own_rect += a / (n - 1), own_angle += b / (n - 1);
    }
    const double shared_rect = std::max(0.0, mean_rect - own_rect / n);
    const double shared_angle = std::max(0.0, mean_angle - own_angle / n);
    const RestCornerError rce = EstimateRestCornerError(closures, tag, pose.heading());
    const double spread_p = 0.5 * (var.x() + var.y()) / n, spread_h = var.z() / n;
    constexpr double kMm2 = 1e6, kDeg2 = kRadToDeg * kRadToDeg;
    pos.err += 0.5 * (mean.x() * mean.x() + mean.y() * mean.y());
    head.err += mean.z() * mean.z();
    pos.spread += spread_p, head.spread += spread_h;
    pos.bounds += spread_p + 0.5 * kMm2 * (rce.shared_covariance(0, 0) + rce.shared_covariance(1, 1));
    head.bounds += spread_h + kDeg2 * rce.shared_covariance(2, 2);
    pos.expected += spread_p + 0.5 * kMm2 * (rce.expected_shared_covariance(0, 0) + rce.expected_shared_covariance(1, 1));
    head.expected += spread_h + kDeg2 * rce.expected_shared_covariance(2, 2);
    pos.split += spread_p + shared_rect / 4.0;
    head.split += spread_h + shared_angle / (6.0 * L * L) * kDeg2;
    if (verbose)
      std::printf("  rest %3d: error %+.4f %+.4f mm %+.5f deg; spread %.4f mm %.5f deg; closure per coordinate "
                  "%.4f mm shared, %.4f own\n",
                  r, mean.x(), mean.y(), mean.z(), std::sqrt(spread_p), std::sqrt(spread_h), rce.sigma_shared_mm,
                  rce.sigma_independent_mm);
  }
  if (used == 0) {
    std::printf("| %s | no rest measured |\n", name.c_str());
    return;
  }
  // RMS error / RMS stated, and its 95 % interval from the errors' number
  // (2 per rest for position, x and y; 1 for heading).
  auto cell = [&](const Sums& s, double stated, int dof) {
    const double ratio = std::sqrt(s.err / stated);
    if (!(ratio < 1e4)) return std::string("∞ (frozen frames)");
    char buf[64];
    std::snprintf(buf, sizeof(buf), "%.2f (%.2f-%.2f)", ratio, ratio * std::sqrt(dof / Chi2Quantile(0.975, dof)),
                  ratio * std::sqrt(dof / Chi2Quantile(0.025, dof)));
    return std::string(buf);
  };
  const double u = used;
  const double closure_mode = (modes[4] + 3.0 * modes[5]) / 4.0;  // the closure's average mode
  std::printf("| %s | %d | %.4f, %.5f | %s; %s | %s; %s | **%s; %s** | %s; %s | %.2f, %.2f, %.2f |\n", name.c_str(),
              used, std::sqrt(pos.err / u), std::sqrt(head.err / u), cell(pos, pos.spread, 2 * used).c_str(),
              cell(head, head.spread, used).c_str(), cell(pos, pos.bounds, 2 * used).c_str(),
              cell(head, head.bounds, used).c_str(), cell(pos, pos.expected, 2 * used).c_str(),
              cell(head, head.expected, used).c_str(), cell(pos, pos.split, 2 * used).c_str(),
              cell(head, head.split, used).c_str(), 0.5 * (modes[0] + modes[1]) / closure_mode,
              modes[2] / closure_mode, modes[4] / closure_mode);
  std::fflush(stdout);
}

// The rests of videos `odocal simulate` rendered (DIR/recording.mp4 with its
// per-frame truth DIR/recording.frames.csv) on the segment-video test's
// 640x360 camera (or its 1280x720 variant, fx 1400), as the truth has it: each rest (the robot's true pose
// unchanged for 10 frames or more: the pauses at a square's corners left
// out) measured frame by frame as above, its mean against the truth. The
// first rest (before any motion) apart from the ones after motion, these
// in halves: a codec codes them from moving frames, and settles.
struct VideoClass {
  double err_p = 0, err_h = 0, exp_p = 0, exp_h = 0;
  int n = 0;
};

void RunVideo(const std::string& dir, std::array<VideoClass, 3>* classes) {
  CameraModel camera(Intrinsics{640, 360, 933.3, 933.3, 320.0, 180.0, {-0.12, 0.05, 0.0, 0.0, 0.0}},
                     CameraMount{0.0, 0.0, 2000.0, 0.0, 3.0, 0.0});
  TagSpec tag;
  tag.family = "tag36h11";
  tag.id = 5;
  tag.size_mm = 80.0;
  tag.height_mm = 150.0;
  std::ifstream csv(dir + "/recording.frames.csv");
  std::string line;
  std::getline(csv, line);
  std::vector<Eigen::Vector3d> truth;  // robot x, y (mm), heading (deg) per frame
  while (std::getline(csv, line)) {
    std::stringstream in(line);
    std::string cell;
    std::vector<double> v;
    while (std::getline(in, cell, ',')) v.push_back(std::stod(cell));
    truth.emplace_back(v[4], v[5], v[6]);
  }
  odocal::media::VideoReader reader;
  if (!reader.Open(dir + "/recording.mp4").ok()) {
    std::printf("%s: cannot open the video\n", dir.c_str());
    return;
  }
  auto detector = TagDetector::Create(DetectorOptions{}).detector;
  struct Frame {
    bool measured = false;
    Eigen::Vector3d error;  // mm, mm, deg
    std::array<Eigen::Vector2d, 4> closure;
  };
  std::vector<Frame> frames;
  cv::Mat grey;
  while (frames.size() < truth.size() && reader.Read(&grey)) {
    // The sweep's 720p variant: the same camera with fx 1400.
    if (frames.empty() && grey.cols == 1280)
      camera = CameraModel(Intrinsics{1280, 720, 1400.0, 1400.0, 640.0, 360.0, {-0.12, 0.05, 0.0, 0.0, 0.0}},
                           CameraMount{0.0, 0.0, 2000.0, 0.0, 3.0, 0.0});
    Frame f;
    const FindResult found = detector->Find(grey, tag.id);
    if (found.status == DetectStatus::kOk) {
      const auto half = RefineTagCorners(grey, found.detection->corners_px, &camera);
      const auto exact =
          half.ok() ? RefineTagCornersModelFree(grey, half.corners_px, &camera) : ModelFreeRefineResult{};
      if (exact.ok()) {
        const PlanarPoseResult m = MeasureTagPose(camera, tag, exact.corners_px);
        const Eigen::Vector3d& t = truth[frames.size()];
        if (m.ok()) {
          f.measured = true;
          f.error = Eigen::Vector3d(m.T_world_robot.x() * 1e3 - t.x(), m.T_world_robot.y() * 1e3 - t.y(),
                                    WrapAngle(m.T_world_robot.heading() - t.z() / kRadToDeg) * kRadToDeg);
          f.closure = m.closure_mm;
        }
      }
    }
    if (std::getenv("ODOCAL_BENCH_FRAMES") && f.measured)
      std::printf("    frame %zu: %+.4f %+.4f mm %+.5f deg\n", frames.size(), f.error.x(), f.error.y(), f.error.z());
    frames.push_back(f);
  }
  // Rests: runs of frames with the same true pose; the ones after motion
  // split in halves (just after the motion, then settled).
  size_t a = 0;
  auto add = [&](int cls, size_t from, size_t to) {
    std::vector<std::array<Eigen::Vector2d, 4>> closures;
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (size_t k = from; k <= to; ++k)
      if (frames[k].measured) mean += frames[k].error, closures.push_back(frames[k].closure);
    const int n = static_cast<int>(closures.size());
    if (n < 3) return;
    mean /= n;
    const RestCornerError rce = EstimateRestCornerError(closures, tag, truth[from].z() / kRadToDeg);
    VideoClass& c = (*classes)[cls];
    c.err_p += 0.5 * (mean.x() * mean.x() + mean.y() * mean.y());
    c.err_h += mean.z() * mean.z();
    c.exp_p += 0.5e6 * (rce.expected_shared_covariance(0, 0) + rce.expected_shared_covariance(1, 1));
    c.exp_h += rce.expected_shared_covariance(2, 2) * kRadToDeg * kRadToDeg;
    ++c.n;
    if (std::getenv("ODOCAL_BENCH_VERBOSE"))
      std::printf("  %s frames %zu-%zu: error %+.4f %+.4f mm %+.5f deg\n", dir.c_str(), from, to, mean.x(), mean.y(),
                  mean.z());
  };
  while (a < frames.size()) {
    size_t b = a;
    while (b + 1 < frames.size() && (truth[b + 1] - truth[a]).norm() < 1e-6) ++b;
    if (b - a + 1 >= 10) {  // a rest, not a pause at a square's corner
      if (a == 0) {
        add(0, a, b);
      } else {
        const size_t mid = (a + b) / 2;
        add(1, a, mid);
        add(2, mid + 1, b);
      }
    }
    a = b + 1;
  }
  std::fflush(stdout);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc > 2 && std::string(argv[1]) == "--videos") {
    std::array<VideoClass, 3> classes{};
    for (int k = 2; k < argc; ++k) RunVideo(argv[k], &classes);
    std::printf("%d videos, true camera; a rest's mean error against the truth, and the closure's expectation\n\n"
                "| rests | n | RMS error (mm per axis, deg) | expected (mm, deg) | error / expected |\n"
                "|---|---|---|---|---|\n", argc - 2);
    const char* names[3] = {"the first, before any motion", "after motion, first half", "after motion, second half"};
    for (int c = 0; c < 3; ++c) {
      const VideoClass& v = classes[c];
      if (v.n == 0) continue;
      std::printf("| %s | %d | %.4f, %.5f | %.4f, %.5f | %.2f, %.2f |\n", names[c], v.n, std::sqrt(v.err_p / v.n),
                  std::sqrt(v.err_h / v.n), std::sqrt(v.exp_p / v.n), std::sqrt(v.exp_h / v.n),
                  std::sqrt(v.err_p / v.exp_p), std::sqrt(v.err_h / v.exp_h));
    }
    return 0;
  }
  const int frames = argc > 1 ? std::atoi(argv[1]) : 12;
  const int rests = argc > 2 ? std::atoi(argv[2]) : 60;
  const uint64_t seed = argc > 3 ? std::strtoull(argv[3], nullptr, 10) : 1;
  const std::string which = argc > 4 ? argv[4] : "all";
  const bool standard = argc > 5 && std::string(argv[5]) == "1080";
  const bool verbose = std::getenv("ODOCAL_BENCH_VERBOSE") != nullptr;
  std::printf("%s camera, %d rests of %d frames, seed %llu; error / stated sigma, RMS over the rests (95 %%)\n\n",
              standard ? "1920x1080" : "640x360", rests, frames, static_cast<unsigned long long>(seed));
  std::printf("| camera | rests | RMS error (mm per axis, deg) | spread only: position; heading | bounds (batch) | "
              "expected (setup-check) | edge split | mode energy / the closure's mean: translation, rotation, "
              "rectangle |\n|---|---|---|---|---|---|---|---|\n");
  const std::vector<std::string> cameras =
      which == "all" ? std::vector<std::string>{"renderer-nocodec", "renderer", "machine-vision", "webcam",
                                                "webcam-mjpeg", "phone"}
                     : std::vector<std::string>{which};
  for (const std::string& name : cameras) RunCamera(name, frames, rests, seed, standard, verbose);
  return 0;
}
