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
#include <algorithm>
#include <array>
#include <cmath>
#include <utility>
#include <vector>

#include <ceres/ceres.h>

#include "odocal/vision/corner_refine.h"

#include "corner_geometry.h"
#include "odocal/vision/internal/edge_costs.h"
#include "edge_model_refine.h"

namespace odocal::vision {
namespace {

using EdgePixels = internal::EdgeBandSamples;

using FittedLine = internal::EdgeLine;

// Five parameters: 12 pixels leave 7 degrees of freedom for the residual
// that scales the covariance (a rendered 10 px tag's steep edge had 14-19;
// real 10 px Kalibr tags, 1 px a cell, 7-11: FitEdge's shorter margin).
constexpr size_t kMinEdgePixels = 12;

// The mean grey level inside (towards the tag's centre) minus outside, more
// than half a pixel from the line.
double BandContrast(const EdgePixels& band) {
  double in = 0.0, out = 0.0;
  int n_in = 0, n_out = 0;
  for (size_t i = 0; i < band.value.size(); ++i) {
    if (band.offset_px[i] < -0.5) in += band.value[i], ++n_in;
    if (band.offset_px[i] > 0.5) out += band.value[i], ++n_out;
  }
  return n_in > 3 && n_out > 3 ? in / n_in - out / n_out : 0.0;
}

// Where an edge's pixels are sampled: the image (whose pixel (0, 0) is
// `origin`), the detector's edge a-b of the tag centred at `centre_px`, the
// lens, and the band's half width.
struct EdgeBand {
  const cv::Mat& grey;
  const cv::Point& origin;
  const cv::Point2d& a_px;
  const cv::Point2d& b_px;
  const cv::Point2d& centre_px;
  const CameraModel* camera;
  double half_width;

