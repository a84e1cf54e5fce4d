#include "odocal/calibration/trajectory_fit.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <memory>
#include <numeric>
#include <random>
#include <ostream>
#include <sstream>

#include <Eigen/Dense>
#include <ceres/ceres.h>

#include "effects/effects.h"
#include "odocal/base/format.h"
#include "odocal/base/units.h"
#include "odocal/calibration/arc.h"
#include "odocal/calibration/effect_registry.h"
#include "odocal/calibration/internal/trajectory_fit_stages.h"
#include "odocal/calibration/statistics.h"

namespace odocal::calibration {
namespace internal {
namespace {

// The dead-reckoned poses of a run at its telemetry times, from `start`
// (x_m, y_m, heading_rad), with `base_scales` (r_left, r_right, Eb) and the
// effect block `effect_values` (EffectParams order). Each effect's term is in
// its own file (effects/<name>.h); this is the order they act in.
template <typename T>
void DeadReckon(const RunData& run, const ModelConstants& constants, const T* base_scales, const T* start,
                const T* effect_values, std::vector<T>* xs_m, std::vector<T>* ys_m, std::vector<T>* headings_rad) {
  const size_t n = run.t_s.size();
  xs_m->resize(n);
  ys_m->resize(n);
  headings_rad->resize(n);
  T x = start[0], y = start[1], h = start[2];
  (*xs_m)[0] = x;
  (*ys_m)[0] = y;
  (*headings_rad)[0] = h;
  int left_direction = run.left_direction0, right_direction = run.right_direction0;
  T left_dead_ticks(0.0), right_dead_ticks(0.0);
  std::int64_t left_count = run.left_count0, right_count = run.right_count0;
  const T track_m = base_scales[2] * constants.track_m;
  const T& backlash_ticks = effect_values[EffectParams::kBacklash];
  for (size_t k = 1; k < n; ++k) {
    const std::int64_t left_ticks = run.left_step_ticks[k], right_ticks = run.right_step_ticks[k];
    if (left_ticks != 0 || right_ticks != 0) {
      const double dt_s = std::max(run.t_s[k] - run.t_s[k - 1], 1e-6);
      T left_m = MovingTicks(left_ticks, &left_direction, &left_dead_ticks, backlash_ticks) *
                 constants.left_m_per_tick * base_scales[0];
      T right_m = MovingTicks(right_ticks, &right_direction, &right_dead_ticks, backlash_ticks) *
                  constants.right_m_per_tick * base_scales[1];
      EccentricWheel(effect_values, constants.ticks_per_rev, left_count, left_ticks, right_count, right_ticks, &left_m,
                     &right_m);
      SpeedSlip(effect_values, dt_s, &left_m, &right_m);
      ArcScale(effect_values, run.curvature_per_m[k], &left_m, &right_m);
      const T ds_m = (left_m + right_m) / 2.0;
      if (run.kind[k] == MotionKind::kTurn) TurnSlip(effect_values, dt_s, track_m, &left_m, &right_m);
      const T h0 = h;
      AdvanceArc(left_m, right_m, track_m, &x, &y, &h);
      if (run.kind[k] == MotionKind::kStraight) CarpetDrift(effect_values, h0, ds_m, &x, &y, &h);
    }
    left_count += left_ticks;
    right_count += right_ticks;
    (*xs_m)[k] = x;
    (*ys_m)[k] = y;
    (*headings_rad)[k] = h;
  }
}

// Frame j's image row fraction - 1/2 (0 when unknown or not extracted).
double RowOffsetOf(const RunData& run, size_t j) {
  return j < run.frame_row_offset.size() ? run.frame_row_offset[j] : 0.0;
}

// The telemetry time frame j of `run` shows (camera_latency, rolling_shutter).
double FrameTelemetryTime(const RunData& run, size_t j, const EffectParams& effects) {
  return RollingShutter(effects.values.data(), RowOffsetOf(run, j),
                        CameraLatency(effects.values.data(), run.frame_t_s[j]));
}

// The measured pose predicted for a camera frame stamped `stamp_s` whose tag
// is `row_offset` (image row fraction - 1/2) from the middle row: the frame's
// telemetry time, the dead-reckoned pose there, and what the measurement
// makes of it, each effect's term from its file (effects/<name>.h).
template <typename T>
void PredictFrame(const RunData& run, const ModelConstants& constants, const std::vector<T>& xs_m,
                  const std::vector<T>& ys_m, const std::vector<T>& headings_rad,
                  const T* effect_values, double stamp_s, double row_offset, T* px_m, T* py_m,
                  T* ph_rad) {
  const T t = RollingShutter(effect_values, row_offset, CameraLatency(effect_values, stamp_s));
  const double ts = Scalar(t);
  const size_t n = run.t_s.size();
  if (ts <= run.t_s.front()) {
    *px_m = xs_m.front(), *py_m = ys_m.front(), *ph_rad = headings_rad.front();
  } else if (ts >= run.t_s.back()) {
    *px_m = xs_m.back(), *py_m = ys_m.back(), *ph_rad = headings_rad.back();
  } else {
    const size_t k = static_cast<size_t>(std::upper_bound(run.t_s.begin(), run.t_s.end(), ts) -
                                         run.t_s.begin()) - 1;
    const size_t k1 = std::min(k + 1, n - 1);
    const double span_s = std::max(run.t_s[k1] - run.t_s[k], 1e-9);
    const T u = (t - run.t_s[k]) / span_s;
    *px_m = xs_m[k] + u * (xs_m[k1] - xs_m[k]);
    *py_m = ys_m[k] + u * (ys_m[k1] - ys_m[k]);
    *ph_rad = headings_rad[k] + u * (headings_rad[k1] - headings_rad[k]);
  }
  TagOffset(effect_values, *ph_rad, px_m, py_m);
  TrackerYaw(effect_values, ph_rad);
  LensDistortion(effect_values, constants.camera, px_m, py_m);
}

// One run's frames against the model, whitened and robust-weighted: one cost
// block, since the frames share the run's dead reckoning.
struct RunResidual {
  const RunData* run;
  const ModelConstants* constants;

  template <typename T>
  bool operator()(const T* base_scales, const T* start, const T* effect_values,
                  T* residuals) const {
    std::vector<T> xs_m, ys_m, headings_rad;
    DeadReckon(*run, *constants, base_scales, start, effect_values, &xs_m, &ys_m, &headings_rad);
    const int m = run->residuals_per_frame;
    for (size_t j = 0; j < run->frame_t_s.size(); ++j) {
      T px_m, py_m, ph_rad;
      PredictFrame(*run, *constants, xs_m, ys_m, headings_rad, effect_values, run->frame_t_s[j],
                   RowOffsetOf(*run, j), &px_m, &py_m, &ph_rad);
      const double w = run->sqrt_weight[j];
      residuals[m * j + 0] = w * (px_m - run->measured_x_m[j]) / run->sigma_position_m[j];
      residuals[m * j + 1] = w * (py_m - run->measured_y_m[j]) / run->sigma_position_m[j];
      if (m == 3) {
        T dh_rad = ph_rad - run->measured_heading_rad[j];
        dh_rad -= 2.0 * M_PI * std::round(Scalar(dh_rad) / (2.0 * M_PI));
        residuals[m * j + 2] = w * dh_rad / run->sigma_heading_rad[j];
      }
    }
    return true;
  }
};

// The solve's cost of a run. RunResidual's Jets carry a derivative for each
// of its 24 parameters (base, start pose, the 18 of the effect block) whatever
// is fitted, and a fit of the base model, or of the base and one candidate,
// spent most of its time differentiating effect parameters held at zero. Here
// the effect block is cut to `slots`, the (at most kSolveSlots) effect
// parameters being fitted; the others enter as the constants they are held
// at. A Jet's derivatives are computed each on its own, so the residuals and
// the fitted parameters' columns are RunResidual's to the bit, and so is the
// solve. Without a fitted effect parameter the block is left out.
inline constexpr int kSolveSlots = 4;

struct SolveResidual {
  RunResidual model;
  const std::array<double, kEffectParams>* held;  // every effect parameter's value
  std::array<int, kSolveSlots> slots;             // its EffectParams index, or -1: unused

