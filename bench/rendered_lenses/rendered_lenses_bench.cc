// Kalibr's aprilgrid through lenses odocal's tests do not have (docs/vision.md,
// "Other lenses"): a webcam, a EuRoC-like global-shutter camera with strong
// barrel distortion, and two fisheyes (a TUM-VI-like 512 x 512 lens seeing
// 190 degrees, a 1280 x 800 action-camera-like one). For each, views of the
// board anywhere in the field, near and far, tilted: the tags fully in the
// image against those DetectBoard finds (as calibrate-camera's first pass,
// edges as straight lines, and its second, through the lens), and the
// corners against the rendered truth.
//
//   rendered_lenses_bench [--views N] [--seed S] [--lens NAME-PREFIX] [--verbose 1]
//                         [--write DIR] [--supersample N]
//
// --write DIR: each lens's views also written as a Kalibr/yac-style data set,
// DIR/<lens>/cam0/data/NNNNNN.png and DIR/<lens>/target.yaml (with cam0's
// dist_model), which real_photographs_bench reads as it reads real ones.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <cstdio>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "odocal/vision/board_render.h"
#include "odocal/vision/camera_calibration.h"

using namespace odocal::vision;
namespace fs = std::filesystem;

namespace {

struct Lens {
  std::string name;
  Intrinsics intrinsics;
  double max_off_axis_deg;  // board centres up to this far from the axis
  double near_m, far_m;     // board distances
};

std::vector<Lens> Lenses() {
  Intrinsics webcam{1280, 720, 920.0, 921.0, 641.0, 358.0, {0.08, -0.18, 0.0005, -0.0003, 0.1}};
  Intrinsics euroc{752, 480, 458.7, 457.3, 367.2, 248.4, {-0.283, 0.0740, 0.00019, 1.76e-05, 0.0}};
  Intrinsics tumvi{512, 512, 190.98, 190.97, 254.93, 256.90, {0.00348, 0.000715, -0.00205, 0.000203, 0.0}};
  tumvi.lens = LensModel::kEquidistant;
  Intrinsics action{1280, 800, 410.0, 410.5, 642.0, 398.0, {0.021, -0.012, 0.004, -0.0008, 0.0}};
  action.lens = LensModel::kEquidistant;
  return {{"webcam 1280x720 plumb_bob", webcam, 30.0, 0.9, 2.2},
          {"euroc-like 752x480 plumb_bob k1 -0.28", euroc, 35.0, 0.6, 1.6},
          {"tum-vi-like 512x512 equidistant 190 deg", tumvi, 60.0, 0.35, 0.9},
          {"action 1280x800 equidistant 170 deg", action, 65.0, 0.4, 1.2}};
}

struct Stats {
  double sum2 = 0.0, max = 0.0, mx = 0.0, my = 0.0;
  int n = 0;
  void Add(const cv::Point2d& e) {
    sum2 += e.dot(e) / 2.0;
    mx += e.x;
    my += e.y;
    max = std::max(max, std::hypot(e.x, e.y));
    ++n;
  }
  double Rms() const { return n ? std::sqrt(sum2 / n) : NAN; }
};

}  // namespace

