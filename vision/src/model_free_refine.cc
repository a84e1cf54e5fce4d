// Corner refinement free of the PSF's shape and of a power-law tone curve
// (edge_quality.h explains the model and why).
#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include <ceres/ceres.h>

#include "odocal/vision/edge_quality.h"

#include "corner_geometry.h"
#include "odocal/vision/internal/edge_costs.h"

namespace odocal::vision {

bool QualityGate::IsValid(std::string* why) const {
  const auto fail = [why](const std::string& what) {
    if (why) *why = "quality gate: " + what;
    return false;
  };
  if (!(min_contrast_grey >= 0.0)) return fail("min_contrast_grey must not be negative");
  if (!(max_blur_cells > 0.0)) return fail("max_blur_cells must be positive");
  if (!(max_saturated_fraction >= 0.0 && max_saturated_fraction <= 1.0))
    return fail("max_saturated_fraction must be in [0, 1]");
  if (!(max_relative_residual > 0.0)) return fail("max_relative_residual must be positive");
  return true;
}

const char* ToString(ObservationFlag flag) {
  switch (flag) {
    case ObservationFlag::kDefocused:
      return "defocused";
    case ObservationFlag::kDetectorUnavailable:
      return "detector_unavailable";
    case ObservationFlag::kDuplicateId:
      return "duplicate_id";
    case ObservationFlag::kEdgeNotStraight:
      return "edge_not_straight";
    case ObservationFlag::kEdgesNotFitted:
      return "edges_not_fitted";
    case ObservationFlag::kLowContrast:
      return "low_contrast";
    case ObservationFlag::kNotSeen:
      return "not_seen";
    case ObservationFlag::kOverexposed:
      return "overexposed";
  }
  return "unknown";
}

std::vector<ObservationFlag> QualityFlags(const TagImageQuality& q, const QualityGate& gate) {
  std::vector<ObservationFlag> flags;
  if (q.saturated_fraction > gate.max_saturated_fraction) flags.push_back(ObservationFlag::kOverexposed);
  if (q.contrast_grey < gate.min_contrast_grey) flags.push_back(ObservationFlag::kLowContrast);
  if (q.blur_sigma_px > gate.max_blur_cells * q.cell_px) flags.push_back(ObservationFlag::kDefocused);
  if (q.relative_residual > gate.max_relative_residual) flags.push_back(ObservationFlag::kEdgeNotStraight);
  return flags;
}

namespace {

// Parameters per edge: theta (normal angle), c (offset along the normal), a
// and b (linear-light dark level and contrast). Shared by the tag's four
// edges: log s1, log s2, w, log gamma. Sharing matters: fitted per edge, the
// tone exponent and the spread trade off against the edge's offset (a steeper
// tone curve moves the half-level), and four independent trade-offs scatter
// the tag's centre by ~0.05 px; shared, any error in them moves all four
// edges alike, which changes the tag's apparent size only.
constexpr int kEdgeParams = 4;
constexpr int kSharedParams = 4;

using BandPixels = internal::EdgeBandSamples;

struct EdgeBand {
  BandPixels pixels;
  cv::Point2d normal_px;  // outwards, distorted pixels
  double start[kEdgeParams] = {0, 0, 0, 0};
  int saturated = 0;
};

// The band of pixels along one edge and a start for its parameters.
std::optional<EdgeBand> PrepareEdge(const cv::Mat& grey, const cv::Point& origin, const cv::Point2d& a_px,
                                    const cv::Point2d& b_px, const cv::Point2d& centre_px,
                                    const CameraModel* camera, double half_width, double end_margin) {
  EdgeBand band;
  band.pixels = internal::SampleEdgeBand(grey, origin, a_px, b_px, centre_px, camera, half_width, end_margin);
  band.normal_px = band.pixels.normal_px;
  std::vector<double> dark_side, light_side;
  for (size_t i = 0; i < band.pixels.value.size(); ++i) {
    const double v = band.pixels.value[i], d = band.pixels.offset_px[i];
    band.saturated += (v <= 0.0 || v >= 255.0) ? 1 : 0;
    // Plateau levels from the band's outer thirds (a robust start).
    if (d < -half_width / 3) dark_side.push_back(v);
    if (d > half_width / 3) light_side.push_back(v);
  }
  if (band.pixels.value.size() < 20 || dark_side.empty() || light_side.empty()) return std::nullopt;
  auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    return v[v.size() / 2];
  };
  const double dark = median(dark_side), light = median(light_side);
  if (light - dark < 10.0) return std::nullopt;
  band.start[0] = band.pixels.start_angle;
  band.start[1] = band.pixels.start_offset;
  band.start[2] = std::max(dark, 1.0);
  band.start[3] = light - dark;
  return band;
}


// Ends the fit once its corners have settled (CornerRefineOptions::
// model_free_settled_px). Each corner is where two neighbouring edges' lines
// cross, in the undistorted pixels the lines are fitted in; the fit stops
// after two successful steps in a row that moved none by more than the
// tolerance.
class CornersSettled : public ceres::IterationCallback {
 public:
  CornersSettled(const std::array<std::array<double, kEdgeParams>, 4>* p, double tolerance_px)
      : p_(p), tolerance_px_(tolerance_px) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary& summary) override {
    if (!summary.step_is_successful) return ceres::SOLVER_CONTINUE;
    double moved = 0.0;
    for (int k = 0; k < 4; ++k) {
      // Where edge k's line n . q = c meets edge k + 1's.
      const std::array<double, kEdgeParams>& a = (*p_)[k];
      const std::array<double, kEdgeParams>& b = (*p_)[(k + 1) % 4];
      const double ax = std::cos(a[0]), ay = std::sin(a[0]), bx = std::cos(b[0]), by = std::sin(b[0]);
      const double det = ax * by - ay * bx;
      const cv::Point2d corner = std::abs(det) > 1e-9
                                     ? cv::Point2d((a[1] * by - ay * b[1]) / det, (ax * b[1] - a[1] * bx) / det)
                                     : cv::Point2d(1e9, 1e9);
      if (summary.iteration > 0) moved = std::max(moved, cv::norm(corner - corners_[k]));
      corners_[k] = corner;
    }
    settled_ = summary.iteration > 0 && moved < tolerance_px_ ? settled_ + 1 : 0;
    return settled_ >= 2 ? ceres::SOLVER_TERMINATE_SUCCESSFULLY : ceres::SOLVER_CONTINUE;
  }

