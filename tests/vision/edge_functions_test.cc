// The edge models' normal CDF and density (vision/internal/edge_functions.h):
// the table against std::erfc and std::exp, and the Jets' derivatives
// against the closed forms' central differences.
#include <cmath>
#include <random>

#include <ceres/jet.h>
#include <gtest/gtest.h>

#include "odocal/vision/internal/edge_functions.h"

namespace odocal::vision::internal {
namespace {

double CdfExact(double z) { return 0.5 * std::erfc(-z * M_SQRT1_2); }
double PdfExact(double z) { return std::exp(-0.5 * z * z) / std::sqrt(2.0 * M_PI); }

TEST(EdgeFunctions, TheTabulatedNormalIsTheExactOneToTheLastDigits) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> z_of(-10.0, 10.0);
  double worst_cdf = 0.0, worst_pdf = 0.0;
  for (int i = 0; i < 400000; ++i) {
    const double z = i < 2000 ? -kNormalRange + i / 1000.0 * kNormalRange : z_of(rng);  // the nodes' ends too
    const Normal n = NormalAt(z);
    worst_cdf = std::max(worst_cdf, std::abs(n.cdf - CdfExact(z)));
    worst_pdf = std::max(worst_pdf, std::abs(n.pdf - PdfExact(z)));
  }
  std::printf("figures: table - exact, worst: CDF %.2g, density %.2g\n", worst_cdf, worst_pdf);
  EXPECT_LT(worst_cdf, 3e-15);  // beyond 8.5, the tail itself: below 1e-17
  EXPECT_LT(worst_pdf, 3e-15);
  // Exactly at a node, and at the range's ends and beyond.
  for (double z : {-kNormalRange, -1.0, 0.0, 0.015625, 3.0, kNormalRange - 1e-12, kNormalRange, 40.0, -40.0}) {
    EXPECT_NEAR(NormalAt(z).cdf, CdfExact(z), 3e-15) << z;
    EXPECT_NEAR(NormalAt(z).pdf, PdfExact(z), 3e-15) << z;
  }
  EXPECT_TRUE(std::isnan(NormalAt(NAN).cdf));
}

TEST(EdgeFunctions, JetsCarryTheClosedFormsDerivatives) {
  using Jet = ceres::Jet<double, 2>;
  for (double z : {-7.3, -2.0, -0.4, 0.0, 0.3, 1.7, 5.5, 9.0}) {
    Jet x(z, 0);
    x.v[1] = 0.5;  // a second direction, scaled
    const double h = 1e-5;
    auto d = [&](double (*f)(double)) { return (f(z + h) - f(z - h)) / (2.0 * h); };
    const Jet phi = Phi(x), g = G(x), hh = H(x);
    EXPECT_NEAR(phi.a, Phi(z), 1e-15);
    EXPECT_NEAR(g.a, G(z), 1e-14);
    EXPECT_NEAR(hh.a, H(z), 1e-13);
    EXPECT_NEAR(phi.v[0], d([](double t) { return Phi(t); }), 1e-9) << z;
    EXPECT_NEAR(g.v[0], d([](double t) { return G(t); }), 1e-9) << z;
    EXPECT_NEAR(hh.v[0], d([](double t) { return H(t); }), 1e-8) << z;
    EXPECT_NEAR(hh.v[1], 0.5 * hh.v[0], 1e-15) << z;
  }
}

}  // namespace
}  // namespace odocal::vision::internal
