// Internal: the closed forms of a pixel-integrated, Gaussian-blurred straight
// edge, shared by the exact edge model (edge_model_refine.cc) and the
// PSF- and tone-free one (model_free_refine.cc). Templates for Ceres' Jets.
#ifndef ODOCAL_VISION_SRC_EDGE_FUNCTIONS_H_
#define ODOCAL_VISION_SRC_EDGE_FUNCTIONS_H_

#include <cmath>

#include <ceres/jet.h>

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

// The same on Ceres' Jets, by their derivatives (Phi' = SmallPhi,
// G' = Phi, H' = G): one erf and one exp of the scalar part and one scaled
// copy of the derivative part, where Jet arithmetic through the formulas
// above takes an erf and two exps and a dozen Jet products.
template <typename T, int N>
ceres::Jet<T, N> Phi(const ceres::Jet<T, N>& z) {
  return ceres::Jet<T, N>(Phi(z.a), SmallPhi(z.a) * z.v);
}

template <typename T, int N>
ceres::Jet<T, N> G(const ceres::Jet<T, N>& z) {
  const T phi = Phi(z.a);
  return ceres::Jet<T, N>(z.a * phi + SmallPhi(z.a), phi * z.v);
}

template <typename T, int N>
ceres::Jet<T, N> H(const ceres::Jet<T, N>& z) {
  const T phi = Phi(z.a), small_phi = SmallPhi(z.a);
  const T g = z.a * phi + small_phi;
  return ceres::Jet<T, N>(0.5 * ((z.a * z.a + 1.0) * phi + z.a * small_phi), g * z.v);
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
