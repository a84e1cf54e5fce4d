#include "odocal/measure/estimator_choice.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <utility>

#include "odocal/base/format.h"
#include "odocal/base/parallel.h"
#include "odocal/base/units.h"
#include "odocal/calibration/corrections.h"
#include "odocal/calibration/statistics.h"
#include "odocal/measure/estimate_session.h"

namespace odocal::measure {
namespace {

constexpr Estimator kCandidates[] = {Estimator::kUmbmark, Estimator::kTrajectory};
constexpr size_t kN = 2;

// UMBMark and CVRA on `sessions`: batch's `--estimator umbmark` parameters.
std::optional<calibration::WheelParams> UmbmarkParams(const std::vector<SessionMeasurement>& sessions) {
  const SessionEstimate e = EstimateSession(sessions);
  if (!e.any()) return std::nullopt;
  return CorrectedParams(sessions.front().session.nominal, e);
}

// `sessions` without run `run` of session `session`.
std::vector<SessionMeasurement> Without(const std::vector<SessionMeasurement>& sessions, size_t session,
                                        size_t run) {
  std::vector<SessionMeasurement> out = sessions;
  out[session].runs.erase(out[session].runs.begin() + static_cast<std::ptrdiff_t>(run));
  return out;
}

// The trajectory fit without pooled run `k`, started from the full fit (as
// the jackknife does: one run fewer moves it a little).
calibration::TrajectoryFitResult RefitWithout(const calibration::MeasuredSession& pooled,
                                              const calibration::TrajectoryFitResult& full, size_t k) {
  const auto at = static_cast<std::ptrdiff_t>(k);
  calibration::MeasuredSession without = pooled;
  without.runs.erase(without.runs.begin() + at);
  calibration::TrajectoryFitResult warm;
  warm.status = full.status;
  warm.scales = full.scales;
  warm.effects = full.effects;
  warm.run_used = full.run_used;
  warm.start_poses = full.start_poses;
  if (k < warm.run_used.size()) warm.run_used.erase(warm.run_used.begin() + at);
  if (k < warm.start_poses.size()) warm.start_poses.erase(warm.start_poses.begin() + at);
  return calibration::FitTrajectory(without, full.options, &warm);
}

std::string Mm(double m) { return Fixed(m * kMToMm, 2); }

std::string Score(const CandidateScore& c) {
  return std::string(ToString(c.estimator)) + " " + Mm(c.mean_m) + " +/- " + Mm(c.sigma_m) + " mm";
}

EstimatorChoice FallBack(EstimatorChoice choice, const std::string& why) {
  choice.chosen = Estimator::kUmbmark;
  choice.cross_validated = false;
  choice.runs.clear();
  for (CandidateScore& c : choice.candidates) {
    c.final_error_m.clear();
    c.rms_error_m.clear();
    c.mean_m = c.sigma_m = c.max_m = c.rms_mean_m = c.rms_sigma_m = 0.0;
    c.versus_lowest_m = c.versus_lowest_sigma_m = 0.0;
    c.scale_sigma = 0.0;
  }
  choice.basis = ChoiceBasis::kFallback;
  choice.paired_difference_m = choice.paired_sigma_m = 0.0;
  choice.told_apart = false;
  choice.scale = {};
  choice.why = "umbmark (the default before auto): " + why;
  return choice;
}

// Mean of a candidate's travel scale: mean wheel diameter over the believed.
double TravelScale(const calibration::WheelParams& believed, const calibration::WheelParams& p) {
  return calibration::WheelScalesFrom(believed, p).mean();
}

// The delete-one jackknife's standard error from the n leave-one-out
// values: sqrt((n - 1) / n * sum (x_i - mean)^2) (Efron & Stein 1981).
double JackknifeSigma(const std::vector<double>& left_out) {
  const size_t n = left_out.size();
  if (n < 2) return 0.0;
  const double mean = calibration::Mean(left_out);
  double sum = 0.0;
  for (double x : left_out) sum += (x - mean) * (x - mean);
  return std::sqrt(static_cast<double>(n - 1) / static_cast<double>(n) * sum);
}

}  // namespace

const char* ToString(ChoiceBasis b) {
  switch (b) {
    case ChoiceBasis::kFallback: return "fallback";
    case ChoiceBasis::kHeldOutRuns: return "heldout_runs";
    case ChoiceBasis::kDistanceScale: return "distance_scale";
    case ChoiceBasis::kSimpler: return "simpler";
  }
  return "?";
}

const char* ToString(Estimator e) {
  switch (e) {
    case Estimator::kUmbmark: return "umbmark";
    case Estimator::kTrajectory: return "trajectory";
  }
  return "?";
}

bool EstimatorChoiceOptions::IsValid(std::string* why) const {
  if (min_runs < 2) {
    *why = "min_runs must be at least 2 (a standard error needs two held-out runs)";
    return false;
  }
  if (threads < 0) {
    *why = "threads must be >= 0 (0: one per core)";
    return false;
  }
  if (!(tell_apart_z > 0.0) || !(scale_z > 0.0)) {
    *why = "tell_apart_z and scale_z must be > 0";
    return false;
  }
  std::string replay_why;
  if (!replay.IsValid(&replay_why)) {
    *why = "replay: " + replay_why;
    return false;
  }
  return true;
}

const CandidateScore* EstimatorChoice::Find(Estimator e) const {
  for (const CandidateScore& c : candidates)
    if (c.estimator == e) return &c;
  return nullptr;
}

void ApplyChoiceRule(const EstimatorChoiceOptions& options, EstimatorChoice* choice) {
  choice->tell_apart_z = options.tell_apart_z;
  choice->scale_z = options.scale_z;
  std::vector<CandidateScore>& c = choice->candidates;
  if (c.size() != kN || c[0].final_error_m.size() != c[1].final_error_m.size() || c[0].final_error_m.size() < 2) {
    choice->chosen = Estimator::kUmbmark;
    choice->basis = ChoiceBasis::kFallback;
    return;
  }
  // Paired, run by run: trajectory - umbmark.
  std::vector<double> d(c[0].final_error_m.size());
  for (size_t i = 0; i < d.size(); ++i) d[i] = c[1].final_error_m[i] - c[0].final_error_m[i];
  choice->paired_difference_m = calibration::Mean(d);
  choice->paired_sigma_m = calibration::StandardError(d).value_or(0.0);
  const size_t lowest = c[1].mean_m < c[0].mean_m ? 1 : 0;
  for (size_t k = 0; k < kN; ++k) {
    c[k].versus_lowest_m = k == lowest ? 0.0 : (k == 1 ? 1.0 : -1.0) * choice->paired_difference_m;
    c[k].versus_lowest_sigma_m = k == lowest ? 0.0 : choice->paired_sigma_m;
  }
  choice->told_apart = std::abs(choice->paired_difference_m) > options.tell_apart_z * choice->paired_sigma_m;
  if (choice->told_apart) {
    choice->chosen = kCandidates[lowest];
    choice->basis = ChoiceBasis::kHeldOutRuns;
  } else if (std::abs(choice->scale.difference) > options.scale_z * choice->scale.sigma) {
    choice->chosen = Estimator::kTrajectory;
    choice->basis = ChoiceBasis::kDistanceScale;
  } else {
    choice->chosen = Estimator::kUmbmark;
    choice->basis = ChoiceBasis::kSimpler;
  }
}

namespace {

// ChooseEstimator's steps, in order.

// The pooled runs held out in turn: those with a measured pose to compare
// the final pose with (the others are noted).
std::vector<size_t> HeldOutRuns(const calibration::MeasuredSession& pooled, EstimatorChoice* choice) {
  std::vector<size_t> folds;
  for (size_t k = 0; k < pooled.runs.size(); ++k) {
    const calibration::MeasuredRun& run = pooled.runs[k];
    if (std::any_of(run.camera.begin(), run.camera.end(), [](const calibration::CameraRecord& c) { return c.valid; }))
      folds.push_back(k);
    else
      choice->notes.push_back(run.name + ": no measured pose; not held out");
  }
  return folds;
}

// Fold by fold: each candidate fitted without the held-out run, which is
// then replayed through it.
struct Fold {
  std::optional<calibration::WheelParams> params[kN];
  std::string undefined[kN];
  calibration::RunReplay replay[kN];
};

// Each fold's candidates, fitted without its run, and that run replayed
// through each; in parallel within options.threads.
std::vector<Fold> FitFolds(const std::vector<SessionMeasurement>& sessions, const calibration::MeasuredSession& pooled,
                           const std::vector<std::pair<size_t, size_t>>& origin, const std::vector<size_t>& folds,
                           const calibration::TrajectoryFitResult& full_fit, const EstimatorChoiceOptions& options,
                           const std::vector<calibration::RunLeftOut>* left_out) {
  const calibration::WheelParams& nominal = sessions.front().session.nominal;
  std::vector<Fold> results(folds.size());
  ParallelFor(folds.size(), static_cast<unsigned>(options.threads), [&](size_t i) {
    const size_t k = folds[i];
    Fold& f = results[i];
    const auto [s, r] = origin[k];
    f.params[0] = UmbmarkParams(Without(sessions, s, r));
    if (!f.params[0]) f.undefined[0] = "UMBMark and CVRA give nothing";
    if (left_out != nullptr && k < left_out->size() && (*left_out)[k].refitted) {
      const calibration::RunLeftOut& o = (*left_out)[k];
      if (o.determines_wheels)
        f.params[1] = calibration::ApplyWheelScales(nominal, o.scales);
      else
        f.undefined[1] = "the trajectory fit: " + o.message;
    } else {
      const calibration::TrajectoryFitResult refit = RefitWithout(pooled, full_fit, k);
      if (DeterminesWheels(refit))
        f.params[1] = calibration::ApplyWheelScales(nominal, refit.scales);
      else
        f.undefined[1] = refit.ok() ? "the trajectory fit does not determine every wheel parameter"
                                    : "the trajectory fit failed (" + refit.message + ")";
    }
    for (size_t c = 0; c < kN; ++c) {
      if (!f.params[c]) continue;
      const calibration::ReplayModel model{calibration::WheelScalesFrom(pooled.believed, *f.params[c]), {}};
      f.replay[c] = calibration::ReplayRun(pooled.runs[k], pooled.believed, model, std::nullopt, options.replay);
    }
  });
  return results;
}

// The replayed folds' errors, run by run, into the candidates' scores;
// nullopt, or why leave-one-run-out cannot compare.
std::optional<std::string> ScoreFolds(const calibration::MeasuredSession& pooled, const std::vector<size_t>& folds,
                                      const std::vector<Fold>& results, EstimatorChoice* choice) {
  for (size_t i = 0; i < folds.size(); ++i) {
    const calibration::MeasuredRun& run = pooled.runs[folds[i]];
    for (size_t c = 0; c < kN; ++c)
      if (!results[i].params[c])
        return std::string(ToString(kCandidates[c])) + " is undefined without run " + run.name + " (" +
               results[i].undefined[c] + "), so leave-one-run-out cannot compare";
  }
  for (size_t i = 0; i < folds.size(); ++i) {
    const calibration::MeasuredRun& run = pooled.runs[folds[i]];
    const Fold& f = results[i];
    std::string failed;
    for (size_t c = 0; c < kN; ++c)
      if (!f.replay[c].ok()) failed = f.replay[c].message;
    if (!failed.empty()) {
      choice->notes.push_back(run.name + ": not scored (" + failed + ")");
      continue;
    }
    choice->runs.push_back(run.name);
    for (size_t c = 0; c < kN; ++c) {
      choice->candidates[c].final_error_m.push_back(f.replay[c].final_position_error_m);
      choice->candidates[c].rms_error_m.push_back(f.replay[c].rms_position_error_m);
    }
  }
  return std::nullopt;
}

// Each candidate's mean, standard error and worst held-out error, and its
// travel scale with the jackknife of it over every fold (scored or not:
// each is the fit without one run).
void SummariseCandidates(const calibration::WheelParams& nominal, const std::vector<Fold>& results,
                         double camera_scale_sigma, EstimatorChoice* choice) {
  for (CandidateScore& c : choice->candidates) {
    c.mean_m = calibration::Mean(c.final_error_m);
    c.sigma_m = calibration::StandardError(c.final_error_m).value_or(0.0);
    c.max_m = *std::max_element(c.final_error_m.begin(), c.final_error_m.end());
    c.rms_mean_m = calibration::Mean(c.rms_error_m);
    c.rms_sigma_m = calibration::StandardError(c.rms_error_m).value_or(0.0);
  }
  // Step 2's evidence.
  {
    std::vector<double> fold_scale[kN], fold_difference;
    for (const Fold& f : results) {
      for (size_t c = 0; c < kN; ++c) fold_scale[c].push_back(TravelScale(nominal, *f.params[c]));
      fold_difference.push_back(fold_scale[1].back() - fold_scale[0].back());
    }
    for (size_t c = 0; c < kN; ++c) {
      choice->candidates[c].scale = TravelScale(nominal, *choice->candidates[c].params);
      choice->candidates[c].scale_sigma = JackknifeSigma(fold_scale[c]);
    }
    // The camera's length scale moves every run's distances alike, which
    // no fold shows; it moves the trajectory fit's scale 1:1.
    choice->scale.difference = choice->candidates[1].scale - choice->candidates[0].scale;
    choice->scale.sigma = std::hypot(JackknifeSigma(fold_difference), camera_scale_sigma * choice->candidates[1].scale);
  }
}

// The choice in words: what decided, with the figures.
std::string WhyChosen(const EstimatorChoiceOptions& options, const EstimatorChoice& choice) {
  const std::string over = " (leave-one-run-out over " + std::to_string(choice.runs.size()) +
                           " runs, mean final position error +/- its standard error)";
  const std::string paired = "trajectory - umbmark " + Mm(choice.paired_difference_m) + " +/- " +
                             Mm(choice.paired_sigma_m) + " mm paired run by run";
  const std::string scales = "the trajectory fit's travel scale " + Fixed(choice.candidates[1].scale, 5) +
                             ", umbmark's " + Fixed(choice.candidates[0].scale, 5) + ": " +
                             Fixed(choice.scale.z(), 1) + " sigma apart";
  const std::string both = Score(choice.candidates[0]) + ", " + Score(choice.candidates[1]);
  switch (choice.basis) {
    case ChoiceBasis::kHeldOutRuns:
      return std::string(ToString(choice.chosen)) + " predicts the held-out runs best: " + both + "; " + paired +
             ", beyond " + Fixed(options.tell_apart_z, 2) + " standard errors" + over;
    case ChoiceBasis::kDistanceScale:
      return "trajectory: the held-out runs cannot tell the candidates apart (" + both + "; " + paired +
             "), but they disagree on the distance scale, which UMBMark does not measure and these runs " +
             "barely see (" + scales + ")" + over;
    default:
      return "umbmark, the simpler: the held-out runs cannot tell the candidates apart (" + both + "; " + paired +
             ") and their distance scales agree (" + scales + ")" + over;
  }
}

}  // namespace

EstimatorChoice ChooseEstimator(const std::vector<SessionMeasurement>& sessions,
                                const calibration::TrajectoryFitResult* full_fit, const EstimatorChoiceOptions& options,
                                const std::vector<calibration::RunLeftOut>* left_out) {
  EstimatorChoice choice;
  for (Estimator e : kCandidates) {
    CandidateScore c;
    c.estimator = e;
    choice.candidates.push_back(c);
  }
  if (sessions.empty()) return FallBack(choice, "no sessions");
  std::string why;
  if (!options.IsValid(&why)) return FallBack(choice, "estimator choice options: " + why);

  const calibration::WheelParams& nominal = sessions.front().session.nominal;
  choice.candidates[0].params = UmbmarkParams(sessions);
  const bool trajectory_defined = full_fit != nullptr && DeterminesWheels(*full_fit);
  if (trajectory_defined) choice.candidates[1].params = calibration::ApplyWheelScales(nominal, full_fit->scales);

  std::vector<std::string> pool_notes;
  std::vector<std::pair<size_t, size_t>> origin;
  const calibration::MeasuredSession pooled = PoolTrajectoryRuns(sessions, &pool_notes, &origin);
  if (!pool_notes.empty())
    choice.notes.push_back(
        "the runs of sessions recorded with other believed parameters are not held out "
        "(the trajectory fit leaves them out)");
  const std::vector<size_t> folds = HeldOutRuns(pooled, &choice);
  if (pooled.runs.empty())
    return FallBack(choice, "no run has telemetry, and held-out runs are predicted by replaying their ticks");
  if (!choice.candidates[0].params)
    return FallBack(choice, "UMBMark and CVRA give nothing on these runs, so there is nothing to compare with");
  if (!trajectory_defined)
    return FallBack(choice, std::string("the trajectory fit ") +
                                (full_fit == nullptr || !full_fit->ok() ? "failed or had no runs"
                                                                        : "does not determine every wheel parameter") +
                                " on these runs, so there is nothing to compare with");
  if (static_cast<int>(folds.size()) < options.min_runs)
    return FallBack(choice, std::to_string(folds.size()) +
                                " runs with telemetry and measured poses; cross-validation needs " +
                                std::to_string(options.min_runs));

  const std::vector<Fold> results = FitFolds(sessions, pooled, origin, folds, *full_fit, options, left_out);
  if (const auto cannot = ScoreFolds(pooled, folds, results, &choice)) return FallBack(choice, *cannot);
  if (static_cast<int>(choice.runs.size()) < options.min_runs)
    return FallBack(choice, std::to_string(choice.runs.size()) +
                                " held-out runs could be replayed; cross-validation needs " +
                                std::to_string(options.min_runs));

  SummariseCandidates(nominal, results, pooled.camera_scale_sigma, &choice);
  ApplyChoiceRule(options, &choice);
  choice.cross_validated = true;
  choice.why = WhyChosen(options, choice);
  return choice;
}

}  // namespace odocal::measure
