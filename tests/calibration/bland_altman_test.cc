// Bland-Altman agreement statistics: analytic cases and a seeded Monte Carlo
// (the reported bias and limits recover what was put in, and the intervals
// cover the truth as often as they claim).
#include "odocal/calibration/bland_altman.h"

#include <cmath>
#include <cstdio>
#include <random>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace odocal::calibration {
namespace {

TEST(BlandAltman, AnalyticSmallCase) {
  // Differences 1, 2, 3, 4, 5: mean 3, sample SD sqrt(2.5).
  const std::vector<double> reference = {10, 20, 30, 40, 50};
  const std::vector<double> test = {11, 22, 33, 44, 55};
  const BlandAltmanResult r = BlandAltman(test, reference);
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_EQ(r.n, 5);
  EXPECT_NEAR(r.bias, 3.0, 1e-12);
  EXPECT_NEAR(r.sd, std::sqrt(2.5), 1e-12);
  EXPECT_NEAR(r.z, 1.959963985, 1e-8);
  EXPECT_NEAR(r.t, 2.776445105, 1e-8);  // t_{0.975, 4}
  EXPECT_NEAR(r.lower_limit, 3.0 - 1.959963985 * std::sqrt(2.5), 1e-8);
  EXPECT_NEAR(r.upper_limit, 3.0 + 1.959963985 * std::sqrt(2.5), 1e-8);
  const double se_bias = std::sqrt(2.5 / 5.0);
  EXPECT_NEAR(r.bias_ci.lower, 3.0 - 2.776445105 * se_bias, 1e-8);
  EXPECT_NEAR(r.bias_ci.upper, 3.0 + 2.776445105 * se_bias, 1e-8);
  const double se_limit = std::sqrt(2.5) * std::sqrt(1.0 / 5 + 1.959963985 * 1.959963985 / 8.0);
  EXPECT_NEAR(r.upper_limit_ci.half_width(), 2.776445105 * se_limit, 1e-8);
  EXPECT_NEAR(r.lower_limit_ci.lower, r.lower_limit - 2.776445105 * se_limit, 1e-8);
  EXPECT_NEAR(r.means[0], 10.5, 1e-12);
  EXPECT_NEAR(r.differences[4], 5.0, 1e-12);
  EXPECT_TRUE(r.outliers.empty());
  EXPECT_TRUE(r.outside_limits.empty());
  EXPECT_NEAR(r.error_bound(), 3.0 + 1.959963985 * std::sqrt(2.5), 1e-8);
}

TEST(BlandAltman, ConstantOffsetHasZeroWidth) {
  const BlandAltmanResult r = BlandAltman({1.5, 2.5, 3.5, 4.5}, {0, 1, 2, 3});
  ASSERT_TRUE(r.ok());
  EXPECT_NEAR(r.bias, 1.5, 1e-12);
  EXPECT_NEAR(r.sd, 0.0, 1e-12);
  EXPECT_NEAR(r.upper_limit - r.lower_limit, 0.0, 1e-12);
  EXPECT_TRUE(r.outliers.empty());
}

TEST(BlandAltman, OtherConfidenceUsesItsQuantiles) {
  BlandAltmanOptions o;
  o.confidence = 0.90;
  const BlandAltmanResult r = BlandAltman({1, 2, 4}, {0, 0, 0}, o);
  ASSERT_TRUE(r.ok());
  EXPECT_NEAR(r.z, 1.644853627, 1e-8);
  EXPECT_NEAR(r.t, 2.919985580, 1e-8);  // t_{0.95, 2}
}

TEST(BlandAltman, OneWildReadingIsAnOutlier) {
  std::vector<double> test = {0.1, -0.2, 0.15, 0.0, -0.1, 0.05, 12.0, -0.05};
  const std::vector<double> reference(test.size(), 0.0);
  const BlandAltmanResult r = BlandAltman(test, reference);
  ASSERT_TRUE(r.ok());
  ASSERT_EQ(r.outliers.size(), 1u);
  EXPECT_EQ(r.outliers[0], 6);
}

TEST(BlandAltman, BadInputSaysWhy) {
  EXPECT_FALSE(BlandAltman({1, 2}, {1, 2}).ok());
  EXPECT_THAT(BlandAltman({1, 2}, {1, 2}).message, ::testing::HasSubstr("at least 3"));
  EXPECT_FALSE(BlandAltman({1, 2, 3}, {1, 2}).ok());
  EXPECT_FALSE(BlandAltman({1, NAN, 3}, {1, 2, 3}).ok());
  BlandAltmanOptions o;
  o.confidence = 1.5;
  EXPECT_FALSE(BlandAltman({1, 2, 3}, {1, 2, 3}, o).ok());
}

// Seeded Monte Carlo: test = reference + bias + N(0, sd). With many pairs the
// estimates land on what was put in; with few pairs the 95 % intervals cover
// the true bias and the true limits about 95 % of the time.
TEST(BlandAltman, MonteCarloRecoversBiasAndLimits) {
  std::mt19937 rng(20261121);
  const double bias = 1.2, sd = 3.1, z = 1.959963985;
  std::normal_distribution<double> noise(0.0, sd);
  std::uniform_real_distribution<double> value(-200.0, 200.0);
  {
    std::vector<double> test, reference;
    for (int i = 0; i < 4000; ++i) {
      reference.push_back(value(rng));
      test.push_back(reference.back() + bias + noise(rng));
    }
    const BlandAltmanResult r = BlandAltman(test, reference);
    ASSERT_TRUE(r.ok());
    std::printf("n 4000: %s\n", r.BriefReport().c_str());
    EXPECT_TRUE(r.bias_ci.Contains(bias)) << r.bias_ci;
    EXPECT_TRUE(r.lower_limit_ci.Contains(bias - z * sd)) << r.lower_limit_ci;
    EXPECT_TRUE(r.upper_limit_ci.Contains(bias + z * sd)) << r.upper_limit_ci;
    EXPECT_NEAR(r.bias, bias, 0.15);
    EXPECT_NEAR(r.sd, sd, 0.15);
  }
  const int trials = 4000, n = 12;
  int bias_covered = 0, lower_covered = 0, upper_covered = 0, outside = 0, outliers = 0;
  for (int k = 0; k < trials; ++k) {
    std::vector<double> test, reference;
    for (int i = 0; i < n; ++i) {
      reference.push_back(value(rng));
      test.push_back(reference.back() + bias + noise(rng));
    }
    const BlandAltmanResult r = BlandAltman(test, reference);
    ASSERT_TRUE(r.ok());
    bias_covered += r.bias_ci.Contains(bias);
    lower_covered += r.lower_limit_ci.Contains(bias - z * sd);
    upper_covered += r.upper_limit_ci.Contains(bias + z * sd);
    outside += static_cast<int>(r.outside_limits.size());
    outliers += static_cast<int>(r.outliers.size());
  }
  const double cb = double(bias_covered) / trials, cl = double(lower_covered) / trials,
               cu = double(upper_covered) / trials;
  std::printf("coverage over %d trials of n = %d: bias %.3f, lower limit %.3f, upper limit %.3f; "
              "points outside the limits %.3f; false outliers %.4f\n",
              trials, n, cb, cl, cu, double(outside) / (trials * n), double(outliers) / (trials * n));
  // Binomial SD of a 95 % coverage over 4000 trials: 0.0034. The exact t
  // interval of the bias is exact; the limits' interval is Bland & Altman's
  // large-sample approximation (slightly off at n = 12).
  EXPECT_NEAR(cb, 0.95, 0.012);
  EXPECT_NEAR(cl, 0.95, 0.025);
  EXPECT_NEAR(cu, 0.95, 0.025);
  // The leave-one-out prediction interval is exact for normal data: 1 in 1000.
  EXPECT_NEAR(double(outliers) / (trials * n), 0.001, 0.0006);
}

}  // namespace
}  // namespace odocal::calibration
