// Full-trajectory least squares: the odometry model, driven by the recorded
// encoder ticks, fitted to every pose the camera measured (in the spirit of
// Antonelli, Chiaverini & Fusco 2005, "A calibration method for odometry of
// mobile robots based on the least-squares technique", IEEE T-RO 21(5), and
// Censi, Franchi, Marchionni & Oriolo 2013, "Simultaneous calibration of
// odometry and sensor parameters for mobile robots", IEEE T-RO 29(2)).
//
// Model. For each run, a start pose (x, y, heading) in the camera's
// measurement frame is a nuisance parameter. From it the model dead-reckons
// with candidate parameters: between two telemetry samples the wheels roll
// true travel = ticks * believed metres-per-tick * r (r_left, r_right), on a
// true track Eb * believed track, along an exact arc (arc.h). The predicted
// pose at each camera timestamp (interpolated between telemetry samples) is
// compared with the measured pose, each frame whitened by its stated sigmas.
// The rests before and after a run are part of the camera record (their
// frames weigh n times one frame, as their mean would).
//
// Effects (the model library of `explain`): each adds its own parameters to
// the model; those not enabled stay at zero. They are the inverses of what
// the virtual world does (sim/effects.h):
//   tag_offset       measured position = p + R(heading) (x, y)_tag
//   camera_latency   a frame stamped s shows the robot at telemetry time s + latency
//   turn_slip        in-place turns achieve (1 - f |omega|) of the wheel rotation
//   lens_distortion  the tag seen through a lens whose k1 is off by dk1, in
//                    the camera's geometry over the plane (floor_camera.h),
//                    with the camera tilt the plane estimate absorbed as a
//                    nuisance (tilt_x, tilt_y)
//   encoder_backlash after a wheel's ticks reverse, `ticks` counts pass without motion
//   carpet_drift     while not turning in place, lateral drift to the left of
//                    rate cos(heading - grain) per metre forward; fitted as the
//                    linear pair (a, b) = rate (cos grain, sin grain)
//   tracker_yaw      the tracked body's (tag's) heading is off the robot's by a
//                    constant: measured heading = heading + yaw (the position
//                    part of a rotated body offset is tag_offset's)
//   speed_slip       each wheel's ground travel = tick travel (1 - k |v_wheel|),
//                    v_wheel that wheel's speed over the telemetry step (m/s)
//   arc_scale        on arcs (both wheels the same way, |curvature| >=
//                    kArcMinCurvature), each wheel's ground travel = tick
//                    travel (1 - c |kappa|), kappa the path curvature (1/m)
//                    from the ticks over a few steps; 0 on straights, not
//                    applied to in-place turns (turn_slip's)
//   rolling_shutter  the image rows are exposed one after another over the
//                    readout time T: a frame stamped s whose tag centre is at
//                    image row fraction f (CameraRecord::image_row_fraction,
//                    v / (H - 1)) shows the robot at telemetry time
//                    s + latency + (f - 1/2) T; frames without a row: no shift
//
// Robust loss: Huber on each frame's whitened error, by iteratively
// reweighted least squares (the frames of a run share one dead-reckoned
// cost block, so Ceres' per-block loss would down-weight a whole run). Huber
// because it is quadratic for inliers (the covariance stays the Gaussian one)
// and convex (no new local minima), while a lost or mis-detected tag frame
// counts only linearly.
//
// Uncertainty: the covariance (J^T J)^-1 of the whitened problem (scaled up
// when the residuals exceed the stated sigmas), plus the wheel noise the
// model cannot fit: each step's random ground-travel error moves all later
// poses, and through the pseudo-inverse of J the estimate (a sandwich term,
// pinv(J) J_w Q J_w^T pinv(J)^T, with Q from wheel_sigma_m_per_sqrt_m).
// Without it, intervals of Ed and Eb cover the truth far less than 95 %.
// (3) the camera's length scale (MeasuredSession::camera_scale_sigma), a
// common factor on every measured position: pinv (z / sigma) per unit.
// Identifiability: the singular values of the column-normalised
// Jacobian; a combination whose singular value is below
// `rank_tolerance` of the largest is reported, not estimated.
//
// Frames: measurement frame REP-103; robot REP-103. Units: SI.
#ifndef ODOCAL_CALIBRATION_TRAJECTORY_FIT_H_
#define ODOCAL_CALIBRATION_TRAJECTORY_FIT_H_

