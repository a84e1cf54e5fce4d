// Internal: the image-formation pieces the renderers share (the tag scene in
// renderer.cc, the calibration board in board_render.cc).
//
// Area-correct anti-aliasing by inverse mapping: every pixel corner is
// undistorted once into a ray, the ray meets the scene plane, and the plane
// point is classified into a region id. A pixel whose four corners share one
// id is uniform (one look-up); any other pixel is integrated with ss x ss
// stratified samples, their plane points interpolated bilinearly between the
// corners' (within one pixel the pixel-to-plane map is bilinear to far better
// than 1e-4 px, so this is exact for the purpose and saves an undistortion
// per sample).
//
// Pixels: OpenCV convention; pixel (u, v) covers [u-0.5, u+0.5] x [v-0.5, v+0.5].
#ifndef ODOCAL_VISION_SRC_RASTER_H_
#define ODOCAL_VISION_SRC_RASTER_H_

#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "odocal/vision/camera_model.h"

namespace odocal::vision::internal {

// Undistorted normalised coordinates (x/z, y/z) of every pixel corner
// (u - 0.5, v - 0.5), u in [0, W], v in [0, H]: a (H+1) x (W+1) CV_64FC2 map.
cv::Mat PixelCornerRays(const CameraModel& camera);

// Odd Gaussian kernel size reaching 4 sigma on each side.
int BlurKernelSize(double sigma_px);

// For the w x h pixels whose (w+1) x (h+1) corners have plane points `q` and
// region ids `id` (row-major, corner (i, j) at j * (w + 1) + i), adds
// weight * (area mean of the scene value) to acc (CV_32F, h x w).
//   classify(const Eigen::Vector2d& plane_point) -> int region id
//   value(int id, int i, int j) -> double grey level of region `id` at pixel (i, j)
template <typename ClassifyFn, typename ValueFn>
void IntegratePixels(int w, int h, const std::vector<Eigen::Vector2d>& q,
                     const std::vector<int>& id, int supersample, double weight,
                     const ClassifyFn& classify, const ValueFn& value, cv::Mat* acc) {
  const int ss = supersample;
  const double inv_ss2 = 1.0 / (ss * ss);
  for (int j = 0; j < h; ++j) {
    float* out = acc->ptr<float>(j);
    for (int i = 0; i < w; ++i) {
      const int k00 = j * (w + 1) + i, k10 = k00 + 1, k01 = k00 + w + 1, k11 = k01 + 1;
      double v;
      if (id[k00] == id[k10] && id[k00] == id[k01] && id[k00] == id[k11]) {
        v = value(id[k00], i, j);
      } else {
        double sum = 0.0;
        for (int b = 0; b < ss; ++b) {
          const double ty = (b + 0.5) / ss;
          const Eigen::Vector2d left = q[k00] * (1 - ty) + q[k01] * ty;
          const Eigen::Vector2d right = q[k10] * (1 - ty) + q[k11] * ty;
          for (int a = 0; a < ss; ++a) {
            const double tx = (a + 0.5) / ss;
            sum += value(classify(left * (1 - tx) + right * tx), i, j);
          }
        }
        v = sum * inv_ss2;
      }
      out[i] += static_cast<float>(weight * v);
    }
  }
}

}  // namespace odocal::vision::internal

#endif  // ODOCAL_VISION_SRC_RASTER_H_
