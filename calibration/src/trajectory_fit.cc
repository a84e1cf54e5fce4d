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

#include "odocal/calibration/arc.h"

namespace odocal::calibration {
namespace {

constexpr int kBase = 3;
constexpr int kFx = EffectParams::kSize;

inline double Scalar(double v) { return v; }
template <typename T, int N>
double Scalar(const ceres::Jet<T, N>& j) {
  return Scalar(j.a);
}

// Everything the model needs of one run, extracted once.
struct RunData {
  int run = 0;
  std::vector<double> t;                   // telemetry times (robot clock)
  std::vector<std::int64_t> dl, dr;        // tick deltas of step k (t[k-1] -> t[k]), k >= 1
  std::vector<MotionKind> kind;            // of step k
  std::vector<double> curvature;           // of step k on arcs (1/m), else 0 (arc_scale)
  int left_direction0 = 1, right_direction0 = 1;  // shaft directions before the run
  // Used camera frames.
  std::vector<double> frame_t, zx, zy, zh, sigma_p, sigma_h;
  std::vector<double> sqrt_w;  // IRLS weights (square roots)
  int residuals_per_frame = 3;
};

struct ModelConstants {
  double left_m_per_tick = 0.0;
  double right_m_per_tick = 0.0;
  double track_m = 0.0;
  std::optional<FloorCamera> camera;
};

// encoder_backlash: the ticks of step `d` that moved the wheel.
template <typename T>
T MovingTicks(std::int64_t d, int* direction, T* dead, const T& backlash) {
  if (d == 0) return T(0.0);
  const int s = d > 0 ? 1 : -1;
  if (s != *direction) {
    *direction = s;
    *dead = backlash;
  }
  const double magnitude = static_cast<double>(d > 0 ? d : -d);
  const T consumed = Scalar(*dead) < magnitude ? *dead : T(magnitude);
  *dead -= consumed;
  return T(static_cast<double>(d)) - double(s) * consumed;
}

// The dead-reckoned poses of a run at its telemetry times, from `start`.
template <typename T>
void DeadReckon(const RunData& run, const ModelConstants& c, const T* base, const T* start,
                const T* fx, std::vector<T>* xs, std::vector<T>* ys, std::vector<T>* hs) {
  using std::abs;
  using std::cos;
  using std::sin;
  const size_t n = run.t.size();
  xs->resize(n);
  ys->resize(n);
  hs->resize(n);
  T x = start[0], y = start[1], h = start[2];
  (*xs)[0] = x;
  (*ys)[0] = y;
  (*hs)[0] = h;
  int left_direction = run.left_direction0, right_direction = run.right_direction0;
  T left_dead(0.0), right_dead(0.0);
  const T track = base[2] * c.track_m;
  for (size_t k = 1; k < n; ++k) {
    const std::int64_t dl = run.dl[k], dr = run.dr[k];
    if (dl != 0 || dr != 0) {
      const double dt = std::max(run.t[k] - run.t[k - 1], 1e-6);
      T left = MovingTicks(dl, &left_direction, &left_dead, fx[EffectParams::kBacklash]) *
               c.left_m_per_tick * base[0];
      T right = MovingTicks(dr, &right_direction, &right_dead, fx[EffectParams::kBacklash]) *
                c.right_m_per_tick * base[1];
      // speed_slip: each wheel loses k |v| of its travel, v its speed over the step.
      left *= 1.0 - fx[EffectParams::kSpeedSlip] * abs(left) / dt;
      right *= 1.0 - fx[EffectParams::kSpeedSlip] * abs(right) / dt;
      // arc_scale: on an arc both wheels lose c |kappa| of their travel.
      if (run.curvature[k] != 0.0) {
        const T scale = 1.0 - fx[EffectParams::kArcScale] * std::abs(run.curvature[k]);
        left *= scale;
        right *= scale;
      }
      const T ds = (left + right) / 2.0;
      if (run.kind[k] == MotionKind::kTurn) {
        const T dtheta = (right - left) / track;
        const T achieved = dtheta * (1.0 - fx[EffectParams::kSlip] * abs(dtheta) / dt);
        left = ds - achieved * track / 2.0;
        right = ds + achieved * track / 2.0;
      }
      const T h0 = h;
      AdvanceArc(left, right, track, &x, &y, &h);
      if (run.kind[k] == MotionKind::kStraight) {
        const T mid = (h0 + h) / 2.0;
        const T lateral =
            (fx[EffectParams::kDriftA] * cos(mid) + fx[EffectParams::kDriftB] * sin(mid)) * ds;
        x -= lateral * sin(mid);
        y += lateral * cos(mid);
      }
    }
    (*xs)[k] = x;
    (*ys)[k] = y;
    (*hs)[k] = h;
  }
}

// The measured pose predicted for a camera frame stamped `stamp_s`.
template <typename T>
void PredictFrame(const RunData& run, const ModelConstants& c, const std::vector<T>& xs,
                  const std::vector<T>& ys, const std::vector<T>& hs, const T* fx, double stamp_s,
                  T* px, T* py, T* ph) {
  using std::cos;
  using std::sin;
  const T t = stamp_s + fx[EffectParams::kLatency];
  const double ts = Scalar(t);
  const size_t n = run.t.size();
  if (ts <= run.t.front()) {
    *px = xs.front(), *py = ys.front(), *ph = hs.front();
  } else if (ts >= run.t.back()) {
    *px = xs.back(), *py = ys.back(), *ph = hs.back();
  } else {
    const size_t k = static_cast<size_t>(std::upper_bound(run.t.begin(), run.t.end(), ts) -
                                         run.t.begin()) - 1;
    const size_t k1 = std::min(k + 1, n - 1);
    const double span = std::max(run.t[k1] - run.t[k], 1e-9);
    const T u = (t - run.t[k]) / span;
    *px = xs[k] + u * (xs[k1] - xs[k]);
    *py = ys[k] + u * (ys[k1] - ys[k]);
    *ph = hs[k] + u * (hs[k1] - hs[k]);
  }
  // tag_offset: the camera measures the tag, taken to be at the axle midpoint.
  const T tx = fx[EffectParams::kTagX], ty = fx[EffectParams::kTagY];
  const T ch = cos(*ph), sh = sin(*ph);
  *px += ch * tx - sh * ty;
  *py += sh * tx + ch * ty;
  // tracker_yaw: the tracked body's heading is off the robot's by a constant.
  *ph += fx[EffectParams::kTrackerYaw];
  // lens_distortion: where the pipeline measures the tag through a lens whose k1 is off.
  if (c.camera) {
    const T x = *px, y = *py;
    SeenThroughLens(*c.camera, x, y, fx[EffectParams::kK1], fx[EffectParams::kTiltX],
                    fx[EffectParams::kTiltY], px, py);
  }
}

struct RunResidual {
  const RunData* run;
  const ModelConstants* constants;