 private:
  const std::array<std::array<double, kEdgeParams>, 4>* p_;
  double tolerance_px_;
  std::array<cv::Point2d, 4> corners_{};
  int settled_ = 0;
};

// The tag's fit: its four edges' bands, their parameters, and the shared
// parameters (log s1, log s2, w, log gamma) from their start.
struct ModelFreeFit {
  std::array<EdgeBand, 4> bands;
  std::array<std::array<double, kEdgeParams>, 4> p;
  double shared[kSharedParams] = {std::log(0.6), std::log(1.5), 0.3, 0.0};
};

// Widths from a fifth of a pixel (a sharp lens still integrates over the
// pixel) to beyond any usable blur; the mixture weight allows an overshoot
// (w < 0) but not a second edge; gamma within any camera's tone curves.
void BoundSharedParameters(ceres::Problem* problem, double* shared) {
  for (int i : {0, 1}) {
    problem->SetParameterLowerBound(shared, i, std::log(0.2));
    problem->SetParameterUpperBound(shared, i, std::log(6.0));
  }
  problem->SetParameterLowerBound(shared, 2, -0.6);
  problem->SetParameterUpperBound(shared, 2, 1.0);
  problem->SetParameterLowerBound(shared, 3, std::log(0.3));
  problem->SetParameterUpperBound(shared, 3, std::log(4.0));
}

