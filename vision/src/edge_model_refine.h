// Internal: the exact edge-model refinement (edge_model_refine.cc) with each
// corner's covariance, for odocal detect's per-corner sigma.
#ifndef ODOCAL_VISION_SRC_EDGE_MODEL_REFINE_H_
#define ODOCAL_VISION_SRC_EDGE_MODEL_REFINE_H_

#include <array>

#include <opencv2/core.hpp>

#include "odocal/vision/corner_refine.h"

namespace odocal::vision::internal {

// RefineTagCornersByEdgeModel, and when `corner_covariance_px` is given each
// corner's 2x2 covariance (px^2): each edge's line from its fit's
// Gauss-Newton covariance scaled by the fit's residual variance, the two
// lines through a corner taken as independent; in the image's pixels (with a
// camera, mapped from the undistorted plane through the lens at the corner).
CornerRefineResult RefineTagCornersByEdgeModelWithCovariance(
    const cv::Mat& grey, const std::array<cv::Point2d, 4>& corners_px, const CameraModel* camera,
    const CornerRefineOptions& options, const cv::Point& origin,
    std::array<cv::Matx22d, 4>* corner_covariance_px);

}  // namespace odocal::vision::internal

#endif  // ODOCAL_VISION_SRC_EDGE_MODEL_REFINE_H_
