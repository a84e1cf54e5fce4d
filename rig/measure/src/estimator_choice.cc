#include "odocal/measure/estimator_choice.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <utility>

#include "odocal/base/parallel.h"
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

std::string Mm(double m) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.2f", m * 1e3);
  return text;
}

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
  }
  choice.why = "umbmark (the default before auto): " + why;
  return choice;
}

}  // namespace

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

size_t OneStandardErrorChoice(const std::vector<CandidateScore>& scored) {
  if (scored.empty()) return 0;
  size_t best = 0;
  for (size_t c = 1; c < scored.size(); ++c)
    if (scored[c].mean_m < scored[best].mean_m) best = c;
  for (size_t c = 0; c < best; ++c)
    if (scored[c].mean_m <= scored[best].mean_m + scored[best].sigma_m) return c;
  return best;
}

EstimatorChoice ChooseEstimator(const std::vector<SessionMeasurement>& sessions,
                                const calibration::TrajectoryFitResult* full_fit,
                                const EstimatorChoiceOptions& options,
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
    choice.notes.push_back("the runs of sessions recorded with other believed parameters are not held out "
                           "(the trajectory fit leaves them out)");
  // Held out: pooled runs with a measured pose to compare the final pose with.
  std::vector<size_t> folds;
  for (size_t k = 0; k < pooled.runs.size(); ++k) {
    const calibration::MeasuredRun& run = pooled.runs[k];
    if (std::any_of(run.camera.begin(), run.camera.end(), [](const calibration::CameraRecord& c) { return c.valid; }))
      folds.push_back(k);
    else
      choice.notes.push_back(run.name + ": no measured pose; not held out");
  }
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
    return FallBack(choice, std::to_string(folds.size()) + " runs with telemetry and measured poses; cross-validation needs " +
                                std::to_string(options.min_runs));

  // Fold by fold: each candidate fitted without the held-out run, which is
  // then replayed through it.
  struct Fold {
    std::optional<calibration::WheelParams> params[kN];
    std::string undefined[kN];
    calibration::RunReplay replay[kN];
  };
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
      const calibration::TrajectoryFitResult refit = RefitWithout(pooled, *full_fit, k);
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

  for (size_t i = 0; i < folds.size(); ++i) {
    const calibration::MeasuredRun& run = pooled.runs[folds[i]];
    for (size_t c = 0; c < kN; ++c)
      if (!results[i].params[c])
        return FallBack(choice, std::string(ToString(kCandidates[c])) + " is undefined without run " + run.name +
                                    " (" + results[i].undefined[c] + "), so leave-one-run-out cannot compare");
  }
  for (size_t i = 0; i < folds.size(); ++i) {
    const calibration::MeasuredRun& run = pooled.runs[folds[i]];
    const Fold& f = results[i];
    std::string failed;
    for (size_t c = 0; c < kN; ++c)
      if (!f.replay[c].ok) failed = f.replay[c].message;
    if (!failed.empty()) {
      choice.notes.push_back(run.name + ": not scored (" + failed + ")");
      continue;
    }
    choice.runs.push_back(run.name);
    for (size_t c = 0; c < kN; ++c) {
      choice.candidates[c].final_error_m.push_back(f.replay[c].final_position_error_m);
      choice.candidates[c].rms_error_m.push_back(f.replay[c].rms_position_error_m);
    }
  }
  if (static_cast<int>(choice.runs.size()) < options.min_runs)
    return FallBack(choice, std::to_string(choice.runs.size()) + " held-out runs could be replayed; cross-validation needs " +
                                std::to_string(options.min_runs));

  for (CandidateScore& c : choice.candidates) {
    c.mean_m = calibration::Mean(c.final_error_m);
    c.sigma_m = calibration::StandardError(c.final_error_m).value_or(0.0);
    c.max_m = *std::max_element(c.final_error_m.begin(), c.final_error_m.end());
    c.rms_mean_m = calibration::Mean(c.rms_error_m);
    c.rms_sigma_m = calibration::StandardError(c.rms_error_m).value_or(0.0);
  }
  size_t best = 0;
  for (size_t c = 1; c < kN; ++c)
    if (choice.candidates[c].mean_m < choice.candidates[best].mean_m) best = c;
  const CandidateScore& b = choice.candidates[best];
  const size_t chosen = OneStandardErrorChoice(choice.candidates);
  choice.chosen = kCandidates[chosen];
  choice.cross_validated = true;
  const std::string over = " (leave-one-run-out over " + std::to_string(choice.runs.size()) +
                           " runs, mean final position error +/- its standard error)";
  std::string others;
  for (size_t c = 0; c < kN; ++c)
    if (c != chosen) others += (others.empty() ? "" : ", ") + Score(choice.candidates[c]);
  const CandidateScore& pick = choice.candidates[chosen];
  if (chosen == best)
    choice.why = std::string(ToString(pick.estimator)) + " predicts the held-out runs best: " + Score(pick) +
                 " against " + others + over;
  else
    choice.why = std::string(ToString(pick.estimator)) + ", the simpler: " + Score(b) + " is lower, but " +
                 Score(pick) + " is within its standard error" + over;
  return choice;
}

}  // namespace odocal::measure