// The fitted tag's image quality into `result` and its edges' lines into
// `lines`; false with a message when an edge was fitted without contrast.
bool ReadFittedEdges(const ModelFreeFit& fit, double cell_px, const CornerRefineOptions& options,
                     std::array<internal::EdgeLine, 4>* lines, ModelFreeRefineResult* result) {
  const auto& p = fit.p;
  const double* shared = fit.shared;
  TagImageQuality& q = result->quality;
  q.cell_px = cell_px;
  q.side_px = cell_px * options.width_at_border;
  q.gamma = std::exp(shared[3]);
  const double s1 = std::exp(shared[0]), s2 = std::exp(shared[1]), w = shared[2];
  q.blur_sigma_px = std::sqrt(std::max(0.0, (1.0 - w) * s1 * s1 + w * s2 * s2));
  auto encode = [&](double x) { return 255.0 * std::pow(std::max(x, 1e-3) / 255.0, 1.0 / q.gamma); };
  q.contrast_grey = 1e9;
  int pixels = 0, saturated = 0;
  for (int k = 0; k < 4; ++k) {
    if (!(p[k][3] > 1.0)) {
      result->message = "edge " + std::to_string(k) + " fitted without contrast";
      return false;
    }
    const cv::Point2d n(std::cos(p[k][0]), std::sin(p[k][0]));
    (*lines)[k] = internal::EdgeLine{n * p[k][1], cv::Point2d(-n.y, n.x)};
    q.contrast_grey = std::min(q.contrast_grey, encode(p[k][2] + p[k][3]) - encode(p[k][2]));
    // Each edge's own residual: an occluder spoils one edge, not the mean.
    const size_t m = fit.bands[k].pixels.value.size();
    std::vector<double> r(m);
    const double* blocks[] = {p[k].data(), shared};
    internal::ModelFreeCost(&fit.bands[k].pixels).Evaluate(blocks, r.data(), nullptr);
    double sq = 0.0;
    for (double v : r) sq += v * v;
    q.rms_residual_grey = std::max(q.rms_residual_grey, std::sqrt(sq / m));
    pixels += static_cast<int>(m);
    saturated += fit.bands[k].saturated;
  }
  q.saturated_fraction = static_cast<double>(saturated) / std::max(1, pixels);
  q.relative_residual = q.rms_residual_grey / std::max(1.0, q.contrast_grey);
  return true;
}

}  // namespace

ModelFreeRefineResult RefineTagCornersModelFree(const cv::Mat& grey,
                                                const std::array<cv::Point2d, 4>& corners_px,
                                                const CameraModel* camera,
                                                const CornerRefineOptions& options,
                                                const cv::Point& origin) {
  ModelFreeRefineResult result;
  result.corners_px = corners_px;
  const auto extent = internal::CheckRefinementInput(grey, corners_px, options, &result.message);
  if (!extent) return result;
  ModelFreeFit fit;
  for (int k = 0; k < 4; ++k) {
    auto band = PrepareEdge(grey, origin, corners_px[k], corners_px[(k + 1) % 4], extent->centre_px,
                            camera, extent->half_width_px, options.end_margin);
    if (!band) {
      result.message = "edge " + std::to_string(k) + " has too few pixels or no contrast";
      return result;
    }
    fit.bands[k] = std::move(*band);
  }
  ceres::Problem problem;
  for (int k = 0; k < 4; ++k) {
    std::copy(fit.bands[k].start, fit.bands[k].start + kEdgeParams, fit.p[k].begin());
    problem.AddResidualBlock(new internal::ModelFreeCost(&fit.bands[k].pixels), nullptr, fit.p[k].data(), fit.shared);
  }
  BoundSharedParameters(&problem, fit.shared);
  ceres::Solver::Options solver;
  solver.linear_solver_type = ceres::DENSE_QR;
  ApplyTo(options.model_free_solver, &solver);
  CornersSettled settled(&fit.p, options.model_free_settled_px);
  if (options.model_free_settled_px > 0.0) {
    solver.update_state_every_iteration = true;
    solver.callbacks.push_back(&settled);
  }
  ceres::Solver::Summary summary;
  ceres::Solve(solver, &problem, &summary);
  if (!summary.IsSolutionUsable()) {
    result.message = "edge fit did not converge";
    return result;
  }
  std::array<internal::EdgeLine, 4> lines;
  if (!ReadFittedEdges(fit, extent->cell_px, options, &lines, &result)) return result;
  internal::CornersFromEdges(lines, camera, corners_px, extent->cell_px, &result);
  return result;
}

}  // namespace odocal::vision
