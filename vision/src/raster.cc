#include "raster.h"

#include <algorithm>
#include <cmath>

namespace odocal::vision::internal {

cv::Mat PixelCornerRays(const CameraModel& camera) {
  const int W = camera.intrinsics().width, H = camera.intrinsics().height;
  std::vector<cv::Point2d> corners;
  corners.reserve(static_cast<size_t>(W + 1) * (H + 1));
  for (int v = 0; v <= H; ++v) {
    for (int u = 0; u <= W; ++u) corners.emplace_back(u - 0.5, v - 0.5);
  }
  const auto normalized = camera.UndistortToNormalized(corners);
  cv::Mat rays(H + 1, W + 1, CV_64FC2);
  std::copy(normalized.begin(), normalized.end(), rays.ptr<cv::Point2d>(0));
  return rays;
}

int BlurKernelSize(double sigma_px) { return 2 * static_cast<int>(std::ceil(4.0 * sigma_px)) + 1; }

}  // namespace odocal::vision::internal
