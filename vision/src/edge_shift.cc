// The edge shift of a tag image (edge_shift.h has the model and why).
//
// Coordinates. u: the tag plane in cells as the refined outer corners give
// it (the homography H maps u to undistorted pixels; its square is the print
// grown by s on every side). With s in cells, the print's square is H's
// shrunk by lambda = n / (n + 2 s), so a printed boundary at k cells lies at
// lambda k in u, and a black cell's side that faces white at lambda (k +/- s).
// The outer edges land at lambda (n/2 + s) = n/2: where the edge fit put them.
#include "odocal/vision/edge_shift.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <Eigen/Dense>
#include <ceres/ceres.h>
#include <opencv2/imgproc.hpp>

#include "odocal/calibration/statistics.h"
#include "odocal/vision/tag.h"

#include "apriltag_util.h"
#include "odocal/vision/internal/edge_costs.h"
#include "odocal/vision/internal/edge_functions.h"

namespace odocal::vision {

bool EdgeShiftOptions::IsValid(std::string* why) const {
  const auto fail = [why](const std::string& what) {
    if (why) *why = "edge shift options: " + what;
    return false;
  };
  if (!(margin_cells >= 0.0 && margin_cells <= 2.0)) return fail("margin_cells must be in [0, 2]");
  if (!(corner_cells >= 0.0)) return fail("corner_cells must not be negative");
  if (!(min_cell_px > 0.0)) return fail("min_cell_px must be positive");
  if (!(max_blur_cells > 0.0)) return fail("max_blur_cells must be positive");
  if (!(max_pixels >= 100.0)) return fail("max_pixels must be at least 100");
  return solver.IsValid(why);
}

Result<TagCells> TagCells::Of(const std::string& family, int id) {
  using R = Result<TagCells>;
  auto f = internal::CreateFamily(family);
  if (!f) return R::Error(StatusCode::kInvalidArgument, "unknown tag family '" + family + "'");
  if (id < 0 || id >= static_cast<int>(f->ncodes))
    return R::Error(StatusCode::kInvalidArgument, "tag id " + std::to_string(id) + " is not in family " + family);
  if (f->reversed_border)
    return R::Error(StatusCode::kInvalidArgument, "family " + family + " has its black border inside (not measured)");
  internal::ImageU8Ptr im(apriltag_to_image(f.get(), id));
  TagCells cells;
  cells.n = static_cast<int>(f->width_at_border);
  const int start = (im->width - cells.n) / 2;
  cells.black.resize(static_cast<size_t>(cells.n * cells.n));
  for (int r = 0; r < cells.n; ++r)
    for (int c = 0; c < cells.n; ++c)
      cells.black[static_cast<size_t>(r * cells.n + c)] = im->buf[(r + start) * im->stride + c + start] < 128;
  return R::Ok(std::move(cells));
}

namespace {

using internal::ShiftPixel;

// The blurred print's black fraction at u (cells) for a pixel with the
// black cells of `q`, shift s (cells), lambda = n / (n + 2 s), blur sigma
// (cells).
template <typename T>
T BlackAt(const ShiftPixel& q, const T& ux, const T& uy, const T& s, const T& lambda, const T& sigma) {
  T black = T(0.0);
  for (const ShiftPixel::Cell& c : q.cells) {
    const T x0 = lambda * (c.x0 - (c.wl ? s : T(0.0))), x1 = lambda * (c.x1 + (c.wr ? s : T(0.0)));
    const T y0 = lambda * (c.y0 - (c.wb ? s : T(0.0))), y1 = lambda * (c.y1 + (c.wt ? s : T(0.0)));
    const T bx = internal::Phi((x1 - ux) / sigma) - internal::Phi((x0 - ux) / sigma);
    const T by = internal::Phi((y1 - uy) / sigma) - internal::Phi((y0 - uy) / sigma);
    black += bx * by;
  }
  return black;
}

// The whole tag: the outer square's four corners (undistorted pixels) free
// too, so every black/white boundary of the tag, not only the outer four,
// places it.
class TagPatternCost {
 public:
  TagPatternCost(const std::vector<ShiftPixel>* pixels, double n) : pixels_(pixels), n_(n) {}
  // corners: 4 x (x, y) undistorted pixels of the square u = +-n/2 in
  // SquareCorner's order; p as EdgeShiftCost's.
  template <typename T>
  bool operator()(const T* const corners, const T* const p, T* residual) const {
    using std::exp;
    using std::sqrt;
    // G: undistorted pixel -> u, the homography taking the four corners to
    // the square (h33 = 1; a direct 8 x 8 solve).
    static constexpr int kSx[4] = {-1, 1, 1, -1}, kSy[4] = {-1, -1, 1, 1};
    Eigen::Matrix<T, 8, 8> A;
    Eigen::Matrix<T, 8, 1> b;
    const double h = 0.5 * n_;
    for (int k = 0; k < 4; ++k) {
      const T x = corners[2 * k], y = corners[2 * k + 1];
      const double X = kSx[k] * h, Y = kSy[k] * h;
      A.row(2 * k) << x, y, T(1.0), T(0.0), T(0.0), T(0.0), -X * x, -X * y;
      A.row(2 * k + 1) << T(0.0), T(0.0), T(0.0), x, y, T(1.0), -Y * x, -Y * y;
      b(2 * k) = T(X);
      b(2 * k + 1) = T(Y);
    }
    const Eigen::Matrix<T, 8, 1> g = A.partialPivLu().solve(b);
    const T s = p[0];
    const T lambda = n_ / (n_ + 2.0 * s);
    const T blur = exp(p[1]);
    const T blur2 = blur * blur + 1.0 / 12.0;
    for (size_t i = 0; i < pixels_->size(); ++i) {
      const ShiftPixel& q = (*pixels_)[i];
      const T w = g(6) * q.qx + g(7) * q.qy + 1.0;
      const T ux = (g(0) * q.qx + g(1) * q.qy + g(2)) / w;
      const T uy = (g(3) * q.qx + g(4) * q.qy + g(5)) / w;
      const T sigma = sqrt(blur2) * q.cells_per_px;
      residual[i] = p[2] + p[3] * (1.0 - BlackAt(q, ux, uy, s, lambda, sigma)) - q.value;
    }
    return true;
  }