  template <typename T>
  bool operator()(const T* base_scales, const T* start, const T* slot_values, T* residuals) const {
    std::array<T, kEffectParams> effect_values;
    for (int i = 0; i < kEffectParams; ++i) effect_values[i] = T((*held)[i]);
    for (int k = 0; k < kSolveSlots; ++k)
      if (slots[k] >= 0) effect_values[slots[k]] = slot_values[k];
    return model(base_scales, start, effect_values.data(), residuals);
  }
  template <typename T>
  bool operator()(const T* base_scales, const T* start, T* residuals) const {
    std::array<T, kEffectParams> effect_values;
    for (int i = 0; i < kEffectParams; ++i) effect_values[i] = T((*held)[i]);
    return model(base_scales, start, effect_values.data(), residuals);
  }
};
template <int... kBlockSizes>
using SolveCost = ceres::AutoDiffCostFunction<SolveResidual, ceres::DYNAMIC, kBlockSizes...>;
using BaseSolveCost = SolveCost<kBaseParams, kStartPoseParams>;
using SlotsSolveCost = SolveCost<kBaseParams, kStartPoseParams, kSolveSlots>;

// A weak prior on the base ratios at 1 (the nominal parameters): it keeps
// the solver in a physical region along directions the data leave free, and
// weighs ~1e-7 of the data on a determined parameter. It is left out of the
// identifiability analysis and the covariance.
struct BasePrior {
  double sigma = 0.2;
  template <typename T>
  bool operator()(const T* base_scales, T* residuals) const {
    for (int i = 0; i < kBaseParams; ++i) residuals[i] = (base_scales[i] - 1.0) / sigma;
    return true;
  }
};

// The parameter blocks in the order of the cost blocks.
std::array<const double*, 3> BlocksOf(const FitParameters& params, size_t run_index) {
  return {params.base_scales.data(), params.start_poses[run_index].data(),
          params.effects.values.data()};
}

}  // namespace

MotionKind StepKind(std::int64_t left_step_ticks, std::int64_t right_step_ticks) {
  if (left_step_ticks == 0 && right_step_ticks == 0) return MotionKind::kRest;
  if ((left_step_ticks > 0 && right_step_ticks < 0) || (left_step_ticks < 0 && right_step_ticks > 0))
    return MotionKind::kTurn;
  return MotionKind::kStraight;
}

RunData ExtractTelemetry(const MeasuredRun& run, int index, int* left_direction,
                         int* right_direction) {
  RunData rd;
  rd.run = index;
  rd.left_direction0 = *left_direction;
  rd.right_direction0 = *right_direction;
  const std::vector<TelemetryRecord>& telemetry = run.telemetry;
  if (!telemetry.empty()) {
    rd.left_count0 = telemetry.front().left_ticks;
    rd.right_count0 = telemetry.front().right_ticks;
  }
  for (size_t k = 0; k < telemetry.size(); ++k) {
    rd.t_s.push_back(telemetry[k].t_s);
    const std::int64_t left_ticks = k == 0 ? 0 : telemetry[k].left_ticks - telemetry[k - 1].left_ticks;
    const std::int64_t right_ticks =
        k == 0 ? 0 : telemetry[k].right_ticks - telemetry[k - 1].right_ticks;
    rd.left_step_ticks.push_back(left_ticks);
    rd.right_step_ticks.push_back(right_ticks);
    rd.kind.push_back(StepKind(left_ticks, right_ticks));
    if (left_ticks != 0) *left_direction = left_ticks > 0 ? 1 : -1;
    if (right_ticks != 0) *right_direction = right_ticks > 0 ? 1 : -1;
  }
  return rd;
}

// arc_scale's curvature of each step: the believed wheel travels summed over
// the same-direction steps within kArcWindowSteps either side (one step's
// ticks differ by a tick or two on a straight: ~0.2 /m at 50 Hz and 50 mm/s),
// kappa = (right - left) / (track (right + left) / 2).
void MarkArcs(const ModelConstants& constants, RunData* rd) {
  const size_t n = rd->t_s.size();
  rd->curvature_per_m.assign(n, 0.0);
  // Both wheels moving the same way: not at rest, not a turn in place, and
  // not the first or last step of one (a single wheel still counting).
  auto forward_like = [&](size_t k) {
    return (rd->left_step_ticks[k] > 0 && rd->right_step_ticks[k] > 0) ||
           (rd->left_step_ticks[k] < 0 && rd->right_step_ticks[k] < 0);
  };
  for (size_t k = 1; k < n; ++k) {
    if (!forward_like(k)) continue;
    double left_m = 0.0, right_m = 0.0;
    const size_t from = k > static_cast<size_t>(kArcWindowSteps) ? k - kArcWindowSteps : 1;
    const size_t to = std::min(n - 1, k + kArcWindowSteps);
    for (size_t j = from; j <= to; ++j) {
      // Same way as step k: a direct reversal would cancel the travel.
      if (!forward_like(j) || (rd->left_step_ticks[j] > 0) != (rd->left_step_ticks[k] > 0))
        continue;
      left_m += rd->left_step_ticks[j] * constants.left_m_per_tick;
      right_m += rd->right_step_ticks[j] * constants.right_m_per_tick;
    }
    const double ds_m = 0.5 * (left_m + right_m);
    if (std::abs(ds_m) < 1e-9) continue;
    // A backward arc turns the other way for the same wheel difference; the
    // curvature's sign is only reported, the effect uses |kappa|.
    const double kappa_per_m = (right_m - left_m) / (constants.track_m * ds_m);
    if (std::abs(kappa_per_m) >= kArcMinCurvature) rd->curvature_per_m[k] = kappa_per_m;
  }
}

ModelConstants ConstantsOf(const WheelParams& believed, const std::optional<FloorCamera>& camera) {
  ModelConstants c;
  c.left_m_per_tick = believed.LeftMetresPerTick();
  c.right_m_per_tick = believed.RightMetresPerTick();
  c.track_m = believed.track_m;
  c.ticks_per_rev = believed.ticks_per_rev;
  c.camera = camera;
  return c;
}

std::string ValidateFitInputs(const MeasuredSession& session, const TrajectoryFitOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) return "options: " + why;
  if (!session.believed.IsValid(&why)) return "believed parameters: " + why;
  const bool lens_on = std::find(options.effects.begin(), options.effects.end(),
                                 Effect::kLensDistortion) != options.effects.end();
  if (lens_on && (!session.camera || !session.camera->IsValid()))
    return "lens_distortion needs the camera's geometry over the tag plane (session.camera)";
  return "";
}

ExtractedRuns ExtractRuns(const MeasuredSession& session, const TrajectoryFitOptions& options,
                          const ModelConstants& constants) {
  ExtractedRuns out;
  out.run_used.assign(session.runs.size(), false);
  int left_direction = 1, right_direction = 1;
  for (size_t i = 0; i < session.runs.size(); ++i) {
    const MeasuredRun& mr = session.runs[i];
    RunData rd = ExtractTelemetry(mr, static_cast<int>(i), &left_direction, &right_direction);
    MarkArcs(constants, &rd);
    rd.residuals_per_frame = options.use_heading ? 3 : 2;
    if (rd.t_s.size() < 2) continue;
    for (const CameraRecord& f : mr.camera) {
      if (!f.valid) continue;
      rd.frame_t_s.push_back(f.t_s);
      rd.frame_row_offset.push_back(EffectParams::RowOffset(f.image_row_fraction));
      rd.measured_x_m.push_back(f.T_world_robot.x());
      rd.measured_y_m.push_back(f.T_world_robot.y());
      rd.measured_heading_rad.push_back(f.T_world_robot.heading());
      rd.sigma_position_m.push_back(f.sigma_position_m > 0.0 ? f.sigma_position_m
                                                             : options.default_position_sigma_m);
      rd.sigma_heading_rad.push_back(f.sigma_heading_rad > 0.0 ? f.sigma_heading_rad
                                                               : options.default_heading_sigma_rad);
    }
    if (rd.n_frames() < options.min_frames_per_run) continue;
    rd.sqrt_weight.assign(rd.frame_t_s.size(), 1.0);
    out.run_used[i] = true;
    out.runs.push_back(std::move(rd));
  }
  return out;
}

FitParameters InitialParameters(const std::vector<RunData>& runs,
                                const std::vector<bool>& run_used,
                                const TrajectoryFitOptions& options,
                                const TrajectoryFitResult* warm_start) {
  FitParameters params;
  params.start_poses.resize(runs.size());
  for (size_t r = 0; r < runs.size(); ++r)
    params.start_poses[r] = {runs[r].measured_x_m[0], runs[r].measured_y_m[0],
                             runs[r].measured_heading_rad[0]};
  for (Effect e : options.effects)
    for (int idx : EffectParamIndices(e)) params.effect_enabled[idx] = true;
  if (warm_start && warm_start->ok() && warm_start->run_used == run_used) {
    params.base_scales = {warm_start->scales.r_left, warm_start->scales.r_right,
                          warm_start->scales.Eb};
    for (int i = 0; i < kEffectParams; ++i)
      if (params.effect_enabled[i]) params.effects.values[i] = warm_start->effects.values[i];
    for (size_t r = 0; r < runs.size(); ++r) {
      const Pose2& p = warm_start->start_poses[runs[r].run];
      params.start_poses[r] = {p.x(), p.y(), p.heading()};
    }
  }
  return params;
}

TrajectoryProblem::TrajectoryProblem() = default;
TrajectoryProblem::TrajectoryProblem(TrajectoryProblem&&) noexcept = default;
TrajectoryProblem::~TrajectoryProblem() = default;

TrajectoryProblem BuildProblem(const std::vector<RunData>& runs, const ModelConstants& constants,
                               const TrajectoryFitOptions& options) {
  TrajectoryProblem problem;
  problem.constants = &constants;
  for (const RunData& rd : runs) {
    auto* functor = new RunResidual{&rd, &constants};
    problem.run_costs.emplace_back(
        new ceres::AutoDiffCostFunction<RunResidual, ceres::DYNAMIC, kBaseParams,
                                        kStartPoseParams, kEffectParams>(functor,
                                                                         rd.n_residuals()));
  }
  problem.base_prior.reset(new ceres::AutoDiffCostFunction<BasePrior, kBaseParams, kBaseParams>(
      new BasePrior{options.base_prior_sigma}));
  return problem;
}

std::vector<double> RunResiduals(const TrajectoryProblem& problem, const FitParameters& params,
                                 size_t run_index) {
  const ceres::CostFunction& cost = *problem.run_costs[run_index];
  std::vector<double> residuals(cost.num_residuals());
  const std::array<const double*, 3> blocks = BlocksOf(params, run_index);
  cost.Evaluate(blocks.data(), residuals.data(), nullptr);
  return residuals;
}

void ReweightHuber(const TrajectoryProblem& problem, const FitParameters& params,
                   double huber_threshold, std::vector<RunData>* runs) {
  std::vector<std::vector<double>> frame_norms(runs->size());
  std::vector<double> components;
  for (size_t r = 0; r < runs->size(); ++r) {
    const RunData& rd = (*runs)[r];
    const int m = rd.residuals_per_frame;
    const std::vector<double> residuals = RunResiduals(problem, params, r);
    for (size_t j = 0; j < rd.frame_t_s.size(); ++j) {
      double sq = 0.0;
      for (int c = 0; c < m; ++c) {
        const double e = residuals[m * j + c] / rd.sqrt_weight[j];
        sq += e * e;
        components.push_back(std::abs(e));
      }
      frame_norms[r].push_back(std::sqrt(sq));
    }
  }
  const double robust_sigma = std::max(1.4826 * Median(components), 1e-12);
  for (size_t r = 0; r < runs->size(); ++r) {
    RunData& rd = (*runs)[r];
    const double threshold =
        huber_threshold * robust_sigma * std::sqrt(double(rd.residuals_per_frame));
    for (size_t j = 0; j < rd.frame_t_s.size(); ++j)
      rd.sqrt_weight[j] =
          frame_norms[r][j] <= threshold ? 1.0 : std::sqrt(threshold / frame_norms[r][j]);
  }
}

SolveOutcome SolveWithIrls(const TrajectoryProblem& problem, const TrajectoryFitOptions& options,
                           std::vector<RunData>* runs, FitParameters* params) {
  SolveOutcome outcome;
  ceres::Solver::Summary summary;
  // The fitted effect parameters, in slots when they fit (SolveResidual);
  // else the whole effect block with the others held (problem.run_costs).
  std::vector<int> fitted, held_at_zero;
  for (int i = 0; i < kEffectParams; ++i) {
    std::vector<int>& list = params->effect_enabled[i] ? fitted : held_at_zero;
    list.push_back(i);
  }
  const bool in_slots = static_cast<int>(fitted.size()) <= kSolveSlots;
  std::array<double, kSolveSlots> slot_values{};
  std::vector<int> unused_slots;
  std::vector<std::unique_ptr<ceres::CostFunction>> solve_costs;
  if (in_slots) {
    std::array<int, kSolveSlots> slots;
    slots.fill(-1);
    for (int k = 0; k < kSolveSlots; ++k) {
      if (k >= static_cast<int>(fitted.size())) {
        unused_slots.push_back(k);
        continue;
      }
      slots[k] = fitted[k];
      slot_values[k] = params->effects.values[fitted[k]];
    }
    for (const RunData& rd : *runs) {
      auto* functor = new SolveResidual{{&rd, problem.constants}, &params->effects.values, slots};
      const int rows = rd.n_residuals();
      if (fitted.empty())
        solve_costs.emplace_back(new BaseSolveCost(functor, rows));
      else
        solve_costs.emplace_back(new SlotsSolveCost(functor, rows));
    }
  }
  double* const slot_block = slot_values.data();
  for (int round = 0; round < options.irls_rounds; ++round) {
    ceres::Problem::Options problem_options;
    problem_options.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    problem_options.manifold_ownership = ceres::TAKE_OWNERSHIP;
    ceres::Problem ceres_problem(problem_options);
    for (size_t r = 0; r < runs->size(); ++r) {
      double* base = params->base_scales.data();
      double* start = params->start_poses[r].data();
      double* effects = params->effects.values.data();
      if (!in_slots)
        ceres_problem.AddResidualBlock(problem.run_costs[r].get(), nullptr, base, start, effects);
      else if (fitted.empty())
        ceres_problem.AddResidualBlock(solve_costs[r].get(), nullptr, base, start);
      else
        ceres_problem.AddResidualBlock(solve_costs[r].get(), nullptr, base, start, slot_block);
    }
    if (options.base_prior_sigma > 0.0)
      ceres_problem.AddResidualBlock(problem.base_prior.get(), nullptr,
                                     params->base_scales.data());
    if (!in_slots && !held_at_zero.empty())
      ceres_problem.SetManifold(params->effects.values.data(),
                                new ceres::SubsetManifold(kEffectParams, held_at_zero));
    if (in_slots && !fitted.empty() && !unused_slots.empty())
      ceres_problem.SetManifold(slot_block, new ceres::SubsetManifold(kSolveSlots, unused_slots));
    ceres::Solver::Options solver_options;
    solver_options.linear_solver_type = ceres::DENSE_SCHUR;
    ApplyTo(options.solver, &solver_options);
    ceres::Solve(solver_options, &ceres_problem, &summary);
    if (in_slots)
      for (size_t k = 0; k < fitted.size(); ++k) params->effects.values[fitted[k]] = slot_values[k];
    if (summary.termination_type == ceres::FAILURE || !std::isfinite(summary.final_cost)) {
      outcome.failed = true;
      outcome.message = summary.message;
      return outcome;
    }
    if (options.huber_threshold <= 0.0 || round + 1 == options.irls_rounds) break;
    // Reweight: Huber on each frame's whitened error norm, at a threshold
    // in robust standard deviations of the current errors.
    ReweightHuber(problem, *params, options.huber_threshold, runs);
  }
  outcome.solution_usable = summary.IsSolutionUsable();
  outcome.message = summary.message;
  return outcome;
}

int Linearization::n_residuals() const {
  int n = 0;
  for (const RunLinearization& run : runs) n += static_cast<int>(run.residuals.size());
  return n;
}

double Linearization::weighted_sse() const {
  // One reduction over all the residuals, not a sum of the runs' sums: a BIC
  // score is a difference of two nearly equal costs times thousands of
  // frames, and the order of the additions shows in its last digits.
  Eigen::VectorXd all(n_residuals());
  int row = 0;
  for (const RunLinearization& run : runs) {
    all.segment(row, run.residuals.size()) = run.residuals;
    row += static_cast<int>(run.residuals.size());
  }
  return all.squaredNorm();
}

Linearization Linearize(const TrajectoryProblem& problem, const std::vector<RunData>& runs,
                        const FitParameters& params) {
  Linearization lin;
  lin.runs.resize(runs.size());
  for (size_t r = 0; r < runs.size(); ++r) {
    const RunData& rd = runs[r];
    const int m = rd.residuals_per_frame;
    const int rows = rd.n_residuals();
    RunLinearization& out = lin.runs[r];
    out.residuals.resize(rows);
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> J_base(rows, kBaseParams),
        J_start(rows, kStartPoseParams), J_effects(rows, kEffectParams);
    const std::array<const double*, 3> blocks = BlocksOf(params, r);
    double* jacobians[] = {J_base.data(), J_start.data(), J_effects.data()};
    problem.run_costs[r]->Evaluate(blocks.data(), out.residuals.data(), jacobians);
    out.J_global.resize(rows, kGlobalParams);
    out.J_global << J_base, J_effects;
    out.J_start = J_start;
    // Lag-one autocorrelation per residual component along the run.
    const Eigen::VectorXd& res = out.residuals;
    for (int c = 0; c < m; ++c)
      for (size_t j = 0; j + 1 < rd.frame_t_s.size(); ++j) {
        lin.lag1_numerator += res[m * j + c] * res[m * (j + 1) + c];
        lin.lag1_denominator += res[m * j + c] * res[m * j + c];
      }
  }
  return lin;
}

DeadReckonedPoses DeadReckonRun(const RunData& run, const ModelConstants& constants,
                                const FitParameters& params, size_t run_index) {
  DeadReckonedPoses poses;
  DeadReckon(run, constants, params.base_scales.data(), params.start_poses[run_index].data(),
             params.effects.values.data(), &poses.x_m, &poses.y_m, &poses.heading_rad);
  return poses;
}

FrameReport ReportFrames(const std::vector<RunData>& runs, const ModelConstants& constants,
                         const FitParameters& params) {
  FrameReport report;
  double sum_sq_gap_m2 = 0.0, sum_sq_noise_m2 = 0.0;
  for (size_t r = 0; r < runs.size(); ++r) {
    const RunData& rd = runs[r];
    const DeadReckonedPoses poses = DeadReckonRun(rd, constants, params, r);
    for (size_t j = 0; j < rd.frame_t_s.size(); ++j) {
      double px_m, py_m, ph_rad;
      PredictFrame(rd, constants, poses.x_m, poses.y_m, poses.heading_rad,
                   params.effects.values.data(), rd.frame_t_s[j], RowOffsetOf(rd, j), &px_m,
                   &py_m, &ph_rad);
      FrameResidual fr;
      fr.run = rd.run;
      fr.t_s = rd.frame_t_s[j];
      const double telemetry_t_s = FrameTelemetryTime(rd, j, params.effects);
      const size_t k = std::min<size_t>(
          std::upper_bound(rd.t_s.begin(), rd.t_s.end(), telemetry_t_s) - rd.t_s.begin(),
          rd.t_s.size() - 1);
      fr.motion = rd.kind[k];
      fr.measured_m = {rd.measured_x_m[j], rd.measured_y_m[j]};
      fr.error_m = {px_m - rd.measured_x_m[j], py_m - rd.measured_y_m[j]};
      fr.heading_error_rad = WrapAngle(ph_rad - rd.measured_heading_rad[j]);
      fr.measured_heading_rad = rd.measured_heading_rad[j];
      fr.weight = rd.sqrt_weight[j] * rd.sqrt_weight[j];
      sum_sq_gap_m2 += fr.error_m.squaredNorm();
      sum_sq_noise_m2 += 2.0 * rd.sigma_position_m[j] * rd.sigma_position_m[j];
      report.residuals.push_back(fr);
    }
  }
  const double n_frames = static_cast<int>(report.residuals.size());
  report.gap_m = std::sqrt(sum_sq_gap_m2 / n_frames);
  report.noise_floor_m = std::sqrt(sum_sq_noise_m2 / n_frames);
  return report;
}

FittedColumns SelectFittedColumns(const MeasuredSession& session,
                                  const std::vector<RunData>& runs,
                                  const TrajectoryFitOptions& options) {
  FittedColumns columns;
  columns.names = {"r_left", "r_right", "Eb"};
  for (int i = 0; i < kBaseParams; ++i) columns.index.push_back(i);
  for (Effect e : options.effects) {
    const std::vector<int> idx = EffectParamIndices(e);
    const std::vector<std::string> names = EffectParamNames(e);
    for (size_t k = 0; k < idx.size(); ++k) {
      columns.index.push_back(kBaseParams + idx[k]);
      columns.names.push_back(std::string(ToString(e)) + "." + names[k]);
    }
  }
  columns.n_global = static_cast<int>(columns.index.size());
  for (size_t r = 0; r < runs.size(); ++r)
    for (int c = 0; c < kStartPoseParams; ++c) {
      columns.index.push_back(kGlobalParams + kStartPoseParams * static_cast<int>(r) + c);
      columns.names.push_back(session.runs[runs[r].run].name + ".start_" + "xyh"[c]);
    }
  return columns;
}

Eigen::MatrixXd RunFittedJacobian(const RunLinearization& run, const FittedColumns& columns) {
  const int q = columns.n_global;
  Eigen::MatrixXd J(run.J_global.rows(), q + kStartPoseParams);
  for (int c = 0; c < q; ++c) J.col(c) = run.J_global.col(columns.index[c]);
  J.rightCols<kStartPoseParams>() = run.J_start;
  return J;
}

namespace {

// The square upper triangle R of a Householder QR (Q never formed; rows
// beyond a short matrix's height zero).
Eigen::MatrixXd UpperR(const Eigen::MatrixXd& A) {
  const Eigen::HouseholderQR<Eigen::MatrixXd> qr(A);
  const int p = static_cast<int>(A.cols());
  const int k = std::min<int>(p, static_cast<int>(A.rows()));
  Eigen::MatrixXd R = Eigen::MatrixXd::Zero(p, p);
  R.topRows(k) = qr.matrixQR().topRows(k).triangularView<Eigen::Upper>();
  return R;
}

// From R with R^T R = J^T J of the column-normalised Jacobian (any such R:
// its singular values and V are J's). The SVD of the small R rather than of
// the tall J, whose Jacobi SVD with an explicit Q took a quarter of
// explain's time on real sessions.
Identifiability IdentifiabilityOfR(const Eigen::MatrixXd& R, Eigen::VectorXd column_norms,
                                   double rank_tolerance) {
  const int p = static_cast<int>(R.cols());
  Identifiability id;
  id.column_norms = std::move(column_norms);
  const Eigen::BDCSVD<Eigen::MatrixXd> svd(R, Eigen::ComputeThinV);
  id.singular_values = svd.singularValues();
  id.V = svd.matrixV();
  const Eigen::VectorXd& s = id.singular_values;
  id.condition_number = s[p - 1] > 0.0 ? s[0] / s[p - 1] : INFINITY;
  id.determined.assign(p, false);
  for (int i = 0; i < p; ++i) {
    if (s[i] > rank_tolerance * s[0]) {
      id.determined[i] = true;
      continue;
    }
    // A singular vector's sign is the SVD's choice: its largest component
    // positive, so that its description does not depend on how R was formed.
    Eigen::VectorXd v = id.V.col(i);
    Eigen::Index largest = 0;
    v.cwiseAbs().maxCoeff(&largest);
    if (v[largest] < 0.0) v = -v;
    id.null_vectors.push_back(v);
  }
  return id;
}

Eigen::VectorXd NonZero(Eigen::VectorXd norms) {
  for (Eigen::Index c = 0; c < norms.size(); ++c) norms[c] = norms[c] > 0.0 ? norms[c] : 1.0;
  return norms;
}

}  // namespace

Identifiability AnalyseIdentifiability(const Eigen::MatrixXd& J_fitted, double rank_tolerance) {
  const Eigen::VectorXd norms = NonZero(J_fitted.colwise().norm().transpose());
  return IdentifiabilityOfR(UpperR(J_fitted * norms.cwiseInverse().asDiagonal()), norms,
                            rank_tolerance);
}

Identifiability AnalyseIdentifiability(const Linearization& lin, const FittedColumns& columns,
                                       double rank_tolerance) {
  const int q = columns.n_global;
  const int p = static_cast<int>(columns.index.size());
  const int n_runs = static_cast<int>(lin.runs.size());
  Eigen::VectorXd norms = Eigen::VectorXd::Zero(p);
  for (int r = 0; r < n_runs; ++r) {
    for (int c = 0; c < q; ++c) norms[c] += lin.runs[r].J_global.col(columns.index[c]).squaredNorm();
    norms.segment<kStartPoseParams>(q + kStartPoseParams * r) =
        lin.runs[r].J_start.colwise().squaredNorm().transpose();
  }
  norms = NonZero(norms.cwiseSqrt());
  // R of the normalised J, in the fitted columns' order, run by run: the QR
  // of a run's [start pose | globals] leaves 3 rows of R on its start pose
  // (and the globals) and q rows on the globals alone, which a last QR over
  // the runs merges. p x p; no N x p matrix is formed.
  Eigen::MatrixXd R = Eigen::MatrixXd::Zero(p, p);
  Eigen::MatrixXd global_rows(q * n_runs, q);
  for (int r = 0; r < n_runs; ++r) {
    const int start = q + kStartPoseParams * r;
    const Eigen::MatrixXd J = RunFittedJacobian(lin.runs[r], columns);
    Eigen::MatrixXd A(J.rows(), kStartPoseParams + q);
    A.leftCols<kStartPoseParams>() =
        J.rightCols<kStartPoseParams>() *
        norms.segment<kStartPoseParams>(start).cwiseInverse().asDiagonal();
    A.rightCols(q) = J.leftCols(q) * norms.head(q).cwiseInverse().asDiagonal();
    const Eigen::MatrixXd Rr = UpperR(A);
    R.block<kStartPoseParams, kStartPoseParams>(kStartPoseParams * r, start) =
        Rr.topLeftCorner<kStartPoseParams, kStartPoseParams>();
    R.block(kStartPoseParams * r, 0, kStartPoseParams, q) = Rr.topRightCorner(kStartPoseParams, q);
    global_rows.middleRows(q * r, q) = Rr.bottomRightCorner(q, q);
  }
  R.bottomLeftCorner(q, q) = UpperR(global_rows);
  return IdentifiabilityOfR(R, norms, rank_tolerance);
}

ReducedGlobals ReduceGlobals(const Linearization& lin) {
  const int n_runs = static_cast<int>(lin.runs.size());
  ReducedGlobals out;
  out.column_norms = Eigen::VectorXd::Zero(kGlobalParams);
  Eigen::MatrixXd global_rows(kGlobalParams * n_runs, kGlobalParams);
  for (int r = 0; r < n_runs; ++r) {
    const RunLinearization& run = lin.runs[r];
    out.column_norms += run.J_global.colwise().squaredNorm().transpose();
    Eigen::MatrixXd A(run.J_global.rows(), kStartPoseParams + kGlobalParams);
    A << run.J_start, run.J_global;
    global_rows.middleRows(kGlobalParams * r, kGlobalParams) =
        UpperR(A).bottomRightCorner<kGlobalParams, kGlobalParams>();
  }
  out.column_norms = out.column_norms.cwiseSqrt();
  out.R = UpperR(global_rows);
  return out;
}

ParameterCovariance CameraNoiseCovariance(const Identifiability& id, int n_residuals,
                                          double weighted_sse, const Linearization& lin) {
  const int p = static_cast<int>(id.column_norms.size());
  const Eigen::VectorXd& s = id.singular_values;
  // Over the determined directions: cov = V S^-2 V^T (normalised).
  Eigen::VectorXd inverse_s = Eigen::VectorXd::Zero(p);
  for (int i = 0; i < p; ++i)
    if (id.determined[i]) inverse_s[i] = 1.0 / s[i];
  const Eigen::MatrixXd V_scaled = id.V * inverse_s.asDiagonal();
  const Eigen::MatrixXd cov_normalised = V_scaled * V_scaled.transpose();
  ParameterCovariance out;
  const int dof = std::max(1, n_residuals - (p - static_cast<int>(id.null_vectors.size())));
  out.lag1_autocorrelation =
      lin.lag1_denominator > 0.0
          ? std::clamp(lin.lag1_numerator / lin.lag1_denominator, 0.0, 0.95)
          : 0.0;
  // Camera noise: the stated sigmas, scaled up when the residuals say they
  // are larger (never down: a fit is not more certain than its sensor).
  out.variance_factor = std::max(1.0, weighted_sse / dof);
  out.normal_inverse = id.column_norms.cwiseInverse().asDiagonal() * cov_normalised *
                       id.column_norms.cwiseInverse().asDiagonal();
  out.covariance = out.normal_inverse * out.variance_factor;
  return out;
}

std::vector<Eigen::MatrixXd> GlobalPseudoInverseByRun(const Linearization& lin,
                                                      const FittedColumns& columns,
                                                      const Eigen::MatrixXd& normal_inverse) {
  // pinv(J) = normal_inverse J^T; run r's rows of J are non-zero only in the
  // global columns and its own start pose.
  const int q = columns.n_global;
  std::vector<Eigen::MatrixXd> out(lin.runs.size());
  for (size_t r = 0; r < lin.runs.size(); ++r) {
    Eigen::MatrixXd M(q, q + kStartPoseParams);
    M.leftCols(q) = normal_inverse.topLeftCorner(q, q);
    M.rightCols<kStartPoseParams>() =
        normal_inverse.block(0, q + kStartPoseParams * static_cast<int>(r), q, kStartPoseParams);
    out[r] = M * RunFittedJacobian(lin.runs[r], columns).transpose();
  }
  return out;
}

void AddWheelNoiseCovariance(const std::vector<RunData>& runs, const ModelConstants& constants,
                             const FitParameters& params, double wheel_sigma_m_per_sqrt_m,
                             ParameterCovariance* covariance) {
  // Suffix sums over the frames make this O(steps * q) per run.
  const int q = static_cast<int>(covariance->pinv_by_run.front().rows());
  const double q_m = wheel_sigma_m_per_sqrt_m * wheel_sigma_m_per_sqrt_m;  // variance per metre
  const double true_track_m = params.base_scales[2] * constants.track_m;
  Eigen::MatrixXd sandwich = Eigen::MatrixXd::Zero(q, q);
  for (size_t r = 0; r < runs.size(); ++r) {
    const RunData& rd = runs[r];
    const Eigen::MatrixXd& pinv = covariance->pinv_by_run[r];
    const int m = rd.residuals_per_frame;
    const DeadReckonedPoses poses = DeadReckonRun(rd, constants, params, r);
    // Over the frames after step k: the sums of pinv's columns for x and y
    // (weighted), for the heading, and the x columns times the frames' y
    // and the y columns times their x (for rotations about a point).
    Eigen::VectorXd sum_x = Eigen::VectorXd::Zero(q), sum_y = sum_x, sum_h = sum_x,
                    sum_x_times_y = sum_x, sum_y_times_x = sum_x;
    int j = rd.n_frames() - 1;
    for (int k = static_cast<int>(rd.t_s.size()) - 1; k >= 1; --k) {
      // Frames at or after the end of step k feel its noise.
      for (; j >= 0 && FrameTelemetryTime(rd, j, params.effects) >= rd.t_s[k]; --j) {
        const double g = rd.sqrt_weight[j] / rd.sigma_position_m[j];
        const Eigen::VectorXd ax = pinv.col(m * j) * g;
        const Eigen::VectorXd ay = pinv.col(m * j + 1) * g;
        sum_x += ax;
        sum_y += ay;
        sum_x_times_y += ax * rd.measured_y_m[j];
        sum_y_times_x += ay * rd.measured_x_m[j];
        if (m == 3) sum_h += pinv.col(m * j + 2) * (rd.sqrt_weight[j] / rd.sigma_heading_rad[j]);
      }
      const double left_m =
          std::abs(rd.left_step_ticks[k] * constants.left_m_per_tick * params.base_scales[0]);
      const double right_m =
          std::abs(rd.right_step_ticks[k] * constants.right_m_per_tick * params.base_scales[1]);
      if (left_m == 0.0 && right_m == 0.0) continue;
      // The estimate's sensitivity to a translation (x, y) and to a rotation
      // about the pose at k of everything after step k.
      const Eigen::VectorXd g_x = sum_x, g_y = sum_y;
      const Eigen::VectorXd g_rotation = sum_h - (sum_x_times_y - poses.y_m[k] * sum_x) +
                                         (sum_y_times_x - poses.x_m[k] * sum_y);
      const double half_cos = std::cos(poses.heading_rad[k]) / 2.0,
                   half_sin = std::sin(poses.heading_rad[k]) / 2.0;
      // A travel error of one wheel: half of it along the heading, and a
      // turn of -/+ 1/track.
      const Eigen::VectorXd g_left = g_x * half_cos + g_y * half_sin - g_rotation / true_track_m;
      const Eigen::VectorXd g_right = g_x * half_cos + g_y * half_sin + g_rotation / true_track_m;
      sandwich += q_m * left_m * g_left * g_left.transpose() +
                  q_m * right_m * g_right * g_right.transpose();
    }
  }
  covariance->covariance.topLeftCorner(q, q) += sandwich;
}

void AddCameraScaleCovariance(const std::vector<RunData>& runs, double camera_scale_sigma,
                              ParameterCovariance* covariance) {
  const int q = static_cast<int>(covariance->pinv_by_run.front().rows());
  Eigen::VectorXd v = Eigen::VectorXd::Zero(q);
  for (size_t r = 0; r < runs.size(); ++r) {
    const RunData& rd = runs[r];
    const int m = rd.residuals_per_frame;
    Eigen::VectorXd residuals_per_unit_scale = Eigen::VectorXd::Zero(rd.n_residuals());
    for (size_t j = 0; j < rd.frame_t_s.size(); ++j) {
      const double g = rd.sqrt_weight[j] / rd.sigma_position_m[j];
      residuals_per_unit_scale[m * j] = rd.measured_x_m[j] * g;
      residuals_per_unit_scale[m * j + 1] = rd.measured_y_m[j] * g;
    }
    v += covariance->pinv_by_run[r] * residuals_per_unit_scale;
  }
  covariance->covariance.topLeftCorner(q, q) +=
      camera_scale_sigma * camera_scale_sigma * v * v.transpose();
}

ParameterCovariance ComputeCovariance(const MeasuredSession& session,
                                      const std::vector<RunData>& runs,
                                      const ModelConstants& constants,
                                      const FitParameters& params,
                                      const TrajectoryFitOptions& options,
                                      const Identifiability& identifiability,
                                      const FittedColumns& columns,
                                      const Linearization& linearization) {
  ParameterCovariance cov = CameraNoiseCovariance(
      identifiability, linearization.n_residuals(), linearization.weighted_sse(), linearization);
  const bool wheels = options.wheel_sigma_m_per_sqrt_m > 0.0;
  const bool scale = session.camera_scale_sigma > 0.0;
  if (!wheels && !scale) return cov;
  cov.pinv_by_run = GlobalPseudoInverseByRun(linearization, columns, cov.normal_inverse);
  if (wheels) AddWheelNoiseCovariance(runs, constants, params, options.wheel_sigma_m_per_sqrt_m, &cov);
  if (scale) AddCameraScaleCovariance(runs, session.camera_scale_sigma, &cov);
  return cov;
}

namespace {

// One draw of the wheels' random walk over a run: the whitened residual
// change of each frame (displacement of a later point p: shift + rotation *
// (-p.y, p.x)).
Eigen::VectorXd WheelNoiseDraw(const RunData& rd, const ModelConstants& constants,
                               const FitParameters& params, const DeadReckonedPoses& poses,
                               double sigma_w, double true_track_m,
                               std::normal_distribution<double>& normal, std::mt19937& rng) {
  const int m = rd.residuals_per_frame;
  Eigen::VectorXd delta = Eigen::VectorXd::Zero(rd.n_residuals());
  double shift_x_m = 0.0, shift_y_m = 0.0, rotation_rad = 0.0;
  size_t j = 0;
  auto assign_until = [&](double t_s) {
    for (; j < rd.frame_t_s.size() && FrameTelemetryTime(rd, j, params.effects) < t_s; ++j) {
      const double g = rd.sqrt_weight[j] / rd.sigma_position_m[j];
      delta[m * j] = (shift_x_m - rotation_rad * rd.measured_y_m[j]) * g;
      delta[m * j + 1] = (shift_y_m + rotation_rad * rd.measured_x_m[j]) * g;
      if (m == 3) delta[m * j + 2] = rotation_rad * rd.sqrt_weight[j] / rd.sigma_heading_rad[j];
    }
  };
  for (size_t k = 1; k < rd.t_s.size(); ++k) {
    assign_until(rd.t_s[k]);
    const double left_m =
        std::abs(rd.left_step_ticks[k] * constants.left_m_per_tick * params.base_scales[0]);
    const double right_m =
        std::abs(rd.right_step_ticks[k] * constants.right_m_per_tick * params.base_scales[1]);
    if (left_m == 0.0 && right_m == 0.0) continue;
    const double left_error_m = sigma_w * std::sqrt(left_m) * normal(rng);
    const double right_error_m = sigma_w * std::sqrt(right_m) * normal(rng);
    const double ds_m = 0.5 * (left_error_m + right_error_m),
                 dtheta_rad = (right_error_m - left_error_m) / true_track_m;
    shift_x_m += ds_m * std::cos(poses.heading_rad[k]) + dtheta_rad * poses.y_m[k];
    shift_y_m += ds_m * std::sin(poses.heading_rad[k]) - dtheta_rad * poses.x_m[k];
    rotation_rad += dtheta_rad;
  }
  assign_until(INFINITY);
  return delta;
}

}  // namespace

double WheelNoiseGap(const std::vector<RunData>& runs, const ModelConstants& constants,
                     const FitParameters& params, const TrajectoryFitOptions& options,
                     const Linearization& linearization, const FittedColumns& columns,
                     const Eigen::MatrixXd& normal_inverse, int n_frames) {
  // A travel error at step k moves every later frame rigidly (translation
  // along the heading, rotation about the pose at k); the fit removes its
  // projection on J. Explain's `unexplained` needs it: with a precise camera
  // the wheel noise, not the camera, sets the floor.
  if (!(options.wheel_sigma_m_per_sqrt_m > 0.0 && options.wheel_noise_draws > 0)) return 0.0;
  const int q = columns.n_global;
  std::vector<Eigen::MatrixXd> J(runs.size());
  std::vector<DeadReckonedPoses> poses(runs.size());
  for (size_t r = 0; r < runs.size(); ++r) {
    J[r] = RunFittedJacobian(linearization.runs[r], columns);
    poses[r] = DeadReckonRun(runs[r], constants, params, r);
  }
  std::mt19937 rng(20261123);
  std::normal_distribution<double> normal(0.0, 1.0);
  const double sigma_w = options.wheel_sigma_m_per_sqrt_m;
  const double true_track_m = params.base_scales[2] * constants.track_m;
  double sum_sq_m2 = 0.0;
  for (int draw = 0; draw < options.wheel_noise_draws; ++draw) {
    // Each run's whitened residual change, and J^T of it (globals, then the start poses).
    std::vector<Eigen::VectorXd> delta(runs.size());
    Eigen::VectorXd J_t_delta = Eigen::VectorXd::Zero(normal_inverse.rows());
    for (size_t r = 0; r < runs.size(); ++r) {
      delta[r] = WheelNoiseDraw(runs[r], constants, params, poses[r], sigma_w, true_track_m,
                                normal, rng);
      const Eigen::VectorXd t = J[r].transpose() * delta[r];
      J_t_delta.head(q) += t.head(q);
      J_t_delta.segment<kStartPoseParams>(q + kStartPoseParams * static_cast<int>(r)) =
          t.tail<kStartPoseParams>();
    }
    const Eigen::VectorXd x = normal_inverse * J_t_delta;  // pinv(J) delta
    for (size_t r = 0; r < runs.size(); ++r) {
      const RunData& rd = runs[r];
      const int m = rd.residuals_per_frame;
      Eigen::VectorXd x_run(q + kStartPoseParams);
      x_run << x.head(q), x.segment<kStartPoseParams>(q + kStartPoseParams * static_cast<int>(r));
      const Eigen::VectorXd left_over = delta[r] - J[r] * x_run;
      for (size_t j = 0; j < rd.frame_t_s.size(); ++j) {
        const double g = rd.sqrt_weight[j] / rd.sigma_position_m[j];
        sum_sq_m2 += (left_over[m * j] * left_over[m * j] +
                      left_over[m * j + 1] * left_over[m * j + 1]) /
                     (g * g);
      }
    }
  }
  return std::sqrt(sum_sq_m2 / (options.wheel_noise_draws * n_frames));
}

Eigen::Matrix<double, kEffectParams, kEffectParams> EffectBlockCovariance(
    const Eigen::MatrixXd& covariance, const std::vector<Effect>& effects) {
  Eigen::Matrix<double, kEffectParams, kEffectParams> block =
      Eigen::Matrix<double, kEffectParams, kEffectParams>::Zero();
  std::vector<int> effect_index;  // fitted column kBaseParams + a -> EffectParams index
  for (Effect e : effects)
    for (int idx : EffectParamIndices(e)) effect_index.push_back(idx);
  for (size_t a = 0; a < effect_index.size(); ++a)
    for (size_t b = 0; b < effect_index.size(); ++b)
      block(effect_index[a], effect_index[b]) = covariance(kBaseParams + a, kBaseParams + b);
  return block;
}

std::vector<std::string> DescribeNullVectors(const Identifiability& identifiability,
                                             const std::vector<std::string>& column_names) {
  const int p = static_cast<int>(column_names.size());
  std::vector<std::string> lines;
  for (const Eigen::VectorXd& v : identifiability.null_vectors) {
    std::vector<int> order(p);
    std::iota(order.begin(), order.end(), 0);
    std::sort(order.begin(), order.end(), [&](int a, int b) { return std::abs(v[a]) > std::abs(v[b]); });
    std::ostringstream os;
    os << "the combination";
    for (int k = 0; k < std::min(p, 4); ++k) {
      if (std::abs(v[order[k]]) < 0.1) break;
      os << " " << (v[order[k]] >= 0 ? "+" : "-") << Fixed(std::abs(v[order[k]]), 2) << " "
         << column_names[order[k]];
    }
    os << " (normalised) does not change what was measured";
    lines.push_back(os.str());
  }
  return lines;
}

namespace {

// DeriveEstimates' steps, in order.

// The estimates derived so far, each with its sigma by the delta method.
struct EstimateList {
  const Identifiability& identifiability;
  const Eigen::MatrixXd& covariance;
  std::vector<ParameterEstimate> estimates;

