// Internal: the image-formation pieces the renderers share (the tag scene in
// renderer.cc, the calibration board in board_render.cc).
//
// Area-correct anti-aliasing by inverse mapping: every pixel corner is
// undistorted once into a ray, the ray meets the scene plane, and the plane
// point is classified into a region id. A pixel whose four corners share one
// id is uniform (one look-up); a scene may give a mixed pixel's mean in
// closed form (the robot's tag inside its plate: renderer.cc); any other
// pixel is integrated with ss x ss stratified samples, the grid shifted
// within its strata by a per-pixel pseudo-random offset. A fixed grid
// quantizes an edge's coverage to 1/ss and, along an edge parallel to the
// pixel grid, every pixel makes the same quantization error: a bias of up to
// 1/(2 ss) px in the rendered edge (0.03 px at ss = 16, 0.04 deg of tag
// heading), which no measurement can undo. The shifted grid makes the
// coverage unbiased; what is left is per-pixel noise that averages out along
// the edge. Plane points are interpolated bilinearly between the corners'
// (within one pixel the pixel-to-plane map is bilinear to far better than
// 1e-4 px, so this is exact for the purpose and saves an undistortion per
// sample).
//
// Pixels: OpenCV convention; pixel (u, v) covers [u-0.5, u+0.5] x [v-0.5, v+0.5].
#ifndef ODOCAL_VISION_SRC_RASTER_H_
#define ODOCAL_VISION_SRC_RASTER_H_

#include <cmath>
#include <cstdint>
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

// Optical blur of an area-sampled image: the samples treated as a
// piecewise-linear function convolved continuously with the Gaussian, i.e.
// the kernel w_m = integral hat(t - m) gaussian(t) dt. At the image's own
// resolution this still leaves edges parallel to the pixel grid ~0.02 px off
// a camera's continuous blur (measured); the tag renderer therefore blurs at
// twice the resolution and area-averages (renderer.cc).
cv::Mat OpticalBlurKernel(double sigma_px);
void OpticalBlur(const cv::Mat& src, cv::Mat* dst, double sigma_px);

// For the w x h pixels whose (w+1) x (h+1) corners have plane points `q` and
// region ids `id` (row-major, corner (i, j) at j * (w + 1) + i), adds
// weight * (area mean of the scene value) to acc (CV_32F, h x w).
// `jitter_seed` chooses the grid offsets; give each frame its own.
//   classify(const Eigen::Vector2d& plane_point) -> int region id
//   value(int id, int i, int j) -> double grey level of region `id` at pixel (i, j)
//   exact(int k00, int k10, int k11, int k01, int i, int j, double* v) -> bool:
//     the pixel's area mean in closed form, when the scene allows it there
//     (its corners' indices in q and id, counter-clockwise in the image);
//     false leaves the pixel to the samples.
template <typename ClassifyFn, typename ValueFn, typename ExactFn>
void IntegratePixels(int w, int h, const std::vector<Eigen::Vector2d>& q, const std::vector<int>& id, int supersample,
                     double weight, std::uint64_t jitter_seed, const ClassifyFn& classify, const ValueFn& value,
                     const ExactFn& exact, cv::Mat* acc) {
  const int ss = supersample;
  const double inv_ss2 = 1.0 / (ss * ss);
  for (int j = 0; j < h; ++j) {
    float* out = acc->ptr<float>(j);
    for (int i = 0; i < w; ++i) {
      const int k00 = j * (w + 1) + i, k10 = k00 + 1, k01 = k00 + w + 1, k11 = k01 + 1;
      double v;
      if (id[k00] == id[k10] && id[k00] == id[k01] && id[k00] == id[k11]) {
        v = value(id[k00], i, j);
      } else if (!exact(k00, k10, k11, k01, i, j, &v)) {
        // SplitMix64 of the pixel and the seed: two offsets in [0, 1).
        std::uint64_t z = jitter_seed + 0x9E3779B97F4A7C15ull * (static_cast<std::uint64_t>(j) * 65599u + i + 1);
        z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
        z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
        z ^= z >> 31;
        const double ox = static_cast<double>(z & 0xFFFFFFFFu) / 4294967296.0;
        const double oy = static_cast<double>(z >> 32) / 4294967296.0;
        double sum = 0.0;
        for (int b = 0; b < ss; ++b) {
          const double ty = (b + oy) / ss;
          const Eigen::Vector2d left = q[k00] * (1 - ty) + q[k01] * ty;
          const Eigen::Vector2d right = q[k10] * (1 - ty) + q[k11] * ty;
          for (int a = 0; a < ss; ++a) {
            const double tx = (a + ox) / ss;
            sum += value(classify(left * (1 - tx) + right * tx), i, j);
          }
        }
        v = sum * inv_ss2;
      }
      out[i] += static_cast<float>(weight * v);
    }
  }
}

// The same with every mixed pixel sampled.
template <typename ClassifyFn, typename ValueFn>
void IntegratePixels(int w, int h, const std::vector<Eigen::Vector2d>& q, const std::vector<int>& id, int supersample,
                     double weight, std::uint64_t jitter_seed, const ClassifyFn& classify, const ValueFn& value,
                     cv::Mat* acc) {
  IntegratePixels(
      w, h, q, id, supersample, weight, jitter_seed, classify, value,
      [](int, int, int, int, int, int, double*) { return false; }, acc);
}

// Area of the convex polygon p[0..n) (any orientation).
inline double PolygonArea(const Eigen::Vector2d* p, int n) {
  double twice = 0.0;
  for (int k = 0, l = n - 1; k < n; l = k++) twice += p[l].x() * p[k].y() - p[k].x() * p[l].y();
  return 0.5 * std::abs(twice);
}

// The part of the convex polygon in[0..n) where coordinate `axis` is below
// `bound` (keep_below) or above it, into out (at most n + 1 vertices);
// returns its vertex count.
inline int ClipToHalfPlane(const Eigen::Vector2d* in, int n, int axis, double bound, bool keep_below,
                           Eigen::Vector2d* out) {
  int m = 0;
  for (int k = 0, l = n - 1; k < n; l = k++) {
    const double dl = in[l][axis] - bound, dk = in[k][axis] - bound;
    const bool l_in = keep_below ? dl < 0.0 : dl >= 0.0, k_in = keep_below ? dk < 0.0 : dk >= 0.0;
    if (l_in != k_in) out[m++] = in[l] + (in[k] - in[l]) * (dl / (dl - dk));
    if (k_in) out[m++] = in[k];
  }
  return m;
}

}  // namespace odocal::vision::internal

#endif  // ODOCAL_VISION_SRC_RASTER_H_
