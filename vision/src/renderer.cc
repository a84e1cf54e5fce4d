#include "odocal/base/units.h"
#include "odocal/vision/renderer.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <random>

#include <opencv2/imgproc.hpp>

#include "apriltag_util.h"
#include "raster.h"

namespace odocal::vision {

using calibration::Pose2;

bool RenderOptions::IsValid(std::string* why) const {
  auto fail = [&](const char* msg) {
    if (why) *why = msg;
    return false;
  };
  if (!(noise_sigma >= 0.0)) return fail("noise_sigma must be >= 0");
  if (!(blur_sigma_px >= 0.0) || blur_sigma_px > 20.0) return fail("blur_sigma_px must be in [0, 20]");
  if (!(exposure_s >= 0.0)) return fail("exposure_s must be >= 0");
  if (max_motion_substeps < 1) return fail("max_motion_substeps must be >= 1");
  if (!(motion_step_px > 0.0)) return fail("motion_step_px must be > 0");
  if (!(body_radius_mm >= 0.0)) return fail("body_radius_mm must be >= 0");
  if (!(plate_margin_mm >= 0.0)) return fail("plate_margin_mm must be >= 0");
  if (edge_supersample < 1 || edge_supersample > 64) return fail("edge_supersample must be in [1, 64]");
  if (optical_oversample < 1 || optical_oversample > 4) return fail("optical_oversample must be in [1, 4]");
  if (!(tag_bow_mm >= 0.0 && tag_bow_mm <= 50.0)) return fail("tag bow_mm must be in [0, 50]");
  return formation.IsValid(why);
}

namespace {

// A Pose2 with its rotation evaluated once: the renderer transforms millions
// of points by a handful of poses a frame, and Pose2's operator* takes a
// sine and a cosine every time. The same arithmetic, so the same bits.
struct Rigid2 {
  explicit Rigid2(const Pose2& pose)
      : c(std::cos(pose.heading())), s(std::sin(pose.heading())), x(pose.x()), y(pose.y()) {}
  Eigen::Vector2d operator*(const Eigen::Vector2d& p) const {
    return {x + c * p.x() - s * p.y(), y + s * p.x() + c * p.y()};
  }
  double c, s, x, y;
};


// Value noise: a seeded hash of the lattice point, smoothstep-interpolated.
double LatticeValue(int64_t ix, int64_t iy, uint64_t seed) {
  uint64_t h = seed * 0x9E3779B97F4A7C15ull;
  h ^= static_cast<uint64_t>(ix) * 0xC2B2AE3D27D4EB4Full;
  h = (h ^ (h >> 31)) * 0xBF58476D1CE4E5B9ull;
  h ^= static_cast<uint64_t>(iy) * 0x165667B19E3779F9ull;
  h = (h ^ (h >> 29)) * 0x94D049BB133111EBull;
  h ^= h >> 32;
  return static_cast<double>(h & 0xFFFFFF) / static_cast<double>(0xFFFFFF) * 2.0 - 1.0;
}

double ValueNoise(double x, double y, uint64_t seed) {
  const double fx = std::floor(x), fy = std::floor(y);
  const auto ix = static_cast<int64_t>(fx), iy = static_cast<int64_t>(fy);
  double tx = x - fx, ty = y - fy;
  tx = tx * tx * (3.0 - 2.0 * tx);
  ty = ty * ty * (3.0 - 2.0 * ty);
  const double a = LatticeValue(ix, iy, seed), b = LatticeValue(ix + 1, iy, seed);
  const double c = LatticeValue(ix, iy + 1, seed), d = LatticeValue(ix + 1, iy + 1, seed);
  return (a * (1 - tx) + b * tx) * (1 - ty) + (c * (1 - tx) + d * tx) * ty;
}

double FloorTexture(double x_m, double y_m, uint64_t seed) {
  // Tiles from 0.4 m down to 2.5 cm: structure at every scale the camera sees.
  return 0.5 * ValueNoise(x_m / 0.4, y_m / 0.4, seed) +
         0.3 * ValueNoise(x_m / 0.1, y_m / 0.1, seed + 1) +
         0.2 * ValueNoise(x_m / 0.025, y_m / 0.025, seed + 2);
}

// Region ids for the coverage test: a pixel is uniform when its four corners
// share one id. Tag cells get their own id each, so a pixel straddling two
// cells of the same colour is still integrated (cheap, and never wrong).
constexpr int kFloor = 0;
constexpr int kBody = 1;
constexpr int kPlate = 2;
constexpr int kFirstCell = 16;

// Paints one floor tag into the sharp floor (CV_32F, pixel-centre samples of
// the texture): every pixel whose footprint on the floor reaches the tag's
// paper is integrated over its footprint with stratified samples, as the
// robot's tag is. False with `why` for an unknown family.
bool PaintFloorTag(const CameraModel& camera, const cv::Mat& corner_rays,
                   const FloorTagPlacement& placement, const RenderOptions& options, cv::Mat* floor,
                   std::string* why) {
  auto family = internal::CreateFamily(placement.family);
  if (!family) {
    if (why) *why = "floor tag: unknown family '" + placement.family + "'";
    return false;
  }
  internal::ImageU8Ptr im(apriltag_to_image(family.get(), placement.id));
  const int n = im->width;
  const double cell_m = placement.size_mm * kMmToM / family->width_at_border;
  const double half_grid_m = 0.5 * n * cell_m;
  const double paper_half_m = half_grid_m + placement.paper_margin_mm * kMmToM;
  // Image box of the paper.
  double x0 = 1e18, y0 = 1e18, x1 = -1e18, y1 = -1e18;
  for (int sx = -1; sx <= 1; sx += 2) {
    for (int sy = -1; sy <= 1; sy += 2) {
      const Eigen::Vector2d p = placement.T_world_tag * Eigen::Vector2d(sx * paper_half_m, sy * paper_half_m);
      const auto px = camera.ProjectWorld(Eigen::Vector3d(p.x(), p.y(), 0.0));
      if (!px) return true;  // behind the camera: not seen
      x0 = std::min(x0, px->x());
      y0 = std::min(y0, px->y());
      x1 = std::max(x1, px->x());
      y1 = std::max(y1, px->y());
    }
  }
  const cv::Rect roi = cv::Rect(static_cast<int>(std::floor(x0)) - 2, static_cast<int>(std::floor(y0)) - 2,
                                static_cast<int>(std::ceil(x1 - x0)) + 5, static_cast<int>(std::ceil(y1 - y0)) + 5) &
                       cv::Rect(0, 0, floor->cols, floor->rows);
  if (roi.area() == 0) return true;
  const Eigen::Matrix3d R = camera.T_world_camera().linear();
  const Eigen::Vector3d c = camera.T_world_camera().translation();
  const calibration::Pose2 T_tag_world = placement.T_world_tag.inverse();
  // Tag-frame floor point of each pixel corner of the box.
  const int w = roi.width, h = roi.height;
  std::vector<Eigen::Vector2d> q((w + 1) * (h + 1));
  auto classify = [&](const Eigen::Vector2d& t) {
    if (std::abs(t.x()) > paper_half_m || std::abs(t.y()) > paper_half_m) return kFloor;
    const int col = static_cast<int>(std::floor((t.x() + half_grid_m) / cell_m));
    const int row = static_cast<int>(std::floor((half_grid_m - t.y()) / cell_m));
    if (col >= 0 && col < n && row >= 0 && row < n) return kFirstCell + row * n + col;
    return kPlate;
  };
  std::vector<int> id(q.size());
  for (int j = 0; j <= h; ++j) {
    for (int i = 0; i <= w; ++i) {
      const cv::Vec2d r = corner_rays.at<cv::Vec2d>(roi.y + j, roi.x + i);
      const Eigen::Vector3d d = R * Eigen::Vector3d(r[0], r[1], 1.0);
      const double s = -c.z() / d.z();
      const int k = j * (w + 1) + i;
      q[k] = s > 0.0 ? T_tag_world * (c + s * d).head<2>().eval() : Eigen::Vector2d(1e9, 1e9);
      id[k] = classify(q[k]);
    }
  }
  cv::Mat painted(h, w, CV_32F, cv::Scalar(0.0));
  internal::IntegratePixels(
      w, h, q, id, options.edge_supersample, 1.0, options.seed * 31 + placement.id, classify,
      [&](int region, int i, int j) -> double {
        if (region >= kFirstCell) {
          const int k = region - kFirstCell;
          return im->buf[(k / n) * im->stride + k % n] > 127 ? options.tag_white : options.tag_black;
        }
        if (region == kPlate) return options.tag_white;
        return floor->at<float>(roi.y + j, roi.x + i);
      },
      &painted);
  painted.copyTo((*floor)(roi));
  return true;
}

}  // namespace

struct Renderer::Impl {
  CameraModel camera;
  TagSpec tag;
  RenderOptions options;
  int width = 0, height = 0;
  // Grey level of each cell of the tag's bitmap, row-major (total_width^2):
  // looked up per sample by the cell's index, without dividing it back
  // into a row and a column.
  std::vector<double> cell_grey;
  int total_width = 0;
  int width_at_border = 0;
  double cell_m = 0.0;
  double plate_half_m = 0.0;
  Pose2 tag_T_robot;      // the tag frame from the robot frame
  cv::Mat corner_rays;    // (H+1) x (W+1) CV_64FC2: normalised coords of pixel corners
  cv::Mat bg_sharp;       // CV_32F
  cv::Mat bg_blur;        // CV_32F
  std::vector<float> noise_pool;
  cv::RNG rng;
  std::mt19937_64 offset_rng;
  int blur_margin = 0;
  int blur_ksize = 1;
  cv::Mat illumination;  // CV_32F relative irradiance, with a sensor chain only
  bool sensor_chain = false;