  // A direction in parameter space is estimable when it is orthogonal to
  // every null vector (in the normalised coordinates).
  bool Estimable(const Eigen::VectorXd& gradient) const {
    const Eigen::VectorXd g = gradient.cwiseQuotient(identifiability.column_norms);
    if (g.norm() == 0.0) return true;
    for (const Eigen::VectorXd& v : identifiability.null_vectors)
      if (std::abs(g.normalized().dot(v)) > 0.02) return false;
    return true;
  }
  // Adds `name` = `value`, whose gradient in the fitted columns is `gradient`.
  void Add(const std::string& name, double value, const Eigen::VectorXd& gradient) {
    ParameterEstimate e;
    e.name = name;
    e.value = value;
    e.identifiable = Estimable(gradient);
    e.sigma = std::sqrt(std::max(0.0, gradient.dot(covariance * gradient)));
    estimates.push_back(e);
  }
};

// The ratios of the base parameters: Ed = r_r / r_l; Es = (r_l D_L + r_r
// D_R) / (D_L + D_R); Eb; and the turn gain Eb / Es.
void AddBaseRatios(const WheelParams& believed, const FitParameters& params, EstimateList* list) {
  const int p = static_cast<int>(list->covariance.rows());
  const std::array<double, kBaseParams>& base = params.base_scales;  // r_left, r_right, Eb
  const double left_diameter_m = believed.left_wheel_diameter_m,
               right_diameter_m = believed.right_wheel_diameter_m;
  const double diameter_sum_m = left_diameter_m + right_diameter_m;
  Eigen::VectorXd g = Eigen::VectorXd::Zero(p);
  g[0] = -base[1] / (base[0] * base[0]);
  g[1] = 1.0 / base[0];
  list->Add("Ed", base[1] / base[0], g);
  g.setZero();
  g[0] = left_diameter_m / diameter_sum_m;
  g[1] = right_diameter_m / diameter_sum_m;
  const double es = (base[0] * left_diameter_m + base[1] * right_diameter_m) / diameter_sum_m;
  list->Add("Es", es, g);
  g.setZero();
  g[2] = 1.0;
  list->Add("Eb", base[2], g);
  // The turn gain Eb / Es (what UMBMark measures; free of the camera's scale).
  g.setZero();
  g[0] = -base[2] / (es * es) * left_diameter_m / diameter_sum_m;
  g[1] = -base[2] / (es * es) * right_diameter_m / diameter_sum_m;
  g[2] = 1.0 / es;
  list->Add("turn_gain", base[2] / es, g);
}

// A ratio whose uncertainty spans more than its plausible range is not
// determined by these data, whatever the rank test says (a nearly flat
// direction just above the tolerance).
void MarkImplausibleRatios(double max_ratio_sigma, std::vector<ParameterEstimate>* estimates,
                           std::vector<std::string>* unidentifiable) {
  for (ParameterEstimate& e : *estimates)
    if (e.identifiable && e.sigma > max_ratio_sigma) {
      e.identifiable = false;
      unidentifiable->push_back(e.name + ": sigma " + Fixed(e.sigma, 4) + " exceeds the plausible range of a ratio (" +
                                Fixed(max_ratio_sigma, 3) + ")");
    }
}

// Each effect's parameters, named "<effect>.<parameter>"; carpet drift's as
// its grain and rate.
void AddEffectEstimates(const FitParameters& params, const std::vector<Effect>& effects, EstimateList* list) {
  const int p = static_cast<int>(list->covariance.rows());
  Eigen::VectorXd g = Eigen::VectorXd::Zero(p);
  const EffectParams& fx = params.effects;
  int c = kBaseParams;  // the fitted column of the next effect parameter
  for (Effect e : effects) {
    const std::string prefix = std::string(ToString(e)) + ".";
    if (e == Effect::kCarpetDrift) {
      const double a = fx.values[EffectParams::kDriftA], b = fx.values[EffectParams::kDriftB];
      const double rate = std::hypot(a, b);
      g.setZero();
      if (rate > 0.0) {
        g[c] = -b / (rate * rate);
        g[c + 1] = a / (rate * rate);
      }
      list->Add(prefix + "grain_rad", std::atan2(b, a), g);
      g.setZero();
      if (rate > 0.0) {
        g[c] = a / rate;
        g[c + 1] = b / rate;
      }
      list->Add(prefix + "rate_m_per_m", rate, g);
      c += 2;
      continue;
    }
    const std::vector<int> idx = EffectParamIndices(e);
    const std::vector<std::string> names = EffectParamNames(e);
    for (size_t k = 0; k < idx.size(); ++k, ++c) {
      g.setZero();
      g[c] = 1.0;
      list->Add(prefix + names[k], fx.values[idx[k]], g);
    }
  }
}

}  // namespace

std::vector<ParameterEstimate> DeriveEstimates(const WheelParams& believed, const FitParameters& params,
                                               const TrajectoryFitOptions& options,
                                               const Identifiability& identifiability,
                                               const Eigen::MatrixXd& covariance,
                                               std::vector<std::string>* unidentifiable) {
  EstimateList list{identifiability, covariance, {}};
  AddBaseRatios(believed, params, &list);
  MarkImplausibleRatios(options.max_ratio_sigma, &list.estimates, unidentifiable);
  AddEffectEstimates(params, options.effects, &list);
  return list.estimates;
}

}  // namespace internal

