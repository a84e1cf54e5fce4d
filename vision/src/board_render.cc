#include "odocal/base/units.h"
#include "odocal/vision/board_render.h"

#include <cmath>
#include <optional>
#include <limits>
#include <random>
#include <utility>

#include <opencv2/imgproc.hpp>

#include "odocal/vision/tag.h"

#include "apriltag_util.h"
#include "raster.h"

namespace odocal::vision {
namespace {

// Region ids: cells are numbered from 0; these two are the rest of the plane.
constexpr int kBeyondBoard = -1;
constexpr int kQuietZone = -2;

}  // namespace

bool BoardPattern::IsValid(std::string* why) const {
  auto fail = [&](const char* msg) {
    if (why) *why = msg;
    return false;
  };
  if (cells.empty() || cells.type() != CV_8UC1) return fail("pattern cells must be a non-empty CV_8UC1 image");
  if (!(cell_m > 0.0)) return fail("pattern cell size must be positive");
  if (!(margin_m >= 0.0)) return fail("pattern margin must be >= 0");
  return true;
}

BoardPattern BoardPattern::Chessboard(int inner_cols, int inner_rows, double square_m) {
  BoardPattern p;
  p.cells.create(inner_rows + 1, inner_cols + 1, CV_8U);
  for (int r = 0; r <= inner_rows; ++r) {
    for (int c = 0; c <= inner_cols; ++c) p.cells.at<uint8_t>(r, c) = (r + c) % 2 ? 255 : 0;
  }
  p.cell_m = square_m;
  p.margin_m = square_m;
  return p;
}

namespace {

struct AprilgridCells {
  int width = 0;  // cells across a tag's black square
  int gap = 0;    // cells between tags
};

std::optional<AprilgridCells> GridCells(const CalibrationBoard& board, std::string* why) {
  std::string reason;
  if (board.type != CalibrationBoard::Type::kAprilgrid || !board.IsValid(&reason)) {
    if (why) *why = reason.empty() ? "not an aprilgrid" : reason;
    return std::nullopt;
  }
  AprilgridCells g;
  g.width = TagWidthAtBorder(board.tag_family);
  const double gap = board.spacing * g.width;
  g.gap = static_cast<int>(std::lround(gap));
  if (g.gap < 1 || std::abs(gap - g.gap) > 1e-6) {
    if (why) *why = "the aprilgrid's gap is not a whole number of cells";
    return std::nullopt;
  }
  return g;
}

}  // namespace

Result<BoardPattern> AprilgridPattern(const CalibrationBoard& board) {
  std::string why;
  const auto g = GridCells(board, &why);
  if (!g) return Result<BoardPattern>::Error(StatusCode::kInvalidArgument, why);
  const int pitch = g->width + g->gap;
  BoardPattern p;
  p.cells = cv::Mat(board.rows * pitch + g->gap, board.cols * pitch + g->gap, CV_8U, cv::Scalar(255));
  auto family = internal::CreateFamily(board.tag_family);
  const int ring = (family->total_width - family->width_at_border) / 2;  // the bitmap's white ring
  for (int r = 0; r < board.rows; ++r) {
    for (int c = 0; c < board.cols; ++c) {
      const int id = board.first_id + r * board.cols + c;
      internal::ImageU8Ptr im(apriltag_to_image(family.get(), id));
      // Kalibr's row r counts up the print; the pattern's rows run down it.
      const int row0 = g->gap + (board.rows - 1 - r) * pitch, col0 = g->gap + c * pitch;
      for (int y = 0; y < g->width; ++y) {
        for (int x = 0; x < g->width; ++x) {
          p.cells.at<uint8_t>(row0 + y, col0 + x) = im->buf[(ring + y) * im->stride + ring + x] ? 255 : 0;
        }
      }
    }
  }
  for (int j = 0; j <= board.rows; ++j) {
    for (int i = 0; i <= board.cols; ++i) {
      p.cells(cv::Rect(i * pitch, j * pitch, g->gap, g->gap)).setTo(0);
    }
  }
  p.cell_m = board.square_m / g->width;
  p.margin_m = g->gap * p.cell_m;
  return Result<BoardPattern>::Ok(std::move(p));
}

Eigen::Vector3d AprilgridPointInPattern(const CalibrationBoard& board, const cv::Point3f& kalibr_point) {
  const auto g = GridCells(board, nullptr);
  const double cell = board.square_m / (g ? g->width : 1);
  const double pitch = g ? g->width + g->gap : 1.0, gap = g ? g->gap : 0.0;
  const double height = (board.rows * pitch + gap) * cell;
  return Eigen::Vector3d(gap * cell + kalibr_point.x, height - gap * cell - kalibr_point.y, -kalibr_point.z);
}

std::vector<Eigen::Vector3d> ChessboardCorners(int inner_cols, int inner_rows, double square_m) {
  std::vector<Eigen::Vector3d> out;
  for (int r = 0; r < inner_rows; ++r) {
    for (int c = 0; c < inner_cols; ++c) out.emplace_back((c + 1) * square_m, (r + 1) * square_m, 0.0);
  }
  return out;
}

bool BoardRenderOptions::IsValid(std::string* why) const {
  auto fail = [&](const char* msg) {
    if (why) *why = msg;
    return false;
  };
  if (!(noise_sigma >= 0.0)) return fail("noise_sigma must be >= 0");
  if (!(blur_sigma_px >= 0.0) || blur_sigma_px > 20.0) return fail("blur_sigma_px must be in [0, 20]");
  if (supersample < 1 || supersample > 64) return fail("supersample must be in [1, 64]");
  return true;
}

namespace {

// The board's sharp image: each pixel the board's grey levels integrated
// over its footprint on the board plane (CV_32F, the image's size).
cv::Mat IntegrateBoard(const CameraModel& camera, const BoardPattern& pattern, const Eigen::Isometry3d& T_camera_board,
                       const BoardRenderOptions& options) {
  const int W = camera.intrinsics().width, H = camera.intrinsics().height;
  const cv::Mat rays = internal::PixelCornerRays(camera);

  const Eigen::Matrix3d R = T_camera_board.linear();
  const Eigen::Vector3d t = T_camera_board.translation();
  const Eigen::Vector3d n = R.col(2);
  const double n_t = n.dot(t);
  const int rows = pattern.cells.rows, cols = pattern.cells.cols;
  const double width_m = cols * pattern.cell_m, height_m = rows * pattern.cell_m;

  auto classify = [&](const Eigen::Vector2d& q) {
    const double x = q.x() / pattern.cell_m, y = q.y() / pattern.cell_m;
    if (x >= 0.0 && y >= 0.0 && x < cols && y < rows) {
      return static_cast<int>(y) * cols + static_cast<int>(x);
    }
    if (q.x() >= -pattern.margin_m && q.y() >= -pattern.margin_m && q.x() <= width_m + pattern.margin_m &&
        q.y() <= height_m + pattern.margin_m) {
      return kQuietZone;
    }
    return kBeyondBoard;
  };
  auto value = [&](int id, int, int) {
    if (id >= 0) return pattern.cells.at<uint8_t>(id / cols, id % cols) ? options.white : options.black;
    return id == kQuietZone ? options.white : options.background;
  };

  std::vector<Eigen::Vector2d> q(static_cast<size_t>(W + 1) * (H + 1));
  std::vector<int> id(q.size());
  for (int v = 0; v <= H; ++v) {
    const cv::Vec2d* row = rays.ptr<cv::Vec2d>(v);
    for (int u = 0; u <= W; ++u) {
      const size_t k = static_cast<size_t>(v) * (W + 1) + u;
      const Eigen::Vector3d d(row[u][0], row[u][1], 1.0);
      const double n_d = n.dot(d);
      const double s = std::abs(n_d) > 1e-12 ? n_t / n_d : -1.0;
      if (s > 0.0) {
        const Eigen::Vector3d p_board = R.transpose() * (s * d - t);
        q[k] = p_board.head<2>();
        id[k] = classify(q[k]);
      } else {
        // The ray misses the plane: far away, so samples interpolated towards it stay off the board.
        q[k] = Eigen::Vector2d(1e9, 1e9);
        id[k] = kBeyondBoard;
      }
    }
  }
  cv::Mat acc = cv::Mat::zeros(H, W, CV_32F);
  internal::IntegratePixels(W, H, q, id, options.supersample, 1.0, options.seed * 0x2545F4914F6CDD1Dull + 1,
                            classify, value, &acc);
  return acc;
}

// The camera over the sharp image: the optics' blur, then the sensor's noise.
void BlurAndNoise(const BoardRenderOptions& options, cv::Mat* acc) {
  if (options.blur_sigma_px > 0.0) {
    cv::Mat blurred;
    internal::OpticalBlur(*acc, &blurred, options.blur_sigma_px);
    *acc = blurred;
  }
  if (options.noise_sigma > 0.0) {
    cv::Mat noise(acc->rows, acc->cols, CV_32F);
    cv::RNG rng(options.seed * 6364136223846793005ull + 1442695040888963407ull);
    rng.fill(noise, cv::RNG::NORMAL, 0.0, options.noise_sigma);
    *acc += noise;
  }
}

// The board points' true pixels into the frame (NaN behind the camera), and
// whether all are in the image `margin_px` from its border.
void ProjectBoardPoints(const CameraModel& camera, const Eigen::Isometry3d& T_camera_board,
                        const std::vector<Eigen::Vector3d>& points_board, double margin_px, RenderedBoard* frame) {
  frame->all_visible = true;
  for (const Eigen::Vector3d& p : points_board) {
    const auto px = camera.ProjectCamera(T_camera_board * p);
    if (!px) {
      const double nan = std::numeric_limits<double>::quiet_NaN();
      frame->points_px.emplace_back(nan, nan);
      frame->all_visible = false;
      continue;
    }
    frame->points_px.emplace_back(px->x(), px->y());
    frame->all_visible &= camera.InImage(*px, margin_px);
  }
}

}  // namespace

BoardRenderResult RenderBoard(const Intrinsics& intrinsics, const BoardPattern& pattern,
                              const Eigen::Isometry3d& T_camera_board, const std::vector<Eigen::Vector3d>& points_board,
                              const BoardRenderOptions& options, double margin_px) {
  BoardRenderResult result;
  if (!intrinsics.IsValid(&result.message) || !pattern.IsValid(&result.message) || !options.IsValid(&result.message)) {
    result.status = StatusCode::kInvalidArgument;
    return result;
  }
  // The mount is irrelevant here: everything happens in the camera frame.
  const CameraModel camera(intrinsics, CameraMount{});
  cv::Mat acc = IntegrateBoard(camera, pattern, T_camera_board, options);
  BlurAndNoise(options, &acc);
  acc.convertTo(result.frame.image, CV_8U);  // rounds and saturates
  ProjectBoardPoints(camera, T_camera_board, points_board, margin_px, &result.frame);
  result.status = StatusCode::kOk;
  return result;
}

namespace {

// The corners of the axis-aligned box around `points` (not empty).
std::pair<Eigen::Vector3d, Eigen::Vector3d> BoundingBox(const std::vector<Eigen::Vector3d>& points) {
  Eigen::Vector3d lo = points[0], hi = points[0];
  for (const auto& p : points) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  return {lo, hi};
}

}  // namespace

std::optional<std::vector<Eigen::Isometry3d>> SampleBoardPoses(
    const Intrinsics& intrinsics, const std::vector<Eigen::Vector3d>& points_board,
    const BoardPoseSampling& sampling) {
  if (points_board.empty() || !intrinsics.IsValid(nullptr)) return std::nullopt;
  const CameraModel camera(intrinsics, CameraMount{});
  const auto [lo, hi] = BoundingBox(points_board);
  const Eigen::Vector3d centre = 0.5 * (lo + hi);
  const double extent_m = (hi - lo).head<2>().norm();
  std::mt19937_64 rng(sampling.seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  auto uniform = [&](double a, double b) { return a + (b - a) * unit(rng); };
  auto tilt = [&]() {
    const double t = uniform(sampling.min_tilt_deg, sampling.max_tilt_deg) * kDegToRad;
    return unit(rng) < 0.5 ? -t : t;
  };
  std::vector<Eigen::Isometry3d> poses;
  for (int attempt = 0; attempt < 1000 * sampling.count && static_cast<int>(poses.size()) < sampling.count;
       ++attempt) {
    const Eigen::Matrix3d R =
        (Eigen::AngleAxisd(uniform(-sampling.max_turn_deg, sampling.max_turn_deg) * kDegToRad, Eigen::Vector3d::UnitZ()) *
         Eigen::AngleAxisd(tilt(), Eigen::Vector3d::UnitY()) *
         Eigen::AngleAxisd(tilt(), Eigen::Vector3d::UnitX()))
            .toRotationMatrix();
    const double z = intrinsics.fx * extent_m /
                     (uniform(sampling.min_fill, sampling.max_fill) * intrinsics.width);
    // Board centre on the ray through a random pixel (pinhole; the check below is exact).
    const double u = uniform(0.0, intrinsics.width), v = uniform(0.0, intrinsics.height);
    const Eigen::Vector3d c((u - intrinsics.cx) / intrinsics.fx * z, (v - intrinsics.cy) / intrinsics.fy * z, z);
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = R;
    T.translation() = c - R * centre;
    bool inside = true;
    for (const auto& p : points_board) {
      const auto px = camera.ProjectCamera(T * p);
      inside = inside && px && camera.InImage(*px, sampling.margin_px);
      if (!inside) break;
    }
    if (inside) poses.push_back(T);
  }
  if (static_cast<int>(poses.size()) < sampling.count) return std::nullopt;
  return poses;
}

std::optional<std::vector<Eigen::Isometry3d>> SampleFieldBoardPoses(
    const Intrinsics& intrinsics, const std::vector<Eigen::Vector3d>& points_board,
    const FieldPoseSampling& sampling) {
  if (points_board.empty() || !intrinsics.IsValid(nullptr)) return std::nullopt;
  const CameraModel camera(intrinsics, CameraMount{});
  const auto [lo, hi] = BoundingBox(points_board);
  const Eigen::Vector3d centre = 0.5 * (lo + hi);
  std::mt19937_64 rng(sampling.seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::vector<Eigen::Isometry3d> poses;
  for (int attempt = 0; attempt < 1000 * sampling.count && static_cast<int>(poses.size()) < sampling.count;
       ++attempt) {
    // Uniform over the ring of directions min..max off the axis (area ~ off^2).
    const double lo2 = sampling.min_off_axis_deg * sampling.min_off_axis_deg;
    const double hi2 = sampling.max_off_axis_deg * sampling.max_off_axis_deg;
    const double off = kDegToRad * std::sqrt(lo2 + (hi2 - lo2) * unit(rng));
    const double azimuth = 2.0 * M_PI * unit(rng);
    const double distance = sampling.near_m + (sampling.far_m - sampling.near_m) * unit(rng);
    const Eigen::Vector3d ray(std::sin(off) * std::cos(azimuth), std::sin(off) * std::sin(azimuth), std::cos(off));
    // The board's z axis (away from the camera seeing its face) along the ray, then tilted and turned.
    const double tilt = sampling.max_tilt_deg * kDegToRad;
    const Eigen::Matrix3d R =
        Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), ray).toRotationMatrix() *
        (Eigen::AngleAxisd((2.0 * unit(rng) - 1.0) * tilt, Eigen::Vector3d::UnitX()) *
         Eigen::AngleAxisd((2.0 * unit(rng) - 1.0) * tilt, Eigen::Vector3d::UnitY()) *
         Eigen::AngleAxisd(2.0 * M_PI * unit(rng), Eigen::Vector3d::UnitZ()))
            .toRotationMatrix();
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = R;
    T.translation() = distance * ray - R * centre;
    int in_view = 0;
    for (const auto& p : points_board) {
      const Eigen::Vector3d c = T * p;
      const auto px = c.z() > 0.0 ? camera.ProjectCamera(c) : std::nullopt;
      in_view += px && camera.InImage(*px, sampling.margin_px);
    }
    if (in_view >= sampling.min_points_in_view) poses.push_back(T);
  }
  if (static_cast<int>(poses.size()) < sampling.count) return std::nullopt;
  return poses;
}

}  // namespace odocal::vision