  // The optics, by the PSF model when one is given, else the Gaussian.
  void Blur(const cv::Mat& src, cv::Mat* dst, int scale) const {
    if (options.formation.psf) {
      ApplyPsf(src, dst, *options.formation.psf, scale);
    } else if (options.blur_sigma_px > 0.0) {
      internal::OpticalBlur(src, dst, options.blur_sigma_px * scale);
    } else {
      src.copyTo(*dst);
    }
  }

  int Classify(const Eigen::Vector2d& q_robot, const Rigid2& T_tag_robot) const {
    const Eigen::Vector2d t = T_tag_robot * q_robot;
    if (std::abs(t.x()) <= plate_half_m && std::abs(t.y()) <= plate_half_m) {
      const double half = 0.5 * total_width * cell_m;
      const int col = static_cast<int>(std::floor((t.x() + half) / cell_m));
      const int row = static_cast<int>(std::floor((half - t.y()) / cell_m));
      if (col >= 0 && col < total_width && row >= 0 && row < total_width) {
        return kFirstCell + row * total_width + col;
      }
      return kPlate;
    }
    if (q_robot.squaredNorm() <= std::pow(options.body_radius_mm * kMmToM, 2)) return kBody;
    return kFloor;
  }

  double Value(int id, double floor_value) const {
    if (id >= kFirstCell) {
      return cell_grey[id - kFirstCell];
    }
    if (id == kPlate) return options.tag_white;
    if (id == kBody) return options.body_grey;
    return floor_value;
  }