#include <array>
#include <cmath>
#include <iosfwd>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "odocal/base/solver_settings.h"
#include "odocal/base/status.h"
#include "odocal/base/units.h"
#include "odocal/calibration/measured_session.h"
#include "odocal/calibration/pose2.h"
#include "odocal/calibration/robot_model.h"

namespace odocal::calibration {

// The candidate effects, named as scenario files name them.
enum class Effect {
  kTagOffset,
  kCameraLatency,
  kTurnSlip,
  kLensDistortion,
  kEncoderBacklash,
  kCarpetDrift,
  kTrackerYaw,
  kSpeedSlip,
  kArcScale,
  kRollingShutter,
  kEccentricWheel
};
inline constexpr std::array<Effect, 11> kAllEffects = {
    Effect::kTagOffset,       Effect::kCameraLatency,  Effect::kTurnSlip,      Effect::kLensDistortion,
    Effect::kEncoderBacklash, Effect::kCarpetDrift,    Effect::kTrackerYaw,    Effect::kSpeedSlip,
    Effect::kArcScale,        Effect::kRollingShutter, Effect::kEccentricWheel};
std::string_view ToString(Effect effect);

// The effect parameter block. Indices into `values` are fixed; a disabled
// effect's values are held at zero.
struct EffectParams {
  enum Index {
    kTagX = 0,
    kTagY,
    kLatency,
    kSlip,
    kK1,
    kBacklash,
    kDriftA,
    kDriftB,
    kTiltX,
    kTiltY,
    kTrackerYaw,
    kSpeedSlip,
    kArcScale,
    kReadout,
    kEccLeftSin,
    kEccLeftCos,
    kEccRightSin,
    kEccRightCos,
    kSize
  };
  std::array<double, kSize> values{};

