// Which estimator to write into an export when the user does not choose:
// the one that predicts runs it never saw best. Leave-one-run-out
// cross-validation over a batch's runs with telemetry: each candidate is
// fitted on the other runs, the held-out run's ticks are replayed through
// its parameters (calibration/replay.h, as `odocal check` does) and its
// final pose compared with the pose source's. The score is the mean final
// position error over the held-out runs.
//
// The rule, in two steps (docs/realdata.md, "Which estimator"):
// 1. The held-out runs decide when they can tell the candidates apart: the
//    paired difference of their final errors (both replay the same runs, so
//    what a run does to both cancels) beyond `tell_apart_z` of its standard
//    error. The lower wins.
// 2. When they cannot, the candidates still differ in what the runs cannot
//    see. The one thing UMBMark cannot measure is the distance scale (it
//    keeps the believed mean wheel size unless a CVRA scale run measures
//    it), and closed paths (squares, out-and-back, spins) barely move their
//    end with it, so a tie on such runs is no evidence that the believed
//    scale is right. The trajectory fit measures it from every frame. If
//    the two candidates' scales differ by more than `scale_z` of the
//    difference's delete-one jackknife standard error over the same folds
//    (with the camera's length-scale sigma added), the data refute
//    UMBMark's scale and the trajectory fit is chosen; otherwise the
//    simpler, umbmark.
// Both thresholds are two-sided 95 % tests fixed from first principles, not
// fitted to any data set.
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

// Simplest first.
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
  // Step 1: the runs tell two candidates apart when their paired mean
  // difference exceeds this many of its standard errors (1.96: two-sided
  // 95 %).
  double tell_apart_z = 1.96;
  // Step 2: the candidates' distance scales differ when their difference
  // exceeds this many of its jackknife standard errors (two-sided 95 %).
  double scale_z = 1.96;

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
  // Paired against the candidate with the lowest mean, run by run: the mean
  // of (this − lowest) and its standard error (0 for the lowest itself).
  double versus_lowest_m = 0.0;
  double versus_lowest_sigma_m = 0.0;
  // Its mean travel scale (mean wheel diameter / believed) fitted on every
  // run, and the delete-one jackknife's standard error of it over the folds.
  double scale = 1.0;
  double scale_sigma = 0.0;
};

// How the rule decided (step 1 or 2 above).
enum class ChoiceBasis {
  kFallback,     // not cross-validated: umbmark
  kHeldOutRuns,  // step 1: the held-out runs told the candidates apart
  kDistanceScale,  // step 2: a tie, and the scales differ: trajectory
  kSimpler,      // step 2: a tie, and the scales agree: umbmark
};
// "fallback", "heldout_runs", "distance_scale", "simpler".
const char* ToString(ChoiceBasis b);

// Step 2's comparison: trajectory's scale minus umbmark's, and its sigma
// (the jackknife over the folds of the paired difference, with the camera's
// length-scale sigma added in quadrature).
struct ScaleComparison {
  double difference = 0.0;
  double sigma = 0.0;
  double z() const { return sigma > 0.0 ? difference / sigma : 0.0; }
};

struct EstimatorChoice {
  Estimator chosen = Estimator::kUmbmark;
  // False: the runs could not be cross-validated and umbmark (the default
  // before auto) was kept; `why` says what was missing.
  bool cross_validated = false;
  std::string why;  // one sentence
  ChoiceBasis basis = ChoiceBasis::kFallback;
  // Step 1: the paired difference trajectory − umbmark of the held-out
  // final errors, its standard error, and whether it told them apart.
  double paired_difference_m = 0.0;
  double paired_sigma_m = 0.0;
  bool told_apart = false;
  ScaleComparison scale;  // step 2 (computed whenever cross-validated)
  // The thresholds the rule used (EstimatorChoiceOptions').
  double tell_apart_z = 0.0;
  double scale_z = 0.0;
  std::vector<std::string> runs;  // the held-out runs scored
  std::vector<CandidateScore> candidates;  // simplest first
  std::vector<std::string> notes;  // runs left out of the scoring, and why

  const CandidateScore* Find(Estimator e) const;
};

// The rule on two scored candidates (umbmark, trajectory): per-run final
// errors in the same runs' order, and the scale comparison. Sets chosen,
// basis, paired_difference_m, paired_sigma_m and told_apart of `choice`
// (whose candidates it reads); pure.
void ApplyChoiceRule(const EstimatorChoiceOptions& options, EstimatorChoice* choice);

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