  // The world direction of the ray through a (fractional) pixel corner;
  // corner index (cu, cv) is pixel position (cu - 0.5, cv - 0.5). Rays
  // between the stored integer corners are interpolated bilinearly: the
  // undistortion map is smooth far beyond what that needs.
  Eigen::Vector3d RayDirection(double cu, double cv_) const {
    const int u0 = std::min(static_cast<int>(cu), corner_rays.cols - 2);
    const int v0 = std::min(static_cast<int>(cv_), corner_rays.rows - 2);
    const double fu = cu - u0, fv = cv_ - v0;
    const cv::Vec2d n = (corner_rays.at<cv::Vec2d>(v0, u0) * (1 - fu) + corner_rays.at<cv::Vec2d>(v0, u0 + 1) * fu) * (1 - fv) +
                        (corner_rays.at<cv::Vec2d>(v0 + 1, u0) * (1 - fu) + corner_rays.at<cv::Vec2d>(v0 + 1, u0 + 1) * fu) * fv;
    return camera.T_world_camera().linear() * Eigen::Vector3d(n[0], n[1], 1.0);
  }

  // World (x, y) where that ray meets the tag plane; nullopt when it looks
  // away from the plane. The same for every pose of an exposure.
  std::optional<Eigen::Vector2d> PlanePoint(double cu, double cv_) const {
    const Eigen::Vector3d d = RayDirection(cu, cv_);
    const Eigen::Vector3d c = camera.T_world_camera().translation();
    const double s = (tag.height_m() - c.z()) / d.z();
    if (!(s > 0.0)) return std::nullopt;
    const Eigen::Vector3d p = c + s * d;
    return Eigen::Vector2d(p.x(), p.y());
  }

  // Robot-frame point of a pixel corner whose plane point is `plane` (from
  // PlanePoint at (cu, cv)), the robot at T_robot_world.
  Eigen::Vector2d CornerOnPlane(const std::optional<Eigen::Vector2d>& plane, double cu, double cv_,
                                const Rigid2& T_robot_world) const {
    if (!plane) return Eigen::Vector2d(1e9, 1e9);  // looks away from the plane: floor
    Eigen::Vector2d q = T_robot_world * *plane;
    if (options.tag_bow_mm > 0.0) {
      // The ray meets the bowed paper where its height matches: a fixed
      // point, converged to < 1 nm in three steps (the lift is ~1e-3 of the range).
      const Eigen::Vector3d d = RayDirection(cu, cv_);
      const Eigen::Vector3d c = camera.T_world_camera().translation();
      const Rigid2 T_tag_robot(tag_T_robot);
      for (int it = 0; it < 3; ++it) {
        const double lift = BowLift(T_tag_robot * q);
        const Eigen::Vector3d b = c + ((tag.height_m() + lift - c.z()) / d.z()) * d;
        q = T_robot_world * Eigen::Vector2d(b.x(), b.y());
      }
    }
    return q;
  }

  // Height of the bowed paper above the tag plane at tag-frame point t (m).
  double BowLift(const Eigen::Vector2d& t) const {
    if (std::abs(t.x()) > plate_half_m || std::abs(t.y()) > plate_half_m) return 0.0;
    const double u = t.x() / plate_half_m;
    return options.tag_bow_mm * kMmToM * (1.0 - u * u);
  }

