// The stages of FitTrajectory, each on a small session whose answer is known:
// a 2048-tick robot's ticks, and camera frames placed exactly where the
// model (PredictMeasuredPoses) puts them for known scales.
#include "odocal/calibration/internal/trajectory_fit_stages.h"

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Dense>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "odocal/calibration/trajectory_fit.h"

namespace odocal::calibration::internal {
namespace {

WheelParams Believed() {
  WheelParams p;
  p.left_wheel_diameter_m = 0.070;
  p.right_wheel_diameter_m = 0.070;
  p.track_m = 0.300;
  p.ticks_per_rev = 2048;
  return p;
}

// A run of `steps` telemetry samples at 50 Hz: each step adds
// (left_ticks, right_ticks), after `rest_steps` steps at rest.
MeasuredRun MakeRun(const std::string& name, int steps, int left_ticks, int right_ticks,
                    int rest_steps = 5) {
  MeasuredRun run;
  run.name = name;
  std::int64_t left = 1000, right = -500;
  for (int k = 0; k <= steps; ++k) {
    if (k > rest_steps) {
      left += left_ticks;
      right += right_ticks;
    }
    run.telemetry.push_back({0.02 * k, left, right, Pose2::Identity()});
  }
  return run;
}

// Camera frames at every telemetry time, where the model says the robot is
// for `truth` (a noise-free measurement), with the stated sigmas.
void MeasureExactly(const WheelParams& believed, const WheelScales& truth, const Pose2& start,
                    MeasuredRun* run, double sigma_position_m = 1e-3,
                    double sigma_heading_rad = 0.0) {
  std::vector<double> stamps_s;
  for (const TelemetryRecord& t : run->telemetry) stamps_s.push_back(t.t_s);
  const std::vector<Pose2> poses =
      PredictMeasuredPoses(*run, believed, truth, EffectParams{}, std::nullopt, start, stamps_s);
  run->camera.clear();
  for (size_t j = 0; j < poses.size(); ++j)
    run->camera.push_back({stamps_s[j], true, poses[j], sigma_position_m, sigma_heading_rad});
}

// Square, spins both ways, an arc: enough to determine r_left, r_right and Eb.
MeasuredSession ExactSession(const WheelScales& truth) {
  MeasuredSession s;
  s.believed = Believed();
  s.runs = {MakeRun("straight", 120, 40, 40), MakeRun("spin_ccw", 120, -30, 30),
            MakeRun("spin_cw", 120, 30, -30), MakeRun("arc", 120, 30, 50)};
  const Pose2 starts[] = {Pose2::FromXYHeading(0.1, 0.2, 0.3), Pose2::FromXYHeading(-0.3, 0.1, 1.0),
                          Pose2::FromXYHeading(0.2, -0.2, -2.0), Pose2::FromXYHeading(0.0, 0.0, 0.5)};
  for (size_t i = 0; i < s.runs.size(); ++i) MeasureExactly(s.believed, truth, starts[i], &s.runs[i]);
  return s;
}

TEST(TrajectoryFitStages, ValidateFitInputsNamesWhatIsWrong) {
  MeasuredSession s = ExactSession({});
  EXPECT_EQ(ValidateFitInputs(s, {}), "");
  TrajectoryFitOptions bad;
  bad.irls_rounds = 0;
  EXPECT_THAT(ValidateFitInputs(s, bad), ::testing::HasSubstr("options: irls_rounds"));
  TrajectoryFitOptions lens;
  lens.effects = {Effect::kLensDistortion};
  EXPECT_THAT(ValidateFitInputs(s, lens), ::testing::HasSubstr("lens_distortion"));
  s.believed.track_m = 0.0;
  EXPECT_THAT(ValidateFitInputs(s, {}), ::testing::HasSubstr("believed parameters"));
}

TEST(TrajectoryFitStages, ExtractRunsKeepsStepsFramesAndDirections) {
  MeasuredSession s = ExactSession({});
  // A run with too few valid frames is left out, but its shafts' directions
  // carry over to the next run.
  MeasuredRun few = MakeRun("few", 20, -10, -10);
  MeasureExactly(s.believed, {}, Pose2::Identity(), &few);
  for (size_t j = 3; j < few.camera.size(); ++j) few.camera[j].valid = false;
  s.runs.insert(s.runs.begin() + 1, few);
  s.runs[0].camera[4].sigma_position_m = 0.0;  // stands in the default sigma
  TrajectoryFitOptions options;
  options.min_frames_per_run = 10;
  const ExtractedRuns extracted = ExtractRuns(s, options, ConstantsOf(s.believed, std::nullopt));
  ASSERT_EQ(extracted.runs.size(), 4u);
  EXPECT_EQ(extracted.run_used, (std::vector<bool>{true, false, true, true, true}));
  const RunData& straight = extracted.runs[0];
  EXPECT_EQ(straight.run, 0);
  EXPECT_EQ(straight.n_frames(), 121);
  EXPECT_EQ(straight.n_residuals(), 3 * 121);
  EXPECT_EQ(straight.left_step_ticks[0], 0);
  EXPECT_EQ(straight.left_step_ticks[5], 0);
  EXPECT_EQ(straight.left_step_ticks[6], 40);
  EXPECT_EQ(straight.kind[5], MotionKind::kRest);
  EXPECT_EQ(straight.kind[6], MotionKind::kStraight);
  EXPECT_EQ(straight.sigma_position_m[4], options.default_position_sigma_m);
  EXPECT_EQ(straight.sigma_heading_rad[0], options.default_heading_sigma_rad);
  EXPECT_EQ(straight.sqrt_weight, std::vector<double>(121, 1.0));
  // The spin after the left-out backward run starts with both shafts backward.
  const RunData& spin = extracted.runs[1];
  EXPECT_EQ(spin.run, 2);
  EXPECT_EQ(spin.left_direction0, -1);
  EXPECT_EQ(spin.right_direction0, -1);
  EXPECT_EQ(spin.kind[10], MotionKind::kTurn);
  // Without headings, two residuals per frame.
  options.use_heading = false;
  EXPECT_EQ(ExtractRuns(s, options, ConstantsOf(s.believed, std::nullopt)).runs[0].n_residuals(),
            2 * 121);
}

TEST(TrajectoryFitStages, MarkArcsOnlyOnArcs) {
  const MeasuredSession s = ExactSession({});
  const ExtractedRuns extracted = ExtractRuns(s, {}, ConstantsOf(s.believed, std::nullopt));
  // Straight and spins: no curvature. Arc: (50 - 30) / (0.3 * 40) per metre.
  for (int r = 0; r < 3; ++r)
    for (double kappa : extracted.runs[r].curvature_per_m) EXPECT_EQ(kappa, 0.0);
  EXPECT_NEAR(extracted.runs[3].curvature_per_m[60], 20.0 / (0.3 * 40.0), 1e-9);
}

TEST(TrajectoryFitStages, InitialParametersStartAtFirstFramesOrAWarmStart) {
  const MeasuredSession s = ExactSession({});
  TrajectoryFitOptions options;
  options.effects = {Effect::kCameraLatency};
  const ExtractedRuns extracted = ExtractRuns(s, options, ConstantsOf(s.believed, std::nullopt));
  FitParameters p = InitialParameters(extracted.runs, extracted.run_used, options, nullptr);
  EXPECT_EQ(p.base_scales, (std::array<double, 3>{1.0, 1.0, 1.0}));
  ASSERT_EQ(p.start_poses.size(), 4u);
  EXPECT_DOUBLE_EQ(p.start_poses[1][0], -0.3);
  EXPECT_DOUBLE_EQ(p.start_poses[1][2], 1.0);
  EXPECT_TRUE(p.effect_enabled[EffectParams::kLatency]);
  EXPECT_FALSE(p.effect_enabled[EffectParams::kTagX]);

  TrajectoryFitResult warm;
  warm.status = StatusCode::kOk;
  warm.run_used = extracted.run_used;
  warm.scales = {1.01, 0.99, 1.02};
  warm.effects.values[EffectParams::kLatency] = 0.03;
  warm.effects.values[EffectParams::kTagX] = 0.01;  // disabled: not taken
  warm.start_poses.assign(4, Pose2::FromXYHeading(1.0, 2.0, 0.5));
  p = InitialParameters(extracted.runs, extracted.run_used, options, &warm);
  EXPECT_EQ(p.base_scales, (std::array<double, 3>{1.01, 0.99, 1.02}));
  EXPECT_EQ(p.effects.values[EffectParams::kLatency], 0.03);
  EXPECT_EQ(p.effects.values[EffectParams::kTagX], 0.0);
  EXPECT_DOUBLE_EQ(p.start_poses[2][1], 2.0);
  // A warm start over other runs is ignored.
  warm.run_used[0] = false;
  p = InitialParameters(extracted.runs, extracted.run_used, options, &warm);
  EXPECT_EQ(p.base_scales, (std::array<double, 3>{1.0, 1.0, 1.0}));
}

TEST(TrajectoryFitStages, BuildAndSolveRecoverExactScales) {
  const WheelScales truth{1.004, 0.997, 1.012};
  const MeasuredSession s = ExactSession(truth);
  const TrajectoryFitOptions options;
  const ModelConstants constants = ConstantsOf(s.believed, std::nullopt);
  ExtractedRuns extracted = ExtractRuns(s, options, constants);
  FitParameters p = InitialParameters(extracted.runs, extracted.run_used, options, nullptr);
  const TrajectoryProblem problem = BuildProblem(extracted.runs, constants, options);
  ASSERT_EQ(problem.run_costs.size(), 4u);
  const SolveOutcome solved = SolveWithIrls(problem, options, &extracted.runs, &p);
  ASSERT_FALSE(solved.failed) << solved.message;
  EXPECT_TRUE(solved.solution_usable);
  EXPECT_NEAR(p.base_scales[0], truth.r_left, 1e-7);
  EXPECT_NEAR(p.base_scales[1], truth.r_right, 1e-7);
  EXPECT_NEAR(p.base_scales[2], truth.Eb, 1e-7);
  EXPECT_NEAR(p.start_poses[1][0], -0.3, 1e-8);
  for (size_t r = 0; r < 4; ++r)
    for (double e : RunResiduals(problem, p, r)) EXPECT_NEAR(e, 0.0, 1e-4);  // 0.1 um
}

TEST(TrajectoryFitStages, ReweightHuberDownweightsOnlyTheOutlier) {
  MeasuredSession s = ExactSession({});
  s.runs[0].camera[50].T_world_robot =
      s.runs[0].camera[50].T_world_robot * Pose2::FromXYHeading(0.05, 0.0, 0.0);
  const TrajectoryFitOptions options;
  const ModelConstants constants = ConstantsOf(s.believed, std::nullopt);
  ExtractedRuns extracted = ExtractRuns(s, options, constants);
  // Noise of 0.1 sigma on every later frame so that the robust sigma is not
  // zero (the first frames set the start poses).
  std::mt19937 rng(7);
  std::normal_distribution<double> normal(0.0, 0.1);
  for (RunData& rd : extracted.runs)
    for (int j = 1; j < rd.n_frames(); ++j) {
      rd.measured_x_m[j] += normal(rng) * rd.sigma_position_m[j];
      rd.measured_y_m[j] += normal(rng) * rd.sigma_position_m[j];
      rd.measured_heading_rad[j] += normal(rng) * rd.sigma_heading_rad[j];
    }
  const FitParameters p = InitialParameters(extracted.runs, extracted.run_used, options, nullptr);
  const TrajectoryProblem problem = BuildProblem(extracted.runs, constants, options);
  ReweightHuber(problem, p, 3.0, &extracted.runs);
  EXPECT_LT(extracted.runs[0].sqrt_weight[50], 0.5);
  int downweighted = 0;
  for (const RunData& rd : extracted.runs)
    for (double w : rd.sqrt_weight) downweighted += w < 1.0;
  EXPECT_LE(downweighted, 5);
}

TEST(TrajectoryFitStages, LinearizeKeepsEachRunsBlocks) {
  const MeasuredSession s = ExactSession({1.004, 0.997, 1.012});
  TrajectoryFitOptions options;
  const ModelConstants constants = ConstantsOf(s.believed, std::nullopt);
  const ExtractedRuns extracted = ExtractRuns(s, options, constants);
  const FitParameters p = InitialParameters(extracted.runs, extracted.run_used, options, nullptr);
  const TrajectoryProblem problem = BuildProblem(extracted.runs, constants, options);
  const Linearization lin = Linearize(problem, extracted.runs, p);
  ASSERT_EQ(lin.runs.size(), 4u);
  const int rows1 = extracted.runs[1].n_residuals();
  ASSERT_EQ(lin.runs[1].J_global.cols(), kBaseParams + kEffectParams);
  ASSERT_EQ(lin.runs[1].J_start.rows(), rows1);
  ASSERT_EQ(lin.n_residuals(), extracted.runs[0].n_residuals() + 3 * rows1);
  // Run 1's start heading and its Eb, by central differences.
  const double h = 1e-7;
  FitParameters plus = p, minus = p;
  plus.start_poses[1][2] += h;
  minus.start_poses[1][2] -= h;
  std::vector<double> rp = RunResiduals(problem, plus, 1), rm = RunResiduals(problem, minus, 1);
  for (int i = 0; i < rows1; ++i)
    EXPECT_NEAR(lin.runs[1].J_start(i, 2), (rp[i] - rm[i]) / (2 * h), 1e-4) << i;
  plus = minus = p;
  plus.base_scales[2] += h;
  minus.base_scales[2] -= h;
  rp = RunResiduals(problem, plus, 1), rm = RunResiduals(problem, minus, 1);
  for (int i = 0; i < rows1; ++i)
    EXPECT_NEAR(lin.runs[1].J_global(i, 2), (rp[i] - rm[i]) / (2 * h), 1e-4) << i;
  const std::vector<double> r0 = RunResiduals(problem, p, 0);
  // (Evaluated with Jets there, with doubles here: equal to rounding.)
  for (int i = 0; i < extracted.runs[0].n_residuals(); ++i)
    EXPECT_NEAR(lin.runs[0].residuals[i], r0[i], 1e-12 * (1.0 + std::abs(r0[i])));
}

TEST(TrajectoryFitStages, ReportFramesGapAndNoiseFloor) {
  MeasuredSession s = ExactSession({});
  const TrajectoryFitOptions options;
  const ModelConstants constants = ConstantsOf(s.believed, std::nullopt);
  ExtractedRuns extracted = ExtractRuns(s, options, constants);
  // Every measured x 2 mm off: gap 2 mm; sigma 1 mm per axis: floor sqrt(2) mm.
  for (RunData& rd : extracted.runs)
    for (double& x : rd.measured_x_m) x -= 0.002;
  FitParameters p = InitialParameters(extracted.runs, extracted.run_used, options, nullptr);
  for (size_t r = 0; r < p.start_poses.size(); ++r) p.start_poses[r][0] += 0.002;
  const FrameReport report = ReportFrames(extracted.runs, constants, p);
  ASSERT_EQ(report.residuals.size(), 4u * 121u);
  EXPECT_NEAR(report.gap_m, 0.002, 1e-12);
  EXPECT_NEAR(report.noise_floor_m, std::sqrt(2.0) * 1e-3, 1e-15);
  EXPECT_EQ(report.residuals[0].motion, MotionKind::kRest);
  EXPECT_EQ(report.residuals[121 + 60].motion, MotionKind::kTurn);
  EXPECT_EQ(report.residuals[121 + 60].run, 1);
}

TEST(TrajectoryFitStages, SelectFittedColumnsNamesThem) {
  const MeasuredSession s = ExactSession({});
  TrajectoryFitOptions options;
  options.effects = {Effect::kTrackerYaw, Effect::kTagOffset};
  const ExtractedRuns extracted = ExtractRuns(s, options, ConstantsOf(s.believed, std::nullopt));
  const FittedColumns columns = SelectFittedColumns(s, extracted.runs, options);
  ASSERT_EQ(columns.index.size(), 3u + 3u + 12u);
  EXPECT_EQ(columns.names[3], "tracker_yaw.yaw_rad");
  EXPECT_EQ(columns.index[3], kBaseParams + EffectParams::kTrackerYaw);
  EXPECT_EQ(columns.names[5], "tag_offset.y_m");
  EXPECT_EQ(columns.names[6], "straight.start_x");
  EXPECT_EQ(columns.index[17], kBaseParams + kEffectParams + 11);
  EXPECT_EQ(columns.n_global, 6);
  RunLinearization run;
  run.J_global = Eigen::MatrixXd::Random(5, kBaseParams + kEffectParams);
  run.J_start = Eigen::MatrixXd::Random(5, 3);
  const Eigen::MatrixXd J_fitted = RunFittedJacobian(run, columns);
  ASSERT_EQ(J_fitted.cols(), 6 + 3);
  EXPECT_TRUE(J_fitted.col(4) == run.J_global.col(kBaseParams + EffectParams::kTagX));
  EXPECT_TRUE(J_fitted.col(8) == run.J_start.col(2));
}

TEST(TrajectoryFitStages, IdentifiabilityFindsTheNullDirection) {
  std::mt19937 rng(11);
  std::normal_distribution<double> normal(0.0, 1.0);
  Eigen::MatrixXd J(40, 4);
  for (int i = 0; i < J.size(); ++i) J.data()[i] = normal(rng);
  const Identifiability full = AnalyseIdentifiability(J, 1e-5);
  EXPECT_TRUE(full.null_vectors.empty());
  EXPECT_GT(full.condition_number, 1.0);
  EXPECT_LT(full.condition_number, 10.0);
  // Column 3 = 2 x column 1: in normalised columns, (col1 - col3) / sqrt(2) is free.
  J.col(3) = 2.0 * J.col(1);
  const Identifiability rank3 = AnalyseIdentifiability(J, 1e-5);
  ASSERT_EQ(rank3.null_vectors.size(), 1u);
  const Eigen::VectorXd& v = rank3.null_vectors[0];
  EXPECT_NEAR(std::abs(v[1]), std::sqrt(0.5), 1e-9);
  EXPECT_NEAR(v[1] + v[3], 0.0, 1e-9);
  EXPECT_GT(rank3.condition_number, 1e12);
  const std::vector<std::string> lines = DescribeNullVectors(rank3, {"a", "b", "c", "d"});
  ASSERT_EQ(lines.size(), 1u);
  EXPECT_THAT(lines[0], ::testing::HasSubstr("0.71 b")) << lines[0];
  EXPECT_THAT(lines[0], ::testing::HasSubstr("0.71 d")) << lines[0];
  // A zero column counts as norm 1 (and is a null direction of its own).
  J.col(3).setZero();
  const Identifiability zero = AnalyseIdentifiability(J, 1e-5);
  EXPECT_EQ(zero.column_norms[3], 1.0);
  EXPECT_EQ(zero.null_vectors.size(), 1u);
}

// Random run blocks and the dense N x (17 + 3 runs) Jacobian they make.
struct BlockCase {
  Linearization lin;
  FittedColumns columns;
  Eigen::MatrixXd J_full;    // every global column, then 3 per run
  Eigen::MatrixXd J_fitted;  // the fitted columns
};
BlockCase RandomBlocks(int n_runs, int rows, std::mt19937* rng) {
  std::normal_distribution<double> normal(0.0, 1.0);
  BlockCase b;
  TrajectoryFitOptions options;
  options.effects = {Effect::kTagOffset, Effect::kTurnSlip};
  b.J_full = Eigen::MatrixXd::Zero(n_runs * rows, kGlobalParams + 3 * n_runs);
  std::vector<RunData> runs(n_runs);
  MeasuredSession session;
  for (int r = 0; r < n_runs; ++r) {
    RunLinearization run;
    run.J_global = Eigen::MatrixXd::NullaryExpr(rows, kGlobalParams, [&] { return normal(*rng); });
    run.J_global.col(0) *= 1e3;  // columns of very different scales
    run.J_start = Eigen::MatrixXd::NullaryExpr(rows, 3, [&] { return normal(*rng); });
    run.residuals = Eigen::VectorXd::Zero(rows);
    b.J_full.block(r * rows, 0, rows, kGlobalParams) = run.J_global;
    b.J_full.block(r * rows, kGlobalParams + 3 * r, rows, 3) = run.J_start;
    b.lin.runs.push_back(run);
    runs[r].run = r;
    session.runs.push_back(MeasuredRun{});
    session.runs.back().name = "run" + std::to_string(r);
  }
  b.columns = SelectFittedColumns(session, runs, options);
  b.J_fitted.resize(b.J_full.rows(), b.columns.index.size());
  for (size_t c = 0; c < b.columns.index.size(); ++c)
    b.J_fitted.col(c) = b.J_full.col(b.columns.index[c]);
  return b;
}

// Run by run, the same singular values, covariance and pseudo-inverse as the
// dense Jacobian's, and the globals' information with the start poses
// eliminated is the Schur complement of the full one.
TEST(TrajectoryFitStages, RunByRunAlgebraEqualsTheDenseJacobians) {
  std::mt19937 rng(7);
  const BlockCase b = RandomBlocks(4, 30, &rng);
  const Identifiability dense = AnalyseIdentifiability(b.J_fitted, 1e-5);
  const Identifiability blocks = AnalyseIdentifiability(b.lin, b.columns, 1e-5);
  EXPECT_LT((dense.singular_values - blocks.singular_values).norm(),
            1e-12 * dense.singular_values.norm());
  EXPECT_NEAR(dense.condition_number, blocks.condition_number, 1e-12 * dense.condition_number);
  const ParameterCovariance c_dense = CameraNoiseCovariance(dense, 120, 1.0, b.lin);
  const ParameterCovariance c_blocks = CameraNoiseCovariance(blocks, 120, 1.0, b.lin);
  const Eigen::MatrixXd normal_inverse = (b.J_fitted.transpose() * b.J_fitted).inverse();
  EXPECT_LT((c_blocks.normal_inverse - normal_inverse).norm(), 1e-10 * normal_inverse.norm());
  EXPECT_LT((c_blocks.normal_inverse - c_dense.normal_inverse).norm(), 1e-12 * normal_inverse.norm());
  // pinv(J)'s global rows, run by run.
  const Eigen::MatrixXd pinv = normal_inverse * b.J_fitted.transpose();
  const std::vector<Eigen::MatrixXd> by_run =
      GlobalPseudoInverseByRun(b.lin, b.columns, c_blocks.normal_inverse);
  const int q = b.columns.n_global;
  for (int r = 0; r < 4; ++r)
    EXPECT_LT((by_run[r] - pinv.block(0, 30 * r, q, 30)).norm(), 1e-10 * pinv.norm()) << r;
  // Reduced globals: R^T R = the Schur complement of the start poses in J^T J.
  const Eigen::MatrixXd H = b.J_full.transpose() * b.J_full;
  const int g = kGlobalParams, s = static_cast<int>(H.rows()) - g;
  const Eigen::MatrixXd schur =
      H.topLeftCorner(g, g) -
      H.topRightCorner(g, s) * H.bottomRightCorner(s, s).inverse() * H.bottomLeftCorner(s, g);
  const ReducedGlobals reduced = ReduceGlobals(b.lin);
  EXPECT_LT((reduced.R.transpose() * reduced.R - schur).norm(), 1e-10 * schur.norm());
  EXPECT_LT((reduced.column_norms - b.J_full.leftCols(g).colwise().norm().transpose()).norm(),
            1e-12 * reduced.column_norms.norm());
}

TEST(TrajectoryFitStages, CameraNoiseCovarianceIsTheInverseNormalMatrix) {
  std::mt19937 rng(5);
  std::normal_distribution<double> normal(0.0, 1.0);
  Eigen::MatrixXd J(30, 4);
  for (int i = 0; i < J.size(); ++i) J.data()[i] = normal(rng);
  J.col(2) *= 1e3;  // columns of very different scales
  const Identifiability id = AnalyseIdentifiability(J, 1e-5);
  const Eigen::MatrixXd normal_inverse = (J.transpose() * J).inverse();
  Linearization lin;
  lin.lag1_numerator = 0.3;
  lin.lag1_denominator = 1.0;
  // Residuals within their sigmas: the factor stays 1.
  ParameterCovariance c = CameraNoiseCovariance(id, 30, 20.0, lin);
  EXPECT_EQ(c.variance_factor, 1.0);
  EXPECT_NEAR(c.lag1_autocorrelation, 0.3, 1e-15);
  EXPECT_LT((c.covariance - normal_inverse).norm(), 1e-10 * normal_inverse.norm());
  EXPECT_LT((c.normal_inverse - normal_inverse).norm(), 1e-10 * normal_inverse.norm());
  // Larger residuals than stated: scaled by the reduced chi-square.
  c = CameraNoiseCovariance(id, 30, 2.0 * 26, lin);
  EXPECT_NEAR(c.variance_factor, 2.0, 1e-15);
  EXPECT_LT((c.covariance - 2.0 * normal_inverse).norm(), 1e-10 * normal_inverse.norm());
}

TEST(TrajectoryFitStages, CameraScaleAddsOneRankOneTerm) {
  // One run, two frames without headings: the whitened residuals per unit of
  // camera scale are (z / sigma).
  RunData rd;
  rd.residuals_per_frame = 2;
  rd.frame_t_s = {0.0, 1.0};
  rd.measured_x_m = {1.0, 2.0};
  rd.measured_y_m = {-1.0, 0.5};
  rd.sigma_position_m = {0.5, 0.25};
  rd.sqrt_weight = {1.0, 1.0};
  ParameterCovariance c;
  c.pinv_by_run = {Eigen::MatrixXd::Identity(4, 4)};
  c.covariance = Eigen::MatrixXd::Zero(4, 4);
  AddCameraScaleCovariance({rd}, 0.1, &c);
  const Eigen::Vector4d v(2.0, -2.0, 8.0, 2.0);
  EXPECT_LT((c.covariance - 0.01 * v * v.transpose()).norm(), 1e-14);
}

TEST(TrajectoryFitStages, DeriveEstimatesByTheDeltaMethod) {
  WheelParams believed = Believed();
  believed.right_wheel_diameter_m = 0.072;
  FitParameters p;
  p.base_scales = {1.01, 0.99, 1.02};
  TrajectoryFitOptions options;
  options.max_ratio_sigma = 0.00905;
  Identifiability id;
  id.column_norms = Eigen::VectorXd::Ones(3);
  Eigen::Matrix3d cov;
  cov << 4e-6, 1e-6, 0.0, 1e-6, 9e-6, 2e-6, 0.0, 2e-6, 0.81e-4;
  std::vector<std::string> unidentifiable;
  const std::vector<ParameterEstimate> e =
      DeriveEstimates(believed, p, options, id, cov, &unidentifiable);
  ASSERT_EQ(e.size(), 4u);
  EXPECT_EQ(e[0].name, "Ed");
  EXPECT_DOUBLE_EQ(e[0].value, 0.99 / 1.01);
  const double es = (1.01 * 0.070 + 0.99 * 0.072) / 0.142;
  EXPECT_DOUBLE_EQ(e[1].value, es);
  EXPECT_DOUBLE_EQ(e[2].value, 1.02);
  EXPECT_DOUBLE_EQ(e[3].value, 1.02 / es);
  EXPECT_NEAR(e[2].sigma, 9e-3, 1e-15);
  // The turn gain's sigma against a numeric gradient.
  auto turn_gain = [&](const Eigen::Vector3d& b) {
    return b[2] / ((b[0] * 0.070 + b[1] * 0.072) / 0.142);
  };
  const Eigen::Vector3d b(1.01, 0.99, 1.02);
  Eigen::Vector3d g;
  for (int i = 0; i < 3; ++i) {
    const Eigen::Vector3d d = Eigen::Vector3d::Unit(i) * 1e-6;
    g[i] = (turn_gain(b + d) - turn_gain(b - d)) / 2e-6;
  }
  EXPECT_NEAR(e[3].sigma, std::sqrt(g.dot(cov * g)), 1e-9);
  // Eb's sigma (0.0090) is not above the limit; the turn gain's (0.0091) is.
  EXPECT_TRUE(e[2].identifiable);
  EXPECT_FALSE(e[3].identifiable);
  ASSERT_EQ(unidentifiable.size(), 1u);
  EXPECT_EQ(unidentifiable[0].rfind("turn_gain: sigma", 0), 0u);
  // A null direction along r_left - r_right hides Ed but not Eb.
  id.null_vectors = {Eigen::Vector3d(1.0, -1.0, 0.0).normalized()};
  unidentifiable.clear();
  const std::vector<ParameterEstimate> hidden =
      DeriveEstimates(believed, p, options, id, cov, &unidentifiable);
  EXPECT_FALSE(hidden[0].identifiable);
  EXPECT_TRUE(hidden[2].identifiable);
}

TEST(TrajectoryFitStages, EffectBlockCovarianceInEffectParamsOrder) {
  // Fitted columns: 3 base, then tracker_yaw, then carpet_drift (a, b).
  Eigen::MatrixXd cov = Eigen::MatrixXd::Zero(6, 6);
  for (int i = 0; i < 6; ++i)
    for (int j = 0; j < 6; ++j) cov(i, j) = 10 * i + j;
  const auto block = EffectBlockCovariance(cov, {Effect::kTrackerYaw, Effect::kCarpetDrift});
  EXPECT_EQ(block(EffectParams::kTrackerYaw, EffectParams::kTrackerYaw), 33.0);
  EXPECT_EQ(block(EffectParams::kTrackerYaw, EffectParams::kDriftB), 35.0);
  EXPECT_EQ(block(EffectParams::kDriftA, EffectParams::kTrackerYaw), 43.0);
  EXPECT_EQ(block(EffectParams::kTagX, EffectParams::kTagX), 0.0);
}

}  // namespace
}  // namespace odocal::calibration::internal
