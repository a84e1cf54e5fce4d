// The stages of FitTrajectory (trajectory_fit.h), one function each, so that
// each can be read and tested on its own. Not part of the public surface:
// the names and shapes may change with the fit.
//
//   ValidateFitInputs       options, believed parameters, the lens candidate's camera
//   ExtractRuns             telemetry steps and the used camera frames of each run
//   InitialParameters       scales at 1, start poses at the first frames (or a warm start)
//   BuildProblem            one dead-reckoned cost block per run, the weak base prior
//   SolveWithIrls           Ceres, with Huber reweighting between rounds
//   Linearize               the whitened residuals and the Jacobian at the solution, by run
//   ReportFrames            each frame against the model, the gap and the noise floor
//   SelectFittedColumns     the Jacobian columns of the fitted parameters, named
//   AnalyseIdentifiability  SVD of the column-normalised Jacobian (its R, assembled
//                           run by run), its null space
//   ComputeCovariance       camera noise, wheel-noise sandwich, camera scale (kept apart
//                           from the solve, as ceres::Covariance is from ceres::Solve)
//   WheelNoiseGap           the gap the wheel noise alone leaves (seeded Monte Carlo)
//   DeriveEstimates         Ed, Es, Eb, turn gain and the effects, with their sigmas
//
// Frames: measurement frame REP-103; robot REP-103. Units: SI, in the names.
#ifndef ODOCAL_CALIBRATION_INTERNAL_TRAJECTORY_FIT_STAGES_H_
#define ODOCAL_CALIBRATION_INTERNAL_TRAJECTORY_FIT_STAGES_H_

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "odocal/calibration/floor_camera.h"
#include "odocal/calibration/measured_session.h"
#include "odocal/calibration/robot_model.h"
#include "odocal/calibration/trajectory_fit.h"

namespace ceres {
class CostFunction;
}  // namespace ceres

namespace odocal::calibration::internal {

// Base parameters: r_left, r_right, Eb (ratios to the believed values).
inline constexpr int kBaseParams = 3;
inline constexpr int kEffectParams = EffectParams::kSize;
inline constexpr int kStartPoseParams = 3;  // x_m, y_m, heading_rad
inline constexpr int kGlobalParams = kBaseParams + kEffectParams;  // shared by every run

// Everything the model needs of one run, extracted once.
struct RunData {
  int run = 0;                                // index into MeasuredSession::runs
  std::vector<double> t_s;                    // telemetry times (robot clock)
  // Tick deltas of step k (t_s[k-1] -> t_s[k]); index 0 is 0.
  std::vector<std::int64_t> left_step_ticks, right_step_ticks;
  std::vector<MotionKind> kind;               // of step k
  std::vector<double> curvature_per_m;        // of step k on arcs, else 0 (arc_scale)
  int left_direction0 = 1, right_direction0 = 1;  // shaft directions before the run
  // The encoder counts at t_s[0]: with the step deltas, each wheel's count
  // (its angle, when the counts run on from run to run) at every step.
  std::int64_t left_count0 = 0, right_count0 = 0;
  // The used (valid) camera frames.
  std::vector<double> frame_t_s;
  // Each frame's image row fraction - 1/2 (rolling_shutter), 0 when unknown.
  std::vector<double> frame_row_offset;
  std::vector<double> measured_x_m, measured_y_m, measured_heading_rad;
  std::vector<double> sigma_position_m, sigma_heading_rad;
  std::vector<double> sqrt_weight;  // IRLS weights (square roots)
  int residuals_per_frame = 3;      // 2 without headings