  // Adds weight * (the scene at pose T_world_robot) over `roi` to acc, which
  // holds `roi` at `scale` x the image resolution.
  // The plane points of the (w + 1) x (h + 1) corners of `roi` at `scale`
  // x the resolution (row-major), shared by every pose of an exposure.
  std::vector<std::optional<Eigen::Vector2d>> PlanePoints(const cv::Rect& roi, int scale) const {
    const int w = roi.width * scale, h = roi.height * scale;
    std::vector<std::optional<Eigen::Vector2d>> plane((w + 1) * (h + 1));
    for (int j = 0; j <= h; ++j) {
      for (int i = 0; i <= w; ++i) {
        plane[j * (w + 1) + i] =
            PlanePoint(roi.x + static_cast<double>(i) / scale, roi.y + static_cast<double>(j) / scale);
      }
    }
    return plane;
  }

  void RenderPose(const Pose2& T_world_robot, const cv::Rect& roi,
                  const std::vector<std::optional<Eigen::Vector2d>>& plane, double weight,
                  std::uint64_t jitter_seed, int scale, cv::Mat* acc) const {
    const Rigid2 T_robot_world(T_world_robot.inverse());
    const Rigid2 T_tag_robot(tag.T_robot_tag().inverse());
    const int w = roi.width * scale, h = roi.height * scale;
    std::vector<Eigen::Vector2d> q((w + 1) * (h + 1));
    std::vector<int> id((w + 1) * (h + 1));
    for (int j = 0; j <= h; ++j) {
      for (int i = 0; i <= w; ++i) {
        const int k = j * (w + 1) + i;
        q[k] = CornerOnPlane(plane[k], roi.x + static_cast<double>(i) / scale,
                             roi.y + static_cast<double>(j) / scale, T_robot_world);
        id[k] = Classify(q[k], T_tag_robot);
      }
    }
    internal::IntegratePixels(
        w, h, q, id, std::max(1, options.edge_supersample / scale), weight, jitter_seed,
        [&](const Eigen::Vector2d& p) { return Classify(p, T_tag_robot); },
        [&](int region, int i, int j) {
          return Value(region, bg_sharp.at<float>(roi.y + j / scale, roi.x + i / scale));
        },
        [&](int k00, int k10, int k11, int k01, int, int, double* v) {
          return CellsInClosedForm({q[k00], q[k10], q[k11], q[k01]}, {id[k00], id[k10], id[k11], id[k01]}, T_tag_robot,
                                   v);
        },
        acc);
  }

  // A pixel inside the plate whose corners (robot frame, counter-clockwise in
  // the image) lie in at most two neighbouring columns and two neighbouring
  // rows of the bitmap (its cells and the plate's margin around them) is cut
  // by at most one line of each: its area mean in closed form, the pixel's
  // quadrilateral clipped by those lines into up to four cells. The samples
  // see the same quadrilateral through its bilinear map, which within a
  // pixel matches the straight-sided one to far better than 1e-4 of its
  // area; the closed form has no sampling noise. False for any other pixel
  // (the plate's rim, the body's, two lines of a kind).
  bool CellsInClosedForm(const std::array<Eigen::Vector2d, 4>& corners, const std::array<int, 4>& ids,
                         const Rigid2& T_tag_robot, double* v) const {
    // On the plate (convex), so is the whole pixel.
    if (std::any_of(ids.begin(), ids.end(), [](int id) { return id < kPlate; })) return false;
    const double half = 0.5 * total_width * cell_m;
    // Column (row) of the bitmap, -1 and n the plate's margin.
    const auto index = [&](double along) {
      return std::clamp(static_cast<int>(std::floor((along + half) / cell_m)), -1, total_width);
    };
    Eigen::Vector2d t[4];
    int c0 = total_width, c1 = -1, r0 = total_width, r1 = -1;
    for (int m = 0; m < 4; ++m) {
      t[m] = T_tag_robot * corners[m];
      const int col = index(t[m].x()), row = index(-t[m].y());  // rows run down the tag
      c0 = std::min(c0, col);
      c1 = std::max(c1, col);
      r0 = std::min(r0, row);
      r1 = std::max(r1, row);
    }
    if (c1 - c0 > 1 || r1 - r0 > 1) return false;
    const double x_line = -half + (c0 + 1) * cell_m;  // column c0 below it, c1 above
    const double y_line = half - (r0 + 1) * cell_m;   // row r0 above it, r1 below
    double sum = 0.0, area = 0.0;
    for (int col = c0; col <= c1; ++col) {
      for (int row = r0; row <= r1; ++row) {
        Eigen::Vector2d by_x[5], by_y[6];
        const Eigen::Vector2d* piece = t;
        int n = 4;
        if (c1 > c0) {
          n = internal::ClipToHalfPlane(piece, n, 0, x_line, col == c0, by_x);
          piece = by_x;
        }
        if (r1 > r0 && n >= 3) {
          n = internal::ClipToHalfPlane(piece, n, 1, y_line, row == r1, by_y);
          piece = by_y;
        }
        if (n < 3) continue;
        const double a = internal::PolygonArea(piece, n);
        const bool in_grid = col >= 0 && col < total_width && row >= 0 && row < total_width;
        // On the plate: no floor value needed.
        sum += a * Value(in_grid ? kFirstCell + row * total_width + col : kPlate, 0.0);
        area += a;
      }
    }
    if (!(area > 0.0)) return false;
    *v = sum / area;
    return true;
  }

