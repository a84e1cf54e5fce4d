// Which estimator to write into an export when the user does not choose:
// the one that predicts runs it never saw best. Leave-one-run-out
// cross-validation over a batch's runs with telemetry: each candidate is
// fitted on the other runs, the held-out run's ticks are replayed through
// its parameters (calibration/replay.h, as `odocal check` does) and its
// final pose compared with the pose source's. The score is the mean final
// position error over the held-out runs, with its standard error across
// runs; the lowest wins, and when a simpler candidate is within one standard
// error of the lowest (the one-standard-error rule, Hastie, Tibshirani &
// Friedman, "The Elements of Statistical Learning", 7.10) the simpler is
// kept.
//
// The candidates, simplest first, are what `batch --estimator` writes:
// umbmark (UMBMark and CVRA from the return errors, CorrectedParams) and
// trajectory (the full-trajectory fit's wheel scales,
// FitSessionTrajectories). Explain's final model is not one: its effects
// (drift, slip, ...) have no place in a firmware or ROS 2 export, and its
// search costs minutes per session (docs/realdata.md, "Which estimator").
//
// No I/O. Units SI.
#ifndef ODOCAL_MEASURE_ESTIMATOR_CHOICE_H_
#define ODOCAL_MEASURE_ESTIMATOR_CHOICE_H_

#include <optional>
#include <string>
#include <vector>

#include "odocal/calibration/replay.h"
#include "odocal/calibration/robot_model.h"
#include "odocal/calibration/trajectory_fit.h"
#include "odocal/measure/measure.h"

namespace odocal::measure {

// Simplest first: a tie (within one standard error) goes to the earlier.
enum class Estimator { kUmbmark, kTrajectory };
// "umbmark", "trajectory": batch's --estimator names.
const char* ToString(Estimator e);

struct EstimatorChoiceOptions {
  // Fewer held-out runs than this (runs with telemetry and measured poses,
  // of the sessions the trajectory fit pools): no cross-validation, umbmark.
  int min_runs = 3;
  // Folds refitted at once (0: one per core).
  int threads = 0;
  // How each held-out run is replayed.
  calibration::ReplayOptions replay;

  bool IsValid(std::string* why) const;
};

// One candidate's held-out score.
struct CandidateScore {
  Estimator estimator = Estimator::kUmbmark;
  // Its parameters fitted on every run (what an export would hold);
  // nullopt when the candidate is undefined on the whole batch.
  std::optional<calibration::WheelParams> params;
  // Per held-out run (names in EstimatorChoice::runs' order), the final
  // position error, m. Empty when not cross-validated.
  std::vector<double> final_error_m;
  double mean_m = 0.0;
  double sigma_m = 0.0;  // standard error of the mean across runs
  double max_m = 0.0;
  // The same replays' RMS position error over every frame, per run, and
  // its mean and standard error: reported, not used for the choice.
  std::vector<double> rms_error_m;
  double rms_mean_m = 0.0;
  double rms_sigma_m = 0.0;
};

struct EstimatorChoice {
  Estimator chosen = Estimator::kUmbmark;
  // False: the runs could not be cross-validated and umbmark (the default
  // before auto) was kept; `why` says what was missing.
  bool cross_validated = false;
  std::string why;  // one sentence
  std::vector<std::string> runs;  // the held-out runs scored
  std::vector<CandidateScore> candidates;  // simplest first
  std::vector<std::string> notes;  // runs left out of the scoring, and why

  const CandidateScore* Find(Estimator e) const;
};

// The one-standard-error rule over scored candidates (simplest first): the
// first whose mean is within the lowest mean's standard error of it.
// Index into `scored`; 0 when empty.
size_t OneStandardErrorChoice(const std::vector<CandidateScore>& scored);

// Cross-validates umbmark against the trajectory fit over `sessions` (as
// measured by MeasureSessions). `full_fit` is FitSessionTrajectories' result
// on the same sessions (nullptr or failed: trajectory is undefined); the
// folds start from it. Runs without telemetry serve the fits but cannot be
// held out. Never fails: what cannot be cross-validated falls back to
// umbmark with the reason in `why`. Invalid options fall back too.
// `left_out` (FitSessionTrajectories' jackknife refits), when given, serves
// as the trajectory fit of each fold it covers instead of refitting.
EstimatorChoice ChooseEstimator(const std::vector<SessionMeasurement>& sessions,
                                const calibration::TrajectoryFitResult* full_fit,
                                const EstimatorChoiceOptions& options = {},
                                const std::vector<calibration::RunLeftOut>* left_out = nullptr);

}  // namespace odocal::measure

#endif  // ODOCAL_MEASURE_ESTIMATOR_CHOICE_H_
