// The hand-written derivatives of calibration against central differences, at
// seeded random points:
//   Between (rest.cc)          J_start, J_end of T_start^-1 T_end, through the
//                              covariance they propagate
//   Distort (floor_camera.h)   the lens distortion's 2x2 Jacobian
//   AddWheelNoiseCovariance    the trajectory fit's wheel-noise sandwich: how a
//   (trajectory_fit.cc)        travel error of one wheel at one step moves the
//                              later frames' whitened residuals
#include <cmath>
#include <random>
#include <vector>

#include <Eigen/Dense>
#include <gtest/gtest.h>

#include "odocal/calibration/arc.h"
#include "odocal/calibration/floor_camera.h"
#include "odocal/calibration/internal/trajectory_fit_stages.h"
#include "odocal/calibration/pose2.h"
#include "odocal/calibration/rest.h"

namespace odocal::calibration {
namespace {

Eigen::Matrix3d RandomCovariance(std::mt19937* rng) {
  std::normal_distribution<double> normal(0.0, 1.0);
  Eigen::Matrix3d a;
  for (int i = 0; i < 9; ++i) a.data()[i] = normal(*rng);
  return a * a.transpose() * 1e-4 + Eigen::Matrix3d::Identity() * 1e-6;
}

Eigen::Vector3d XYHeading(const Pose2& p) { return {p.x(), p.y(), p.heading()}; }

// d(T_start^-1 T_end as x, y, heading) / d(x, y, heading of `which`).
Eigen::Matrix3d NumericBetweenJacobian(const Pose2& start, const Pose2& end, bool wrt_start) {
  const double h = 1e-6;
  Eigen::Matrix3d J;
  for (int i = 0; i < 3; ++i) {
    Eigen::Vector3d plus = XYHeading(wrt_start ? start : end), minus = plus;
    plus[i] += h;
    minus[i] -= h;
    auto relative = [&](const Eigen::Vector3d& v) {
      const Pose2 moved = Pose2::FromXYHeading(v[0], v[1], v[2]);
      return XYHeading(wrt_start ? moved.inverse() * end : start.inverse() * moved);
    };
    Eigen::Vector3d d = relative(plus) - relative(minus);
    d[2] = WrapAngle(d[2]);
    J.col(i) = d / (2.0 * h);
  }
  return J;
}

TEST(AnalyticJacobians, BetweenPropagatesWithTheNumericJacobians) {
  std::mt19937 rng(20261123);
  std::uniform_real_distribution<double> position(-2.0, 2.0), heading(-M_PI, M_PI);
  for (int trial = 0; trial < 50; ++trial) {
    RestWindow start, end;
    start.mean = Pose2::FromXYHeading(position(rng), position(rng), heading(rng));
    end.mean = Pose2::FromXYHeading(position(rng), position(rng), heading(rng));
    start.covariance = RandomCovariance(&rng);
    end.covariance = RandomCovariance(&rng);
    const RelativePose r = Between(start, end);
    const Eigen::Matrix3d J_start = NumericBetweenJacobian(start.mean, end.mean, true);
    const Eigen::Matrix3d J_end = NumericBetweenJacobian(start.mean, end.mean, false);
    const Eigen::Matrix3d expected = J_start * start.covariance * J_start.transpose() +
                                     J_end * end.covariance * J_end.transpose();
    EXPECT_LT((r.covariance - expected).norm(), 1e-7 * expected.norm()) << "trial " << trial;
    // Each Jacobian on its own (the other mean exact).
    RestWindow exact_end = end;
    exact_end.covariance.setZero();
    const Eigen::Matrix3d start_only = J_start * start.covariance * J_start.transpose();
    EXPECT_LT((Between(start, exact_end).covariance - start_only).norm(), 1e-7 * start_only.norm());
  }
}

TEST(AnalyticJacobians, LensDistortionJacobian) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> coefficient(-0.3, 0.3), tangential(-0.01, 0.01),
      point(-0.8, 0.8);
  for (int trial = 0; trial < 100; ++trial) {
    const std::array<double, 5> d = {coefficient(rng), coefficient(rng), tangential(rng),
                                     tangential(rng), coefficient(rng)};
    const double x = point(rng), y = point(rng);
    double xd, yd, jac[4];
    floor_camera_internal::Distort(d, x, y, &xd, &yd, jac);
    const double h = 1e-6;
    double xp, yp, xm, ym, unused[4];
    floor_camera_internal::Distort(d, x + h, y, &xp, &yp, unused);
    floor_camera_internal::Distort(d, x - h, y, &xm, &ym, unused);
    EXPECT_NEAR(jac[0], (xp - xm) / (2 * h), 1e-7) << "dxd/dx, trial " << trial;
    EXPECT_NEAR(jac[2], (yp - ym) / (2 * h), 1e-7) << "dyd/dx, trial " << trial;
    floor_camera_internal::Distort(d, x, y + h, &xp, &yp, unused);
    floor_camera_internal::Distort(d, x, y - h, &xm, &ym, unused);
    EXPECT_NEAR(jac[1], (xp - xm) / (2 * h), 1e-7) << "dxd/dy, trial " << trial;
    EXPECT_NEAR(jac[3], (yp - ym) / (2 * h), 1e-7) << "dyd/dy, trial " << trial;
  }
}

// The wheel-noise sandwich with pinv = identity is sum_k q |travel_k|
// (d r / d e_k)(d r / d e_k)^T over both wheels: the whitened residuals'
// derivatives with respect to a travel error e_k of a wheel at step k. The
// analytic derivative moves the later frames rigidly with the heading and the
// pose at the end of step k; the exact one (here by central differences
// through the arcs) differs by the step's half-turn: first order in it.
TEST(AnalyticJacobians, WheelNoiseSandwichMatchesNumericDerivatives) {
  using namespace internal;
  std::mt19937 rng(31);
  std::uniform_int_distribution<int> ticks(5, 12);
  ModelConstants constants;
  constants.left_m_per_tick = 1.1e-4;
  constants.right_m_per_tick = 1.0e-4;
  constants.track_m = 0.3;
  RunData rd;
  rd.residuals_per_frame = 3;
  const int n = 60;
  for (int k = 0; k <= n; ++k) {
    rd.t_s.push_back(0.02 * k);
    std::int64_t left = 0, right = 0;
    if (k > 0 && k < 20) left = right = ticks(rng);                // a straight
    if (k >= 20 && k < 40) left = -(right = ticks(rng));           // a turn in place
    if (k >= 40) left = ticks(rng), right = left + 4;              // an arc
    rd.left_step_ticks.push_back(left);
    rd.right_step_ticks.push_back(right);
    rd.kind.push_back(StepKind(left, right));
  }
  rd.curvature_per_m.assign(rd.t_s.size(), 0.0);
  FitParameters params;
  params.base_scales = {1.002, 0.998, 1.01};
  params.start_poses = {{0.1, -0.2, 0.3}};
  // Frames at every telemetry time, measured where the model puts them (the
  // analytic derivative takes the lever arms from the measured positions).
  const DeadReckonedPoses truth = DeadReckonRun(rd, constants, params, 0);
  std::uniform_real_distribution<double> weight(0.5, 1.0);
  for (int k = 0; k <= n; ++k) {
    rd.frame_t_s.push_back(rd.t_s[k]);
    rd.measured_x_m.push_back(truth.x_m[k]);
    rd.measured_y_m.push_back(truth.y_m[k]);
    rd.measured_heading_rad.push_back(truth.heading_rad[k]);
    rd.sigma_position_m.push_back(1e-3 * weight(rng));
    rd.sigma_heading_rad.push_back(1e-2 * weight(rng));
    rd.sqrt_weight.push_back(weight(rng));
  }
  const int n_rows = rd.n_residuals();

  // The whitened residuals with travel errors added to the wheels at step k.
  const double true_track_m = params.base_scales[2] * constants.track_m;
  auto residuals = [&](int step, double left_error_m, double right_error_m) {
    Eigen::VectorXd r(n_rows);
    double x = params.start_poses[0][0], y = params.start_poses[0][1], h = params.start_poses[0][2];
    for (int k = 0; k <= n; ++k) {
      if (k > 0) {
        double left_m = rd.left_step_ticks[k] * constants.left_m_per_tick * params.base_scales[0];
        double right_m = rd.right_step_ticks[k] * constants.right_m_per_tick * params.base_scales[1];
        if (k == step) left_m += left_error_m, right_m += right_error_m;
        AdvanceArc(left_m, right_m, true_track_m, &x, &y, &h);
      }
      r[3 * k] = rd.sqrt_weight[k] * (x - rd.measured_x_m[k]) / rd.sigma_position_m[k];
      r[3 * k + 1] = rd.sqrt_weight[k] * (y - rd.measured_y_m[k]) / rd.sigma_position_m[k];
      r[3 * k + 2] =
          rd.sqrt_weight[k] * WrapAngle(h - rd.measured_heading_rad[k]) / rd.sigma_heading_rad[k];
    }
    return r;
  };
  EXPECT_LT(residuals(0, 0.0, 0.0).norm(), 1e-9);  // the reference is the model

  const double sigma = 0.05e-3, q = sigma * sigma, e = 1e-7;
  Eigen::MatrixXd expected = Eigen::MatrixXd::Zero(n_rows, n_rows);
  for (int k = 1; k <= n; ++k) {
    const Eigen::VectorXd d_left = (residuals(k, e, 0.0) - residuals(k, -e, 0.0)) / (2 * e);
    const Eigen::VectorXd d_right = (residuals(k, 0.0, e) - residuals(k, 0.0, -e)) / (2 * e);
    const double left_m = std::abs(rd.left_step_ticks[k] * constants.left_m_per_tick *
                                   params.base_scales[0]);
    const double right_m = std::abs(rd.right_step_ticks[k] * constants.right_m_per_tick *
                                    params.base_scales[1]);
    expected += q * left_m * d_left * d_left.transpose() + q * right_m * d_right * d_right.transpose();
  }
  ParameterCovariance sandwich;
  sandwich.pinv_by_run = {Eigen::MatrixXd::Identity(n_rows, n_rows)};
  sandwich.covariance = Eigen::MatrixXd::Zero(n_rows, n_rows);
  AddWheelNoiseCovariance({rd}, constants, params, sigma, &sandwich);
  // A step turns by at most 12 * 2e-4 / 0.3 = 8e-3 rad: its half-turn sets
  // the agreement (a sign or a lever-arm error would be of order 1).
  const double scale = expected.cwiseAbs().maxCoeff();
  EXPECT_LT((sandwich.covariance - expected).cwiseAbs().maxCoeff(), 1e-2 * scale);
  EXPECT_LT((sandwich.covariance - expected).norm(), 1e-2 * expected.norm());
  // Frame 0 (before any step) feels no wheel noise.
  EXPECT_EQ(sandwich.covariance.row(0).norm(), 0.0);
}

}  // namespace
}  // namespace odocal::calibration