std::string_view ToString(Effect effect) { return Describe(effect).name; }

std::string_view ToString(MotionKind kind) {
  switch (kind) {
    case MotionKind::kRest: return "rest";
    case MotionKind::kStraight: return "straight";
    case MotionKind::kTurn: return "turn";
  }
  return "?";
}

double EffectParams::drift_rate_m_per_m() const {
  return std::hypot(values[kDriftA], values[kDriftB]);
}
double EffectParams::drift_grain_rad() const { return std::atan2(values[kDriftB], values[kDriftA]); }

double EffectParams::TelemetryTimeOf(double stamp_s, double image_row_fraction) const {
  return internal::RollingShutter(values.data(), RowOffset(image_row_fraction),
                                  internal::CameraLatency(values.data(), stamp_s));
}

std::vector<int> EffectParamIndices(Effect effect) { return Describe(effect).params; }

std::vector<int> EffectTestedIndices(Effect effect) { return Describe(effect).tested; }

std::vector<std::string> EffectParamNames(Effect effect) {
  const EffectDescriptor& d = Describe(effect);
  return {d.param_names.begin(), d.param_names.end()};
}

std::string DistinguishingRuns(Effect effect) { return std::string(Describe(effect).distinguishing_runs); }

bool TrajectoryFitOptions::IsValid(std::string* why) const {
  auto fail = [why](const char* m) {
    if (why) *why = m;
    return false;
  };
  if (!(default_position_sigma_m > 0.0)) return fail("default_position_sigma_m must be positive");
  if (!(default_heading_sigma_rad > 0.0)) return fail("default_heading_sigma_rad must be positive");
  if (!(wheel_sigma_m_per_sqrt_m >= 0.0)) return fail("wheel_sigma_m_per_sqrt_m must not be negative");
  if (!(huber_threshold >= 0.0)) return fail("huber_threshold must not be negative");
  if (irls_rounds < 1) return fail("irls_rounds must be at least 1");
  if (!solver.IsValid(why)) return false;
  if (!(rank_tolerance > 0.0 && rank_tolerance < 1.0))
    return fail("rank_tolerance must be in (0, 1)");
  if (min_frames_per_run < 2) return fail("min_frames_per_run must be at least 2");
  if (wheel_noise_draws < 0) return fail("wheel_noise_draws must not be negative");
  if (!(base_prior_sigma >= 0.0)) return fail("base_prior_sigma must not be negative");
  if (!(max_ratio_sigma > 0.0)) return fail("max_ratio_sigma must be positive");
  for (size_t i = 0; i < effects.size(); ++i)
    for (size_t j = i + 1; j < effects.size(); ++j)
      if (effects[i] == effects[j]) return fail("an effect is listed twice");
  return true;
}