  template <typename T>
  bool operator()(const T* base, const T* start, const T* fx, T* residuals) const {
    std::vector<T> xs, ys, hs;
    DeadReckon(*run, *constants, base, start, fx, &xs, &ys, &hs);
    const int m = run->residuals_per_frame;
    for (size_t j = 0; j < run->frame_t.size(); ++j) {
      T px, py, ph;
      PredictFrame(*run, *constants, xs, ys, hs, fx, run->frame_t[j], &px, &py, &ph);
      const double w = run->sqrt_w[j];
      residuals[m * j + 0] = w * (px - run->zx[j]) / run->sigma_p[j];
      residuals[m * j + 1] = w * (py - run->zy[j]) / run->sigma_p[j];
      if (m == 3) {
        T dh = ph - run->zh[j];
        dh -= 2.0 * M_PI * std::round(Scalar(dh) / (2.0 * M_PI));
        residuals[m * j + 2] = w * dh / run->sigma_h[j];
      }
    }
    return true;
  }
};

// A weak prior on the base ratios at 1 (the nominal parameters): it keeps
// the solver in a physical region along directions the data leave free, and
// weighs ~1e-7 of the data on a determined parameter. It is left out of the
// identifiability analysis and the covariance.
struct BasePrior {
  double sigma = 0.2;
  template <typename T>
  bool operator()(const T* base, T* residuals) const {
    for (int i = 0; i < kBase; ++i) residuals[i] = (base[i] - 1.0) / sigma;
    return true;
  }
};

MotionKind StepKind(std::int64_t dl, std::int64_t dr) {
  if (dl == 0 && dr == 0) return MotionKind::kRest;
  if ((dl > 0 && dr < 0) || (dl < 0 && dr > 0)) return MotionKind::kTurn;
  return MotionKind::kStraight;
}

// The telemetry part of a run: its times, each step's tick deltas and
// motion. The shafts' last directions (encoder_backlash) come in and go out
// through `left_direction` and `right_direction`.
RunData ExtractTelemetry(const MeasuredRun& mr, int index, int* left_direction,
                         int* right_direction) {
  RunData rd;
  rd.run = index;
  rd.left_direction0 = *left_direction;
  rd.right_direction0 = *right_direction;
  for (size_t k = 0; k < mr.telemetry.size(); ++k) {
    rd.t.push_back(mr.telemetry[k].t_s);
    const std::int64_t dl = k == 0 ? 0 : mr.telemetry[k].left_ticks - mr.telemetry[k - 1].left_ticks;
    const std::int64_t dr = k == 0 ? 0 : mr.telemetry[k].right_ticks - mr.telemetry[k - 1].right_ticks;
    rd.dl.push_back(dl);
    rd.dr.push_back(dr);
    rd.kind.push_back(StepKind(dl, dr));
    if (dl != 0) *left_direction = dl > 0 ? 1 : -1;
    if (dr != 0) *right_direction = dr > 0 ? 1 : -1;
  }
  return rd;
}

// arc_scale's curvature of each step: the believed wheel travels summed over
// the same-direction steps within kArcWindowSteps either side (one step's
// ticks differ by a tick or two on a straight: ~0.2 /m at 50 Hz and 50 mm/s),
// kappa = (right - left) / (track (right + left) / 2).
void MarkArcs(const ModelConstants& c, RunData* rd) {
  const size_t n = rd->t.size();
  rd->curvature.assign(n, 0.0);
  // Both wheels moving the same way: not at rest, not a turn in place, and
  // not the first or last step of one (a single wheel still counting).
  auto forward_like = [&](size_t k) {
    return (rd->dl[k] > 0 && rd->dr[k] > 0) || (rd->dl[k] < 0 && rd->dr[k] < 0);
  };
  for (size_t k = 1; k < n; ++k) {
    if (!forward_like(k)) continue;
    double left = 0.0, right = 0.0;
    const size_t from = k > static_cast<size_t>(kArcWindowSteps) ? k - kArcWindowSteps : 1;
    const size_t to = std::min(n - 1, k + kArcWindowSteps);
    for (size_t j = from; j <= to; ++j) {
      // Same way as step k: a direct reversal would cancel the travel.
      if (!forward_like(j) || (rd->dl[j] > 0) != (rd->dl[k] > 0)) continue;
      left += rd->dl[j] * c.left_m_per_tick;
      right += rd->dr[j] * c.right_m_per_tick;
    }
    const double ds = 0.5 * (left + right);
    if (std::abs(ds) < 1e-9) continue;
    // A backward arc turns the other way for the same wheel difference; the
    // curvature's sign is only reported, the effect uses |kappa|.
    const double kappa = (right - left) / (c.track_m * ds);
    if (std::abs(kappa) >= kArcMinCurvature) rd->curvature[k] = kappa;
  }
}

ModelConstants ConstantsOf(const WheelParams& believed, const std::optional<FloorCamera>& camera) {
  ModelConstants c;
  c.left_m_per_tick = believed.LeftMetresPerTick();
  c.right_m_per_tick = believed.RightMetresPerTick();
  c.track_m = believed.track_m;
  c.camera = camera;
  return c;
}

std::string Fixed(double v, int precision) {
  std::ostringstream os;
  os << std::fixed << std::setprecision(precision) << v;
  return os.str();
}

double Median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const size_t mid = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + mid, v.end());
  return v[mid];
}

}  // namespace