  double tag_x_m() const { return values[kTagX]; }
  double tag_y_m() const { return values[kTagY]; }
  double latency_s() const { return values[kLatency]; }
  double slip_fraction_at_1rad_s() const { return values[kSlip]; }
  double k1_delta() const { return values[kK1]; }
  double backlash_ticks() const { return values[kBacklash]; }
  double tracker_yaw_rad() const { return values[kTrackerYaw]; }
  double speed_slip_at_1m_s() const { return values[kSpeedSlip]; }
  double arc_scale_at_1_per_m() const { return values[kArcScale]; }
  double readout_s() const { return values[kReadout]; }
  // The telemetry time a frame shows: its stamp + latency, and for a rolling
  // shutter + (row fraction - 1/2) readout (no shift when the row is unknown);
  // the effects' own terms (calibration/src/effects/camera_latency.h, rolling_shutter.h).
  double TelemetryTimeOf(double stamp_s, double image_row_fraction) const;
  // f - 1/2 for a known row fraction f, else 0.
  static double RowOffset(double image_row_fraction) {
    return std::isnan(image_row_fraction) ? 0.0 : image_row_fraction - 0.5;
  }
  double drift_rate_m_per_m() const;
  double drift_grain_rad() const;
};

// arc_scale acts on steps whose path curvature, from the ticks over
// kArcWindowSteps steps either side, is at least this (1/m; a radius of 2 m):
// a straight's steering corrections (a tick or two between the wheels) stay
// below it, every arc a calibration drives is above it.
inline constexpr double kArcMinCurvature = 0.5;
inline constexpr int kArcWindowSteps = 5;

// The path curvature (1/m, CCW positive) of each telemetry step of `run` as
// arc_scale sees it: from the believed wheels and track over a window of
// steps whose wheels both move the same way; 0 where below kArcMinCurvature,
// at rest, in turns in place (wheels opposite ways) and on steps where one
// wheel is still. Index k is the step t[k-1] -> t[k].
std::vector<double> ArcCurvatures(const MeasuredRun& run, const WheelParams& believed);

// The indices of an effect's parameters in EffectParams.
std::vector<int> EffectParamIndices(Effect effect);
// Those that name it (tested against zero, checked for aliasing): all but
// the lens candidate's camera-tilt nuisance.
std::vector<int> EffectTestedIndices(Effect effect);
// Their names as reports spell them ("x_mm", ...), one per index.
std::vector<std::string> EffectParamNames(Effect effect);

struct TrajectoryFitOptions {
  // The effects in the model besides the base parameters.
  std::vector<Effect> effects;
  // Fit the measured headings as well as the positions.
  bool use_heading = true;
  // Stand-ins for a frame whose stated sigma is zero.
  double default_position_sigma_m = 1e-3;
  double default_heading_sigma_rad = DegToRad(0.2);
  // The robot's wheel noise: each wheel's ground travel random-walks about
  // what its ticks say, with this standard deviation after 1 m (the
  // scenario default, 0.05 mm/sqrt(m)). The model cannot fit it; it enters
  // the parameters' covariance. From repeated runs or the robot's spec.
  double wheel_sigma_m_per_sqrt_m = 0.05e-3;
  // Huber threshold in robust standard deviations of the current whitened
  // frame errors (1.4826 MAD); 0 turns the robust loss off.
  double huber_threshold = 3.0;
  int irls_rounds = 3;
  // Each IRLS round's solve (Ceres, dense QR): at most 100 iterations, and
  // tolerances tight enough that the fitted ratios settle to ~1e-10.
  SolverSettings solver{.max_iterations = 100, .function_tolerance = 1e-10,
                        .parameter_tolerance = 1e-10};
  // A normalised singular value below this (relative to the largest) marks a
  // parameter combination the data cannot determine.
  double rank_tolerance = 1e-5;
  // A weak prior on r_left, r_right and Eb at 1 with this sigma, only to keep
  // the solver physical along directions the data leave free (it is not part
  // of the covariance or of the identifiability test); 0 turns it off.
  double base_prior_sigma = 0.2;
  // Ed, Es or Eb with a larger sigma is reported as not identifiable.
  double max_ratio_sigma = 0.01;
  // Runs with fewer valid camera frames than this are left out (their start
  // pose cannot be determined).
  int min_frames_per_run = 10;
  // Monte Carlo draws of the wheel noise for wheel_noise_gap_m (0: not computed).
  int wheel_noise_draws = 16;

  bool IsValid(std::string* why) const;
};

enum class MotionKind { kRest, kStraight, kTurn };
std::string_view ToString(MotionKind kind);

// One measured frame against the model.
struct FrameResidual {
  int run = 0;
  double t_s = 0.0;  // the camera timestamp
  MotionKind motion = MotionKind::kRest;
  Eigen::Vector2d measured_m = Eigen::Vector2d::Zero();
  Eigen::Vector2d error_m = Eigen::Vector2d::Zero();  // model - measured
  double heading_error_rad = 0.0;
  double measured_heading_rad = 0.0;
  double weight = 1.0;  // robust (IRLS) weight
};

struct ParameterEstimate {
  std::string name;
  double value = 0.0;
  double sigma = 0.0;  // 1-sigma; meaningless when !identifiable
  bool identifiable = true;
  // 1-sigma from the runs' disagreement (AddRunJackknife); NaN until
  // computed, or when a refit without some run could not determine it.
  double sigma_between_runs = std::numeric_limits<double>::quiet_NaN();
  double lower95() const { return value - 1.959963985 * sigma; }
  double upper95() const { return value + 1.959963985 * sigma; }
};

struct TrajectoryFitResult {
  StatusCode status = StatusCode::kInvalidArgument;
  std::string message;

  TrajectoryFitOptions options;
  WheelScales scales;
  EffectParams effects;
  std::vector<Pose2> start_poses;  // per run; identity for runs left out
  std::vector<bool> run_used;