const ParameterEstimate* TrajectoryFitResult::Find(std::string_view name) const {
  for (const ParameterEstimate& p : parameters)
    if (p.name == name) return &p;
  return nullptr;
}

double TrajectoryFitResult::Wald(Effect effect) const {
  const std::vector<int> idx = EffectTestedIndices(effect);
  const int k = static_cast<int>(idx.size());
  Eigen::VectorXd theta(k);
  Eigen::MatrixXd sigma(k, k);
  for (int a = 0; a < k; ++a) {
    theta[a] = effects.values[idx[a]];
    for (int b = 0; b < k; ++b) sigma(a, b) = effect_covariance(idx[a], idx[b]);
  }
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(sigma);
  if (ldlt.info() != Eigen::Success || !(sigma.diagonal().minCoeff() > 0.0)) return 0.0;
  return theta.dot(ldlt.solve(theta));
}

std::string TrajectoryFitResult::BriefReport() const {
  std::ostringstream os;
  os << "trajectory fit: "
     << (status == StatusCode::kOk ? "ok" : status == StatusCode::kInvalidArgument ? "invalid input"
                                                                         : "no convergence");
  if (!message.empty()) os << " (" << message << ")";
  os << ", " << n_frames << " frames, " << n_parameters << " parameters, gap " << Fixed(gap_m * kMToMm, 3)
     << " mm (noise floor " << Fixed(noise_floor_m * kMToMm, 3) << " mm), condition " << std::setprecision(3)
     << condition_number;
  if (jackknife_runs > 0) {
    os << ", jackknifed over " << jackknife_runs << " runs";
    if (jackknife_groups < jackknife_runs) os << " in " << jackknife_groups << " groups";
  }
  os << "\n";
  for (const ParameterEstimate& p : parameters) {
    os << "  " << std::left << std::setw(36) << p.name << std::right << std::setw(14)
       << std::setprecision(7) << p.value;
    if (p.identifiable) {
      os << " +/- " << std::setprecision(3) << 1.959963985 * p.sigma << " (95 %)";
      if (std::isfinite(p.sigma_between_runs))
        os << ", between runs +/- " << 1.959963985 * p.sigma_between_runs;
    } else
      os << "  (not identifiable)";
    os << "\n";
  }
  for (const std::string& u : unidentifiable) os << "  not identifiable: " << u << "\n";
  return os.str();
}