  // The robot's tag: its cells' grey levels, cell size and plate.
  void LoadTag() {
    auto family = internal::CreateFamily(tag.family);
    internal::ImageU8Ptr im(apriltag_to_image(family.get(), tag.id));
    total_width = im->width;
    cell_grey.resize(static_cast<size_t>(im->height) * im->width);
    for (int r = 0; r < im->height; ++r) {
      for (int c = 0; c < im->width; ++c) {
        cell_grey[r * im->width + c] = im->buf[r * im->stride + c] > 127 ? options.tag_white : options.tag_black;
      }
    }
    width_at_border = family->width_at_border;
    cell_m = tag.size_m() / family->width_at_border;
    plate_half_m = 0.5 * total_width * cell_m + options.plate_margin_mm * kMmToM;
    tag_T_robot = tag.T_robot_tag().inverse();
  }

  // Static floor into bg_sharp, sampled at the ray through the pixel centre.
  void SampleStaticFloor() {
    const int W = width, H = height;
    bg_sharp = cv::Mat(H, W, CV_32F);
    const Eigen::Matrix3d R = camera.T_world_camera().linear();
    const Eigen::Vector3d c = camera.T_world_camera().translation();
    for (int v = 0; v < H; ++v) {
      float* row = bg_sharp.ptr<float>(v);
      for (int u = 0; u < W; ++u) {
        const cv::Vec2d n = (corner_rays.at<cv::Vec2d>(v, u) + corner_rays.at<cv::Vec2d>(v + 1, u + 1)) * 0.5;
        const Eigen::Vector3d d = R * Eigen::Vector3d(n[0], n[1], 1.0);
        const double s = -c.z() / d.z();
        double value = options.floor_mean;
        if (s > 0.0) {
          const Eigen::Vector3d p = c + s * d;
          value += options.floor_contrast * FloorTexture(p.x(), p.y(), options.seed);
        }
        row[u] = static_cast<float>(value);
      }
    }
  }

  // Seeds the generators and fills the pool of pixel noise (with a sensor
  // chain also the illumination field).
  void SeedNoise() {
    const int W = width, H = height;
    rng = cv::RNG(options.seed * 7919 + 17);
    offset_rng.seed(options.seed * 104729 + 3);
    sensor_chain = options.formation.HasSensorChain();
    if (sensor_chain) {
      // Unit deviates: the sensor chain scales them per pixel (shot noise).
      illumination = IlluminationField(options.formation, cv::Size(W, H));
      noise_pool.resize(static_cast<size_t>(W) * H + (1 << 16));
      cv::Mat pool(1, static_cast<int>(noise_pool.size()), CV_32F, noise_pool.data());
      rng.fill(pool, cv::RNG::NORMAL, 0.0, 1.0);
    } else if (options.noise_sigma > 0.0) {
      noise_pool.resize(static_cast<size_t>(W) * H + (1 << 16));
      cv::Mat pool(1, static_cast<int>(noise_pool.size()), CV_32F, noise_pool.data());
      rng.fill(pool, cv::RNG::NORMAL, 0.0, options.noise_sigma);
    }
  }

  // The part of the image a frame's geometry can change: `inner` is the
  // geometry's box plus the blur's reach, `outer` that plus the blur's reach
  // again (the floor the blur draws into `inner`). Empty when nothing is in front.
  struct Window {
    cv::Rect inner, outer;
  };

  // The window that changes over all poses of all bands: geometry box, then
  // + blur margin (inner), + blur margin (outer).
  Window ChangingWindow(const std::vector<std::pair<int, std::vector<Pose2>>>& bands) const {
    cv::Rect2d box;
    bool any = false;
    for (const auto& band : bands) {
      for (const auto& pose : band.second) {
        const cv::Rect2d b = GeometryBox(pose);
        if (b.width <= 0) continue;
        box = any ? (box | b) : b;
        any = true;
      }
    }
    const cv::Rect image_rect(0, 0, width, height);
    Window window;
    if (any) {
      const int x0 = static_cast<int>(std::floor(box.x)) - 1 - blur_margin;
      const int y0 = static_cast<int>(std::floor(box.y)) - 1 - blur_margin;
      const int x1 = static_cast<int>(std::ceil(box.x + box.width)) + 2 + blur_margin;
      const int y1 = static_cast<int>(std::ceil(box.y + box.height)) + 2 + blur_margin;
      window.inner = cv::Rect(x0, y0, x1 - x0, y1 - y0) & image_rect;
      window.outer =
          cv::Rect(x0 - blur_margin, y0 - blur_margin, x1 - x0 + 2 * blur_margin, y1 - y0 + 2 * blur_margin) &
          image_rect;
    }
    return window;
  }