  int n_frames() const { return static_cast<int>(frame_t_s.size()); }
  int n_residuals() const { return n_frames() * residuals_per_frame; }
};

// The believed robot, as the model uses it.
struct ModelConstants {
  double left_m_per_tick = 0.0;
  double right_m_per_tick = 0.0;
  double track_m = 0.0;
  double ticks_per_rev = 0.0;  // a wheel's counts per turn (its angle)
  std::optional<FloorCamera> camera;
};
ModelConstants ConstantsOf(const WheelParams& believed, const std::optional<FloorCamera>& camera);

MotionKind StepKind(std::int64_t left_step_ticks, std::int64_t right_step_ticks);

// The telemetry part of a run: its times, each step's tick deltas and
// motion. The shafts' last directions (encoder_backlash) come in and go out
// through `left_direction` and `right_direction`.
RunData ExtractTelemetry(const MeasuredRun& run, int index, int* left_direction,
                         int* right_direction);
// arc_scale's curvature of each step (RunData::curvature_per_m).
void MarkArcs(const ModelConstants& constants, RunData* run);

// Stage 1. Empty when the fit can start, else the result's message.
std::string ValidateFitInputs(const MeasuredSession& session, const TrajectoryFitOptions& options);

// Stage 2. The runs with telemetry and at least options.min_frames_per_run
// valid frames; shaft directions carry over from run to run (also across
// runs left out).
struct ExtractedRuns {
  std::vector<RunData> runs;
  std::vector<bool> run_used;  // per session run
};
ExtractedRuns ExtractRuns(const MeasuredSession& session, const TrajectoryFitOptions& options,
                          const ModelConstants& constants);

// The parameter blocks the solver moves.
struct FitParameters {
  std::array<double, kBaseParams> base_scales = {1.0, 1.0, 1.0};  // r_left, r_right, Eb
  EffectParams effects;
  std::vector<std::array<double, kStartPoseParams>> start_poses;  // per used run
  std::array<bool, kEffectParams> effect_enabled{};  // by EffectParams index
};

// Stage 3. Scales at 1, effects at 0, each start pose at the run's first
// frame; or, when `warm_start` is ok and used the same runs, its values.
FitParameters InitialParameters(const std::vector<RunData>& runs,
                                const std::vector<bool>& run_used,
                                const TrajectoryFitOptions& options,
                                const TrajectoryFitResult* warm_start);

// Stage 4. One cost block per run (the run's frames share its dead
// reckoning), residuals whitened by the frames' sigmas and weighted by
// RunData::sqrt_weight (read at every evaluation), and the weak base prior.
// Holds pointers to `runs` and `constants`: they must outlive it.
struct TrajectoryProblem {
  std::vector<std::unique_ptr<ceres::CostFunction>> run_costs;
  std::unique_ptr<ceres::CostFunction> base_prior;
  const ModelConstants* constants = nullptr;  // SolveWithIrls builds its costs of the runs with it
  TrajectoryProblem();
  TrajectoryProblem(TrajectoryProblem&&) noexcept;
  ~TrajectoryProblem();
};
TrajectoryProblem BuildProblem(const std::vector<RunData>& runs, const ModelConstants& constants,
                               const TrajectoryFitOptions& options);

// The whitened residuals of one run at `params` (without the prior).
std::vector<double> RunResiduals(const TrajectoryProblem& problem, const FitParameters& params,
                                 size_t run_index);

// Stage 5. options.irls_rounds solves; between them each frame's weight
// becomes Huber's on its whitened error norm (ReweightHuber).
struct SolveOutcome {
  bool failed = false;          // Ceres failed or the cost is not finite: stop
  bool solution_usable = false;  // of the last solve
  std::string message;          // Ceres' message of the last solve
};
SolveOutcome SolveWithIrls(const TrajectoryProblem& problem, const TrajectoryFitOptions& options,
                           std::vector<RunData>* runs, FitParameters* params);
// Huber weights at a threshold of `huber_threshold` robust standard
// deviations (1.4826 MAD of the whitened components) times sqrt(residuals
// per frame), on each frame's whitened error norm.
void ReweightHuber(const TrajectoryProblem& problem, const FitParameters& params,
                   double huber_threshold, std::vector<RunData>* runs);

// Stage 6. The whitened residuals and the Jacobian, run by run: a run's rows
// depend on the global parameters (base, then the effect block in
// EffectParams order) and on its own start pose only, so the Jacobian is kept
// as each run's two blocks (N x 20 in all), never as one N x (17 + 3 runs)
// matrix, whose storage and dense algebra grow as the runs squared.
struct RunLinearization {
  Eigen::MatrixXd J_global;  // rows x kGlobalParams
  Eigen::MatrixXd J_start;   // rows x kStartPoseParams
  Eigen::VectorXd residuals;
};
struct Linearization {
  std::vector<RunLinearization> runs;  // in the order of the used runs
  // Lag-one products of the whitened residuals within runs, per component.
  double lag1_numerator = 0.0, lag1_denominator = 0.0;
  int n_residuals() const;
  double weighted_sse() const;
};
Linearization Linearize(const TrajectoryProblem& problem, const std::vector<RunData>& runs,
                        const FitParameters& params);

// The poses the model dead-reckons at a run's telemetry times.
struct DeadReckonedPoses {
  std::vector<double> x_m, y_m, heading_rad;
};
DeadReckonedPoses DeadReckonRun(const RunData& run, const ModelConstants& constants,
                                const FitParameters& params, size_t run_index);

// Stage 7. Each frame against the model (unweighted), the gap and the noise floor.
struct FrameReport {
  std::vector<FrameResidual> residuals;
  double gap_m = 0.0;
  double noise_floor_m = 0.0;
};
FrameReport ReportFrames(const std::vector<RunData>& runs, const ModelConstants& constants,
                         const FitParameters& params);

// Stage 8. The fitted parameters, named: the fitted global ones (base, the
// enabled effects' parameters in options.effects order), then the start
// poses. index < kGlobalParams: a column of RunLinearization::J_global; else
// kGlobalParams + 3 r + c, column c of used run r's J_start.
struct FittedColumns {
  std::vector<int> index;
  std::vector<std::string> names;
  int n_global = 0;  // the first n_global are global
};
FittedColumns SelectFittedColumns(const MeasuredSession& session,
                                  const std::vector<RunData>& runs,
                                  const TrajectoryFitOptions& options);
// A run's rows over the fitted global columns, then its start pose.
Eigen::MatrixXd RunFittedJacobian(const RunLinearization& run, const FittedColumns& columns);

// Stage 9. The singular values of the column-normalised Jacobian; those
// below rank_tolerance of the largest span the null space.
struct Identifiability {
  Eigen::VectorXd column_norms;     // 1 where a column is zero
  Eigen::VectorXd singular_values;  // of the normalised Jacobian, descending
  Eigen::MatrixXd V;                // its right singular vectors
  std::vector<bool> determined;     // per singular value
  std::vector<Eigen::VectorXd> null_vectors;  // in normalised coordinates
  double condition_number = 0.0;
};
// Of a dense Jacobian (its columns those of the fitted parameters).
Identifiability AnalyseIdentifiability(const Eigen::MatrixXd& J_fitted, double rank_tolerance);
// Of the fitted columns of a linearisation, run by run (the same values).
Identifiability AnalyseIdentifiability(const Linearization& linearization,
                                       const FittedColumns& columns, double rank_tolerance);

// The start poses projected out of the global columns: R (kGlobalParams
// square, upper triangular) with R^T R = J_g^T (I - P_start) J_g, P_start the
// projection on the runs' start-pose columns. Whatever the runs, 17 x 17: the
// aliasing test's Jacobian (TrajectoryFitResult::reduced_jacobian), with
// the norms of the global columns before the projection.
struct ReducedGlobals {
  Eigen::MatrixXd R;
  Eigen::VectorXd column_norms;
};
ReducedGlobals ReduceGlobals(const Linearization& linearization);

// Stage 10. The covariance of the fitted parameters and how each whitened
// residual moves the estimate.
struct ParameterCovariance {
  // pinv(J^T J) over the determined directions (p x p): pinv(J) = normal_inverse J^T.
  Eigen::MatrixXd normal_inverse;
  // Per used run, the rows of pinv(J) of the fitted global parameters over
  // that run's residuals (n_global x rows): all the noise terms below need
  // (the start poses are nuisances), q N numbers instead of p N.
  std::vector<Eigen::MatrixXd> pinv_by_run;
  Eigen::MatrixXd covariance;  // p x p; the noise terms below on its global block
  double variance_factor = 1.0;
  double lag1_autocorrelation = 0.0;
};
// The camera-noise part: (J^T J)^-1 over the determined directions, scaled by
// max(1, reduced chi-square).
ParameterCovariance CameraNoiseCovariance(const Identifiability& identifiability,
                                          int n_residuals, double weighted_sse,
                                          const Linearization& linearization);
// ParameterCovariance::pinv_by_run from normal_inverse.
std::vector<Eigen::MatrixXd> GlobalPseudoInverseByRun(const Linearization& linearization,
                                                      const FittedColumns& columns,
                                                      const Eigen::MatrixXd& normal_inverse);
// The wheel noise: a travel error of a wheel at step k moves every later
// frame rigidly (along the heading at k, and a rotation about the pose at
// k); its effect on the estimate is pinv * dr/dw, added as the sandwich
// pinv J_w Q J_w^T pinv^T with Q = wheel_sigma^2 per metre rolled.
void AddWheelNoiseCovariance(const std::vector<RunData>& runs, const ModelConstants& constants,
                             const FitParameters& params, double wheel_sigma_m_per_sqrt_m,
                             ParameterCovariance* covariance);
// The camera's length scale: a common factor (1 + e) on every measured
// position moves the estimate by pinv * (z / sigma) e.
void AddCameraScaleCovariance(const std::vector<RunData>& runs, double camera_scale_sigma,
                              ParameterCovariance* covariance);
// All three, as FitTrajectory uses them.
ParameterCovariance ComputeCovariance(const MeasuredSession& session,
                                      const std::vector<RunData>& runs,
                                      const ModelConstants& constants,
                                      const FitParameters& params,
                                      const TrajectoryFitOptions& options,
                                      const Identifiability& identifiability,
                                      const FittedColumns& columns,
                                      const Linearization& linearization);

// What the wheel noise alone leaves of the gap once the fit has absorbed
// what it can: seeded Monte Carlo of the wheels' random walk, linearised.
double WheelNoiseGap(const std::vector<RunData>& runs, const ModelConstants& constants,
                     const FitParameters& params, const TrajectoryFitOptions& options,
                     const Linearization& linearization, const FittedColumns& columns,
                     const Eigen::MatrixXd& normal_inverse, int n_frames);

// Stage 11. The effect block's covariance (EffectParams order, zero where
// disabled) from the fitted parameters' covariance.
Eigen::Matrix<double, kEffectParams, kEffectParams> EffectBlockCovariance(
    const Eigen::MatrixXd& covariance, const std::vector<Effect>& effects);
// The null vectors in words ("the combination +0.71 r_left -0.71 ...").
std::vector<std::string> DescribeNullVectors(const Identifiability& identifiability,
                                             const std::vector<std::string>& column_names);
// Ed, Es, Eb, turn_gain, then the effects' parameters, each with its sigma
// (by the delta method) and whether the data determine it. Ratios with a
// sigma above options.max_ratio_sigma are marked not identifiable and
// explained in `unidentifiable`.
std::vector<ParameterEstimate> DeriveEstimates(const WheelParams& believed,
                                               const FitParameters& params,
                                               const TrajectoryFitOptions& options,
                                               const Identifiability& identifiability,
                                               const Eigen::MatrixXd& covariance,
                                               std::vector<std::string>* unidentifiable);

}  // namespace odocal::calibration::internal

#endif  // ODOCAL_CALIBRATION_INTERNAL_TRAJECTORY_FIT_STAGES_H_