std::string_view ToString(Effect effect) {
  switch (effect) {
    case Effect::kTagOffset: return "tag_offset";
    case Effect::kCameraLatency: return "camera_latency";
    case Effect::kTurnSlip: return "turn_slip";
    case Effect::kLensDistortion: return "lens_distortion";
    case Effect::kEncoderBacklash: return "encoder_backlash";
    case Effect::kCarpetDrift: return "carpet_drift";
    case Effect::kTrackerYaw: return "tracker_yaw";
    case Effect::kSpeedSlip: return "speed_slip";
    case Effect::kArcScale: return "arc_scale";
  }
  return "?";
}

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

std::vector<int> EffectParamIndices(Effect effect) {
  switch (effect) {
    case Effect::kTagOffset: return {EffectParams::kTagX, EffectParams::kTagY};
    case Effect::kCameraLatency: return {EffectParams::kLatency};
    case Effect::kTurnSlip: return {EffectParams::kSlip};
    case Effect::kLensDistortion:
      return {EffectParams::kK1, EffectParams::kTiltX, EffectParams::kTiltY};
    case Effect::kEncoderBacklash: return {EffectParams::kBacklash};
    case Effect::kCarpetDrift: return {EffectParams::kDriftA, EffectParams::kDriftB};
    case Effect::kTrackerYaw: return {EffectParams::kTrackerYaw};
    case Effect::kSpeedSlip: return {EffectParams::kSpeedSlip};
    case Effect::kArcScale: return {EffectParams::kArcScale};
  }
  return {};
}

std::vector<int> EffectTestedIndices(Effect effect) {
  if (effect == Effect::kLensDistortion) return {EffectParams::kK1};
  return EffectParamIndices(effect);
}

std::vector<std::string> EffectParamNames(Effect effect) {
  switch (effect) {
    case Effect::kTagOffset: return {"x_m", "y_m"};
    case Effect::kCameraLatency: return {"latency_s"};
    case Effect::kTurnSlip: return {"fraction_at_1rad_s"};
    case Effect::kLensDistortion: return {"k1", "camera_tilt_x_rad", "camera_tilt_y_rad"};
    case Effect::kEncoderBacklash: return {"ticks"};
    case Effect::kCarpetDrift: return {"rate_cos_grain", "rate_sin_grain"};
    case Effect::kTrackerYaw: return {"yaw_rad"};
    case Effect::kSpeedSlip: return {"fraction_at_1m_s"};
    case Effect::kArcScale: return {"fraction_at_1_per_m"};
  }
  return {};
}

std::string DistinguishingRuns(Effect effect) {
  switch (effect) {
    case Effect::kTagOffset:
      return "a spin in place seen by the camera (the tag circles the axle; a centred tag does "
             "not move)";
    case Effect::kCameraLatency:
      return "motion seen by the camera at two speeds (e.g. straights at 100 and 400 mm/s) or a "
             "spin seen by the camera";
    case Effect::kTurnSlip:
      return "in-place turns at two different turn rates (e.g. spins at 30 and 120 deg/s): slip "
             "at one rate is a track error";
    case Effect::kLensDistortion:
      return "runs seen both near the image centre and near its edge (e.g. a square that "
             "crosses the field of view)";
    case Effect::kEncoderBacklash:
      return "runs that reverse each wheel a different number of times per metre (e.g. "
             "out_and_back beside long straights, spins in both directions)";
    case Effect::kCarpetDrift:
      return "straights in several headings seen by the camera (e.g. cw and ccw squares, or "
             "straights at 0, 90, 180 deg): drift along one heading is a wheel-ratio error";
    case Effect::kTrackerYaw:
      return "straights seen by the pose source with their measured headings (the direction of "
             "travel against the heading the tracker reports)";
    case Effect::kSpeedSlip:
      return "straights at two different speeds (e.g. out-and-backs at 100 and 400 mm/s): slip at "
             "one speed is a scale error, and in spins a turn slip";
    case Effect::kArcScale:
      return "arcs (e.g. circles of radius 0.3-1 m) beside straights and turns in place: on arcs of "
             "one curvature it is a scale of both wheels there, which only straights tell from Es "
             "(and spins from Eb)";
  }
  return "";
}

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
  if (max_solver_iterations < 1) return fail("max_solver_iterations must be at least 1");
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
  os << ", " << n_frames << " frames, " << n_parameters << " parameters, gap "
     << Fixed(gap_m * 1e3, 3) << " mm (noise floor " << Fixed(noise_floor_m * 1e3, 3)
     << " mm), condition " << std::setprecision(3) << condition_number << "\n";
  for (const ParameterEstimate& p : parameters) {
    os << "  " << std::left << std::setw(36) << p.name << std::right << std::setw(14)
       << std::setprecision(7) << p.value;
    if (p.identifiable)
      os << " +/- " << std::setprecision(3) << 1.959963985 * p.sigma << " (95 %)";
    else
      os << "  (not identifiable)";
    os << "\n";
  }
  for (const std::string& u : unidentifiable) os << "  not identifiable: " << u << "\n";
  return os.str();
}