  // The whole frame without a sensor chain: blurred floor + pooled noise
  // from `offset` into the pool, quantised into `image` (H x W, CV_8U).
  void PaintStaticFrame(size_t offset, cv::Mat* image) const {
    const int W = width, H = height;
    for (int v = 0; v < H; ++v) {
      const float* bg = bg_blur.ptr<float>(v);
      uint8_t* out = image->ptr<uint8_t>(v);
      if (noise_pool.empty()) {
        for (int u = 0; u < W; ++u) out[u] = cv::saturate_cast<uint8_t>(bg[u]);
      } else {
        const float* nz = noise_pool.data() + offset + static_cast<size_t>(v) * W;
        for (int u = 0; u < W; ++u) out[u] = cv::saturate_cast<uint8_t>(bg[u] + nz[u]);
      }
    }
  }

  // The outer window at image resolution, all bands composed: each band's
  // geometry over the sharp floor, averaged over its exposure, blurred.
  // Empty when the inner window is.
  // The window is formed at optical_oversample x the resolution: a camera
  // blurs the continuous scene and then integrates over its pixels; blurring
  // pixel-integrated samples with a sampled Gaussian is not the same, and the
  // difference shifts edges parallel to the pixel grid by up to 0.03 px (all
  // their pixels share one sub-pixel phase), a bias no measurement can undo.
  // At 2x the sampled Gaussian is close to the continuous one (<= 0.008 px).
  cv::Mat RenderWindow(const std::vector<std::pair<int, std::vector<Pose2>>>& bands, const Window& window,
                       std::uint64_t jitter_seed) const {
    const cv::Rect& inner = window.inner;
    const cv::Rect& outer = window.outer;
    const int scale = options.optical_oversample;
    cv::Mat blurred;
    for (size_t b = 0; b < bands.size() && inner.area() > 0; ++b) {
      const std::vector<Pose2>& poses = bands[b].second;
      // Rows [row_begin, row_end) of the image come from this band's exposure;
      // the band is rendered over those rows and the blur's reach around them.
      const int row_begin = std::max(bands[b].first, outer.y);
      const int row_end = std::min(b + 1 < bands.size() ? bands[b + 1].first : height, outer.y + outer.height);
      if (row_end <= row_begin) continue;
      cv::Rect strip = outer;
      if (bands.size() > 1) {
        const int y0 = std::max(outer.y, row_begin - blur_margin);
        const int y1 = std::min(outer.y + outer.height, row_end + blur_margin);
        strip = cv::Rect(outer.x, y0, outer.width, y1 - y0);
      }
      cv::Mat acc = cv::Mat::zeros(strip.height * scale, strip.width * scale, CV_32F);
      const double weight = 1.0 / static_cast<double>(poses.size());
      const auto plane = PlanePoints(strip, scale);
      for (const auto& pose : poses) RenderPose(pose, strip, plane, weight, jitter_seed, scale, &acc);
      cv::Mat blurred_fine, band_image;
      Blur(acc, &blurred_fine, scale);
      if (scale > 1) {
        cv::resize(blurred_fine, band_image, strip.size(), 0, 0, cv::INTER_AREA);
      } else {
        band_image = blurred_fine;
      }
      if (bands.size() == 1) {
        blurred = band_image;
        break;
      }
      if (blurred.empty()) blurred = cv::Mat::zeros(outer.size(), CV_32F);
      band_image.rowRange(row_begin - strip.y, row_end - strip.y)
          .copyTo(blurred.rowRange(row_begin - outer.y, row_end - outer.y));
    }
    return blurred;
  }

