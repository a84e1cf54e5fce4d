#include "raster.h"

#include <cmath>

#include <opencv2/imgproc.hpp>

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

cv::Mat OpticalBlurKernel(double sigma_px) {
  // w_m = integral of hat(t - m) * gaussian(t) dt, by Simpson's rule on a
  // fine grid (the kernel is computed once per renderer).
  const int half = BlurKernelSize(sigma_px) / 2;
  cv::Mat kernel(2 * half + 1, 1, CV_64F);
  constexpr int kSteps = 400;  // per unit interval, even
  double total = 0.0;
  for (int m = -half; m <= half; ++m) {
    double sum = 0.0;
    for (int s = 0; s <= 2 * kSteps; ++s) {
      const double t = m - 1.0 + static_cast<double>(s) / kSteps;
      const double hat = 1.0 - std::abs(t - m);
      const double g = std::exp(-0.5 * t * t / (sigma_px * sigma_px));
      const double simpson = (s == 0 || s == 2 * kSteps) ? 1.0 : (s % 2 ? 4.0 : 2.0);
      sum += simpson * hat * g;
    }
    kernel.at<double>(m + half) = sum;
    total += sum;
  }
  return kernel / total;
}

void OpticalBlur(const cv::Mat& src, cv::Mat* dst, double sigma_px) {
  if (!(sigma_px > 0.0)) {
    src.copyTo(*dst);
    return;
  }
  const cv::Mat kernel = OpticalBlurKernel(sigma_px);
  cv::sepFilter2D(src, *dst, -1, kernel, kernel, cv::Point(-1, -1), 0.0, cv::BORDER_REPLICATE);
}

}  // namespace odocal::vision::internal
