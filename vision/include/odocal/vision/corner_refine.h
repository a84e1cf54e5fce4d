// Sub-pixel refinement of a detected tag's outer corners from its four edges.
//
// libapriltag's refine_edges moves each edge by a gradient search on a coarse
// grid along a few samples; its corners scatter by ~0.04 px (1 sigma) at the
// standard condition. Here each outer edge of the black border is sampled
// every half pixel, the edge is located on each sample's normal profile at the
// level halfway between the local dark and light plateaus (unbiased for a
// straight edge under any symmetric blur), the points are undistorted when a
// camera is given (so lens distortion does not bend the "straight" edges),
// a line is fitted to each edge with outlier rejection, and adjacent lines
// are intersected. Measured effect: docs/vision.md.
//
// Pixels: OpenCV convention in and out (distorted image pixels).
#ifndef ODOCAL_VISION_CORNER_REFINE_H_
#define ODOCAL_VISION_CORNER_REFINE_H_

#include <array>
#include <string>

#include <opencv2/core.hpp>

#include "odocal/base/solver_settings.h"
#include "odocal/base/status.h"
#include "odocal/vision/camera_model.h"

namespace odocal::vision {

struct CornerRefineOptions {
  // Spacing of the samples along each edge (px).
  double sample_step_px = 0.5;
  // Fraction of each edge left out at both ends (the corners themselves are
  // rounded by blur).
  double end_margin = 0.12;
  // Half-width of the normal profile (px); capped at 0.45 cell so the
  // profile stays on the black border and the white quiet zone.
  double max_half_width_px = 3.0;
  // Refinement needs cells at least this wide (px, the mean over the four
  // sides); smaller tags are returned unchanged with ok = false. 2 px: a
  // tag at a fisheye's rim is squeezed to 2-3 px a cell across the view's
  // radius, and refused at 3 its rests were never measured
  // (FisheyeLens.ASmallTagAtTheRimIsFoundAtFullResolutionAndMeasured).
  double min_cell_px = 2.0;
  // RefineTagCornersByEdgeModel on an aprilgrid: each edge's line continues
  // beyond both corners along a corner square's edge, black and white
  // swapped, for this fraction of the edge's length (Kalibr's spacing, 0.3);
  // those stretches, `extension_margin` (of the edge's length) short of
  // either end, are fitted with the edge. The corner is then where the
  // measured line crosses the next, not an extrapolation beyond its ends.
  // 0: the tag's own edges only.
  double collinear_extension = 0.0;
  double extension_margin = 0.06;
  // RefineTagCornersByEdgeModel: the edge shift (edge_shift.h) when known:
  // the black grown by this much towards the white [px]. Each edge is then
  // fitted where the print's edge is (with collinear_extension, the corner
  // square's edge, black on the other side, lies 2 shifts from the tag's).
  double edge_shift_px = 0.0;
  // ... and where an edge is seen with black on both sides of its line (with
  // collinear_extension), its own shift is fitted within this much of
  // edge_shift_px: the blur, and with it the shift, changes across a board
  // at different depths. 0: edge_shift_px for every edge.
  double edge_shift_freedom_px = 0.0;
  // Tag bits across the black border (8 for tag36h11).
  int width_at_border = 8;
  // Ceres (dense QR) on each edge's profile model (RefineTagCornersByEdgeModel):
  // 5 parameters from a start near the answer; 25 iterations are plenty.
  SolverSettings edge_model_solver{.max_iterations = 25, .function_tolerance = 1e-10,
                                   .parameter_tolerance = 1e-10};
  // Ceres (dense QR) on the four edges with their shared blur and tone curve
  // (RefineTagCornersModelFree): more parameters, bounded, so more iterations.
  SolverSettings model_free_solver{.max_iterations = 50, .function_tolerance = 1e-10,
                                   .parameter_tolerance = 1e-10};
  // ... and stopped once two successful steps in a row moved no corner by
  // more than this [px] (0: the tolerances alone). Where a blur width sits on
  // its bound the steps shrink by a third each and the cost creeps on for
  // tens of iterations with the corners long still: 46 -> 33 iterations a
  // fit on a rendered session, its return errors within 2e-4 mm (what the
  // choice of Ceres' trust-region strategy alone moves them by; the
  // smallest stated sigma 0.012 mm).
  double model_free_settled_px = 3e-5;

  bool IsValid(std::string* why) const;
};

struct CornerRefineResult {
  StatusCode status = StatusCode::kFailed;
  bool ok() const { return status == StatusCode::kOk; }
  std::string message;
  std::array<cv::Point2d, 4> corners_px{};  // refined, or the input when !ok()
  int edge_points_used = 0;
  double rms_line_residual_px = 0.0;
};

// `camera` may be null: the lines are then fitted in the distorted image.
CornerRefineResult RefineTagCorners(const cv::Mat& grey, const std::array<cv::Point2d, 4>& corners_px,
                                    const CameraModel* camera,
                                    const CornerRefineOptions& options = {});

// The exact alternative (edge_model_refine.cc): each edge's line, grey
// levels and blur are fitted to the raw pixels of a band along it, each pixel
// modelled as the area integral of a Gaussian-blurred straight edge. No
// sub-pixel-phase bias on edges parallel to the pixel grid, where the
// half-level method above is off by ~0.02 px (0.02-0.03 deg of heading at the
// standard condition; docs/vision.md). 1.5-4 ms per tag, so the pipeline
// spends it on the frames that are averaged (rests).
// `grey` may be a crop: its pixel (0, 0) is image pixel `origin`; corners
// are in image pixels. rms_line_residual_px reports the fits' rms grey-level
// residual instead.
CornerRefineResult RefineTagCornersByEdgeModel(const cv::Mat& grey,
                                               const std::array<cv::Point2d, 4>& corners_px,
                                               const CameraModel* camera,
                                               const CornerRefineOptions& options = {},
                                               const cv::Point& origin = {0, 0});

}  // namespace odocal::vision

#endif  // ODOCAL_VISION_CORNER_REFINE_H_