  // Ed, Es, Eb, turn_gain (Eb / Es), then the effects' parameters in the
  // order of options.effects.
  std::vector<ParameterEstimate> parameters;
  // Covariance of the effect block (EffectParams order; zero where disabled).
  Eigen::Matrix<double, EffectParams::kSize, EffectParams::kSize> effect_covariance =
      Eigen::Matrix<double, EffectParams::kSize, EffectParams::kSize>::Zero();
  // Wald statistic of an enabled effect's tested parameters against zero
  // (chi-square with as many degrees of freedom as EffectTestedIndices).
  double Wald(Effect effect) const;
  const ParameterEstimate* Find(std::string_view name) const;

  std::vector<FrameResidual> residuals;
  int n_frames = 0;
  int n_parameters = 0;  // including the start poses
  // RMS of |model - measured| position over the frames: the gap.
  double gap_m = 0.0;
  // The gap the stated frame noise alone would leave.
  double noise_floor_m = 0.0;
  // The gap the wheel noise (options.wheel_sigma_m_per_sqrt_m) alone is
  // expected to leave after the fit (seeded Monte Carlo, linearised).
  double wheel_noise_gap_m = 0.0;
  // The gap the model's noise (camera and wheels) explains by itself.
  double expected_gap_m() const {
    return std::sqrt(noise_floor_m * noise_floor_m + wheel_noise_gap_m * wheel_noise_gap_m);
  }
  // Sum of robust-weighted squared whitened residuals.
  double weighted_sse = 0.0;
  // Lag-one autocorrelation of the whitened residuals within runs (for the
  // effective sample size of model selection), and the factor the camera
  // part of the covariance was scaled by (max(1, reduced chi-square)).
  double lag1_autocorrelation = 0.0;
  double variance_factor = 1.0;
  double condition_number = 0.0;
  // Parameter combinations the data cannot determine, as readable lines.
  std::vector<std::string> unidentifiable;
  // Runs of the delete-one jackknife behind sigma_between_runs (0: none).
  int jackknife_runs = 0;
  // The jackknife's refits: jackknife_runs, or kMaxJackknifeGroups groups of runs.
  int jackknife_groups = 0;

  // The whitened, robust-weighted Jacobian at the solution over every global
  // parameter, enabled or not (base r_left, r_right, Eb, then the effect
  // block in EffectParams order), with the runs' start poses projected out:
  // 17 rows whose column products are those of the N rows (R^T R =
  // J_g^T (I - P_start) J_g), whatever the runs. For aliasing tests.
  Eigen::MatrixXd reduced_jacobian;
  // The norms of those 17 columns of the full Jacobian (before the projection).
  Eigen::VectorXd global_column_norms;
  int n_residuals = 0;  // rows of the Jacobian: 2 or 3 per frame