 private:
  const std::vector<ShiftPixel>* pixels_;
  double n_;
};

// Corner k of the square of half-width h (cells), in the detector's order.
cv::Point2d SquareCorner(int k, double h) {
  static constexpr int kSx[4] = {-1, 1, 1, -1}, kSy[4] = {-1, -1, 1, 1};
  return {kSx[k] * h, kSy[k] * h};
}

std::vector<cv::Point2d> Undistort(const std::vector<cv::Point2d>& px, const CameraModel* camera) {
  return camera ? camera->UndistortPixels(px) : px;
}

cv::Point2d Distort(const cv::Point2d& q, const CameraModel* camera) {
  if (!camera) return q;
  const Intrinsics& in = camera->intrinsics();
  const auto px = camera->ProjectCamera(Eigen::Vector3d((q.x - in.cx) / in.fx, (q.y - in.cy) / in.fy, 1.0));
  return px ? cv::Point2d(px->x(), px->y()) : q;
}

// H: u (cells, y up) -> undistorted pixels, from the four corners.
cv::Matx33d SquareHomography(const std::array<cv::Point2d, 4>& undistorted, double half) {
  std::vector<cv::Point2f> from, to;
  for (int k = 0; k < 4; ++k) {
    const cv::Point2d u = SquareCorner(k, half);
    from.emplace_back(static_cast<float>(u.x), static_cast<float>(u.y));
    to.emplace_back(static_cast<float>(undistorted[k].x), static_cast<float>(undistorted[k].y));
  }
  cv::Mat H = cv::getPerspectiveTransform(from, to);
  cv::Matx33d out;
  H.convertTo(cv::Mat(3, 3, CV_64F, out.val), CV_64F);
  return out;
}

cv::Point2d Apply(const cv::Matx33d& H, const cv::Point2d& p) {
  const cv::Vec3d v = H * cv::Vec3d(p.x, p.y, 1.0);
  return {v[0] / v[2], v[1] / v[2]};
}

// MeasureEdgeShift, and with `print_corners` RefineTagByPattern.
// The black cells within reach of the blur of a pixel at `u` (cells, y up):
// col = floor(x + half), row = floor(half - y). Two cells each way are at
// least one cell away, 2 sigma at the largest blur allowed (half a cell): 2 %
// of a level there, < 0.1 % at the blur of a focused camera.
std::vector<ShiftPixel::Cell> BlackCellsNear(const TagCells& cells, const cv::Point2d& u) {
  const double half = 0.5 * cells.n;
  std::vector<ShiftPixel::Cell> near;
  const int col = static_cast<int>(std::floor(u.x + half)), row = static_cast<int>(std::floor(half - u.y));
  const int r = 2;
  for (int rr = row - r; rr <= row + r; ++rr) {
    for (int cc = col - r; cc <= col + r; ++cc) {
      if (!cells.Black(rr, cc)) continue;
      ShiftPixel::Cell c;
      c.x0 = cc - half;
      c.x1 = c.x0 + 1.0;
      c.y1 = half - rr;
      c.y0 = c.y1 - 1.0;
      c.wl = !cells.Black(rr, cc - 1);
      c.wr = !cells.Black(rr, cc + 1);
      c.wt = !cells.Black(rr - 1, cc);
      c.wb = !cells.Black(rr + 1, cc);
      near.push_back(c);
    }
  }
  return near;
}

// The pixels the pattern is fitted to: centres whose u lies within the
// margin of the black square, away from its corners, and inside the crop,
// each with the black cells near it. False when the tag is outside the image.
bool CollectPatternPixels(const cv::Mat& grey, const cv::Point& origin, const cv::Matx33d& H, const TagCells& cells,
                          const CameraModel* camera, const EdgeShiftOptions& options, std::vector<ShiftPixel>* out,
                          double* dark_out, double* light_out) {
  const double half = 0.5 * cells.n;
  const cv::Matx33d Hinv = H.inv();
  const double reach = half + options.margin_cells;
  double x0 = 1e18, y0 = 1e18, x1 = -1e18, y1 = -1e18;
  for (int k = 0; k < 4; ++k) {
    const cv::Point2d c = Distort(Apply(H, SquareCorner(k, reach)), camera);
    x0 = std::min(x0, c.x);
    y0 = std::min(y0, c.y);
    x1 = std::max(x1, c.x);
    y1 = std::max(y1, c.y);
  }
  const int ix0 = std::max(origin.x, static_cast<int>(std::floor(x0)) - 1);
  const int iy0 = std::max(origin.y, static_cast<int>(std::floor(y0)) - 1);
  const int ix1 = std::min(origin.x + grey.cols - 1, static_cast<int>(std::ceil(x1)) + 1);
  const int iy1 = std::min(origin.y + grey.rows - 1, static_cast<int>(std::ceil(y1)) + 1);
  if (ix1 <= ix0 || iy1 <= iy0) return false;
  // A large tag's pixels one in stride x stride: the fit's cost grows with
  // the tag's area, its information with its edges' length.
  const double area = static_cast<double>(ix1 - ix0 + 1) * (iy1 - iy0 + 1);
  const int stride = std::max(1, static_cast<int>(std::ceil(std::sqrt(area / options.max_pixels))));
  std::vector<cv::Point2d> centres;
  for (int y = iy0; y <= iy1; y += stride)
    for (int x = ix0; x <= ix1; x += stride) centres.emplace_back(x, y);
  // Each centre and its four half-pixel neighbours, undistorted in one call.
  constexpr double h = 0.25;
  std::vector<cv::Point2d> probes;
  probes.reserve(5 * centres.size());
  for (const cv::Point2d& c : centres) {
    probes.push_back(c);
    probes.emplace_back(c.x + h, c.y);
    probes.emplace_back(c.x - h, c.y);
    probes.emplace_back(c.x, c.y + h);
    probes.emplace_back(c.x, c.y - h);
  }
  const std::vector<cv::Point2d> q = Undistort(probes, camera);
  std::vector<ShiftPixel> pixels;
  double dark = 255.0, light = 0.0;
  for (size_t i = 0; i < centres.size(); ++i) {
    const cv::Point2d u = Apply(Hinv, q[5 * i]);
    if (!(std::abs(u.x) <= reach && std::abs(u.y) <= reach)) continue;
    if (std::abs(u.x) > half - options.corner_cells && std::abs(u.y) > half - options.corner_cells) continue;
    const cv::Point2d dx = (Apply(Hinv, q[5 * i + 1]) - Apply(Hinv, q[5 * i + 2])) * (0.5 / h);
    const cv::Point2d dy = (Apply(Hinv, q[5 * i + 3]) - Apply(Hinv, q[5 * i + 4])) * (0.5 / h);
    const double det = std::abs(dx.x * dy.y - dx.y * dy.x);
    if (!(det > 0.0) || !std::isfinite(det)) continue;
    ShiftPixel p;
    p.qx = q[5 * i].x;
    p.qy = q[5 * i].y;
    p.ux = u.x;
    p.uy = u.y;
    p.cells_per_px = std::sqrt(det);
    p.value = grey.at<std::uint8_t>(static_cast<int>(centres[i].y) - origin.y,
                                    static_cast<int>(centres[i].x) - origin.x);
    p.cells = BlackCellsNear(cells, u);
    dark = std::min(dark, p.value);
    light = std::max(light, p.value);
    pixels.push_back(std::move(p));
  }
  *out = std::move(pixels);
  *dark_out = dark;
  *light_out = light;
  return true;
}

// The pattern fitted (the shift alone, or with the corners free when
// `c8` is given: the undistorted corners, x y x y ...) from `p`'s start
// (shift cells, log blur, dark, light - dark); into `result`: the shift, its
// sigma, the blur, the residual. False (result->message says why) when the
// fit fails or the shift runs to its bound.
bool SolvePattern(const std::vector<ShiftPixel>& pixels, int n, const EdgeShiftOptions& options, double* c8, double* p,
                  EdgeShiftResult* result) {
  ceres::Problem problem;
  if (c8) {
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<TagPatternCost, ceres::DYNAMIC, 8, 4>(
                                 new TagPatternCost(&pixels, n), static_cast<int>(pixels.size())),
                             nullptr, c8, p);
  } else {
    // The shift alone, u fixed by the refined corners.
    problem.AddResidualBlock(new internal::EdgeShiftCost(&pixels, n), nullptr, p);
  }
  problem.SetParameterLowerBound(p, 0, -0.3);
  problem.SetParameterUpperBound(p, 0, 0.3);
  problem.SetParameterLowerBound(p, 1, std::log(0.05));
  problem.SetParameterUpperBound(p, 1, std::log(std::max(0.1, options.max_blur_cells * result->cell_px)));
  ceres::Solver::Options solver;
  solver.linear_solver_type = ceres::DENSE_QR;
  ApplyTo(options.solver, &solver);
  ceres::Solver::Summary summary;
  ceres::Solve(solver, &problem, &summary);
  if (!summary.IsSolutionUsable() || !(p[3] > 10.0)) {
    result->message = "the tag's pattern could not be fitted";
    return false;
  }
  result->pixels = static_cast<int>(pixels.size());
  result->rms_grey = std::sqrt(2.0 * summary.final_cost / pixels.size());
  result->blur_px = std::exp(p[1]);
  // Gauss-Newton covariance scaled by the residual variance.
  ceres::Covariance::Options cov_options;
  ceres::Covariance covariance(cov_options);
  std::vector<std::pair<const double*, const double*>> blocks = {{p, p}};
  double sigma_cells = 0.0;
  if (covariance.Compute(blocks, &problem)) {
    double c[16];
    covariance.GetCovarianceBlock(p, p, c);
    const double dof = std::max<double>(1.0, static_cast<double>(pixels.size()) - 4.0);
    sigma_cells = std::sqrt(std::max(0.0, c[0]) * 2.0 * summary.final_cost / dof);
  }
  result->shift_px = p[0] * result->cell_px;
  result->sigma_px = sigma_cells * result->cell_px;
  if (std::abs(p[0]) > 0.299) {
    result->message = "the edge shift ran to its bound (" + std::to_string(result->shift_px) + " px)";
    return false;
  }
  return true;
}

EdgeShiftResult FitTagPattern(const cv::Mat& grey, const std::array<cv::Point2d, 4>& corners_px, const TagCells& cells,
                              const CameraModel* camera, const EdgeShiftOptions& options, const cv::Point& origin,
                              std::array<cv::Point2d, 4>* print_corners) {
  EdgeShiftResult result;
  if (!options.IsValid(&result.message)) {
    result.status = StatusCode::kInvalidArgument;
    return result;
  }
  if (grey.empty() || grey.type() != CV_8UC1) {
    result.status = StatusCode::kInvalidArgument;
    result.message = "edge shift needs an 8-bit grey image";
    return result;
  }
  const int n = cells.n;
  if (n < 3 || cells.black.size() != static_cast<size_t>(n * n)) {
    result.message = "tag cells missing";
    return result;
  }
  double perimeter = 0.0;
  for (int k = 0; k < 4; ++k) perimeter += cv::norm(corners_px[(k + 1) % 4] - corners_px[k]);
  result.side_px = perimeter / 4.0;
  result.cell_px = result.side_px / n;
  if (result.cell_px < options.min_cell_px) {
    result.message = "cells too small to measure the edge shift";
    return result;
  }
  const double half = 0.5 * n;
  const std::vector<cv::Point2d> und = Undistort({corners_px[0], corners_px[1], corners_px[2], corners_px[3]}, camera);
  const cv::Matx33d H = SquareHomography({und[0], und[1], und[2], und[3]}, half);

  std::vector<ShiftPixel> pixels;
  double dark = 255.0, light = 0.0;
  if (!CollectPatternPixels(grey, origin, H, cells, camera, options, &pixels, &dark, &light)) {
    result.message = "tag outside the image";
    return result;
  }
  if (pixels.size() < 50 || light - dark < 20.0) {
    result.message = pixels.size() < 50 ? "too few pixels on the tag" : "too little contrast";
    return result;
  }
  double p[4] = {0.0, std::log(0.7), dark, light - dark};
  double c8[8];
  for (int k = 0; k < 4; ++k) {
    c8[2 * k] = und[k].x;
    c8[2 * k + 1] = und[k].y;
  }
  if (!SolvePattern(pixels, n, options, print_corners ? c8 : nullptr, p, &result)) return result;
  if (print_corners) {
    // The print's square, +-lambda n/2 in u, through the fitted corners.
    std::array<cv::Point2d, 4> fitted;
    for (int k = 0; k < 4; ++k) fitted[k] = cv::Point2d(c8[2 * k], c8[2 * k + 1]);
    const cv::Matx33d Hf = SquareHomography(fitted, half);
    const double lambda = n / (n + 2.0 * p[0]);
    for (int k = 0; k < 4; ++k) {
      (*print_corners)[k] = Distort(Apply(Hf, SquareCorner(k, lambda * half)), camera);
      if (cv::norm((*print_corners)[k] - corners_px[k]) > std::max(1.5, 0.3 * result.cell_px)) {
        result.message = "the tag's pattern moved a corner implausibly far";
        return result;
      }
    }
  }
  result.status = StatusCode::kOk;
  return result;
}

}  // namespace