  // The band's pixels along from-to, `end_margin` away from its ends.
  EdgePixels Sample(const cv::Point2d& from, const cv::Point2d& to, double end_margin) const {
    return internal::SampleEdgeBand(grey, origin, from, to, centre_px, camera, half_width, end_margin);
  }
};

// Adds the line's continuation beyond each corner, polarity swapped: where it
// is there. A stretch whose black is not outside the line by at least
// half the tag's edge's contrast (no corner square printed, something in
// the way, the image's border) is left out.
void AddCollinearExtension(const EdgeBand& band, double extension, double extension_margin, EdgePixels* band_pixels) {
  EdgePixels& pixels = *band_pixels;
  pixels.polarity.assign(pixels.value.size(), 1.0);
  const double own = -BandContrast(pixels);  // the tag's edge: light outside
  const cv::Point2d ab = band.b_px - band.a_px;
  const std::array<std::pair<cv::Point2d, cv::Point2d>, 2> stretches = {
      std::pair{band.a_px - ab * (extension - extension_margin), band.a_px - ab * extension_margin},
      std::pair{band.b_px + ab * extension_margin, band.b_px + ab * (extension - extension_margin)}};
  for (const auto& [from, to] : stretches) {
    const EdgePixels more = band.Sample(from, to, 0.0);
    if (!(own > 0.0 && BandContrast(more) > 0.5 * own)) continue;
    pixels.undistorted.insert(pixels.undistorted.end(), more.undistorted.begin(), more.undistorted.end());
    pixels.jacobian.insert(pixels.jacobian.end(), more.jacobian.begin(), more.jacobian.end());
    pixels.value.insert(pixels.value.end(), more.value.begin(), more.value.end());
    pixels.offset_px.insert(pixels.offset_px.end(), more.offset_px.begin(), more.offset_px.end());
    pixels.polarity.insert(pixels.polarity.end(), more.value.size(), -1.0);
  }
}

// The pixels the edge model is fitted to: the band along the edge, and its
// collinear extension when the options ask for it.
EdgePixels SampleEdgePixels(const EdgeBand& band, const CornerRefineOptions& options) {
  const double extension = options.collinear_extension, extension_margin = options.extension_margin;
  // The band: pixels whose centres lie within half_width of the segment
  // (in distorted pixels, where the detector's corners are), away from its ends.
  EdgePixels pixels = band.Sample(band.a_px, band.b_px, options.end_margin);
  // A tag of ~10 px (a Kalibr tag far off a fisheye's axis) leaves 7-11
  // pixels in the band, fewer than the fit needs: the band then runs on
  // nearer the corners, half the end margin.
  if (pixels.value.size() < kMinEdgePixels && options.end_margin > 0.0)
    pixels = band.Sample(band.a_px, band.b_px, 0.5 * options.end_margin);
  if (extension > 0.0 && extension > 2.0 * extension_margin)
    AddCollinearExtension(band, extension, extension_margin, &pixels);
  return pixels;
}

// Gauss-Newton covariance of the free parameters, scaled by the fit's
// own residual variance (the image noise as these pixels show it, JPEG
// and model error included); (angle, offset) is its marginal.
cv::Matx22d AngleOffsetCovariance(ceres::Problem* problem, double* p, double* shift, bool free_shift, size_t n_pixels,
                                  double final_cost) {
  ceres::CRSMatrix jac;
  ceres::Problem::EvaluateOptions evaluate;
  evaluate.parameter_blocks = {p};
  if (free_shift) evaluate.parameter_blocks.push_back(shift);
  problem->Evaluate(evaluate, nullptr, nullptr, nullptr, &jac);
  const int k = free_shift ? 6 : 5;
  cv::Mat jtj = cv::Mat::zeros(k, k, CV_64F);
  for (int r = 0; r < jac.num_rows; ++r) {
    for (int i = jac.rows[r]; i < jac.rows[r + 1]; ++i) {
      for (int j = jac.rows[r]; j < jac.rows[r + 1]; ++j) {
        jtj.at<double>(jac.cols[i], jac.cols[j]) += jac.values[i] * jac.values[j];
      }
    }
  }
  const int dof = std::max<int>(1, static_cast<int>(n_pixels) - k);
  const cv::Mat cov = jtj.inv(cv::DECOMP_SVD) * (2.0 * final_cost / dof);
  return cv::Matx22d(cov.at<double>(0, 0), cov.at<double>(0, 1), cov.at<double>(1, 0), cov.at<double>(1, 1));
}

std::optional<FittedLine> FitEdge(const cv::Mat& grey, const cv::Point& origin, const cv::Point2d& a_px,
                                  const cv::Point2d& b_px, const cv::Point2d& centre_px, const CameraModel* camera,
                                  double half_width, const CornerRefineOptions& options, double* rms,
                                  cv::Matx22d* cov_angle_offset = nullptr) {
  const double shift_px = options.edge_shift_px, shift_freedom_px = options.edge_shift_freedom_px;
  const EdgeBand band{grey, origin, a_px, b_px, centre_px, camera, half_width};
  EdgePixels pixels = SampleEdgePixels(band, options);
  if (pixels.value.size() < kMinEdgePixels) return std::nullopt;
  double dark = 255.0, light = 0.0;
  for (double v : pixels.value) {
    dark = std::min(dark, v);
    light = std::max(light, v);
  }
  if (light - dark < 20.0) return std::nullopt;
  // Start: the detector's edge, mapped like the pixels.
  double p[5] = {pixels.start_angle, pixels.start_offset, dark, light - dark, std::log(0.9)};
  // The edge's own shift: the known one, free within `shift_freedom_px` of
  // it where the band has both polarities (then the two sides of the line
  // tell the shift from the line: black grown moves them apart).
  double shift = shift_px;
  const bool free_shift = shift_freedom_px > 0.0 &&
                          std::any_of(pixels.polarity.begin(), pixels.polarity.end(), [](double side) { return side < 0.0; });
  ceres::Problem problem;
  // Parameters: theta (the normal's angle), c (the line's offset along it),
  // a, b, log s; and the edge shift (internal::EdgeModelCost).
  problem.AddResidualBlock(new internal::EdgeModelCost(&pixels), nullptr, p, &shift);
  if (free_shift) {
    problem.SetParameterLowerBound(&shift, 0, shift_px - shift_freedom_px);
    problem.SetParameterUpperBound(&shift, 0, shift_px + shift_freedom_px);
  } else {
    problem.SetParameterBlockConstant(&shift);
  }
  // The blur between 0.05 and 20 px: on a tiny or low-contrast edge an
  // unbounded log s can run off to where exp underflows and the model is NaN.
  problem.SetParameterLowerBound(p, 4, std::log(0.05));
  problem.SetParameterUpperBound(p, 4, std::log(20.0));
  ceres::Solver::Options solver;
  solver.linear_solver_type = ceres::DENSE_QR;
  ApplyTo(options.edge_model_solver, &solver);
  ceres::Solver::Summary summary;
  ceres::Solve(solver, &problem, &summary);
  if (!summary.IsSolutionUsable() || !(p[3] > 10.0)) return std::nullopt;
  *rms = std::sqrt(2.0 * summary.final_cost / pixels.value.size());
  if (cov_angle_offset)
    *cov_angle_offset = AngleOffsetCovariance(&problem, p, &shift, free_shift, pixels.value.size(), summary.final_cost);
  const cv::Point2d n(std::cos(p[0]), std::sin(p[0]));
  return FittedLine{n * p[1], cv::Point2d(-n.y, n.x)};
}

// Corner k = edges k-1 and k, each the line n(angle) . q = offset: its
// covariance from the two lines' (angle, offset) covariances (independent
// fits). With A = [n_a; n_b], q = A^-1 (c_a, c_b): dq/dc = A^-1 e_i and
// dq/dangle = -A^-1 e_i (n_i' . q), n' the normal turned by 90 degrees.
cv::Matx22d CornerCovariance(const FittedLine& a, const cv::Matx22d& cov_a, const FittedLine& b,
                             const cv::Matx22d& cov_b) {
  const cv::Point2d na(a.dir.y, -a.dir.x), nb(b.dir.y, -b.dir.x);  // the normals (dir = (-n.y, n.x))
  const cv::Matx22d A(na.x, na.y, nb.x, nb.y);
  const cv::Matx22d Ainv = A.inv();
  const cv::Vec2d q = Ainv * cv::Vec2d(na.dot(a.point), nb.dot(b.point));
  const cv::Point2d qp(q[0], q[1]);
  const cv::Point2d ta(-na.y, na.x), tb(-nb.y, nb.x);  // d n / d angle
  const cv::Vec2d e0 = Ainv * cv::Vec2d(1, 0), e1 = Ainv * cv::Vec2d(0, 1);
  const cv::Matx22d Ja(-e0[0] * ta.dot(qp), e0[0], -e0[1] * ta.dot(qp), e0[1]);  // d q / d (angle_a, c_a)
  const cv::Matx22d Jb(-e1[0] * tb.dot(qp), e1[0], -e1[1] * tb.dot(qp), e1[1]);
  return Ja * cov_a * Ja.t() + Jb * cov_b * Jb.t();
}

}  // namespace

CornerRefineResult RefineTagCornersByEdgeModel(const cv::Mat& grey,
                                               const std::array<cv::Point2d, 4>& corners_px,
                                               const CameraModel* camera,
                                               const CornerRefineOptions& options,
                                               const cv::Point& origin) {
  return internal::RefineTagCornersByEdgeModelWithCovariance(grey, corners_px, camera, options, origin,
                                                             nullptr);
}

namespace internal {

CornerRefineResult RefineTagCornersByEdgeModelWithCovariance(
    const cv::Mat& grey, const std::array<cv::Point2d, 4>& corners_px, const CameraModel* camera,
    const CornerRefineOptions& options, const cv::Point& origin,
    std::array<cv::Matx22d, 4>* corner_covariance_px) {
  CornerRefineResult result;
  result.corners_px = corners_px;
  const auto extent = internal::CheckRefinementInput(grey, corners_px, options, &result.message);
  if (!extent) return result;
  const cv::Point2d centre = extent->centre_px;
  const double half_width = extent->half_width_px;
  std::array<FittedLine, 4> lines;
  std::array<cv::Matx22d, 4> line_cov;
  double sq = 0.0;
  for (int k = 0; k < 4; ++k) {
    // A tag seen steeply has cells narrower across some edges than the
    // tag's mean: there the band is kept within 0.55 of the cell across this
    // edge (the tag's extent across it over width_at_border), or it reaches
    // the bits inside the border and the fit leans on them (0.4-0.7 px off on
    // 30 px tags of a steep rendered fisheye view). Edges foreshortened by
    // less than 18 % keep the tag's band.
    const cv::Point2d a = corners_px[k], b = corners_px[(k + 1) % 4];
    const cv::Point2d opposite = 0.5 * (corners_px[(k + 2) % 4] + corners_px[(k + 3) % 4]);
    const cv::Point2d along = (b - a) * (1.0 / std::max(1e-9, cv::norm(b - a)));
    const double across_px = std::abs(along.cross(opposite - a));
    const double edge_half_width = std::min(half_width, 0.55 * across_px / options.width_at_border);
    double rms = 0.0;
    const auto line = FitEdge(grey, origin, a, b, centre, camera, edge_half_width, options, &rms,
                              corner_covariance_px ? &line_cov[k] : nullptr);
    if (!line) {
      result.message = "edge " + std::to_string(k) + " could not be fitted";
      return result;
    }
    lines[k] = *line;
    sq += rms * rms;
  }
  internal::CornersFromEdges(lines, camera, corners_px, extent->cell_px, &result);
  if (!result.ok()) return result;
  result.rms_line_residual_px = std::sqrt(sq / 4.0);  // here: grey-level rms of the fits
  if (corner_covariance_px) {
    for (int k = 0; k < 4; ++k) {
      (*corner_covariance_px)[k] =
          CornerCovariance(lines[(k + 3) % 4], line_cov[(k + 3) % 4], lines[k], line_cov[k]);
    }
    // The lines are the undistorted plane's, so is that covariance: back to
    // the image's pixels through the lens at each corner (C = U^-1 C_u U^-T,
    // U = d undistorted / d pixel; a fisheye's U is up to 2 off the identity).
    if (camera) {
      constexpr double h = 0.25;
      for (int k = 0; k < 4; ++k) {
        const cv::Point2d c = result.corners_px[k];
        const std::vector<cv::Point2d> u =
            camera->UndistortPixels({{c.x + h, c.y}, {c.x - h, c.y}, {c.x, c.y + h}, {c.x, c.y - h}});
        const cv::Point2d dx = (u[0] - u[1]) * (0.5 / h), dy = (u[2] - u[3]) * (0.5 / h);
        const cv::Matx22d U(dx.x, dy.x, dx.y, dy.y);
        if (!(std::abs(cv::determinant(U)) > 1e-9)) continue;
        const cv::Matx22d Ui = U.inv();
        (*corner_covariance_px)[k] = Ui * (*corner_covariance_px)[k] * Ui.t();
      }
    }
  }
  return result;
}

}  // namespace internal

}  // namespace odocal::vision
