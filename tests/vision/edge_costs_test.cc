// The edge models' hand-written derivatives (vision/internal/edge_costs.h)
// against five-point differences of their own residuals, at seeded random
// pixels and parameters: straight edges and a lens's stretched pixels, both
// polarities, the single-box case of an edge along the pixel grid, a free
// edge shift; the model-free edge's two spreads, their mixture and the tone
// curve; and the edge shift's cost over cells with and without white
// sides. The residual of the edge model is checked once against the blurred
// step integrated over the pixel by brute force.
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "odocal/vision/internal/edge_costs.h"
#include "odocal/vision/internal/edge_functions.h"

namespace odocal::vision::internal {
namespace {

// The worst |analytic - central difference| over every residual and
// parameter, relative to the larger of 1 and the derivative's size.
double WorstJacobianError(const ceres::CostFunction& cost, std::vector<std::vector<double>> blocks) {
  const int residuals = cost.num_residuals();
  const auto& sizes = cost.parameter_block_sizes();
  std::vector<std::vector<double>> jacobians(sizes.size());
  std::vector<double*> jacobian_ptrs, block_ptrs;
  for (size_t b = 0; b < sizes.size(); ++b) {
    jacobians[b].assign(static_cast<size_t>(residuals * sizes[b]), 0.0);
    jacobian_ptrs.push_back(jacobians[b].data());
    block_ptrs.push_back(blocks[b].data());
  }
  std::vector<double> r(static_cast<size_t>(residuals)), p1(r), m1(r), p2(r), m2(r);
  EXPECT_TRUE(cost.Evaluate(block_ptrs.data(), r.data(), jacobian_ptrs.data()));
  // Five-point differences (error h^4): the pixel's fraction is a difference
  // of four H over w1 w2, which loses digits when a box is narrow, so the
  // step is not small.
  const auto at = [&](size_t b, int k, double x, std::vector<double>* out) {
    const double keep = blocks[b][k];
    blocks[b][k] = x;
    cost.Evaluate(block_ptrs.data(), out->data(), nullptr);
    blocks[b][k] = keep;
  };
  double worst = 0.0;
  for (size_t b = 0; b < sizes.size(); ++b) {
    for (int k = 0; k < sizes[b]; ++k) {
      const double x = blocks[b][k], h = 1e-4 * std::max(1.0, std::abs(x));
      at(b, k, x + h, &p1);
      at(b, k, x - h, &m1);
      at(b, k, x + 2 * h, &p2);
      at(b, k, x - 2 * h, &m2);
      for (int i = 0; i < residuals; ++i) {
        const double numeric = (8.0 * (p1[i] - m1[i]) - (p2[i] - m2[i])) / (12.0 * h);
        const double analytic = jacobians[b][static_cast<size_t>(i * sizes[b] + k)];
        worst = std::max(worst, std::abs(analytic - numeric) / std::max(1.0, std::abs(numeric)));
      }
    }
  }
  return worst;
}

// A band of pixels across the line n(theta) . q = c, within 3 px of it.
EdgeBandSamples Band(std::mt19937* rng, double theta, double c, bool lens, bool both_polarities) {
  std::uniform_real_distribution<double> along(-10.0, 10.0), across(-3.0, 3.0), stretch(-0.3, 0.3);
  EdgeBandSamples band;
  const double nx = std::cos(theta), ny = std::sin(theta);
  for (int i = 0; i < 60; ++i) {
    const double t = along(*rng), d = across(*rng);
    band.undistorted.emplace_back(c * nx - t * ny + d * nx, c * ny + t * nx + d * ny);
    band.jacobian.push_back(lens ? cv::Vec4d(1.0 + stretch(*rng), stretch(*rng), stretch(*rng), 1.0 + stretch(*rng))
                                 : cv::Vec4d(1.0, 0.0, 0.0, 1.0));
    band.value.push_back(100.0);
    if (both_polarities) band.polarity.push_back(i % 3 == 0 ? -1.0 : 1.0);
  }
  return band;
}

TEST(EdgeCosts, TheEdgeModelsDerivativesAreItsResidualsCentralDifferences) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> angle(-M_PI, M_PI), offset(-20.0, 20.0), blur(std::log(0.3), std::log(2.0)),
      shift(-0.3, 0.3);
  double worst = 0.0;
  for (int trial = 0; trial < 40; ++trial) {
    const bool lens = trial % 2 == 1, both = trial % 4 >= 2;
    // Every 5th trial an edge along the pixel grid: one of the pixel's boxes
    // is then under 1e-3 wide and the model a single box.
    const double theta = trial % 5 == 0 ? (trial % 10 == 0 ? 0.0 : M_PI / 2) : angle(rng);
    const double c = offset(rng);
    const EdgeBandSamples band = Band(&rng, theta, c, lens && trial % 5 != 0, both);
    const EdgeModelCost cost(&band);
    // Parameters near the band's line, as during a fit.
    const double e = worst > 1.0 ? 0.0 : 0.05;
    const double w = WorstJacobianError(cost, {{theta + e, c - 3 * e, 40.0, 150.0, blur(rng)}, {shift(rng)}});
    worst = std::max(worst, w);
  }
  std::printf("figures: edge model, worst relative Jacobian error %.2g\n", worst);
  // 1e-7 typically; up to ~1e-6 where a lens-stretched pixel's box is barely
  // over the 1e-3 of the single-box case and the four H's difference has
  // lost digits. A wrong derivative is off by its own size.
  EXPECT_LT(worst, 1e-5);
}

TEST(EdgeCosts, TheModelFreeEdgesDerivativesAreItsResidualsCentralDifferences) {
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> angle(-M_PI, M_PI), offset(-20.0, 20.0), spread(std::log(0.3), std::log(3.0)),
      mix(-0.3, 0.8), log_gamma(std::log(0.5), std::log(2.5));
  double worst = 0.0;
  for (int trial = 0; trial < 40; ++trial) {
    const double theta = trial % 5 == 0 ? (trial % 10 == 0 ? 0.0 : M_PI / 2) : angle(rng);
    const double c = offset(rng);
    const EdgeBandSamples band = Band(&rng, theta, c, trial % 2 == 1 && trial % 5 != 0, false);
    const ModelFreeCost cost(&band);
    const double e = 0.05;
    worst = std::max(worst, WorstJacobianError(cost, {{theta + e, c - 3 * e, 30.0, 160.0},
                                                      {spread(rng), spread(rng), mix(rng), log_gamma(rng)}}));
  }
  std::printf("figures: model-free edge, worst relative Jacobian error %.2g\n", worst);
  // As the edge model's, and one pixel of the 2 400 whose box is within the
  // differences' step of the single-box switch (1.8e-5 there: the five
  // points straddle the kink). A wrong derivative is off by its own size.
  EXPECT_LT(worst, 1e-4);
}

TEST(EdgeCosts, TheEdgeModelIsTheBlurredStepIntegratedOverThePixel) {
  // One pixel at distance d from a vertical edge (dark on the inside, x < 0):
  // its value is a + b times the mean over the unit square of Phi(x / s).
  EdgeBandSamples band;
  const double d = 0.3, s = 0.7;
  band.undistorted.emplace_back(d, 5.0);
  band.jacobian.emplace_back(1.0, 0.0, 0.0, 1.0);
  band.value.push_back(0.0);
  const EdgeModelCost cost(&band);
  for (const double theta : {0.0, 0.4}) {
    // The pixel square, rotated against the edge by theta: brute force.
    const double nx = std::cos(theta), ny = std::sin(theta);
    const double dist = nx * d + ny * 5.0 - (ny * 5.0);  // the line through (0, 5) with normal n
    double sum = 0.0;
    const int k = 400;
    for (int i = 0; i < k; ++i)
      for (int j = 0; j < k; ++j) {
        const double x = (i + 0.5) / k - 0.5, y = (j + 0.5) / k - 0.5;
        sum += Phi((dist + nx * x + ny * y) / s);
      }
    double p[5] = {theta, ny * 5.0, 10.0, 200.0, std::log(s)}, shift = 0.0, r = 0.0;
    const double* blocks[2] = {p, &shift};
    ASSERT_TRUE(cost.Evaluate(blocks, &r, nullptr));
    EXPECT_NEAR(r, 10.0 + 200.0 * sum / (k * k), 2e-4) << theta;
  }
}

TEST(EdgeCosts, TheEdgeShiftsDerivativesAreItsResidualsCentralDifferences) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-3.5, 3.5), scale(0.15, 0.6), shift(-0.25, 0.25), blur(std::log(0.3), std::log(1.5));
  std::bernoulli_distribution coin(0.5);
  double worst = 0.0;
  for (int trial = 0; trial < 20; ++trial) {
    std::vector<ShiftPixel> pixels(80);
    for (ShiftPixel& q : pixels) {
      q.ux = u(rng);
      q.uy = u(rng);
      q.cells_per_px = scale(rng);
      q.value = 90.0;
      const int col = static_cast<int>(std::floor(q.ux)), row = static_cast<int>(std::floor(q.uy));
      for (int dr = -2; dr <= 2; ++dr)
        for (int dc = -2; dc <= 2; ++dc)
          if (coin(rng))
            q.cells.push_back({double(col + dc), double(col + dc + 1), double(row + dr), double(row + dr + 1), coin(rng),
                               coin(rng), coin(rng), coin(rng)});
    }
    const EdgeShiftCost cost(&pixels, 8.0);
    worst = std::max(worst, WorstJacobianError(cost, {{shift(rng), blur(rng), 30.0, 180.0}}));
  }
  std::printf("figures: edge shift, worst relative Jacobian error %.2g\n", worst);
  EXPECT_LT(worst, 1e-7);
}

}  // namespace
}  // namespace odocal::vision::internal
