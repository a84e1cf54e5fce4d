// Internal: what the two corner refinements (corner_refine.cc: half-level
// profiles; edge_model_refine.cc: exact edge model) share — the checks and
// the tag's size in pixels before, and turning four edge lines back into
// corners after.
#ifndef ODOCAL_VISION_SRC_CORNER_GEOMETRY_H_
#define ODOCAL_VISION_SRC_CORNER_GEOMETRY_H_

#include <array>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "odocal/vision/camera_model.h"
#include "odocal/vision/corner_refine.h"
#include "odocal/vision/internal/edge_costs.h"

namespace odocal::vision::internal {

struct EdgeLine {
  cv::Point2d point;  // undistorted pixels when a camera is given
  cv::Point2d dir;    // unit
};

struct TagExtent {
  cv::Point2d centre_px;
  double cell_px = 0.0;
  double half_width_px = 0.0;  // of the band sampled across each edge
};

// The options, the image and the tag's size checked; nullopt with `why`.
std::optional<TagExtent> CheckRefinementInput(const cv::Mat& grey,
                                              const std::array<cv::Point2d, 4>& corners_px,
                                              const CornerRefineOptions& options, std::string* why);

// Corner k joins edge k-1 and edge k; back to distorted pixels when a camera
// is given; refused when a corner moved implausibly far from the input.
// Fills result->corners_px and ok, or message.
void CornersFromEdges(const std::array<EdgeLine, 4>& lines, const CameraModel* camera,
                      const std::array<cv::Point2d, 4>& input_corners_px, double cell_px,
                      CornerRefineResult* result);

// The pixels of the band along one detected edge a -> b that the edge-model
// refinements fit: those whose centres lie within `half_width` of the
// segment (in distorted pixels, where the detector's corners are) and
// between `end_margin` of its length from either end. Image pixel (x, y) is
// grey(y - origin.y, x - origin.x).
EdgeBandSamples SampleEdgeBand(const cv::Mat& grey, const cv::Point& origin, const cv::Point2d& a_px,
                               const cv::Point2d& b_px, const cv::Point2d& centre_px,
                               const CameraModel* camera, double half_width, double end_margin);

}  // namespace odocal::vision::internal

#endif  // ODOCAL_VISION_SRC_CORNER_GEOMETRY_H_
