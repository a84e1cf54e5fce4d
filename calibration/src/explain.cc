#include "odocal/calibration/explain.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <map>
#include <optional>
#include <sstream>

#include <boost/math/distributions/chi_squared.hpp>

#include "odocal/base/format.h"
#include "odocal/base/parallel.h"
#include "odocal/base/units.h"
#include "odocal/calibration/effect_registry.h"
#include "odocal/calibration/pose2.h"

namespace odocal::calibration {
namespace {

bool Contains(const std::vector<Effect>& effects, Effect e) {
  return std::find(effects.begin(), effects.end(), e) != effects.end();
}

// The BIC drop from `before` to `after` (positive: `after` explains more
// than its added parameters cost).
double BicScore(const TrajectoryFitResult& before, const TrajectoryFitResult& after) {
  const double n = static_cast<double>(after.n_residuals);
  const double rho = after.lag1_autocorrelation;
  const double n_eff = std::max(1.0, n * (1.0 - rho) / (1.0 + rho));
  const int k = after.n_parameters - before.n_parameters;
  if (!(after.weighted_sse > 0.0) || !(before.weighted_sse > 0.0)) return 0.0;
  return n_eff * std::log(before.weighted_sse / after.weighted_sse) - k * std::log(n_eff);
}

std::vector<ParameterEstimate> ParamsOf(const TrajectoryFitResult& fit, Effect e) {
  std::vector<ParameterEstimate> out;
  const std::string prefix = std::string(ToString(e)) + ".";
  for (const ParameterEstimate& p : fit.parameters)
    if (p.name.rfind(prefix, 0) == 0) {
      ParameterEstimate q = p;
      q.name = p.name.substr(prefix.size());
      out.push_back(q);
    }
  return out;
}

unsigned Threads(const ExplainOptions& options) { return options.threads > 0 ? static_cast<unsigned>(options.threads) : 0u; }

// A fit kept only for its parameters: its residuals hold the whole session.
void DropResiduals(TrajectoryFitResult* fit) {
  fit->residuals.clear();
  fit->residuals.shrink_to_fit();
}

// The folds of a cross-validation by run over the runs `fit` used: each run
// alone (leave one out), or run j of them in fold j mod k.
std::vector<std::vector<int>> Folds(const TrajectoryFitResult& fit, const ExplainOptions& options,
                                    std::string* method) {
  std::vector<int> used;
  for (size_t i = 0; i < fit.run_used.size(); ++i)
    if (fit.run_used[i]) used.push_back(static_cast<int>(i));
  std::vector<std::vector<int>> folds;
  if (used.size() < 2) {
    *method = "none";
    return folds;
  }
  if (static_cast<int>(used.size()) <= options.max_leave_one_out_runs) {
    *method = "leave_one_run_out";
    for (int i : used) folds.push_back({i});
  } else {
    *method = "k_fold";
    folds.resize(options.k_folds);
    for (size_t j = 0; j < used.size(); ++j) folds[j % options.k_folds].push_back(used[j]);
  }
  return folds;
}

// The model without the candidate, fitted on each fold's training runs
// (shared by the candidates of one round).
struct FoldFits {
  std::vector<std::vector<int>> folds;
  std::string method;
  std::vector<MeasuredSession> training;
  std::vector<TrajectoryFitResult> without;
  // Each run's wheel directions before it (encoder_backlash), from the whole session.
  std::vector<std::pair<int, int>> directions;
};

FoldFits PrepareFolds(const MeasuredSession& session, const TrajectoryFitResult& current,
                      const ExplainOptions& options) {
  FoldFits f;
  f.folds = Folds(current, options, &f.method);
  int left = 1, right = 1;
  for (const MeasuredRun& run : session.runs) {
    f.directions.push_back({left, right});
    LastShaftDirections(run, &left, &right);
  }
  TrajectoryFitOptions o = options.fit;
  o.effects = current.options.effects;
  for (const std::vector<int>& fold : f.folds) {
    MeasuredSession train = session;
    train.runs.clear();
    for (size_t i = 0; i < session.runs.size(); ++i)
      if (std::find(fold.begin(), fold.end(), static_cast<int>(i)) == fold.end())
        train.runs.push_back(session.runs[i]);
    f.training.push_back(std::move(train));
  }
  f.without.resize(f.folds.size());
  ParallelFor(f.folds.size(), Threads(options), [&](size_t k) {
    f.without[k] = FitTrajectory(f.training[k], o);
    DropResiduals(&f.without[k]);
  });
  return f;
}

CrossValidation CrossValidate(const MeasuredSession& session, const TrajectoryFitResult& current,
                              Effect candidate, const ExplainOptions& options, FoldFits* folds) {
  CrossValidation cv;
  cv.method = folds->method;
  if (!cv.possible()) {
    cv.note = "one run: cross-validation by run is not possible; the other gates decide";
    return cv;
  }
  cv.folds = static_cast<int>(folds->folds.size());
  TrajectoryFitOptions o = options.fit;
  o.effects = current.options.effects;
  o.effects.push_back(candidate);
  // Each fold's refit with the candidate and its held-out replays, in
  // parallel; summed afterwards in fold order (the same sums whatever the
  // threads).
  struct FoldOutcome {
    bool fitted = false;
    int failed_replays = 0;
    std::vector<std::pair<double, double>> squares;  // per replayed run: before, after
  };
  std::vector<FoldOutcome> outcomes(folds->folds.size());
  ParallelFor(folds->folds.size(), Threads(options), [&](size_t k) {
    const TrajectoryFitResult& without = folds->without[k];
    if (!without.ok()) return;
    const TrajectoryFitResult with = FitTrajectory(folds->training[k], o, &without);
    if (!with.ok()) return;
    FoldOutcome& out = outcomes[k];
    out.fitted = true;
    for (int i : folds->folds[k]) {
      ReplayOptions ro = options.replay;
      ro.left_direction0 = folds->directions[i].first;
      ro.right_direction0 = folds->directions[i].second;
      const RunReplay a = ReplayRun(session.runs[i], session.believed,
                                    {without.scales, without.effects}, session.camera, ro);
      const RunReplay b = ReplayRun(session.runs[i], session.believed, {with.scales, with.effects},
                                    session.camera, ro);
      if (!a.ok() || !b.ok()) {
        ++out.failed_replays;
        continue;
      }
      out.squares.emplace_back(a.rms_position_error_m * a.rms_position_error_m,
                               b.rms_position_error_m * b.rms_position_error_m);
    }
  });
  double sum_before = 0.0, sum_after = 0.0;
  int failed_fits = 0, failed_replays = 0;
  for (const FoldOutcome& out : outcomes) {
    if (!out.fitted) {
      ++failed_fits;
      continue;
    }
    failed_replays += out.failed_replays;
    for (const auto& [before, after] : out.squares) {
      sum_before += before;
      sum_after += after;
      ++cv.heldout_runs;
    }
  }
  if (failed_fits > 0)
    cv.note += std::to_string(failed_fits) + " fold fit(s) failed and were left out; ";
  if (failed_replays > 0)
    cv.note += std::to_string(failed_replays) + " held-out run(s) could not be replayed; ";
  if (cv.heldout_runs == 0) {
    cv.method = "none";
    cv.note += "no held-out run could be replayed: the other gates decide";
    return cv;
  }
  cv.heldout_rms_before_m = std::sqrt(sum_before / cv.heldout_runs);
  cv.heldout_rms_after_m = std::sqrt(sum_after / cv.heldout_runs);
  const double gain = cv.heldout_rms_before_m - cv.heldout_rms_after_m;
  cv.improved = gain > options.cv_min_relative_gain * cv.heldout_rms_before_m &&
                gain > options.cv_min_gain_m;
  return cv;
}

}  // namespace

bool ExplainOptions::IsValid(std::string* why) const {
  if (!fit.IsValid(why)) return false;
  if (!(min_explained_m >= 0.0)) {
    if (why) *why = "min_explained_m must not be negative";
    return false;
  }
  if (!(min_score >= 0.0)) {
    if (why) *why = "min_score must not be negative";
    return false;
  }
  if (threads < 0) {
    if (why) *why = "threads must not be negative";
    return false;
  }
  if (max_effects < 0) {
    if (why) *why = "max_effects must not be negative";
    return false;
  }
  if (!(wald_alpha > 0.0 && wald_alpha < 1.0)) {
    if (why) *why = "wald_alpha must be in (0, 1)";
    return false;
  }
  if (!(alias_tolerance > 0.0 && alias_tolerance < 1.0)) {
    if (why) *why = "alias_tolerance must be in (0, 1)";
    return false;
  }
  if (max_leave_one_out_runs < 2 || k_folds < 2) {
    if (why) *why = "max_leave_one_out_runs and k_folds must be at least 2";
    return false;
  }
  if (!(cv_min_relative_gain >= 0.0 && cv_min_relative_gain < 1.0) || !(cv_min_gain_m >= 0.0)) {
    if (why) *why = "cv_min_relative_gain must be in [0, 1) and cv_min_gain_m not negative";
    return false;
  }
  if (!replay.IsValid(why)) return false;
  if (!(unexplained_alpha > 0.0 && unexplained_alpha < 1.0) || !(unexplained_min_excess_m >= 0.0) ||
      !(unexplained_segment_ratio >= 1.0) ||
      !(unexplained_local_ratio >= 1.0) || unexplained_min_frames < 1 ||
      unexplained_max_reported < 1) {
    if (why) *why = "unexplained options: alpha in (0, 1), ratios >= 1, counts >= 1";
    return false;
  }
  return true;
}

ResidualSummary SummariseResiduals(const MeasuredSession& session, const TrajectoryFitResult& fit) {
  ResidualSummary s;
  std::map<int, std::pair<int, double>> motion, run;
  for (const FrameResidual& r : fit.residuals) {
    const double e2 = r.error_m.squaredNorm();
    auto& m = motion[static_cast<int>(r.motion)];
    m.first++;
    m.second += e2;
    auto& u = run[r.run];
    u.first++;
    u.second += e2;
  }
  for (const auto& [kind, acc] : motion)
    s.by_motion.push_back({std::string(ToString(static_cast<MotionKind>(kind))), acc.first,
                           std::sqrt(acc.second / acc.first)});
  for (const auto& [index, acc] : run)
    s.by_run.push_back({session.runs[index].name, acc.first, std::sqrt(acc.second / acc.first)});
  std::vector<const FrameResidual*> sorted;
  for (const FrameResidual& r : fit.residuals) sorted.push_back(&r);
  const size_t n_worst = std::min<size_t>(5, sorted.size());
  std::partial_sort(sorted.begin(), sorted.begin() + n_worst, sorted.end(),
                    [](const FrameResidual* a, const FrameResidual* b) {
                      return a->error_m.squaredNorm() > b->error_m.squaredNorm();
                    });
  for (size_t i = 0; i < n_worst; ++i)
    s.worst.push_back({session.runs[sorted[i]->run].name, sorted[i]->t_s, sorted[i]->motion,
                       sorted[i]->error_m.norm()});
  return s;
}

std::vector<std::string> ExplainResult::EffectsAdded() const {
  std::vector<std::string> names;
  for (const ExplainStep& s : steps) names.emplace_back(ToString(s.effect));
  return names;
}

std::string ExplainResult::BriefReport() const {
  std::ostringstream os;
  if (status != StatusCode::kOk) {
    os << "explain: " << message << "\n";
    return os.str();
  }
  os << "base model: gap " << Fixed(gap_before_m() * kMToMm, 3) << " mm (noise floor "
     << Fixed(base.noise_floor_m * kMToMm, 3) << " mm)\n";
  for (const auto& g : base_residuals.by_motion)
    os << "  during " << std::left << std::setw(9) << g.label << std::right << Fixed(g.rms_m * kMToMm, 3)
       << " mm RMS over " << g.n << " frames\n";
  for (const ExplainStep& s : steps) {
    os << "+ " << ToString(s.effect) << ": score " << Fixed(s.score, 1) << ", gap " << Fixed(s.gap_after_m * kMToMm, 3)
       << " mm;";
    for (const ParameterEstimate& p : s.params) {
      os << " " << p.name << " " << std::setprecision(5) << p.value << " +/- "
         << std::setprecision(2) << 1.959963985 * p.sigma;
      if (std::isfinite(p.sigma_between_runs))
        os << " (between runs +/- " << 1.959963985 * p.sigma_between_runs << ")";
    }
    if (std::isfinite(s.between_runs_z) && !s.holds_across_runs())
      os << "; NOT from run to run (" << Fixed(s.between_runs_z, 1) << " sigma between runs)";
    const CrossValidation& cv = s.cross_validation;
    if (cv.possible())
      os << "; held-out RMS " << Fixed(cv.heldout_rms_before_m * kMToMm, 3) << " -> "
         << Fixed(cv.heldout_rms_after_m * kMToMm, 3) << " mm (" << cv.method << ", " << cv.folds << " folds)";
    else
      os << "; " << cv.note;
    os << "\n";
  }
  for (const CandidateTrial& t : rejected)
    if (t.cross_validation && t.cross_validation->possible())
      os << "- " << ToString(t.effect) << ": passed the fit's gates (score " << Fixed(t.score, 1)
         << ") but does not predict held-out runs better: RMS "
         << Fixed(t.cross_validation->heldout_rms_before_m * kMToMm, 3) << " -> "
         << Fixed(t.cross_validation->heldout_rms_after_m * kMToMm, 3) << " mm\n";
  if (steps.empty()) os << "no effect explains a significant part of the gap\n";
  for (const AliasReport& a : aliased) {
    os << "? " << ToString(a.effect) << ": "
       << (a.no_signal ? "these data carry no signal of it"
                       : "indistinguishable here from the fitted model");
    if (!a.no_signal) {
      os << " (looks like";
      for (const std::string& l : a.looks_like) os << " " << l;
      os << ")";
    }
    os << "; to tell: " << a.distinguishing_runs << "\n";
  }
  const UnexplainedReport& u = unexplained;
  os << "remainder: gap " << Fixed(u.gap_m * kMToMm, 3) << " mm against " << Fixed(u.expected_gap_m * kMToMm, 3)
     << " mm expected from the camera and wheel noise (wheels " << Fixed(u.wheel_noise_gap_m * kMToMm, 3) << " mm); F "
     << Fixed(u.ratio, 2) << " vs " << Fixed(u.threshold, 2) << " ("
     << (u.significant ? "significant" : "not significant") << ")\n";
  for (const UnexplainedSegment& w : u.where)
    os << "! unexplained: " << w.run << " " << Fixed(w.t_from_s, 2) << "-" << Fixed(w.t_to_s, 2) << " s, " << w.motion
       << ", " << Fixed(w.size_m * kMToMm, 3) << " mm RMS over " << w.frames << " frames\n";
  os << "final: gap " << Fixed(gap_after_m() * kMToMm, 3) << " mm\n" << final_fit.BriefReport();
  return os.str();
}

namespace {

// Explain's steps, in order.

// What the model says of candidate `e` beside `current`: aliased with it, or
// without signal when the session lacks the input it needs (MissingInput).
AliasReport AliasOrMissing(const MeasuredSession& session, const TrajectoryFitResult& current, Effect e,
                           double alias_tolerance) {
  AliasReport a;
  if (const std::string missing = MissingInput(session, e); !missing.empty()) {
    a.effect = e;
    a.aliased = a.no_signal = true;
    a.distinguishing_runs = missing;
    return a;
  }
  return CheckAliasing(current, e, alias_tolerance);
}

// The candidates not yet in `current`, in order, each with its aliasing;
// `to_fit` gets the indices of those that can be fitted.
std::vector<CandidateTrial> FormTrials(const MeasuredSession& session, const TrajectoryFitResult& current,
                                       const ExplainOptions& options, std::vector<size_t>* to_fit) {
  std::vector<CandidateTrial> trials;
  for (Effect e : options.candidates) {
    if (Contains(current.options.effects, e)) continue;
    CandidateTrial trial;
    trial.effect = e;
    trial.alias = AliasOrMissing(session, current, e, options.alias_tolerance);
    if (!trial.alias.aliased) to_fit->push_back(trials.size());
    trials.push_back(trial);
  }
  return trials;
}

// The fittable trials refitted with `current`'s effects and theirs (in
// parallel), each scored: BIC, the gap it explains, its Wald statistic.
std::vector<TrajectoryFitResult> FitTrials(const MeasuredSession& session, const TrajectoryFitResult& current,
                                           const TrajectoryFitOptions& fit_options, const ExplainOptions& options,
                                           const std::vector<size_t>& to_fit, std::vector<CandidateTrial>* trials) {
  std::vector<TrajectoryFitResult> fits(to_fit.size());
  ParallelFor(to_fit.size(), Threads(options), [&](size_t k) {
    TrajectoryFitOptions o = fit_options;
    o.effects = current.options.effects;
    o.effects.push_back((*trials)[to_fit[k]].effect);
    fits[k] = FitTrajectory(session, o, &current);
  });
  for (size_t k = 0; k < to_fit.size(); ++k) {
    CandidateTrial& trial = (*trials)[to_fit[k]];
    const Effect e = trial.effect;
    const TrajectoryFitResult& f = fits[k];
    trial.fitted = f.ok();
    if (f.ok()) {
      trial.score = BicScore(current, f);
      trial.gap_m = f.gap_m;
      trial.explained_m = std::sqrt(std::max(0.0, current.gap_m * current.gap_m - f.gap_m * f.gap_m));
      trial.wald = f.Wald(e);
      const int dof = static_cast<int>(EffectTestedIndices(e).size());
      trial.wald_threshold =
          boost::math::quantile(boost::math::complement(boost::math::chi_squared(dof), options.wald_alpha));
    }
  }
  return fits;
}

// The trial to name: of those that pass the three gates, best score first,
// the first that also predicts held-out runs better; its fit, or nullptr.
const TrajectoryFitResult* ChooseTrial(const MeasuredSession& session, const TrajectoryFitResult& current,
                                       const ExplainOptions& options, const std::vector<TrajectoryFitResult>& fits,
                                       std::vector<CandidateTrial>* trials, ExplainStep* step) {
  std::vector<size_t> passing;
  for (size_t i = 0; i < trials->size(); ++i) {
    const CandidateTrial& t = (*trials)[i];
    if (t.fitted && t.wald > t.wald_threshold && t.explained_m >= options.min_explained_m &&
        t.score >= options.min_score)
      passing.push_back(i);
  }
  std::sort(passing.begin(), passing.end(),
            [&](size_t a, size_t b) { return (*trials)[a].score > (*trials)[b].score; });
  std::optional<FoldFits> folds;
  for (size_t i : passing) {
    CandidateTrial& t = (*trials)[i];
    CrossValidation cv;
    if (options.cross_validate) {
      if (!folds) folds = PrepareFolds(session, current, options);
      t.cross_validation = CrossValidate(session, current, t.effect, options, &*folds);
      if (t.cross_validation->possible() && !t.cross_validation->improved) continue;
      cv = *t.cross_validation;
    } else {
      cv.note = "cross-validation turned off";
    }
    const TrajectoryFitResult* best = nullptr;
    for (const TrajectoryFitResult& f : fits)
      if (f.ok() && f.options.effects.back() == t.effect) best = &f;
    step->effect = t.effect;
    step->score = t.score;
    step->cross_validation = cv;
    return best;
  }
  return nullptr;
}

// Every step's parameters from the final fit (they were refitted together
// as effects were added), and how far the runs' disagreement keeps each from
// zero.
void RefreshSteps(const TrajectoryFitResult& final_fit, std::vector<ExplainStep>* steps) {
  for (ExplainStep& s : *steps) {
    s.params = ParamsOf(final_fit, s.effect);
    const auto& not_compared = Describe(s.effect).not_compared_across_runs;
    for (const ParameterEstimate& p : s.params) {
      if (std::find(not_compared.begin(), not_compared.end(), p.name) != not_compared.end()) continue;
      if (std::isfinite(p.sigma_between_runs) && p.sigma_between_runs > 0.0)  // fmax: NaN loses
        s.between_runs_z = std::fmax(s.between_runs_z, std::abs(p.value) / p.sigma_between_runs);
    }
  }
}

}  // namespace

ExplainResult Explain(const MeasuredSession& session, const ExplainOptions& options) {
  ExplainResult result;
  std::string why;
  if (!options.IsValid(&why)) {
    result.message = "options: " + why;
    return result;
  }
  TrajectoryFitOptions fit_options = options.fit;
  fit_options.effects.clear();
  result.base = FitTrajectory(session, fit_options);
  if (!result.base.ok()) {
    result.status = result.base.status == StatusCode::kInvalidArgument
                        ? StatusCode::kInvalidArgument
                        : StatusCode::kNoConvergence;
    result.message = "base fit: " + result.base.message;
    return result;
  }
  result.base_residuals = SummariseResiduals(session, result.base);
  TrajectoryFitResult current = result.base;

  // Round by round: form the candidates, fit them, name the best that passes
  // every gate, until none does.
  while (static_cast<int>(current.options.effects.size()) < options.max_effects) {
    std::vector<size_t> to_fit;  // indices into trials
    std::vector<CandidateTrial> trials = FormTrials(session, current, options, &to_fit);
    const std::vector<TrajectoryFitResult> fits = FitTrials(session, current, fit_options, options, to_fit, &trials);
    ExplainStep step;
    const TrajectoryFitResult* best = ChooseTrial(session, current, options, fits, &trials, &step);
    if (!best) {
      result.rejected = trials;
      break;
    }
    step.gap_after_m = best->gap_m;
    step.trials = trials;
    current = *best;
    step.params = ParamsOf(current, step.effect);
    result.steps.push_back(step);
  }
  if (options.jackknife_final) AddRunJackknife(session, &current, options.threads);
  RefreshSteps(current, &result.steps);
  result.final_fit = current;
  result.final_residuals = SummariseResiduals(session, current);
  for (Effect e : options.candidates) {
    if (Contains(current.options.effects, e)) continue;
    const AliasReport a = AliasOrMissing(session, current, e, options.alias_tolerance);
    if (a.aliased) result.aliased.push_back(a);
  }
  result.unexplained = FindUnexplained(session, current, options);
  result.status = StatusCode::kOk;
  return result;
}

namespace {

// FindUnexplained's steps, in order.

// How many independent samples n samples with lag-1 autocorrelation rho are
// worth.
double EffectiveSamples(double n, double rho) { return std::max(1.0, n * (1.0 - rho) / (1.0 + rho)); }

// The mean square of 2 n_eff standard normal components, over the variance,
// that chance exceeds with probability alpha.
double MeanSquareThreshold(double n_eff, double alpha) {
  const double dof = 2.0 * n_eff;
  return boost::math::quantile(boost::math::complement(boost::math::chi_squared(dof), alpha)) / dof;
}

// Contiguous frames of one motion in one run, with their sums.
struct ResidualSegment {
  UnexplainedSegment s;
  double sum_sq = 0.0;
  double turned_rad = 0.0;
  double last_heading = 0.0;
  MotionKind kind = MotionKind::kRest;
};

// The fit's residuals cut into segments: contiguous frames of one motion in
// one run.
std::vector<ResidualSegment> SegmentResiduals(const MeasuredSession& session, const TrajectoryFitResult& fit) {
  std::vector<ResidualSegment> segments;
  for (const FrameResidual& r : fit.residuals) {
    if (segments.empty() || segments.back().s.run_index != r.run ||
        segments.back().kind != r.motion) {
      ResidualSegment g;
      g.s.run_index = r.run;
      g.s.run = session.runs[r.run].name;
      g.s.t_from_s = r.t_s;
      g.kind = r.motion;
      g.last_heading = r.measured_heading_rad;
      segments.push_back(g);
    }
    ResidualSegment& g = segments.back();
    g.s.t_to_s = r.t_s;
    g.s.frames++;
    g.sum_sq += r.error_m.squaredNorm();
    g.turned_rad += WrapAngle(r.measured_heading_rad - g.last_heading);
    g.last_heading = r.measured_heading_rad;
  }
  return segments;
}

// A segment to report, with its share of the excess (frames times its
// excess mean square).
struct FlaggedSegment {
  double contribution;
  UnexplainedSegment s;
};

// The segments to report, largest contribution first: those far above the
// expected gap, and when the whole is significant also those that carry
// most of it.
std::vector<FlaggedSegment> FlagSegments(std::vector<ResidualSegment> segments, const UnexplainedReport& u,
                                         double expected_sq, double rho, const ExplainOptions& options) {
  std::vector<FlaggedSegment> flagged, candidates;
  const double n_segments = static_cast<double>(segments.size());
  for (ResidualSegment& g : segments) {
    if (g.s.frames < options.unexplained_min_frames) continue;
    const double ms = g.sum_sq / g.s.frames;
    g.s.size_m = std::sqrt(ms);
    g.s.motion = std::string(ToString(g.kind));
    if (g.kind == MotionKind::kStraight && std::abs(g.turned_rad) > DegToRad(15.0)) g.s.motion = "curve";
    const double excess = std::sqrt(std::max(0.0, ms - expected_sq));
    const FlaggedSegment f{g.s.frames * (ms - expected_sq), g.s};
    if (excess < options.unexplained_min_excess_m) continue;
    const double local =
        std::max(options.unexplained_local_ratio * options.unexplained_local_ratio,
                 MeanSquareThreshold(EffectiveSamples(g.s.frames, rho), options.unexplained_alpha / n_segments));
    if (ms / expected_sq > local ||
        (u.significant && ms > options.unexplained_segment_ratio *
                                   options.unexplained_segment_ratio * expected_sq))
      flagged.push_back(f);
    else if (u.significant)
      candidates.push_back(f);
  }
  // Significant as a whole: also the segments that carry most of it (a
  // remainder spread thin has no segment at twice the expected gap, and a
  // short rest that carries an accumulated error may be the only one).
  if (u.significant) {
    std::sort(candidates.begin(), candidates.end(),
              [](const FlaggedSegment& a, const FlaggedSegment& b) { return a.contribution > b.contribution; });
    candidates.resize(std::min<size_t>(candidates.size(), 3));
    flagged.insert(flagged.end(), candidates.begin(), candidates.end());
  }
  std::sort(flagged.begin(), flagged.end(),
            [](const FlaggedSegment& a, const FlaggedSegment& b) { return a.contribution > b.contribution; });
  return flagged;
}

}  // namespace

UnexplainedReport FindUnexplained(const MeasuredSession& session, const TrajectoryFitResult& fit,
                                  const ExplainOptions& options) {
  UnexplainedReport u;
  u.gap_m = fit.gap_m;
  u.expected_gap_m = fit.expected_gap_m();
  u.wheel_noise_gap_m = fit.wheel_noise_gap_m;
  if (fit.residuals.empty() || !(u.expected_gap_m > 0.0)) return u;
  const double expected_sq = u.expected_gap_m * u.expected_gap_m;
  u.excess_m = std::sqrt(std::max(0.0, u.gap_m * u.gap_m - expected_sq));
  u.ratio = u.gap_m * u.gap_m / expected_sq;
  const double rho = fit.lag1_autocorrelation;
  u.n_eff = EffectiveSamples(static_cast<double>(fit.residuals.size()), rho);
  u.threshold = MeanSquareThreshold(u.n_eff, options.unexplained_alpha);
  u.significant = u.ratio > u.threshold && u.excess_m >= options.unexplained_min_excess_m;
  const std::vector<FlaggedSegment> flagged =
      FlagSegments(SegmentResiduals(session, fit), u, expected_sq, rho, options);
  for (const FlaggedSegment& f : flagged) {
    if (static_cast<int>(u.where.size()) >= options.unexplained_max_reported) break;
    u.where.push_back(f.s);
  }
  return u;
}

CrossValidation CrossValidateCandidate(const MeasuredSession& session,
                                       const TrajectoryFitResult& current, Effect candidate,
                                       const ExplainOptions& options) {
  return CrossValidateCandidates(session, current, {candidate}, options).front();
}

std::vector<CrossValidation> CrossValidateCandidates(const MeasuredSession& session,
                                                     const TrajectoryFitResult& current_fit,
                                                     const std::vector<Effect>& candidates,
                                                     const ExplainOptions& options) {
  // The folds' fits without a candidate are the same for every candidate:
  // once (as Explain's rounds do), not once per candidate.
  FoldFits folds = PrepareFolds(session, current_fit, options);
  std::vector<CrossValidation> out;
  for (Effect e : candidates) out.push_back(CrossValidate(session, current_fit, e, options, &folds));
  return out;
}

}  // namespace odocal::calibration
