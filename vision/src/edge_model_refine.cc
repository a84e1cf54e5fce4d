// Corner refinement by fitting an exact edge model to the raw pixels.
//
// A pixel's value is the integral, over its unit square, of the scene blurred
// by the optics. For a straight edge between two grey levels blurred by a
// Gaussian of width s, the scene across the edge is a + b * Phi(d / s), d the
// signed distance to the edge. The square projects on the edge normal
// (cos t, sin t) as the convolution of two boxes of widths |cos t| and
// |sin t|, so the pixel value is, with H'' = Phi,
//   a + b s^2 / (w1 w2) * [H(u+w1/2+w2/2) - H(u+w1/2-w2/2) - H(u-w1/2+w2/2) + H(u-w1/2-w2/2)]
// (u = d / s, widths in units of s), H(z) = ((z^2 + 1) Phi(z) + z phi(z)) / 2.
// Fitting this to the pixels of a band along the edge locates the edge
// without the sub-pixel-phase bias that any interpolated-profile method has
// on edges parallel to the pixel grid (where every sample shares one phase).
// Through a lens the edge is straight only after undistortion, where the
// pixels are not unit squares: each pixel's distance and box widths are taken
// in the image through the undistortion's local Jacobian, so the model holds
// for a fisheye's curved edges too (d, n and the widths above are then the
// image's, the line the undistorted plane's).
#include <cmath>
#include <vector>

#include <ceres/ceres.h>

#include "odocal/vision/corner_refine.h"

#include "corner_geometry.h"
#include "edge_functions.h"

namespace odocal::vision {
namespace {

using internal::G;
using internal::H;

using EdgePixels = internal::EdgeBandSamples;

// Parameters: theta (normal angle), c (offset along the normal), a, b, log s.
class EdgeModelCost {
 public:
  explicit EdgeModelCost(const EdgePixels* pixels) : pixels_(pixels) {}
  template <typename T>
  bool operator()(const T* const p, T* residual) const {
    using std::abs;
    using std::cos;
    using std::exp;
    using std::sin;
    using std::sqrt;
    const T nx = cos(p[0]), ny = sin(p[0]);
    const T s = exp(p[4]);
    for (size_t i = 0; i < pixels_->value.size(); ++i) {
      const cv::Point2d& q = pixels_->undistorted[i];
      // The edge is straight in the undistorted plane; the pixel is a unit
      // square in the image. With J = d undistorted / d pixel, the image's
      // normal to the edge is J^T n and a distance d there is d / |J^T n|
      // in pixels (the identity without a camera).
      const cv::Vec4d& J = pixels_->jacobian[i];
      const T gx = J[0] * nx + J[2] * ny, gy = J[1] * nx + J[3] * ny;
      const T g = sqrt(gx * gx + gy * gy);
      const T w1 = abs(gx) / (g * s), w2 = abs(gy) / (g * s);
      const T u = (nx * q.x + ny * q.y - p[1]) / (g * s);
      T fraction;
      if (w2 < 1e-3 || w1 < 1e-3) {
        const T w = w1 < 1e-3 ? w2 : w1;  // a single box
        fraction = (G(u + 0.5 * w) - G(u - 0.5 * w)) / w;
      } else {
        fraction = (H(u + 0.5 * w1 + 0.5 * w2) - H(u + 0.5 * w1 - 0.5 * w2) -
                    H(u - 0.5 * w1 + 0.5 * w2) + H(u - 0.5 * w1 - 0.5 * w2)) /
                   (w1 * w2);
      }
      residual[i] = p[2] + p[3] * fraction - pixels_->value[i];
    }
    return true;
  }

 private:
  const EdgePixels* pixels_;
};

using FittedLine = internal::EdgeLine;

std::optional<FittedLine> FitEdge(const cv::Mat& grey, const cv::Point& origin, const cv::Point2d& a_px,
                                  const cv::Point2d& b_px, const cv::Point2d& centre_px,
                                  const CameraModel* camera, double half_width, double end_margin,
                                  const SolverSettings& settings,
                                  double* rms) {
  // The band: pixels whose centres lie within half_width of the segment
  // (in distorted pixels, where the detector's corners are), away from its ends.
  const EdgePixels pixels =
      internal::SampleEdgeBand(grey, origin, a_px, b_px, centre_px, camera, half_width, end_margin);
  if (pixels.value.size() < 20) return std::nullopt;
  double dark = 255.0, light = 0.0;
  for (double v : pixels.value) {
    dark = std::min(dark, v);
    light = std::max(light, v);
  }
  if (light - dark < 20.0) return std::nullopt;
  // Start: the detector's edge, mapped like the pixels.
  double p[5] = {pixels.start_angle, pixels.start_offset, dark, light - dark, std::log(0.9)};
  ceres::Problem problem;
  problem.AddResidualBlock(
      new ceres::AutoDiffCostFunction<EdgeModelCost, ceres::DYNAMIC, 5>(
          new EdgeModelCost(&pixels), static_cast<int>(pixels.value.size())),
      nullptr, p);
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::DENSE_QR;
  ApplyTo(settings, &options);
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  if (!summary.IsSolutionUsable() || !(p[3] > 10.0)) return std::nullopt;
  *rms = std::sqrt(2.0 * summary.final_cost / pixels.value.size());
  const cv::Point2d n(std::cos(p[0]), std::sin(p[0]));
  return FittedLine{n * p[1], cv::Point2d(-n.y, n.x)};
}

}  // namespace

CornerRefineResult RefineTagCornersByEdgeModel(const cv::Mat& grey,
                                               const std::array<cv::Point2d, 4>& corners_px,
                                               const CameraModel* camera,
                                               const CornerRefineOptions& options,
                                               const cv::Point& origin) {
  CornerRefineResult result;
  result.corners_px = corners_px;
  const auto extent = internal::CheckRefinementInput(grey, corners_px, options, &result.message);
  if (!extent) return result;
  const cv::Point2d centre = extent->centre_px;
  const double half_width = extent->half_width_px;
  std::array<FittedLine, 4> lines;
  double sq = 0.0;
  for (int k = 0; k < 4; ++k) {
    double rms = 0.0;
    const auto line = FitEdge(grey, origin, corners_px[k], corners_px[(k + 1) % 4], centre, camera,
                              half_width, options.end_margin, options.edge_model_solver, &rms);
    if (!line) {
      result.message = "edge " + std::to_string(k) + " could not be fitted";
      return result;
    }
    lines[k] = *line;
    sq += rms * rms;
  }
  internal::CornersFromEdges(lines, camera, corners_px, extent->cell_px, &result);
  if (!result.ok) return result;
  result.rms_line_residual_px = std::sqrt(sq / 4.0);  // here: grey-level rms of the fits
  return result;
}

}  // namespace odocal::vision
