// The detector wrapper on real photographs (NASA Swarmathon, tag36h11 id 0)
// against reference corners from the AprilTag reference detector
// (quad_decimate = 1, refine_edges = false, AprilTag's pixel convention).
// The images live outside the repository, in ../shared/realdata.
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <regex>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "odocal/test_util/test_util.h"
#include "odocal/vision/corner_refine.h"
#include "odocal/vision/detector.h"
#include "odocal/vision/edge_quality.h"

namespace odocal::vision {
namespace {

namespace fs = std::filesystem;

fs::path RealDataDir() {
  const fs::path candidates[] = {
      fs::path(test_util::SourceDir()) / ".." / "shared" / "realdata" / "apriltag-test",
      fs::path("/work/shared/realdata/apriltag-test")};
  for (const auto& c : candidates) {
    if (fs::exists(c)) return c;
  }
  return {};
}

// Every photograph in `dir` (JPEG or PNG) that has a reference file beside
// it, in name order: the test holds for whatever real photographs are there.
std::vector<fs::path> ReferencedPhotos(const fs::path& dir) {
  std::vector<fs::path> out;
  for (const auto& entry : fs::directory_iterator(dir)) {
    std::string ext = entry.path().extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
    if (ext != ".jpg" && ext != ".jpeg" && ext != ".png") continue;
    if (fs::exists(fs::path(entry.path()).replace_extension(".txt"))) out.push_back(entry.path());
  }
  std::sort(out.begin(), out.end());
  return out;
}

struct Reference {
  int id;
  std::array<cv::Point2d, 4> corners;  // AprilTag convention as stored
};

std::vector<Reference> ReadReference(const fs::path& path) {
  std::vector<Reference> out;
  std::ifstream in(path);
  std::string line;
  const std::regex number(R"([-+]?[0-9]*\.?[0-9]+)");
  while (std::getline(in, line)) {
    std::vector<double> v;
    for (auto it = std::sregex_iterator(line.begin(), line.end(), number); it != std::sregex_iterator(); ++it) {
      v.push_back(std::stod(it->str()));
    }
    if (v.size() != 9) continue;
    Reference r;
    r.id = static_cast<int>(v[0]);
    for (int k = 0; k < 4; ++k) r.corners[k] = cv::Point2d(v[1 + 2 * k], v[2 + 2 * k]);
    out.push_back(r);
  }
  return out;
}

// Largest corner distance between a reference and the wrapper's matching
// detection (reference converted to OpenCV's convention), per reference tag.
std::vector<double> CompareImage(const fs::path& jpg, TagDetector* detector) {
  const cv::Mat grey = cv::imread(jpg.string(), cv::IMREAD_GRAYSCALE);
  EXPECT_FALSE(grey.empty()) << jpg;
  const auto refs = ReadReference(fs::path(jpg).replace_extension(".txt"));
  EXPECT_FALSE(refs.empty());
  const DetectResult det = detector->Detect(grey);
  std::vector<double> worst;
  for (const auto& ref : refs) {
    double best = 1e9;
    for (const auto& d : det.detections) {
      if (d.id != ref.id) continue;
      double w = 0.0;
      for (int k = 0; k < 4; ++k) {
        const cv::Point2d r(ref.corners[k].x + kApriltagToOpenCvPx, ref.corners[k].y + kApriltagToOpenCvPx);
        w = std::max(w, cv::norm(d.corners_px[k] - r));
      }
      best = std::min(best, w);
    }
    worst.push_back(best);
  }
  return worst;
}

TEST(RealData, WrapperMatchesReferenceCornersOnRealPhotographs) {
  const fs::path dir = RealDataDir();
  if (dir.empty()) GTEST_SKIP() << "shared/realdata/apriltag-test not found";
  DetectorOptions options;
  options.quad_decimate = 1.0f;
  options.refine_edges = false;
  options.max_hamming = 2;  // the reference detector's default
  auto created = TagDetector::Create(options);
  ASSERT_TRUE(created.ok()) << created.message;
  // Measured: 44 of the 47 reference tags agree to < 0.003 px; three (odd,
  // overlapping quads in clutter) differ by 0.05-0.14 px, plausibly from a
  // different JPEG decoder or libapriltag build behind the reference.
  int tags_within = 0, tags_total = 0;
  std::vector<double> all;
  const std::vector<fs::path> photos = ReferencedPhotos(dir);
  ASSERT_FALSE(photos.empty()) << "no photograph with reference corners in " << dir;
  for (const fs::path& photo : photos) {
    const std::string name = photo.filename().string();
    const auto worst = CompareImage(photo, created.detector.get());
    int within = 0;
    for (double w : worst) within += w < 0.1 ? 1 : 0;
    std::printf("%s: %d of %zu reference tags within 0.1 px\n", name.c_str(), within, worst.size());
    // Each image: nearly every reference tag found at the reference corners.
    EXPECT_GE(within, static_cast<int>(worst.size()) * 85 / 100) << name;
    tags_within += within;
    tags_total += static_cast<int>(worst.size());
    all.insert(all.end(), worst.begin(), worst.end());
  }
  EXPECT_GE(tags_within, tags_total * 9 / 10);
  // Typical agreement is exact up to the text files' 4 decimals.
  std::nth_element(all.begin(), all.begin() + all.size() / 2, all.end());
  EXPECT_LT(all[all.size() / 2], 0.005);
}

// Without the conversion the same comparison is half a pixel off: the test
// above could not pass with a wrong convention.
TEST(RealData, ConventionOffsetIsHalfAPixel) {
  const fs::path dir = RealDataDir();
  if (dir.empty()) GTEST_SKIP() << "shared/realdata/apriltag-test not found";
  DetectorOptions options;
  options.quad_decimate = 1.0f;  // as the reference was made
  options.refine_edges = false;
  options.max_hamming = 2;
  auto created = TagDetector::Create(options);
  ASSERT_TRUE(created.ok());
  double sx = 0.0, sy = 0.0;
  int n = 0;
  for (const fs::path& jpg : ReferencedPhotos(dir)) {
    const cv::Mat grey = cv::imread(jpg.string(), cv::IMREAD_GRAYSCALE);
    const auto refs = ReadReference(fs::path(jpg).replace_extension(".txt"));
    const auto det = created.detector->Detect(grey);
    for (const auto& ref : refs) {
      for (const auto& d : det.detections) {
        if (cv::norm(d.corners_px[0] - ref.corners[0]) > 2.0) continue;
        for (int k = 0; k < 4; ++k) {
          sx += d.corners_px[k].x - ref.corners[k].x;
          sy += d.corners_px[k].y - ref.corners[k].y;
          ++n;
        }
      }
    }
  }
  ASSERT_GT(n, 0);
  EXPECT_NEAR(sx / n, -0.5, 0.02);
  EXPECT_NEAR(sy / n, -0.5, 0.02);
}

// Refinement on real images, with a truth that does not come from any model:
// a quarter or half turn of the image moves every pixel exactly, so refined
// corners must turn exactly with it. A pixel convention off by half a pixel
// anywhere in the refinement chain (sampling, crop origin, the detector's
// offset) shows as a 0.5-1 px disagreement. The Swarmathon photographs' tags
// are 15-25 px, too small to refine (cells < 3 px), so a photograph up to
// 800 px is enlarged 3x first, a larger one less (bicubic; OpenCV's
// pixel-centre convention). Both refinements of the
// pipeline are checked: the half-level lines (every frame) and the
// PSF/tone-free edge model (the rests). These tags sit on small cubes, with
// a quiet zone a fraction of a cell wide and the cube's edge or shadow right
// beyond it, so the edge model's premise (a plateau either side) fails for
// many: the quality gate refuses most of them; of those it passes, most turn
// with the image, a few do not (docs/vision.md, "Real photographs").
cv::Point2d RotatePoint(const cv::Point2d& p, const cv::Size& before, int turns) {
  // cv::ROTATE_90_CLOCKWISE: pixel (x, y) goes to (H - 1 - y, x).
  cv::Point2d q = p;
  cv::Size size = before;
  for (int t = 0; t < turns; ++t) {
    q = cv::Point2d(size.height - 1 - q.y, q.x);
    size = cv::Size(size.height, size.width);
  }
  return q;
}

struct RefinedTag {
  std::array<cv::Point2d, 4> half_level, model_free;
  TagImageQuality quality;
  bool usable = false;  // passes the quality gate
};

std::vector<RefinedTag> RefineAll(const cv::Mat& grey, TagDetector* detector) {
  std::vector<RefinedTag> out;
  for (const TagDetection& d : detector->Detect(grey).detections) {
    const CornerRefineResult h = RefineTagCorners(grey, d.corners_px, nullptr);
    if (!h.ok()) continue;
    const ModelFreeRefineResult m = RefineTagCornersModelFree(grey, h.corners_px, nullptr);
    if (!m.ok()) continue;
    out.push_back({h.corners_px, m.corners_px, m.quality, QualityFlags(m.quality).empty()});
  }
  return out;
}

// Largest distance from each corner of `a` to the nearest corner of `b`.
double CornerSetDistance(const std::array<cv::Point2d, 4>& a, const std::array<cv::Point2d, 4>& b) {
  double worst = 0.0;
  for (const auto& p : a) {
    double best = 1e9;
    for (const auto& q : b) best = std::min(best, cv::norm(p - q));
    worst = std::max(worst, best);
  }
  return worst;
}

TEST(RealData, RefinedCornersTurnWithTheImage) {
  const fs::path dir = RealDataDir();
  if (dir.empty()) GTEST_SKIP() << "shared/realdata/apriltag-test not found";
  auto created = TagDetector::Create(DetectorOptions{});
  ASSERT_TRUE(created.ok()) << created.message;
  std::vector<double> half_level, usable, refused;
  size_t tried = 0;  // tag orientations that had to be found again
  for (const fs::path& photo : ReferencedPhotos(dir)) {
    const cv::Mat original = cv::imread(photo.string(), cv::IMREAD_GRAYSCALE);
    ASSERT_FALSE(original.empty()) << photo;
    // Enlarged 3x, or less for a photograph larger than 800 px (at most
    // 2400 px across: a larger one is used as it is).
    const double scale =
        std::clamp(2400.0 / std::max(original.cols, original.rows), 1.0, 3.0);
    cv::Mat large = original;
    if (scale > 1.0) cv::resize(original, large, cv::Size(), scale, scale, cv::INTER_CUBIC);
    const std::vector<RefinedTag> upright = RefineAll(large, created.detector.get());
    cv::Mat turned = large;
    for (int turns = 1; turns <= 2; ++turns) {
      cv::rotate(turned.clone(), turned, cv::ROTATE_90_CLOCKWISE);
      const std::vector<RefinedTag> seen = RefineAll(turned, created.detector.get());
      for (const RefinedTag& tag : upright) {
        ++tried;
        std::array<cv::Point2d, 4> expected_h, expected_m;
        for (int k = 0; k < 4; ++k) {
          expected_h[k] = RotatePoint(tag.half_level[k], large.size(), turns);
          expected_m[k] = RotatePoint(tag.model_free[k], large.size(), turns);
        }
        const RefinedTag* match = nullptr;
        for (const RefinedTag& s : seen)
          if (CornerSetDistance(expected_h, s.half_level) < 2.0) match = &s;
        if (!match) continue;
        half_level.push_back(CornerSetDistance(expected_h, match->half_level));
        const double m = CornerSetDistance(expected_m, match->model_free);
        (tag.usable && match->usable ? usable : refused).push_back(m);
      }
    }
  }
  // Whatever photographs are there: nearly every tag refined upright is
  // found and refined again when turned (77 of 79 on the Swarmathon set).
  ASSERT_FALSE(half_level.empty()) << "no real tag refined in both orientations";
  EXPECT_GE(half_level.size() * 10, tried * 9) << half_level.size() << " of " << tried;
  auto sorted = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v;
  };
  const std::vector<double> h = sorted(half_level), u = sorted(usable), r = sorted(refused);
  std::printf("%zu real tags turned: half-level corners agree to %.4f px (median), %.4f (max); the edge model "
              "passes %zu, agreeing to %.4f px (median), %.4f (max); refuses %zu, which disagree by up to "
              "%.3f px (enlarged pixels)\n",
              h.size(), h[h.size() / 2], h.back(), u.size(), u.empty() ? 0.0 : u[u.size() / 2],
              u.empty() ? 0.0 : u.back(), r.size(), r.empty() ? 0.0 : r.back());
  // The conventions: half a pixel anywhere would put the median near 0.5.
  EXPECT_LT(h[h.size() / 2], 0.05);
  // What the gate passes turns with the image, typically (measured: median
  // 0.063 px in 3x pixels over 16; the largest, 0.74 px, on a tag whose
  // quiet zone is the cube's shaded edge: found, not fixed). On these cube
  // mounts the gate refuses most tags, some of whose corners do not turn
  // with the image at all (up to 3 px); on photographs with clean quiet
  // zones it may refuse none, so that is printed, not asserted.
  ASSERT_FALSE(u.empty()) << "the edge model's gate passed no real tag";
  EXPECT_LT(u[u.size() / 2], 0.1);
}

}  // namespace
}  // namespace odocal::vision