  // Image bounding box of body and plate at a pose (empty if not in front).
  cv::Rect2d GeometryBox(const Pose2& T_world_robot) const {
    std::vector<Eigen::Vector3d> pts;
    const double r = options.body_radius_mm * kMmToM;
    for (int k = 0; k < 72; ++k) {
      const double a = 2.0 * M_PI * k / 72.0;
      // Circumscribed polygon so the sampled outline never cuts the disc.
      const Eigen::Vector2d p = T_world_robot * Eigen::Vector2d(r / std::cos(M_PI / 72) * std::cos(a),
                                                                r / std::cos(M_PI / 72) * std::sin(a));
      pts.emplace_back(p.x(), p.y(), tag.height_m());
    }
    const Pose2 T_world_tag = T_world_robot * tag.T_robot_tag();
    for (int sx = -1; sx <= 1; sx += 2) {
      for (int sy = -1; sy <= 1; sy += 2) {
        const Eigen::Vector2d p = T_world_tag * Eigen::Vector2d(sx * plate_half_m, sy * plate_half_m);
        pts.emplace_back(p.x(), p.y(), tag.height_m());
      }
    }
    double x0 = 1e18, y0 = 1e18, x1 = -1e18, y1 = -1e18;
    for (const auto& p : pts) {
      const auto px = camera.ProjectWorld(p);
      if (!px) return {};
      x0 = std::min(x0, px->x());
      y0 = std::min(y0, px->y());
      x1 = std::max(x1, px->x());
      y1 = std::max(y1, px->y());
    }
    return {x0, y0, x1 - x0, y1 - y0};
  }
};

Renderer::Renderer(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Renderer::~Renderer() = default;

RendererResult Renderer::Create(const CameraModel& camera, const TagSpec& tag,
                                const RenderOptions& options) {
  RendererResult result;
  std::string why;
  if (!camera.intrinsics().IsValid(&why) || !tag.IsValid(&why) || !options.IsValid(&why)) {
    result.status = StatusCode::kInvalidArgument;
    result.message = why;
    return result;
  }
  auto impl = std::make_unique<Impl>();
  impl->camera = camera;
  impl->tag = tag;
  impl->options = options;
  impl->width = camera.intrinsics().width;
  impl->height = camera.intrinsics().height;
  impl->LoadTag();

  // Normalised coordinates of every pixel corner (u - 0.5, v - 0.5), once.
  impl->corner_rays = internal::PixelCornerRays(camera);
  impl->SampleStaticFloor();
  for (const FloorTagPlacement& placement : options.floor_tags) {
    if (!PaintFloorTag(camera, impl->corner_rays, placement, options, &impl->bg_sharp, &why)) {
      result.message = why;
      return result;
    }
  }
  if (options.formation.psf) {
    impl->blur_margin = PsfMarginPx(*options.formation.psf);
  } else if (options.blur_sigma_px > 0.0) {
    impl->blur_margin = static_cast<int>(std::ceil(4.0 * options.blur_sigma_px)) + 1;
    impl->blur_ksize = internal::BlurKernelSize(options.blur_sigma_px);
  }
  impl->Blur(impl->bg_sharp, &impl->bg_blur, 1);
  impl->SeedNoise();
  result.renderer.reset(new Renderer(std::move(impl)));
  result.status = StatusCode::kOk;
  return result;
}

RenderedFrame Renderer::Render(const Pose2& T_world_robot) {
  return RenderPoses({T_world_robot}, T_world_robot);
}

RenderedFrame Renderer::RenderExposure(const std::function<Pose2(double)>& trajectory,
                                       double t_mid_s) {
  const double e = impl_->options.exposure_s;
  const Pose2 mid = trajectory(t_mid_s);
  if (e <= 0.0 && impl_->options.formation.rolling_shutter_s <= 0.0) return RenderPoses({mid}, mid);
  // Image motion over the exposure, at the tag corners and the body's rim.
  double motion_px = 0.0;
  const auto c0 = TrueCorners(trajectory(t_mid_s - 0.5 * e));
  const auto c1 = TrueCorners(trajectory(t_mid_s + 0.5 * e));
  if (c0 && c1) {
    for (int k = 0; k < 4; ++k) motion_px = std::max(motion_px, cv::norm((*c0)[k] - (*c1)[k]));
  }
  const Pose2 a = trajectory(t_mid_s - 0.5 * e), b = trajectory(t_mid_s + 0.5 * e);
  const double rim_m = std::hypot(b.x() - a.x(), b.y() - a.y()) +
                       std::abs(calibration::WrapAngle(b.heading() - a.heading())) *
                           impl_->options.body_radius_mm * kMmToM;
  const double px_per_m = impl_->camera.intrinsics().fx /
                          std::max(0.1, impl_->camera.mount().height_mm * kMmToM - impl_->tag.height_m());
  motion_px = std::max(motion_px, rim_m * px_per_m);
  const int n = std::clamp(static_cast<int>(std::ceil(motion_px / impl_->options.motion_step_px)) + 1,
                           1, impl_->options.max_motion_substeps);
  const double rs = impl_->options.formation.rolling_shutter_s;
  const int H = impl_->height;
  auto exposure_at = [&](double t) {
    std::vector<Pose2> poses;
    for (int k = 0; k < n; ++k) poses.push_back(trajectory(t - 0.5 * e + (k + 0.5) / n * e));
    return poses;
  };
  if (rs <= 0.0) return RenderBands({{0, exposure_at(t_mid_s)}}, mid);
  // Rolling shutter: bands of rows, each exposed at its middle row's time, so
  // that the image moves at most motion_step_px between neighbouring bands.
  const double row_time = H > 1 ? rs / (H - 1) : 0.0;
  // Image motion over the read-out, measured like the exposure's above.
  double readout_px = 0.0;
  const auto r0 = TrueCorners(trajectory(t_mid_s - 0.5 * rs));
  const auto r1 = TrueCorners(trajectory(t_mid_s + 0.5 * rs));
  if (r0 && r1) {
    for (int k = 0; k < 4; ++k) readout_px = std::max(readout_px, cv::norm((*r0)[k] - (*r1)[k]));
  }
  const Pose2 ra = trajectory(t_mid_s - 0.5 * rs), rb = trajectory(t_mid_s + 0.5 * rs);
  readout_px = std::max(readout_px, (std::hypot(rb.x() - ra.x(), rb.y() - ra.y()) +
                                     std::abs(calibration::WrapAngle(rb.heading() - ra.heading())) *
                                         impl_->options.body_radius_mm * kMmToM) *
                                        px_per_m);
  const int bands = std::clamp(
      static_cast<int>(std::ceil(readout_px / impl_->options.motion_step_px)) + 1, 1, 256);
  std::vector<std::pair<int, std::vector<Pose2>>> out;
  for (int b = 0; b < bands; ++b) {
    const int row_begin = b * H / bands, row_end = (b + 1) * H / bands;
    const double t_row = t_mid_s + (0.5 * (row_begin + row_end - 1) - 0.5 * (H - 1)) * row_time;
    out.emplace_back(row_begin, exposure_at(t_row));
  }
  return RenderBands(out, mid);
}

RenderedFrame Renderer::RenderPoses(const std::vector<Pose2>& exposure_poses,
                                    const Pose2& T_world_robot_truth) {
  return RenderBands({{0, exposure_poses}}, T_world_robot_truth);
}

RenderedFrame Renderer::RenderBands(
    const std::vector<std::pair<int, std::vector<Pose2>>>& bands,
    const Pose2& T_world_robot_truth) {
  Impl& m = *impl_;
  const std::vector<Pose2>& exposure_poses = bands.front().second;
  const int W = m.width, H = m.height;
  RenderedFrame frame;
  frame.T_world_robot = T_world_robot_truth;
  frame.T_world_tag = T_world_robot_truth * m.tag.T_robot_tag();
  frame.motion_substeps = static_cast<int>(exposure_poses.size());
  if (const auto c = TrueCorners(T_world_robot_truth)) {
    frame.corners_px = *c;
    const double side_px = cv::norm((*c)[0] - (*c)[1]);
    const double margin = side_px / m.width_at_border;
    frame.tag_visible = true;
    for (const auto& p : *c) {
      frame.tag_visible &= m.camera.InImage(Eigen::Vector2d(p.x, p.y), margin);
    }
  }
  const Impl::Window window = m.ChangingWindow(bands);

  // Whole frame: blurred floor + pooled noise.
  frame.image.create(H, W, CV_8U);
  const size_t offset = m.noise_pool.empty() ? 0 : m.offset_rng() % (1u << 16);
  if (!m.sensor_chain) {
    m.PaintStaticFrame(offset, &frame.image);
    if (window.inner.area() <= 0) return frame;
  }

  // Redraw the window: geometry over the sharp floor, averaged over the
  // exposure, blurred, fresh noise, quantised.
  // One grid jitter per frame: the coverage errors of consecutive frames are
  // independent and average out over a rest.
  const std::uint64_t jitter_seed = m.offset_rng();
  const cv::Mat blurred = m.RenderWindow(bands, window, jitter_seed);
  const cv::Rect& inner = window.inner;
  const cv::Rect& outer = window.outer;
  if (m.sensor_chain) {
    cv::Mat irradiance = m.bg_blur.clone();
    if (inner.area() > 0)
      blurred(cv::Rect(inner.x - outer.x, inner.y - outer.y, inner.width, inner.height))
          .copyTo(irradiance(inner));
    frame.image = SensorToGrey(irradiance, m.options.formation, m.options.noise_sigma, m.illumination,
                               m.noise_pool, offset, inner, &m.rng);
    return frame;
  }
  cv::Mat window_image = blurred(cv::Rect(inner.x - outer.x, inner.y - outer.y, inner.width, inner.height));
  cv::Mat noisy = window_image.clone();
  if (m.options.noise_sigma > 0.0) {
    cv::Mat noise(inner.size(), CV_32F);
    m.rng.fill(noise, cv::RNG::NORMAL, 0.0, m.options.noise_sigma);
    noisy += noise;
  }
  noisy.convertTo(frame.image(inner), CV_8U);  // rounds and saturates
  return frame;
}

std::optional<std::array<cv::Point2d, 4>> Renderer::TrueCorners(const Pose2& T_world_robot) const {
  const Pose2 T_world_tag = T_world_robot * impl_->tag.T_robot_tag();
  std::array<cv::Point2d, 4> out;
  const auto model = TagCornersInTag(impl_->tag.size_m());
  for (int k = 0; k < 4; ++k) {
    const Eigen::Vector2d p = T_world_tag * model[k];
    const double z = impl_->tag.height_m() + impl_->BowLift(model[k]);
    const auto px = impl_->camera.ProjectWorld(Eigen::Vector3d(p.x(), p.y(), z));
    if (!px) return std::nullopt;
    out[k] = cv::Point2d(px->x(), px->y());
  }
  return out;
}

const CameraModel& Renderer::camera() const { return impl_->camera; }
const TagSpec& Renderer::tag() const { return impl_->tag; }
const RenderOptions& Renderer::options() const { return impl_->options; }
const cv::Mat& Renderer::background() const { return impl_->bg_blur; }

}  // namespace odocal::vision