EdgeShiftResult MeasureEdgeShift(const cv::Mat& grey, const std::array<cv::Point2d, 4>& corners_px,
                                 const TagCells& cells, const CameraModel* camera,
                                 const EdgeShiftOptions& options, const cv::Point& origin) {
  return FitTagPattern(grey, corners_px, cells, camera, options, origin, nullptr);
}

TagPatternResult RefineTagByPattern(const cv::Mat& grey, const std::array<cv::Point2d, 4>& corners_px,
                                    const TagCells& cells, const CameraModel* camera,
                                    const EdgeShiftOptions& options, const cv::Point& origin) {
  TagPatternResult r;
  r.corners_px = corners_px;
  r.shift = FitTagPattern(grey, corners_px, cells, camera, options, origin, &r.corners_px);
  if (!r.shift.ok()) r.corners_px = corners_px;
  return r;
}

EdgeShiftEstimate PoolEdgeShifts(const std::vector<EdgeShiftResult>& views, double systematic_px) {
  EdgeShiftEstimate e;
  // A view whose own fit's sigma is over kOutlierSigmaRatio times the views'
  // median says it could not measure the shift: left out of the mean, where
  // it would weigh as much as the others. A Kalibr tag of 1.5 px cells with
  // its edges along the pixel grid: -0.21 +/- 0.026 px for an ink of -0.12,
  // its turned views +/- 0.0025 (EdgeShift.MeasuresTheShiftInTagsOfOneAnd-
  // AThirdPixelCells). Views of alike sigmas are all kept.
  constexpr double kOutlierSigmaRatio = 4.0;
  std::vector<double> sigmas;
  for (const EdgeShiftResult& v : views)
    if (v.ok()) sigmas.push_back(v.sigma_px);
  const double limit =
      sigmas.size() >= 3 ? kOutlierSigmaRatio * calibration::Median(sigmas) : std::numeric_limits<double>::infinity();
  double sum = 0.0, sum2 = 0.0, fit2 = 0.0, side = 0.0;
  for (const EdgeShiftResult& v : views) {
    if (!v.ok() || !(v.sigma_px <= limit)) continue;
    ++e.views;
    sum += v.shift_px;
    sum2 += v.shift_px * v.shift_px;
    fit2 += v.sigma_px * v.sigma_px;
    side += v.side_px;
  }
  if (e.views == 0) {
    e.message = views.empty() ? "no views to measure the edge shift in" : views.front().message;
    return e;
  }
  const double n = e.views;
  e.shift_px = sum / n;
  e.spread_px = n > 1 ? std::sqrt(std::max(0.0, (sum2 - n * e.shift_px * e.shift_px) / (n - 1.0))) : 0.0;
  const double statistical = std::max(e.spread_px, std::sqrt(fit2 / n)) / std::sqrt(n);
  e.sigma_px = std::hypot(statistical, systematic_px);
  e.side_px = side / n;
  e.status = StatusCode::kOk;
  return e;
}

std::array<cv::Point2d, 4> RemoveEdgeShift(const std::array<cv::Point2d, 4>& corners_px, double shift_px,
                                           const CameraModel* camera) {
  const std::vector<cv::Point2d> und =
      Undistort({corners_px[0], corners_px[1], corners_px[2], corners_px[3]}, camera);
  // In a square of side 2 (half-width 1): the cell is side/n, so an edge s px
  // outwards is s / (side_px / 2) of the half-width.
  double perimeter = 0.0;
  for (int k = 0; k < 4; ++k) perimeter += cv::norm(corners_px[(k + 1) % 4] - corners_px[k]);
  const double half_px = perimeter / 8.0;
  const double lambda = 1.0 - shift_px / half_px;
  const cv::Matx33d H = SquareHomography({und[0], und[1], und[2], und[3]}, 1.0);
  std::array<cv::Point2d, 4> out;
  for (int k = 0; k < 4; ++k) out[k] = Distort(Apply(H, SquareCorner(k, lambda)), camera);
  return out;
}

}  // namespace odocal::vision