TrajectoryFitResult FitTrajectory(const MeasuredSession& session,
                                  const TrajectoryFitOptions& options,
                                  const TrajectoryFitResult* warm_start) {
  using namespace internal;
  TrajectoryFitResult result;
  result.options = options;
  result.message = ValidateFitInputs(session, options);
  if (!result.message.empty()) return result;

  const ModelConstants constants = ConstantsOf(session.believed, session.camera);
  ExtractedRuns extracted = ExtractRuns(session, options, constants);
  std::vector<RunData>& runs = extracted.runs;
  result.run_used = extracted.run_used;
  result.start_poses.assign(session.runs.size(), Pose2::Identity());
  if (runs.empty()) {
    result.message = "no run has both telemetry and enough camera frames";
    return result;
  }

  FitParameters params = InitialParameters(runs, result.run_used, options, warm_start);
  const TrajectoryProblem problem = BuildProblem(runs, constants, options);
  const SolveOutcome solved = SolveWithIrls(problem, options, &runs, &params);
  if (solved.failed) {
    result.status = StatusCode::kNoConvergence;
    result.message = solved.message;
    return result;
  }

  // The solution: residuals, gap and the Jacobian, by run.
  const Linearization linearization = Linearize(problem, runs, params);
  ReducedGlobals reduced = ReduceGlobals(linearization);
  result.reduced_jacobian = std::move(reduced.R);
  result.global_column_norms = std::move(reduced.column_norms);
  result.n_residuals = linearization.n_residuals();
  FrameReport frames = ReportFrames(runs, constants, params);
  result.residuals = std::move(frames.residuals);
  for (size_t r = 0; r < runs.size(); ++r)
    result.start_poses[runs[r].run] = Pose2::FromXYHeading(
        params.start_poses[r][0], params.start_poses[r][1], params.start_poses[r][2]);
  result.n_frames = static_cast<int>(result.residuals.size());
  result.gap_m = frames.gap_m;
  result.noise_floor_m = frames.noise_floor_m;
  result.weighted_sse = linearization.weighted_sse();
  result.scales.r_left = params.base_scales[0];
  result.scales.r_right = params.base_scales[1];
  result.scales.Eb = params.base_scales[2];
  result.effects = params.effects;

  // Identifiability and covariance over the fitted columns.
  const FittedColumns columns = SelectFittedColumns(session, runs, options);
  result.n_parameters = static_cast<int>(columns.index.size());
  const Identifiability identifiability =
      AnalyseIdentifiability(linearization, columns, options.rank_tolerance);
  result.condition_number = identifiability.condition_number;
  const ParameterCovariance covariance = ComputeCovariance(
      session, runs, constants, params, options, identifiability, columns, linearization);
  result.lag1_autocorrelation = covariance.lag1_autocorrelation;
  result.variance_factor = covariance.variance_factor;
  result.wheel_noise_gap_m = WheelNoiseGap(runs, constants, params, options, linearization,
                                           columns, covariance.normal_inverse, result.n_frames);

  // Derived estimates.
  result.effect_covariance = EffectBlockCovariance(covariance.covariance, options.effects);
  result.unidentifiable = DescribeNullVectors(identifiability, columns.names);
  result.parameters = DeriveEstimates(session.believed, params, options, identifiability,
                                      covariance.covariance, &result.unidentifiable);

  result.status = StatusCode::kOk;
  if (!solved.solution_usable) {
    result.status = StatusCode::kNoConvergence;
    result.message = solved.message;
  } else if (!result.unidentifiable.empty()) {
    result.message = std::to_string(result.unidentifiable.size()) +
                     " parameter combination(s) not identifiable from these data";
  }
  return result;
}