int main(int argc, char** argv) {
  int views = 12;
  unsigned seed = 7;
  std::string only;
  bool verbose = false;
  std::string write_dir;
  int supersample = 8;  // the renderer's samples per axis in edge pixels (16 in the tests)
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i];
    if (a == "--views") views = std::stoi(argv[i + 1]);
    else if (a == "--seed") seed = static_cast<unsigned>(std::stoul(argv[i + 1]));
    else if (a == "--lens") only = argv[i + 1];
    else if (a == "--verbose") verbose = std::string(argv[i + 1]) != "0";
    else if (a == "--write") write_dir = argv[i + 1];
    else if (a == "--supersample") supersample = std::stoi(argv[i + 1]);
    else {
      std::fprintf(stderr, "usage: %s [--views N] [--seed S] [--lens NAME-PREFIX]\n", argv[0]);
      return 2;
    }
  }
  CalibrationBoard board;
  board.type = CalibrationBoard::Type::kAprilgrid;
  board.cols = 6;
  board.rows = 6;
  board.square_m = 0.088;
  board.spacing = 0.3;
  board.tag_family = "tag36h11b2";
  const auto pattern = AprilgridPattern(board);
  if (!pattern) return 1;
  std::vector<Eigen::Vector3d> truth_points;
  for (int id = 0; id < 36; ++id)
    for (int k = 0; k < 4; ++k)
      truth_points.push_back(AprilgridPointInPattern(board, *board.AprilgridCorner(id, k)));

  std::printf("| lens | views | tags fully in view | found, straight edges | found, through the lens | "
              "corners - truth rms / max [px], straight | through the lens | mean (x, y) through the lens [px] | "
              "tags with a corner > 0.1 px off, through the lens | error / stated sigma, rms |\n"
              "|---|---|---|---|---|---|---|---|---|---|\n");
  for (const Lens& lens : Lenses()) {
    if (!only.empty() && lens.name.rfind(only, 0) != 0) continue;
    int visible = 0, found_straight = 0, found_lens = 0, made = 0, bad_tags = 0;
    Stats straight, through, normalised;  // normalised: through the lens, error / stated sigma
    FieldPoseSampling sampling;
    sampling.count = views;
    sampling.seed = seed;
    sampling.max_off_axis_deg = lens.max_off_axis_deg;
    sampling.near_m = lens.near_m;
    sampling.far_m = lens.far_m;
    sampling.max_tilt_deg = 40.0;
    sampling.min_points_in_view = 32;  // 8 tags' worth of corners
    const auto poses = SampleFieldBoardPoses(lens.intrinsics, truth_points, sampling);
    if (!poses) {
      std::fprintf(stderr, "%s: no views\n", lens.name.c_str());
      return 1;
    }
    for (size_t attempt = 0; attempt < poses->size(); ++attempt) {
      const Eigen::Isometry3d& T = (*poses)[attempt];
      BoardRenderOptions o;
      o.seed = seed * 1000 + static_cast<uint64_t>(attempt);
      o.supersample = supersample;
      const auto r = RenderBoard(lens.intrinsics, *pattern, T, truth_points, o);
      if (!r.ok()) continue;
      // The tags whose four corners are in the image (3 px in) and in front.
      std::vector<bool> in_view(36, false);
      int n_in = 0;
      for (int id = 0; id < 36; ++id) {
        bool in = true;
        for (int k = 0; k < 4; ++k) {
          const cv::Point2d p = r.frame.points_px[4 * id + k];
          const Eigen::Vector3d pc = T * truth_points[4 * id + k];
          in = in && pc.z() > 0.05 && std::isfinite(p.x) && p.x > 3 && p.y > 3 &&
               p.x < lens.intrinsics.width - 4 && p.y < lens.intrinsics.height - 4;
        }
        in_view[id] = in;
        n_in += in;
      }
      ++made;
      if (!write_dir.empty()) {
        const fs::path set = fs::path(write_dir) / lens.name.substr(0, lens.name.find(' '));
        fs::create_directories(set / "cam0" / "data");
        char name[32];
        std::snprintf(name, sizeof(name), "%06d.png", made);
        cv::imwrite((set / "cam0" / "data" / name).string(), r.frame.image);
        std::ofstream yaml(set / "target.yaml");
        yaml << "# rendered by rendered_lenses_bench: " << lens.name << "\n"
             << "calib_target:\n  target_type: 'aprilgrid'\n  tag_rows: 6\n  tag_cols: 6\n  tag_size: 0.088\n"
             << "  tag_spacing: 0.3\n\ncam0:\n  resolution: [" << lens.intrinsics.width << ", "
             << lens.intrinsics.height << "]\n  proj_model: \"pinhole\"\n  dist_model: \""
             << (lens.intrinsics.lens == LensModel::kEquidistant ? "equi4" : "radtan4") << "\"\n";
      }
      visible += n_in;
      BoardDetectionOptions with_lens;
      with_lens.lens = lens.intrinsics;
      const BoardDetection a = DetectBoard(r.frame.image, board);
      const BoardDetection b = DetectBoard(r.frame.image, board, with_lens);
      if (verbose) {
        std::vector<bool> got(36, false);
        if (b.found)
          for (int id : b.tag_ids) got[id] = true;
        for (int id = 0; id < 36; ++id) {
          if (!in_view[id] || got[id]) continue;
          const cv::Point2d c = 0.5 * (r.frame.points_px[4 * id] + r.frame.points_px[4 * id + 2]);
          std::string why = "not detected";
          for (const auto& [rid, w] : b.tags_refused)
            if (rid == id) why = w;
          std::fprintf(stderr, "  view %d tag %d missed (%s): %.1f x %.1f px at (%.0f, %.0f)\n", made, id, why.c_str(),
                       cv::norm(r.frame.points_px[4 * id] - r.frame.points_px[4 * id + 1]),
                       cv::norm(r.frame.points_px[4 * id + 1] - r.frame.points_px[4 * id + 2]), c.x, c.y);
        }
      }
      for (const auto* d : {&a, &b}) {
        if (!d->found) continue;
        for (size_t t = 0; t < d->tag_ids.size(); ++t) {
          const int id = d->tag_ids[t];
          (d == &a ? found_straight : found_lens) += in_view[id];
          double worst = 0.0;
          for (int k = 0; k < 4; ++k) {
            const cv::Point2d e = cv::Point2d(d->image_points[4 * t + k]) - r.frame.points_px[4 * id + k];
            (d == &a ? straight : through).Add(e);
            if (d == &b && !b.point_sigma_px.empty() && b.point_sigma_px[4 * t + k] > 0.0)
              normalised.Add(e * (1.0 / b.point_sigma_px[4 * t + k]));
            worst = std::max(worst, cv::norm(e));
          }
          if (d == &b) bad_tags += worst > 0.1;
          if (verbose && d == &b && worst > 0.1)
            for (int k = 0; k < 4; ++k) {
              const cv::Point2d e = cv::Point2d(d->image_points[4 * t + k]) - r.frame.points_px[4 * id + k];
              std::fprintf(stderr, "    corner %d at (%.1f, %.1f): error (%+.3f, %+.3f), sigma %.3f\n", k,
                           r.frame.points_px[4 * id + k].x, r.frame.points_px[4 * id + k].y, e.x, e.y,
                           d->point_sigma_px.empty() ? NAN : d->point_sigma_px[4 * t + k]);
            }
          if (verbose && d == &b && worst > 0.1)
            std::fprintf(stderr, "  view %d tag %d: worst corner %.3f px, tag %.1f px wide at (%.0f, %.0f)\n", made, id,
                         worst, cv::norm(r.frame.points_px[4 * id] - r.frame.points_px[4 * id + 2]) / std::sqrt(2.0),
                         r.frame.points_px[4 * id].x, r.frame.points_px[4 * id].y);
        }
      }
      std::fflush(stdout);
    }
    std::printf("| %s | %d | %d | %d (%.0f %%) | %d (%.0f %%) | %.3f / %.2f | %.3f / %.2f | %+.3f, %+.3f | %d | %.2f |\n",
                lens.name.c_str(), made, visible, found_straight, 100.0 * found_straight / std::max(1, visible),
                found_lens, 100.0 * found_lens / std::max(1, visible), straight.Rms(), straight.max, through.Rms(),
                through.max, through.n ? through.mx / through.n : NAN, through.n ? through.my / through.n : NAN, bad_tags, normalised.Rms());
    std::fflush(stdout);
  }
  return 0;
}
