// Internal: the closed forms of a pixel-integrated, Gaussian-blurred straight
// edge, shared by the exact edge model (edge_model_refine.cc) and the
// PSF- and tone-free one (model_free_refine.cc). Templates for Ceres' Jets.
#ifndef ODOCAL_VISION_SRC_EDGE_FUNCTIONS_H_
#define ODOCAL_VISION_SRC_EDGE_FUNCTIONS_H_

#include <cmath>

namespace odocal::vision::internal {

template <typename T>
T Phi(const T& z) {
  using std::erf;
  return 0.5 * (1.0 + erf(z * M_SQRT1_2));
}

template <typename T>
T SmallPhi(const T& z) {
  using std::exp;
  return exp(-0.5 * z * z) * (0.5 * M_2_SQRTPI * M_SQRT1_2);
}

// Second antiderivative of Phi.
template <typename T>
T H(const T& z) {
  return 0.5 * ((z * z + 1.0) * Phi(z) + z * SmallPhi(z));
}

// First antiderivative of Phi.
template <typename T>
T G(const T& z) {
  return z * Phi(z) + SmallPhi(z);
}

// Mean over a pixel of Phi(d / s) for an edge with unit normal (nx, ny), the
// pixel centre at signed distance d: the pixel square projects on the normal
// as the convolution of two boxes of widths |nx| and |ny|.
template <typename T>
T PixelEdgeFraction(const T& d, const T& nx, const T& ny, const T& s) {
  using std::abs;
  const T u = d / s;
  const T w1 = abs(nx) / s, w2 = abs(ny) / s;
  if (w2 < 1e-3 || w1 < 1e-3) {
    const T w = w1 < 1e-3 ? w2 : w1;  // a single box
    return (G(u + 0.5 * w) - G(u - 0.5 * w)) / w;
  }
  return (H(u + 0.5 * w1 + 0.5 * w2) - H(u + 0.5 * w1 - 0.5 * w2) - H(u - 0.5 * w1 + 0.5 * w2) +
          H(u - 0.5 * w1 - 0.5 * w2)) /
         (w1 * w2);
}

}  // namespace odocal::vision::internal

#endif  // ODOCAL_VISION_SRC_EDGE_FUNCTIONS_H_