std::vector<Pose2> PredictMeasuredPoses(const MeasuredRun& run, const WheelParams& believed,
                                        const WheelScales& scales, const EffectParams& effects,
                                        const std::optional<FloorCamera>& camera,
                                        const Pose2& start, const std::vector<double>& stamps_s,
                                        int left_direction0, int right_direction0,
                                        const std::vector<double>& image_row_fractions) {
  using namespace internal;
  RunData rd = ExtractTelemetry(run, 0, &left_direction0, &right_direction0);
  if (rd.t_s.size() < 2) return {};
  const ModelConstants constants = ConstantsOf(believed, camera);
  MarkArcs(constants, &rd);
  const double base_scales[kBaseParams] = {scales.r_left, scales.r_right, scales.Eb};
  const double start_xyh[kStartPoseParams] = {start.x(), start.y(), start.heading()};
  std::vector<double> xs_m, ys_m, headings_rad;
  DeadReckon(rd, constants, base_scales, start_xyh, effects.values.data(), &xs_m, &ys_m,
             &headings_rad);
  std::vector<Pose2> poses;
  poses.reserve(stamps_s.size());
  for (size_t j = 0; j < stamps_s.size(); ++j) {
    const double row_offset =
        j < image_row_fractions.size() ? EffectParams::RowOffset(image_row_fractions[j]) : 0.0;
    double px_m, py_m, ph_rad;
    PredictFrame(rd, constants, xs_m, ys_m, headings_rad, effects.values.data(), stamps_s[j],
                 row_offset, &px_m, &py_m, &ph_rad);
    poses.push_back(Pose2::FromXYHeading(px_m, py_m, ph_rad));
  }
  return poses;
}