TrajectoryFitResult FitTrajectory(const MeasuredSession& session,
                                  const TrajectoryFitOptions& options,
                                  const TrajectoryFitResult* warm_start) {
  TrajectoryFitResult result;
  result.options = options;
  std::string why;
  if (!options.IsValid(&why)) {
    result.message = "options: " + why;
    return result;
  }
  if (!session.believed.IsValid(&why)) {
    result.message = "believed parameters: " + why;
    return result;
  }
  const bool lens_on = std::find(options.effects.begin(), options.effects.end(),
                                 Effect::kLensDistortion) != options.effects.end();
  if (lens_on && (!session.camera || !session.camera->IsValid())) {
    result.message = "lens_distortion needs the camera's geometry over the tag plane (session.camera)";
    return result;
  }

  const ModelConstants constants = ConstantsOf(session.believed, session.camera);

  // Extract the runs; shaft directions carry over from run to run.
  const size_t n_runs = session.runs.size();
  std::vector<RunData> runs;
  result.run_used.assign(n_runs, false);
  result.start_poses.assign(n_runs, Pose2::Identity());
  int left_direction = 1, right_direction = 1;
  for (size_t i = 0; i < n_runs; ++i) {
    const MeasuredRun& mr = session.runs[i];
    RunData rd = ExtractTelemetry(mr, static_cast<int>(i), &left_direction, &right_direction);
    MarkArcs(constants, &rd);
    rd.residuals_per_frame = options.use_heading ? 3 : 2;
    if (rd.t.size() < 2) continue;
    for (const CameraRecord& f : mr.camera) {
      if (!f.valid) continue;
      rd.frame_t.push_back(f.t_s);
      rd.zx.push_back(f.T_world_robot.x());
      rd.zy.push_back(f.T_world_robot.y());
      rd.zh.push_back(f.T_world_robot.heading());
      rd.sigma_p.push_back(f.sigma_position_m > 0.0 ? f.sigma_position_m
                                                    : options.default_position_sigma_m);
      rd.sigma_h.push_back(f.sigma_heading_rad > 0.0 ? f.sigma_heading_rad
                                                     : options.default_heading_sigma_rad);
    }
    if (static_cast<int>(rd.frame_t.size()) < options.min_frames_per_run) continue;
    rd.sqrt_w.assign(rd.frame_t.size(), 1.0);
    result.run_used[i] = true;
    runs.push_back(std::move(rd));
  }
  if (runs.empty()) {
    result.message = "no run has both telemetry and enough camera frames";
    return result;
  }

  // Parameters.
  std::array<double, kBase> base = {1.0, 1.0, 1.0};
  EffectParams fx;
  std::vector<std::array<double, 3>> starts(runs.size());
  for (size_t r = 0; r < runs.size(); ++r)
    starts[r] = {runs[r].zx[0], runs[r].zy[0], runs[r].zh[0]};
  std::vector<bool> active(kFx, false);
  for (Effect e : options.effects)
    for (int idx : EffectParamIndices(e)) active[idx] = true;
  if (warm_start && warm_start->ok() && warm_start->run_used == result.run_used) {
    base = {warm_start->scales.r_left, warm_start->scales.r_right, warm_start->scales.Eb};
    for (int i = 0; i < kFx; ++i)
      if (active[i]) fx.values[i] = warm_start->effects.values[i];
    for (size_t r = 0; r < runs.size(); ++r) {
      const Pose2& p = warm_start->start_poses[runs[r].run];
      starts[r] = {p.x(), p.y(), p.heading()};
    }
  }

  std::vector<std::unique_ptr<ceres::CostFunction>> costs;
  for (RunData& rd : runs) {
    auto* functor = new RunResidual{&rd, &constants};
    costs.emplace_back(new ceres::AutoDiffCostFunction<RunResidual, ceres::DYNAMIC, kBase, 3, kFx>(
        functor, static_cast<int>(rd.frame_t.size()) * rd.residuals_per_frame));
  }

  std::unique_ptr<ceres::CostFunction> prior(
      new ceres::AutoDiffCostFunction<BasePrior, kBase, kBase>(
          new BasePrior{options.base_prior_sigma}));
  ceres::Solver::Summary summary;
  for (int round = 0; round < options.irls_rounds; ++round) {
    ceres::Problem::Options problem_options;
    problem_options.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    problem_options.manifold_ownership = ceres::TAKE_OWNERSHIP;
    ceres::Problem problem(problem_options);
    for (size_t r = 0; r < runs.size(); ++r)
      problem.AddResidualBlock(costs[r].get(), nullptr, base.data(), starts[r].data(),
                               fx.values.data());
    if (options.base_prior_sigma > 0.0)
      problem.AddResidualBlock(prior.get(), nullptr, base.data());
    std::vector<int> constant;
    for (int i = 0; i < kFx; ++i)
      if (!active[i]) constant.push_back(i);
    if (static_cast<int>(constant.size()) == kFx)
      problem.SetParameterBlockConstant(fx.values.data());
    else if (!constant.empty())
      problem.SetManifold(fx.values.data(), new ceres::SubsetManifold(kFx, constant));
    ceres::Solver::Options solver_options;
    solver_options.linear_solver_type = ceres::DENSE_QR;
    solver_options.max_num_iterations = options.max_solver_iterations;
    solver_options.function_tolerance = 1e-10;
    solver_options.parameter_tolerance = 1e-10;
    solver_options.num_threads = 1;
    ceres::Solve(solver_options, &problem, &summary);
    if (summary.termination_type == ceres::FAILURE || !std::isfinite(summary.final_cost)) {
      result.status = StatusCode::kNoConvergence;
      result.message = summary.message;
      return result;
    }
    if (options.huber_threshold <= 0.0 || round + 1 == options.irls_rounds) break;
    // Reweight: Huber on each frame's whitened error norm, at a threshold
    // in robust standard deviations of the current errors.
    std::vector<std::vector<double>> norms(runs.size());
    std::vector<double> components;
    for (size_t r = 0; r < runs.size(); ++r) {
      RunData& rd = runs[r];
      const int m = rd.residuals_per_frame;
      std::vector<double> res(rd.frame_t.size() * m);
      const double* params[] = {base.data(), starts[r].data(), fx.values.data()};
      costs[r]->Evaluate(params, res.data(), nullptr);
      for (size_t j = 0; j < rd.frame_t.size(); ++j) {
        double sq = 0.0;
        for (int c = 0; c < m; ++c) {
          const double e = res[m * j + c] / rd.sqrt_w[j];
          sq += e * e;
          components.push_back(std::abs(e));
        }
        norms[r].push_back(std::sqrt(sq));
      }
    }
    const double robust_sigma = std::max(1.4826 * Median(components), 1e-12);
    for (size_t r = 0; r < runs.size(); ++r) {
      const double threshold =
          options.huber_threshold * robust_sigma * std::sqrt(double(runs[r].residuals_per_frame));
      for (size_t j = 0; j < runs[r].frame_t.size(); ++j)
        runs[r].sqrt_w[j] = norms[r][j] <= threshold ? 1.0 : std::sqrt(threshold / norms[r][j]);
    }
  }

  // Residuals, gap and the full Jacobian.
  const int n_cols = kBase + kFx + 3 * static_cast<int>(runs.size());
  int n_rows = 0;
  for (const RunData& rd : runs) n_rows += static_cast<int>(rd.frame_t.size()) * rd.residuals_per_frame;
  result.jacobian = Eigen::MatrixXd::Zero(n_rows, n_cols);
  Eigen::VectorXd whitened(n_rows);
  double sum_sq_gap = 0.0, sum_sq_noise = 0.0, lag_num = 0.0, lag_den = 0.0;
  int row = 0;
  for (size_t r = 0; r < runs.size(); ++r) {
    const RunData& rd = runs[r];
    const int m = rd.residuals_per_frame;
    const int rows = static_cast<int>(rd.frame_t.size()) * m;
    std::vector<double> res(rows);
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> jb(rows, kBase),
        js(rows, 3), jf(rows, kFx);
    const double* params[] = {base.data(), starts[r].data(), fx.values.data()};
    double* jacobians[] = {jb.data(), js.data(), jf.data()};
    costs[r]->Evaluate(params, res.data(), jacobians);
    result.jacobian.block(row, 0, rows, kBase) = jb;
    result.jacobian.block(row, kBase, rows, kFx) = jf;
    result.jacobian.block(row, kBase + kFx + 3 * static_cast<int>(r), rows, 3) = js;
    for (int i = 0; i < rows; ++i) whitened[row + i] = res[i];
    // Lag-one autocorrelation per residual component along the run.
    for (int c = 0; c < m; ++c)
      for (size_t j = 0; j + 1 < rd.frame_t.size(); ++j) {
        lag_num += res[m * j + c] * res[m * (j + 1) + c];
        lag_den += res[m * j + c] * res[m * j + c];
      }
    // The frames against the model, unweighted, for the report.
    std::vector<double> xs, ys, hs;
    DeadReckon(rd, constants, base.data(), starts[r].data(), fx.values.data(), &xs, &ys, &hs);
    for (size_t j = 0; j < rd.frame_t.size(); ++j) {
      double px, py, ph;
      PredictFrame(rd, constants, xs, ys, hs, fx.values.data(), rd.frame_t[j], &px, &py, &ph);
      FrameResidual fr;
      fr.run = rd.run;
      fr.t_s = rd.frame_t[j];
      const double tt = rd.frame_t[j] + fx.latency_s();
      const size_t k = std::min<size_t>(
          std::upper_bound(rd.t.begin(), rd.t.end(), tt) - rd.t.begin(), rd.t.size() - 1);
      fr.motion = rd.kind[k];
      fr.measured_m = {rd.zx[j], rd.zy[j]};
      fr.error_m = {px - rd.zx[j], py - rd.zy[j]};
      fr.heading_error_rad = WrapAngle(ph - rd.zh[j]);
      fr.measured_heading_rad = rd.zh[j];
      fr.weight = rd.sqrt_w[j] * rd.sqrt_w[j];
      sum_sq_gap += fr.error_m.squaredNorm();
      sum_sq_noise += 2.0 * rd.sigma_p[j] * rd.sigma_p[j];
      result.residuals.push_back(fr);
    }
    result.start_poses[rd.run] = Pose2::FromXYHeading(starts[r][0], starts[r][1], starts[r][2]);
    row += rows;
  }
  result.n_frames = static_cast<int>(result.residuals.size());
  result.gap_m = std::sqrt(sum_sq_gap / result.n_frames);
  result.noise_floor_m = std::sqrt(sum_sq_noise / result.n_frames);
  result.weighted_sse = whitened.squaredNorm();
  result.scales.r_left = base[0];
  result.scales.r_right = base[1];
  result.scales.Eb = base[2];
  result.effects = fx;

  // Identifiability and covariance over the fitted columns.
  std::vector<int> cols;
  std::vector<std::string> col_names = {"r_left", "r_right", "Eb"};
  for (int i = 0; i < kBase; ++i) cols.push_back(i);
  for (Effect e : options.effects) {
    const std::vector<int> idx = EffectParamIndices(e);
    const std::vector<std::string> names = EffectParamNames(e);
    for (size_t k = 0; k < idx.size(); ++k) {
      cols.push_back(kBase + idx[k]);
      col_names.push_back(std::string(ToString(e)) + "." + names[k]);
    }
  }
  for (size_t r = 0; r < runs.size(); ++r)
    for (int c = 0; c < 3; ++c) {
      cols.push_back(kBase + kFx + 3 * static_cast<int>(r) + c);
      col_names.push_back(session.runs[runs[r].run].name + ".start_" + "xyh"[c]);
    }
  const int p = static_cast<int>(cols.size());
  result.n_parameters = p;
  Eigen::MatrixXd J(n_rows, p);
  for (int c = 0; c < p; ++c) J.col(c) = result.jacobian.col(cols[c]);
  Eigen::VectorXd norms = J.colwise().norm();
  for (int c = 0; c < p; ++c) norms[c] = norms[c] > 0.0 ? norms[c] : 1.0;
  const Eigen::MatrixXd Jn = J * norms.cwiseInverse().asDiagonal();
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(Jn, Eigen::ComputeThinU | Eigen::ComputeThinV);
  const Eigen::VectorXd s = svd.singularValues();
  const Eigen::MatrixXd V = svd.matrixV();
  const Eigen::MatrixXd& U = svd.matrixU();
  result.condition_number = s[p - 1] > 0.0 ? s[0] / s[p - 1] : INFINITY;
  Eigen::MatrixXd cov_n = Eigen::MatrixXd::Zero(p, p);
  // The pseudo-inverse of J (normalised), p x N: how each whitened residual
  // moves the estimate.
  Eigen::MatrixXd pinv_n = Eigen::MatrixXd::Zero(p, n_rows);
  std::vector<Eigen::VectorXd> null_vectors;
  for (int i = 0; i < p; ++i) {
    if (s[i] > options.rank_tolerance * s[0]) {
      cov_n += V.col(i) * V.col(i).transpose() / (s[i] * s[i]);
      pinv_n += V.col(i) * U.col(i).transpose() / s[i];
    } else {
      null_vectors.push_back(V.col(i));
    }
  }
  const int dof = std::max(1, n_rows - (p - static_cast<int>(null_vectors.size())));
  const double rho = lag_den > 0.0 ? std::clamp(lag_num / lag_den, 0.0, 0.95) : 0.0;
  result.lag1_autocorrelation = rho;
  // Camera noise: the stated sigmas, scaled up when the residuals say they
  // are larger (never down: a fit is not more certain than its sensor).
  result.variance_factor = std::max(1.0, result.weighted_sse / dof);
  const Eigen::MatrixXd pinv = norms.cwiseInverse().asDiagonal() * pinv_n;
  Eigen::MatrixXd cov =
      norms.cwiseInverse().asDiagonal() * cov_n * norms.cwiseInverse().asDiagonal() *
      result.variance_factor;
  // Wheel noise: the ground travel of each wheel random-walks about the
  // ticks (sigma^2 per metre). A travel error at step k moves every later
  // pose rigidly (translation, and rotation about the pose at k); its effect
  // on the estimate is pinv * dr/dw. Suffix sums over the frames make this
  // O(steps * p) per run.
  if (options.wheel_sigma_m_per_sqrt_m > 0.0) {
    const double q = options.wheel_sigma_m_per_sqrt_m * options.wheel_sigma_m_per_sqrt_m;
    const double true_track = base[2] * constants.track_m;
    int row0 = 0;
    for (size_t r = 0; r < runs.size(); ++r) {
      const RunData& rd = runs[r];
      const int m = rd.residuals_per_frame;
      std::vector<double> xs, ys, hs;
      DeadReckon(rd, constants, base.data(), starts[r].data(), fx.values.data(), &xs, &ys, &hs);
      Eigen::VectorXd sx = Eigen::VectorXd::Zero(p), sy = sx, sh = sx, sxy = sx, syx = sx;
      int j = static_cast<int>(rd.frame_t.size()) - 1;
      for (int k = static_cast<int>(rd.t.size()) - 1; k >= 1; --k) {
        // Frames at or after the end of step k feel its noise.
        for (; j >= 0 && rd.frame_t[j] + fx.latency_s() >= rd.t[k]; --j) {
          const double g = rd.sqrt_w[j] / rd.sigma_p[j];
          const Eigen::VectorXd ax = pinv.col(row0 + m * j) * g;
          const Eigen::VectorXd ay = pinv.col(row0 + m * j + 1) * g;
          sx += ax;
          sy += ay;
          sxy += ax * rd.zy[j];
          syx += ay * rd.zx[j];
          if (m == 3) sh += pinv.col(row0 + m * j + 2) * (rd.sqrt_w[j] / rd.sigma_h[j]);
        }
        const double left = std::abs(rd.dl[k] * constants.left_m_per_tick * base[0]);
        const double right = std::abs(rd.dr[k] * constants.right_m_per_tick * base[1]);
        if (left == 0.0 && right == 0.0) continue;
        const Eigen::VectorXd gx = sx, gy = sy;
        const Eigen::VectorXd gh = sh - (sxy - ys[k] * sx) + (syx - xs[k] * sy);
        const double c = std::cos(hs[k]) / 2.0, sn = std::sin(hs[k]) / 2.0;
        const Eigen::VectorXd g_left = gx * c + gy * sn - gh / true_track;
        const Eigen::VectorXd g_right = gx * c + gy * sn + gh / true_track;
        cov += q * left * g_left * g_left.transpose() + q * right * g_right * g_right.transpose();
      }
      row0 += static_cast<int>(rd.frame_t.size()) * m;
    }
  }
  // What the wheel noise alone leaves of the gap once the fit has absorbed
  // what it can (start poses, scales): seeded Monte Carlo of the same random
  // walk, linearised: a travel error at step k moves every later frame
  // rigidly (translation along the heading, rotation about the pose at k);
  // the fit removes its projection on J. Explain's `unexplained` needs it:
  // with a precise camera the wheel noise, not the camera, sets the floor.
  if (options.wheel_sigma_m_per_sqrt_m > 0.0 && options.wheel_noise_draws > 0) {
    std::mt19937 rng(20261123);
    std::normal_distribution<double> normal(0.0, 1.0);
    const double sigma_w = options.wheel_sigma_m_per_sqrt_m;
    const double true_track = base[2] * constants.track_m;
    double sum_sq = 0.0;
    for (int draw = 0; draw < options.wheel_noise_draws; ++draw) {
      Eigen::VectorXd delta = Eigen::VectorXd::Zero(n_rows);
      int row0 = 0;
      for (size_t r = 0; r < runs.size(); ++r) {
        const RunData& rd = runs[r];
        const int m = rd.residuals_per_frame;
        std::vector<double> xs, ys, hs;
        DeadReckon(rd, constants, base.data(), starts[r].data(), fx.values.data(), &xs, &ys, &hs);
        // Displacement of a later point p: c + theta * (-p.y, p.x).
        double cx = 0.0, cy = 0.0, theta = 0.0;
        size_t j = 0;
        auto assign_until = [&](double t) {
          for (; j < rd.frame_t.size() && rd.frame_t[j] + fx.latency_s() < t; ++j) {
            const double g = rd.sqrt_w[j] / rd.sigma_p[j];
            delta[row0 + m * j] = (cx - theta * rd.zy[j]) * g;
            delta[row0 + m * j + 1] = (cy + theta * rd.zx[j]) * g;
            if (m == 3) delta[row0 + m * j + 2] = theta * rd.sqrt_w[j] / rd.sigma_h[j];
          }
        };
        for (size_t k = 1; k < rd.t.size(); ++k) {
          assign_until(rd.t[k]);
          const double left = std::abs(rd.dl[k] * constants.left_m_per_tick * base[0]);
          const double right = std::abs(rd.dr[k] * constants.right_m_per_tick * base[1]);
          if (left == 0.0 && right == 0.0) continue;
          const double el = sigma_w * std::sqrt(left) * normal(rng);
          const double er = sigma_w * std::sqrt(right) * normal(rng);
          const double ds = 0.5 * (el + er), dtheta = (er - el) / true_track;
          cx += ds * std::cos(hs[k]) + dtheta * ys[k];
          cy += ds * std::sin(hs[k]) - dtheta * xs[k];
          theta += dtheta;
        }
        assign_until(INFINITY);
        row0 += static_cast<int>(rd.frame_t.size()) * m;
      }
      const Eigen::VectorXd left_over = delta - J * (pinv * delta);
      row0 = 0;
      for (const RunData& rd : runs) {
        const int m = rd.residuals_per_frame;
        for (size_t j = 0; j < rd.frame_t.size(); ++j) {
          const double g = rd.sqrt_w[j] / rd.sigma_p[j];
          sum_sq += (left_over[row0 + m * j] * left_over[row0 + m * j] +
                     left_over[row0 + m * j + 1] * left_over[row0 + m * j + 1]) /
                    (g * g);
        }
        row0 += static_cast<int>(rd.frame_t.size()) * m;
      }
    }
    result.wheel_noise_gap_m = std::sqrt(sum_sq / (options.wheel_noise_draws * result.n_frames));
  }
  // The camera's length scale: a common factor (1 + e) on every measured
  // position moves the estimate by pinv * (z / sigma) e.
  if (session.camera_scale_sigma > 0.0) {
    Eigen::VectorXd b = Eigen::VectorXd::Zero(n_rows);
    int row0 = 0;
    for (const RunData& rd : runs) {
      const int m = rd.residuals_per_frame;
      for (size_t j = 0; j < rd.frame_t.size(); ++j) {
        const double g = rd.sqrt_w[j] / rd.sigma_p[j];
        b[row0 + m * j] = rd.zx[j] * g;
        b[row0 + m * j + 1] = rd.zy[j] * g;
      }
      row0 += static_cast<int>(rd.frame_t.size()) * m;
    }
    const Eigen::VectorXd v = pinv * b;
    cov += session.camera_scale_sigma * session.camera_scale_sigma * v * v.transpose();
  }
  // The effect block's covariance (for significance tests of candidates).
  result.effect_covariance.setZero();
  {
    std::vector<int> fx_index;  // column c of cov -> EffectParams index
    for (Effect e : options.effects)
      for (int idx : EffectParamIndices(e)) fx_index.push_back(idx);
    for (size_t a = 0; a < fx_index.size(); ++a)
      for (size_t b = 0; b < fx_index.size(); ++b)
        result.effect_covariance(fx_index[a], fx_index[b]) = cov(kBase + a, kBase + b);
  }
  // A direction in parameter space is estimable when it is orthogonal to
  // every null vector (in the normalised coordinates).
  auto estimable = [&](const Eigen::VectorXd& gradient) {
    const Eigen::VectorXd g = gradient.cwiseQuotient(norms);  // to normalised coordinates
    if (g.norm() == 0.0) return true;
    for (const Eigen::VectorXd& v : null_vectors)
      if (std::abs(g.normalized().dot(v)) > 0.02) return false;
    return true;
  };
  for (const Eigen::VectorXd& v : null_vectors) {
    std::vector<int> order(p);
    std::iota(order.begin(), order.end(), 0);
    std::sort(order.begin(), order.end(), [&](int a, int b) { return std::abs(v[a]) > std::abs(v[b]); });
    std::ostringstream os;
    os << "the combination";
    for (int k = 0; k < std::min(p, 4); ++k) {
      if (std::abs(v[order[k]]) < 0.1) break;
      os << " " << (v[order[k]] >= 0 ? "+" : "-") << Fixed(std::abs(v[order[k]]), 2) << " "
         << col_names[order[k]];
    }
    os << " (normalised) does not change what was measured";
    result.unidentifiable.push_back(os.str());
  }
  auto estimate = [&](const std::string& name, double value, const Eigen::VectorXd& gradient) {
    ParameterEstimate e;
    e.name = name;
    e.value = value;
    e.identifiable = estimable(gradient);
    e.sigma = std::sqrt(std::max(0.0, gradient.dot(cov * gradient)));
    result.parameters.push_back(e);
  };
  // Ed = r_r / r_l; Es = (r_l D_L + r_r D_R) / (D_L + D_R); Eb.
  const double dl = session.believed.left_wheel_diameter_m,
               dr = session.believed.right_wheel_diameter_m;
  Eigen::VectorXd g = Eigen::VectorXd::Zero(p);
  g[0] = -base[1] / (base[0] * base[0]);
  g[1] = 1.0 / base[0];
  estimate("Ed", base[1] / base[0], g);
  g.setZero();
  g[0] = dl / (dl + dr);
  g[1] = dr / (dl + dr);
  estimate("Es", (base[0] * dl + base[1] * dr) / (dl + dr), g);
  g.setZero();
  g[2] = 1.0;
  estimate("Eb", base[2], g);
  // The turn gain Eb / Es (what UMBMark measures; free of the camera's scale).
  {
    const double es = (base[0] * dl + base[1] * dr) / (dl + dr);
    g.setZero();
    g[0] = -base[2] / (es * es) * dl / (dl + dr);
    g[1] = -base[2] / (es * es) * dr / (dl + dr);
    g[2] = 1.0 / es;
    estimate("turn_gain", base[2] / es, g);
  }
  // A ratio whose uncertainty spans more than its plausible range is not
  // determined by these data, whatever the rank test says (a nearly flat
  // direction just above the tolerance).
  for (ParameterEstimate& e : result.parameters)
    if (e.identifiable && e.sigma > options.max_ratio_sigma) {
      e.identifiable = false;
      result.unidentifiable.push_back(e.name + ": sigma " + Fixed(e.sigma, 4) +
                                      " exceeds the plausible range of a ratio (" +
                                      Fixed(options.max_ratio_sigma, 3) + ")");
    }
  int c = kBase;
  for (Effect e : options.effects) {
    const std::string prefix = std::string(ToString(e)) + ".";
    if (e == Effect::kCarpetDrift) {
      const double a = fx.values[EffectParams::kDriftA], b = fx.values[EffectParams::kDriftB];
      const double rate = std::hypot(a, b);
      g.setZero();
      if (rate > 0.0) {
        g[c] = -b / (rate * rate);
        g[c + 1] = a / (rate * rate);
      }
      estimate(prefix + "grain_rad", std::atan2(b, a), g);
      g.setZero();
      if (rate > 0.0) {
        g[c] = a / rate;
        g[c + 1] = b / rate;
      }
      estimate(prefix + "rate_m_per_m", rate, g);
      c += 2;
      continue;
    }
    const std::vector<int> idx = EffectParamIndices(e);
    const std::vector<std::string> names = EffectParamNames(e);
    for (size_t k = 0; k < idx.size(); ++k, ++c) {
      g.setZero();
      g[c] = 1.0;
      estimate(prefix + names[k], fx.values[idx[k]], g);
    }
  }

  result.status = StatusCode::kOk;
  if (!summary.IsSolutionUsable()) {
    result.status = StatusCode::kNoConvergence;
    result.message = summary.message;
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
                                        int left_direction0, int right_direction0) {
  RunData rd = ExtractTelemetry(run, 0, &left_direction0, &right_direction0);
  if (rd.t.size() < 2) return {};
  const ModelConstants constants = ConstantsOf(believed, camera);
  MarkArcs(constants, &rd);
  const double base[kBase] = {scales.r_left, scales.r_right, scales.Eb};
  const double start_xyh[3] = {start.x(), start.y(), start.heading()};
  std::vector<double> xs, ys, hs;
  DeadReckon(rd, constants, base, start_xyh, effects.values.data(), &xs, &ys, &hs);
  std::vector<Pose2> poses;
  poses.reserve(stamps_s.size());
  for (double stamp : stamps_s) {
    double px, py, ph;
    PredictFrame(rd, constants, xs, ys, hs, effects.values.data(), stamp, &px, &py, &ph);
    poses.push_back(Pose2::FromXYHeading(px, py, ph));
  }
  return poses;
}

std::vector<double> ArcCurvatures(const MeasuredRun& run, const WheelParams& believed) {
  int left_direction = 1, right_direction = 1;
  RunData rd = ExtractTelemetry(run, 0, &left_direction, &right_direction);
  MarkArcs(ConstantsOf(believed, std::nullopt), &rd);
  return rd.curvature;
}

void LastShaftDirections(const MeasuredRun& run, int* left_direction, int* right_direction) {
  ExtractTelemetry(run, 0, left_direction, right_direction);
}

AliasReport CheckAliasing(const TrajectoryFitResult& fit, Effect candidate,
                          double alias_tolerance) {
  AliasReport report;
  report.effect = candidate;
  report.distinguishing_runs = DistinguishingRuns(candidate);
  const Eigen::MatrixXd& J = fit.jacobian;
  if (J.size() == 0) return report;
  // Fitted columns: base, enabled effects, start poses.
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
  for (int c = kBase + kFx; c < J.cols(); ++c) {
    cols.push_back(c);
    names.push_back("the runs' start poses");
  }
  Eigen::MatrixXd A(J.rows(), cols.size());
  for (size_t c = 0; c < cols.size(); ++c) {
    const double n = J.col(cols[c]).norm();
    A.col(c) = n > 0.0 ? Eigen::VectorXd(J.col(cols[c]) / n) : Eigen::VectorXd(J.col(cols[c]));
  }
  Eigen::MatrixXd C(J.rows(), idx.size());
  for (size_t k = 0; k < idx.size(); ++k) {
    const double n = J.col(kBase + idx[k]).norm();
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