  bool ok() const { return status == StatusCode::kOk; }
  std::string BriefReport() const;
};

// Fits the model (base + options.effects) to a session. `warm_start`, when
// given, seeds every parameter from an earlier fit of the same session.
TrajectoryFitResult FitTrajectory(const MeasuredSession& session,
                                  const TrajectoryFitOptions& options = {},
                                  const TrajectoryFitResult* warm_start = nullptr);

// A warm start for a fit of the same session without some of its runs
// (`removed`: positions in the session, ascending): `fit`'s parameters, its
// start poses and used runs without those. A few runs fewer move the
// solution a little, which a refit from here reaches in a few iterations
// instead of a cold start's many (jackknife, cross-validation folds).
TrajectoryFitResult WarmStartWithout(const TrajectoryFitResult& fit,
                                     const std::vector<size_t>& removed);

// How much the parameters move from run to run, whatever moves them. The
// model's sigma holds when the model leaves nothing but independent frame
// and wheel noise; a real robot's runs disagree more (the OptiOdom sets:
// the track's delete-one spread is 7-10 times its model sigma, and it is
// what agrees with the spread between sets of one kind of path;
// docs/realdata.md). Repeats the fit (same options) without each used run
// in turn and sets every parameter's sigma_between_runs to the delete-one
// jackknife's standard error
//   sigma^2 = (n - 1) / n * sum_i (theta_(i) - mean)^2
// over the n used runs; with more than kMaxJackknifeGroups runs, the
// delete-a-group jackknife over g = kMaxJackknifeGroups groups (used run k in
// group k mod g), sigma^2 = (g - 1) / g * sum_j (theta_(j) - mean)^2, so that
// hundreds of short runs cost g refits, not hundreds (Efron & Stein 1981: in expectation it does not read
// low, and it reads high when the runs differ in kind, each carrying what the
// others lack: 2-2.7x the model's sigma on a simulated plan of squares,
// spins and an out-and-back with the model right, 0.85x on six squares).
// Needs n >= 3; with few runs it is itself uncertain (about
// 1/sqrt(2 (n - 1)) relative). An error every run shares, the runs cannot
// show: the camera's length scale (session.camera_scale_sigma) is added to
// Es's and Eb's, which it moves 1:1. A parameter that
// some refit could not determine keeps NaN. Returns the number of refits
// that failed (0 when every one converged); threads: up to `threads` refits
// at once (0: the hardware's).
// `left_out`, when given, receives for each run of `session` the wheel
// scales of the refit that left it out (its group's, with groups; refitted
// false for a run the fit did not use, or with fewer than 3 used runs): the leave-one-run-out fits that batch's
// estimator choice replays each run through (rig/measure/estimator_choice.h).
struct RunLeftOut {
  bool refitted = false;
  // Converged, with Ed, Es, Eb and the turn gain identifiable.
  bool determines_wheels = false;
  WheelScales scales;
  std::string message;  // why not, when refitted and not determines_wheels
};
inline constexpr int kMaxJackknifeGroups = 20;
int AddRunJackknife(const MeasuredSession& session, TrajectoryFitResult* fit, int threads = 0,
                    std::vector<RunLeftOut>* left_out = nullptr, int max_groups = kMaxJackknifeGroups);

// The model's prediction of what the pose source measures for one run: the
// run's ticks dead-reckoned from `start` (the robot's pose at the run's first
// telemetry sample, in the measurement frame) with the believed parameters
// corrected by `scales`, the effects of `effects` (zero: none), seen through
// `camera` when given (the lens candidate), at each camera stamp of
// `stamps_s` (video clock). The same
// model FitTrajectory fits. `left_direction0`/`right_direction0`: each wheel's
// last direction of motion before the run (+1 forward, -1 backward), which
// encoder_backlash needs; LastShaftDirections carries them over from an earlier
// run. `image_row_fractions`, one per stamp when given, are the frames' image
// rows (rolling_shutter; NaN: unknown); empty: no frame has a row.
// Empty when the run has fewer than 2 telemetry samples.
std::vector<Pose2> PredictMeasuredPoses(const MeasuredRun& run, const WheelParams& believed,
                                        const WheelScales& scales, const EffectParams& effects,
                                        const std::optional<FloorCamera>& camera,
                                        const Pose2& start, const std::vector<double>& stamps_s,
                                        int left_direction0 = 1, int right_direction0 = 1,
                                        const std::vector<double>& image_row_fractions = {});

// Each wheel's last direction of motion at the end of `run` (+1, -1), given
// those before it (unchanged for a wheel that did not move).
void LastShaftDirections(const MeasuredRun& run, int* left_direction, int* right_direction);

// How well the data tells a candidate effect apart from the parameters of
// `fit` (its base and enabled effects).
struct AliasReport {
  Effect effect = Effect::kTagOffset;
  // Smallest sine of the angle between a combination of the candidate's
  // Jacobian columns and the span of the fitted ones (1: orthogonal, 0: the
  // data cannot tell them apart).
  double separation = 1.0;
  bool aliased = false;
  // The fitted parameters it looks like (largest loadings first).
  std::vector<std::string> looks_like;
  // The runs that would tell them apart.
  std::string distinguishing_runs;
  bool no_signal = false;  // the candidate changes nothing on these data
};

AliasReport CheckAliasing(const TrajectoryFitResult& fit, Effect candidate,
                          double alias_tolerance = 0.01);

// Which runs separate an effect from the base model, in words.
std::string DistinguishingRuns(Effect effect);

}  // namespace odocal::calibration

#endif  // ODOCAL_CALIBRATION_TRAJECTORY_FIT_H_
