#include "odocal/measure/tape_validation.h"

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace odocal::measure {
namespace {

constexpr double kPi = 3.14159265358979323846;

// A camera return error in metres/radians with the given 1-sigmas.
calibration::RelativePose CameraReturnError(double x_mm, double y_mm, double theta_deg,
                                            double sigma_mm = 0.05) {
  calibration::RelativePose r;
  r.pose = calibration::Pose2::FromXYHeading(x_mm * 1e-3, y_mm * 1e-3, theta_deg * kPi / 180.0);
  r.covariance.diagonal() << std::pow(sigma_mm * 1e-3, 2), std::pow(2.0 * sigma_mm * 1e-3, 2),
      std::pow(0.01 * kPi / 180.0, 2);
  return r;
}

struct Sample {
  std::vector<config::ManualReading> readings;  // owns what the pairs point to
  std::vector<calibration::RelativePose> camera;
  std::vector<TapePair> Pairs() const {
    std::vector<TapePair> pairs;
    for (size_t i = 0; i < readings.size(); ++i) pairs.push_back({&readings[i], camera[i]});
    return pairs;
  }
};

// n runs with camera return errors spread over +-60 mm; the tape reads each
// with `bias_mm` + N(0, sd_mm) on x and `bias_y_mm` + N(0, sd_mm) on y.
Sample MakeSample(int n, double bias_mm, double bias_y_mm, double sd_mm, unsigned seed,
                  bool with_theta = false) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> spread(-60.0, 60.0);
  std::normal_distribution<double> noise(0.0, sd_mm);
  Sample s;
  for (int i = 0; i < n; ++i) {
    const double cx = spread(rng), cy = spread(rng), ct = spread(rng) / 20.0;
    s.camera.push_back(CameraReturnError(cx, cy, ct));
    config::ManualReading r;
    r.run = "run" + std::to_string(i);
    r.line = i + 2;
    r.x_mm = cx + bias_mm + noise(rng);
    r.y_mm = cy + bias_y_mm + noise(rng);
    if (with_theta) r.theta_deg = ct + 0.1;
    s.readings.push_back(r);
  }
  return s;
}

double Mean(const std::vector<double>& v) {
  double sum = 0.0;
  for (double x : v) sum += x;
  return sum / v.size();
}
double SampleSd(const std::vector<double>& v) {
  const double m = Mean(v);
  double ss = 0.0;
  for (double x : v) ss += (x - m) * (x - m);
  return std::sqrt(ss / (v.size() - 1));
}

TEST(TapePair, ConvertsTheCameraToMillimetresAndDegrees) {
  config::ManualReading r;
  const TapePair p{&r, CameraReturnError(12.5, -3.0, 1.5, 0.2)};
  EXPECT_NEAR(p.camera_x_mm(), 12.5, 1e-9);
  EXPECT_NEAR(p.camera_y_mm(), -3.0, 1e-9);
  EXPECT_NEAR(p.camera_theta_deg(), 1.5, 1e-9);
  EXPECT_NEAR(p.sigma_x_mm(), 0.2, 1e-9);
  EXPECT_NEAR(p.sigma_y_mm(), 0.4, 1e-9);
  EXPECT_NEAR(p.sigma_theta_deg(), 0.01, 1e-9);
}

TEST(ValidateTape, RecoversAKnownBiasAndScatter) {
  constexpr int kN = 40;
  constexpr double kBias = 1.2, kBiasY = -0.5, kSd = 1.5;
  const Sample s = MakeSample(kN, kBias, kBiasY, kSd, 20261123);
  const TapeValidation v = ValidateTape(s.Pairs(), {});
  ASSERT_TRUE(v.ok()) << testing::PrintToString(v.notes);
  EXPECT_TRUE(v.notes.empty());
  ASSERT_EQ(v.axes.size(), 2u) << "no reading has theta";
  EXPECT_EQ(v.axes[0].key, "x");
  EXPECT_EQ(v.axes[1].key, "y");
  EXPECT_EQ(v.axes[0].unit, "mm");
  EXPECT_EQ(v.position_n, kN);
  EXPECT_FALSE(v.few_readings());

  // Against the truth the readings were drawn from, at 4 standard errors:
  // the mean's SE is sd/sqrt(n), the sample sd's ~sd/sqrt(2(n-1)), a limit's
  // ~sd sqrt(1/n + z^2/(2(n-1))) (Bland & Altman 1986).
  const double se_bias = kSd / std::sqrt(kN);
  const double se_sd = kSd / std::sqrt(2.0 * (kN - 1));
  const double z = 1.959963984540054;
  const double se_limit = kSd * std::sqrt(1.0 / kN + z * z / (2.0 * (kN - 1)));
  const calibration::BlandAltmanResult& x = v.axes[0].agreement;
  const calibration::BlandAltmanResult& y = v.axes[1].agreement;
  EXPECT_EQ(x.n, kN);
  EXPECT_NEAR(x.bias, kBias, 4.0 * se_bias);
  EXPECT_NEAR(y.bias, kBiasY, 4.0 * se_bias);
  EXPECT_NEAR(x.sd, kSd, 4.0 * se_sd);
  EXPECT_NEAR(y.sd, kSd, 4.0 * se_sd);
  EXPECT_NEAR(x.lower_limit, kBias - z * kSd, 4.0 * se_limit);
  EXPECT_NEAR(x.upper_limit, kBias + z * kSd, 4.0 * se_limit);
  // The bias is a real offset: its interval excludes zero and holds the truth.
  EXPECT_TRUE(x.bias_ci.Contains(kBias));
  EXPECT_GT(x.bias_ci.lower, 0.0) << "differences are manual - camera";
  EXPECT_LT(y.bias_ci.upper, kBiasY + 4.0 * se_bias);

  // Exactly the statistics of the differences the test itself computes.
  std::vector<double> dx, dy;
  for (size_t i = 0; i < s.readings.size(); ++i) {
    dx.push_back(s.readings[i].x_mm - s.camera[i].pose.x() * 1e3);
    dy.push_back(s.readings[i].y_mm - s.camera[i].pose.y() * 1e3);
  }
  EXPECT_NEAR(x.bias, Mean(dx), 1e-9);
  EXPECT_NEAR(x.sd, SampleSd(dx), 1e-9);
  EXPECT_NEAR(y.bias, Mean(dy), 1e-9);
  EXPECT_NEAR(y.sd, SampleSd(dy), 1e-9);

  // The verdict: the worse axis's |bias| + z sd, the far limit bounds, and a
  // round figure at or above three times the bound.
  const double bound_x = std::abs(Mean(dx)) + z * SampleSd(dx);
  const double bound_y = std::abs(Mean(dy)) + z * SampleSd(dy);
  EXPECT_NEAR(v.error_bound_mm, std::max(bound_x, bound_y), 1e-6);
  EXPECT_NEAR(v.error_bound_mm, kBias + z * kSd, 4.0 * se_limit);
  EXPECT_GE(v.limits_worst_case_mm, std::abs(x.upper_limit));
  EXPECT_GE(v.limits_worst_case_mm, std::abs(y.lower_limit));
  EXPECT_NEAR(v.limits_worst_case_mm,
              std::max({std::abs(x.lower_limit_ci.lower), std::abs(x.upper_limit_ci.upper),
                        std::abs(y.lower_limit_ci.lower), std::abs(y.upper_limit_ci.upper)}),
              1e-12);
  EXPECT_NEAR(v.usable_above_emax_mm, NiceCeil(3.0 * v.error_bound_mm), 1e-12);
  EXPECT_GE(v.usable_above_emax_mm, 3.0 * v.error_bound_mm);
  // ~3 x 4.1 mm: 20 mm.
  EXPECT_NEAR(v.usable_above_emax_mm, 20.0, 1e-9);

  EXPECT_NEAR(v.axes[0].camera_sigma_max, 0.05, 1e-9);
  EXPECT_NEAR(v.axes[1].camera_sigma_max, 0.10, 1e-9);
  ASSERT_EQ(v.axes[0].readings.size(), s.readings.size());
  EXPECT_EQ(v.axes[0].readings[7], &s.readings[7]);
}

TEST(ValidateTape, APerfectTapeHasNoBiasAndATightVerdict) {
  Sample s = MakeSample(35, 0.0, 0.0, 1.0, 7);
  for (size_t i = 0; i < s.readings.size(); ++i) {
    s.readings[i].x_mm = s.camera[i].pose.x() * 1e3;
    s.readings[i].y_mm = s.camera[i].pose.y() * 1e3;
  }
  const TapeValidation v = ValidateTape(s.Pairs(), {});
  ASSERT_TRUE(v.ok()) << testing::PrintToString(v.notes);
  ASSERT_EQ(v.axes.size(), 2u);
  for (const AxisAgreement& a : v.axes) {
    EXPECT_NEAR(a.agreement.bias, 0.0, 1e-9) << a.key;
    EXPECT_NEAR(a.agreement.sd, 0.0, 1e-9) << a.key;
  }
  EXPECT_LT(v.error_bound_mm, 1e-9);
  EXPECT_LT(v.limits_worst_case_mm, 1e-9);
  EXPECT_LT(v.usable_above_emax_mm, 1e-8);
}

TEST(ValidateTape, TooFewReadingsHaveNoStatisticsAndSaySo) {
  const Sample s = MakeSample(2, 1.2, 0.0, 1.5, 3);
  const TapeValidation v = ValidateTape(s.Pairs(), {});
  EXPECT_FALSE(v.ok());
  EXPECT_TRUE(v.axes.empty());
  ASSERT_EQ(v.notes.size(), 2u);
  EXPECT_THAT(v.notes[0], testing::StartsWith("x: "));
  EXPECT_THAT(v.notes[1], testing::StartsWith("y: "));
  EXPECT_EQ(v.position_n, 0);
  EXPECT_TRUE(v.few_readings());
  EXPECT_EQ(v.error_bound_mm, 0.0);
  EXPECT_EQ(v.usable_above_emax_mm, 0.0);
}

TEST(ValidateTape, NoPairsIsNotOk) {
  const TapeValidation v = ValidateTape({}, {});
  EXPECT_FALSE(v.ok());
  EXPECT_TRUE(v.axes.empty());
  EXPECT_EQ(v.notes.size(), 2u);
}

TEST(ValidateTape, ThreeReadingsAreEnoughButFew) {
  const Sample s = MakeSample(3, 1.2, 0.0, 1.5, 5);
  const TapeValidation v = ValidateTape(s.Pairs(), {});
  EXPECT_TRUE(v.ok());
  EXPECT_EQ(v.position_n, 3);
  EXPECT_TRUE(v.few_readings()) << "below " << TapeValidation::kFewReadings;
}

TEST(ValidateTape, ThetaOnlyFromTheReadingsThatHaveIt) {
  Sample s = MakeSample(10, 1.2, 0.0, 1.5, 11, /*with_theta=*/true);
  for (size_t i = 4; i < s.readings.size(); ++i) s.readings[i].theta_deg.reset();
  const TapeValidation v = ValidateTape(s.Pairs(), {});
  ASSERT_TRUE(v.ok());
  ASSERT_EQ(v.axes.size(), 3u);
  const AxisAgreement& theta = v.axes[2];
  EXPECT_EQ(theta.key, "theta");
  EXPECT_EQ(theta.unit, "deg");
  EXPECT_FALSE(theta.position());
  EXPECT_EQ(theta.agreement.n, 4);
  EXPECT_NEAR(theta.agreement.bias, 0.1, 1e-9) << "every theta reads 0.1 deg high";
  EXPECT_EQ(v.position_n, 10) << "theta does not count toward the position readings";
  // Theta does not enter the position verdict (its error would be ~0.1).
  EXPECT_GT(v.error_bound_mm, 1.0);

  // Two readings with theta: the position verdict stands, theta is noted.
  s.readings[2].theta_deg.reset();
  s.readings[3].theta_deg.reset();
  const TapeValidation w = ValidateTape(s.Pairs(), {});
  EXPECT_TRUE(w.ok());
  ASSERT_EQ(w.axes.size(), 2u);
  ASSERT_EQ(w.notes.size(), 1u);
  EXPECT_THAT(w.notes[0], testing::StartsWith("theta: "));
}

TEST(NiceCeil, RoundsUpToOneTwoOrFive) {
  EXPECT_EQ(NiceCeil(0.0), 0.0);
  EXPECT_EQ(NiceCeil(-3.0), 0.0);
  EXPECT_EQ(NiceCeil(std::nan("")), 0.0);
  EXPECT_NEAR(NiceCeil(0.3), 0.5, 1e-12);
  EXPECT_NEAR(NiceCeil(1.0), 1.0, 1e-12);
  EXPECT_NEAR(NiceCeil(1.01), 2.0, 1e-12);
  EXPECT_NEAR(NiceCeil(2.0), 2.0, 1e-12);
  EXPECT_NEAR(NiceCeil(4.9), 5.0, 1e-12);
  EXPECT_NEAR(NiceCeil(7.0), 10.0, 1e-12);
  EXPECT_NEAR(NiceCeil(12.3), 20.0, 1e-12);
  EXPECT_NEAR(NiceCeil(499.0), 500.0, 1e-9);
}

}  // namespace
}  // namespace odocal::measure
