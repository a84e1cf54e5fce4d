#include "odocal/vision/corner_refine.h"

#include "corner_geometry.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

namespace odocal::vision {

bool CornerRefineOptions::IsValid(std::string* why) const {
  const auto fail = [why](const std::string& field, const std::string& rule) {
    if (why) *why = "corner refinement: " + field + " " + rule;
    return false;
  };
  if (!(sample_step_px > 0.0)) return fail("sample_step_px", "must be positive");
  if (!(end_margin >= 0.0 && end_margin < 0.5)) return fail("end_margin", "must be in [0, 0.5)");
  if (!(max_half_width_px > 0.5)) return fail("max_half_width_px", "must be over 0.5");
  if (!(min_cell_px > 0.0)) return fail("min_cell_px", "must be positive");
  if (width_at_border < 3) return fail("width_at_border", "must be at least 3");
  if (!(model_free_settled_px >= 0.0)) return fail("model_free_settled_px", "must not be negative");
  std::string solver_why;
  if (!edge_model_solver.IsValid(&solver_why)) return fail("edge_model_solver:", solver_why);
  if (!model_free_solver.IsValid(&solver_why)) return fail("model_free_solver:", solver_why);
  return true;
}

namespace {

// Bilinear sample with OpenCV's convention (pixel centres at integers).
bool Sample(const cv::Mat& im, double x, double y, double* value) {
  const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
  if (x0 < 0 || y0 < 0 || x0 + 1 >= im.cols || y0 + 1 >= im.rows) return false;
  const double fx = x - x0, fy = y - y0;
  const uint8_t* r0 = im.ptr<uint8_t>(y0);
  const uint8_t* r1 = im.ptr<uint8_t>(y0 + 1);
  *value = (r0[x0] * (1 - fx) + r0[x0 + 1] * fx) * (1 - fy) + (r1[x0] * (1 - fx) + r1[x0 + 1] * fx) * fy;
  return true;
}

// Where the profile along `n` through `p` crosses halfway between the dark
// (s < 0, inside) and light (s > 0, outside) plateaus; nullopt if unclear.
std::optional<double> EdgeOffset(const cv::Mat& im, const cv::Point2d& p, const cv::Point2d& n,
                                 double half_width) {
  constexpr double kStep = 0.125;
  const int m = static_cast<int>(std::round(half_width / kStep));
  std::vector<double> prof(2 * m + 1);
  for (int i = -m; i <= m; ++i) {
    const cv::Point2d q = p + n * (i * kStep);
    if (!Sample(im, q.x, q.y, &prof[i + m])) return std::nullopt;
  }
  // Plateaus: the outer 30% of each half.
  const int plateau = std::max(1, static_cast<int>(0.3 * m));
  double dark = 0.0, light = 0.0;
  for (int i = 0; i < plateau; ++i) {
    dark += prof[i];
    light += prof[2 * m - i];
  }
  dark /= plateau;
  light /= plateau;
  if (light - dark < 20.0) return std::nullopt;  // no edge contrast here
  const double mid = 0.5 * (dark + light);
  // The crossing nearest the centre.
  std::optional<double> best;
  for (int i = 0; i < 2 * m; ++i) {
    if ((prof[i] - mid) * (prof[i + 1] - mid) <= 0.0 && prof[i] != prof[i + 1]) {
      const double s = (i - m + (mid - prof[i]) / (prof[i + 1] - prof[i])) * kStep;
      if (!best || std::abs(s) < std::abs(*best)) best = s;
    }
  }
  return best;
}

using Line = internal::EdgeLine;

// Total least squares with two rounds of 3-sigma (MAD) rejection.
std::optional<Line> FitLine(std::vector<cv::Point2d> pts, double* rms) {
  for (int round = 0; round < 3; ++round) {
    if (pts.size() < 5) return std::nullopt;
    cv::Point2d c(0, 0);
    for (const auto& p : pts) c += p;
    c *= 1.0 / pts.size();
    double sxx = 0, sxy = 0, syy = 0;
    for (const auto& p : pts) {
      const cv::Point2d d = p - c;
      sxx += d.x * d.x;
      sxy += d.x * d.y;
      syy += d.y * d.y;
    }
    const double theta = 0.5 * std::atan2(2 * sxy, sxx - syy);
    const Line line{c, cv::Point2d(std::cos(theta), std::sin(theta))};
    const cv::Point2d normal(-line.dir.y, line.dir.x);
    std::vector<double> res;
    for (const auto& p : pts) res.push_back(std::abs((p - c).dot(normal)));
    std::vector<double> sorted = res;
    std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
    const double mad = sorted[sorted.size() / 2];
    double sq = 0.0;
    for (double r : res) sq += r * r;
    *rms = std::sqrt(sq / res.size());
    if (round == 2) return line;
    const double limit = std::max(3.0 * 1.4826 * mad, 1e-3);
    std::vector<cv::Point2d> kept;
    for (size_t i = 0; i < pts.size(); ++i) {
      if (res[i] <= limit) kept.push_back(pts[i]);
    }
    if (kept.size() == pts.size()) return line;
    pts.swap(kept);
  }
  return std::nullopt;
}

}  // namespace

CornerRefineResult RefineTagCorners(const cv::Mat& grey, const std::array<cv::Point2d, 4>& corners_px,
                                    const CameraModel* camera, const CornerRefineOptions& options) {
  CornerRefineResult result;
  result.corners_px = corners_px;
  const auto extent = internal::CheckRefinementInput(grey, corners_px, options, &result.message);
  if (!extent) return result;
  const cv::Point2d centre = extent->centre_px;
  const double cell_px = extent->cell_px;
  const double half_width = extent->half_width_px;

  std::array<Line, 4> lines;
  double sq_sum = 0.0;
  int n_sum = 0;
  for (int k = 0; k < 4; ++k) {
    const cv::Point2d a = corners_px[k], b = corners_px[(k + 1) % 4];
    const double len = cv::norm(b - a);
    const cv::Point2d dir = (b - a) * (1.0 / len);
    cv::Point2d normal(-dir.y, dir.x);
    // Point the normal outwards (from the black border to the quiet zone).
    if ((0.5 * (a + b) - centre).dot(normal) < 0) normal = -normal;
    std::vector<cv::Point2d> pts;
    const int n = static_cast<int>(len * (1.0 - 2.0 * options.end_margin) / options.sample_step_px);
    for (int i = 0; i <= n; ++i) {
      const double t = options.end_margin + (1.0 - 2.0 * options.end_margin) * i / std::max(1, n);
      const cv::Point2d p = a + (b - a) * t;
      auto s = EdgeOffset(grey, p, normal, half_width);
      if (!s || std::abs(*s) > 0.8 * half_width) continue;
      // Once more, centred on the first estimate: balances the plateaus.
      const cv::Point2d p1 = p + normal * *s;
      const auto s1 = EdgeOffset(grey, p1, normal, half_width);
      if (!s1 || std::abs(*s1) > 0.5 * half_width) continue;
      pts.push_back(p1 + normal * *s1);
    }
    if (camera) pts = camera->UndistortPixels(pts);
    double rms = 0.0;
    const auto line = FitLine(pts, &rms);
    if (!line) {
      result.message = "too few edge points on edge " + std::to_string(k);
      return result;
    }
    lines[k] = *line;
    sq_sum += rms * rms * pts.size();
    n_sum += static_cast<int>(pts.size());
  }
  internal::CornersFromEdges(lines, camera, corners_px, cell_px, &result);
  if (!result.ok()) return result;
  result.edge_points_used = n_sum;
  result.rms_line_residual_px = std::sqrt(sq_sum / std::max(1, n_sum));
  return result;
}

}  // namespace odocal::vision
