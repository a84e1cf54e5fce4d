// The closed forms of a pixel-integrated, Gaussian-blurred straight edge:
// the normal's CDF and density and their first and second antiderivatives G
// and H, on doubles for the edge models' costs (edge_costs.h: a pixel's mean
// of a blurred step is four H over its two box widths) and on Ceres' Jets
// for the whole-tag pattern fit (edge_shift.cc). Not part of the public surface (here so that
// tests can check them): the names and shapes may change with the models.
#ifndef ODOCAL_VISION_INTERNAL_EDGE_FUNCTIONS_H_
#define ODOCAL_VISION_INTERNAL_EDGE_FUNCTIONS_H_

#include <cmath>

#include <ceres/jet.h>

namespace odocal::vision::internal {

// The standard normal's CDF and density at one z, together. Every edge model
// evaluates them at each pixel for every residual and Jacobian (most of a
// real aprilgrid frame's time went to erf and exp): inside |z| < kNormalRange
// they come from a table on a 1/64 grid by quintic Hermite interpolation of
// the CDF and the density and their first two derivatives (all exact at the
// nodes), within 3e-15 of std::erfc and std::exp (edge_functions_test);
// outside, 0 or 1 and 0.
struct Normal {
  double cdf = 0.0;
  double pdf = 0.0;
};

inline constexpr double kNormalRange = 8.5;
inline constexpr int kNormalNodesPerUnit = 64;

// Per node z_i = -kNormalRange + i / kNormalNodesPerUnit: CDF, pdf, pdf',
// pdf''. Built once, on first use.
const double* NormalTable();

inline Normal NormalAt(double z) {
  if (!(std::abs(z) < kNormalRange)) {
    // Beyond, the CDF is 0 or 1 and the density 0 to within 1e-16 (a pixel
    // wholly on one side of its edge: most of a band's pixels).
    if (std::isnan(z)) return {z, z};
    return {z > 0.0 ? 1.0 : 0.0, 0.0};
  }
  static const double* const table = NormalTable();
  const double x = (z + kNormalRange) * kNormalNodesPerUnit;
  const int i = static_cast<int>(x);
  const double t = x - i, s = 1.0 - t, h = 1.0 / kNormalNodesPerUnit;
  const double t2 = t * t, t3 = t2 * t, s2 = s * s, s3 = s2 * s;
  // Quintic Hermite basis on [0, 1]: value, first and second derivative
  // (scaled by h, h^2) at each end.
  const double b0 = s3 * (1.0 + 3.0 * t + 6.0 * t2), b1 = t3 * (1.0 + 3.0 * s + 6.0 * s2);
  const double d0 = s3 * t * (1.0 + 3.0 * t) * h, d1 = -t3 * s * (1.0 + 3.0 * s) * h;
  const double e0 = 0.5 * s3 * t2 * h * h, e1 = 0.5 * t3 * s2 * h * h;
  const double* a = table + 4 * i;
  const double* b = a + 4;
  return {b0 * a[0] + b1 * b[0] + d0 * a[1] + d1 * b[1] + e0 * a[2] + e1 * b[2],
          b0 * a[1] + b1 * b[1] + d0 * a[2] + d1 * b[2] + e0 * a[3] + e1 * b[3]};
}

inline double Phi(double z) { return NormalAt(z).cdf; }
inline double SmallPhi(double z) { return NormalAt(z).pdf; }

// Second antiderivative of Phi.
inline double H(double z) {
  const Normal n = NormalAt(z);
  return 0.5 * ((z * z + 1.0) * n.cdf + z * n.pdf);
}

// First antiderivative of Phi.
inline double G(double z) {
  const Normal n = NormalAt(z);
  return z * n.cdf + n.pdf;
}

// The same on Ceres' Jets, by their derivatives (Phi' = SmallPhi,
// G' = Phi, H' = G): the CDF and density of the scalar part and one scaled
// copy of the derivative part (Jet arithmetic through the closed forms took
// an erf, two exps and a dozen Jet products).
template <int N>
ceres::Jet<double, N> Phi(const ceres::Jet<double, N>& z) {
  const Normal n = NormalAt(z.a);
  return ceres::Jet<double, N>(n.cdf, n.pdf * z.v);
}

template <int N>
ceres::Jet<double, N> G(const ceres::Jet<double, N>& z) {
  const Normal n = NormalAt(z.a);
  return ceres::Jet<double, N>(z.a * n.cdf + n.pdf, n.cdf * z.v);
}

template <int N>
ceres::Jet<double, N> H(const ceres::Jet<double, N>& z) {
  const Normal n = NormalAt(z.a);
  const double g = z.a * n.cdf + n.pdf;
  return ceres::Jet<double, N>(0.5 * ((z.a * z.a + 1.0) * n.cdf + z.a * n.pdf), g * z.v);
}

}  // namespace odocal::vision::internal

#endif  // ODOCAL_VISION_INTERNAL_EDGE_FUNCTIONS_H_
