// Internal: the equidistant (Kannala-Brandt) lens fitted to every view by
// least squares (camera_calibration.cc's fisheye path).
//
// cv::fisheye::calibrate initialises each view's pose from a homography of
// the corners as its current lens undistorts them, and with CALIB_CHECK_COND
// leaves out a view whose pose is ill-conditioned at that start — on a
// 190-degree lens the views that reach the rim, which are the ones that
// constrain k1..k4 (4 of 16 rendered views left out); on some data it stops
// with an assertion instead (`fabs(norm_u1) > 0`). Here its result is only a
// start: every view's pose is solved through that lens, and the intrinsics
// and all the poses are adjusted together (Ceres), so a view is left out only
// when no pose for it can be found.
#ifndef ODOCAL_VISION_SRC_FISHEYE_FIT_H_
#define ODOCAL_VISION_SRC_FISHEYE_FIT_H_

#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "odocal/vision/camera_model.h"

namespace odocal::vision::internal {

struct EquidistantFit {
  Intrinsics intrinsics;
  double rms_px = 0.0;           // over all corners of the views used: sqrt(mean(dx^2 + dy^2))
  double weighted_rms_px = 0.0;  // the same of the weighted residuals: what the fit minimised
  std::vector<int> views_left_out;  // input indices with no pose through the start lens
};

// From `start` (an equidistant lens), over every view with a pose through it.
// `weights`: per view, per corner, the weight of its residual (empty: every
// corner 1); rms_px is the unweighted RMS either way. nullopt with `why`
// when fewer than 3 views have a pose or the solver fails.
std::optional<EquidistantFit> FitEquidistant(const std::vector<std::vector<cv::Point3f>>& objects,
                                             const std::vector<std::vector<cv::Point2f>>& images,
                                             const std::vector<std::vector<double>>& weights,
                                             const Intrinsics& start, std::string* why);

}  // namespace odocal::vision::internal

#endif  // ODOCAL_VISION_SRC_FISHEYE_FIT_H_