std::vector<double> ArcCurvatures(const MeasuredRun& run, const WheelParams& believed) {
  int left_direction = 1, right_direction = 1;
  internal::RunData rd = internal::ExtractTelemetry(run, 0, &left_direction, &right_direction);
  internal::MarkArcs(internal::ConstantsOf(believed, std::nullopt), &rd);
  return rd.curvature_per_m;
}

void LastShaftDirections(const MeasuredRun& run, int* left_direction, int* right_direction) {
  internal::ExtractTelemetry(run, 0, left_direction, right_direction);
}

AliasReport CheckAliasing(const TrajectoryFitResult& fit, Effect candidate,
                          double alias_tolerance) {
  constexpr int kBase = internal::kBaseParams;
  AliasReport report;
  report.effect = candidate;
  report.distinguishing_runs = DistinguishingRuns(candidate);
  // The global columns with the runs' start poses projected out: the
  // candidate's distance from the span of the model and the start poses is
  // its distance, there, from the span of the model alone (Frisch-Waugh).
  const Eigen::MatrixXd& J = fit.reduced_jacobian;
  const Eigen::VectorXd& norms = fit.global_column_norms;
  if (J.size() == 0) return report;
  // Fitted columns: base, enabled effects.
  std::vector<int> cols = {0, 1, 2};
  std::vector<std::string> names = {"r_left", "r_right", "Eb"};
  for (Effect e : fit.options.effects)
    for (int idx : EffectParamIndices(e)) {
      cols.push_back(kBase + idx);
      names.push_back(std::string(ToString(e)));
    }
  // The candidate's nuisance parameters come with it: the question is whether
  // its tested ones can be told from everything else that would be fitted.
  const std::vector<int> idx = EffectTestedIndices(candidate);
  for (int i : EffectParamIndices(candidate))
    if (std::find(idx.begin(), idx.end(), i) == idx.end()) {
      cols.push_back(kBase + i);
      names.push_back(std::string(ToString(candidate)) + " (its nuisance)");
    }
  const int n_model = static_cast<int>(cols.size());
  // Each column normalised by its norm in the full Jacobian.
  Eigen::MatrixXd A(J.rows(), cols.size());
  for (size_t c = 0; c < cols.size(); ++c) {
    const double n = norms[cols[c]];
    A.col(c) = n > 0.0 ? Eigen::VectorXd(J.col(cols[c]) / n) : Eigen::VectorXd(J.col(cols[c]));
  }
  Eigen::MatrixXd C(J.rows(), idx.size());
  for (size_t k = 0; k < idx.size(); ++k) {
    const double n = norms[kBase + idx[k]];
    if (n < 1e-9) {
      report.no_signal = true;
      report.aliased = true;
      report.separation = 0.0;
      return report;
    }
    C.col(k) = J.col(kBase + idx[k]) / n;
  }
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(A);
  const Eigen::MatrixXd coeffs = qr.solve(C);
  const Eigen::MatrixXd rest = C - A * coeffs;
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(rest);
  report.separation = svd.singularValues().minCoeff();
  report.aliased = report.separation < alias_tolerance;
  // What it looks like: the fitted model parameters with the largest
  // coefficients in the projection (start poses only if nothing else).
  std::vector<std::pair<double, std::string>> loads;
  for (int c = 0; c < n_model; ++c) loads.push_back({coeffs.row(c).norm(), names[c]});
  std::sort(loads.begin(), loads.end(), [](auto& a, auto& b) { return a.first > b.first; });
  for (const auto& [load, name] : loads) {
    if (load < 0.2 * loads.front().first || load < 0.05) break;
    if (std::find(report.looks_like.begin(), report.looks_like.end(), name) ==
        report.looks_like.end())
      report.looks_like.push_back(name);
  }
  if (report.looks_like.empty()) report.looks_like.push_back("the runs' start poses");
  return report;
}

}  // namespace odocal::calibration
