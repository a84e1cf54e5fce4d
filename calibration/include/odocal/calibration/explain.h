// The explain workflow: where the model (fitted odometry) and the camera's
// measurements disagree, which missing effect explains it, and by how much.
//
// 1. Fit the base model (r_left, r_right, Eb, start poses) to the session
//    (trajectory_fit.h) and summarise its residuals by run and by motion.
// 2. For each candidate effect not yet in the model: if the data cannot
//    tell it from what is already fitted (its Jacobian columns lie in their
//    span, CheckAliasing), report that with the runs that would separate
//    them, and do not fit it; otherwise refit with it.
// 3. Score each refit by the drop in the Bayesian information criterion,
//      score = N_eff ln(SSE_before / SSE_after) - k ln(N_eff),
//    for k added parameters, N_eff = N (1 - rho) / (1 + rho) effective
//    residuals (rho: lag-one autocorrelation of the refit's residuals). BIC
//    rather than AIC because its penalty grows with the data: with thousands
//    of frames AIC's fixed 2 per parameter would let any candidate absorb a
//    little wheel noise and name invented physics. Keep the best candidate if
//    its score exceeds `min_score` (10: "very strong" on Kass & Raftery's
//    scale) and its parameters differ from zero beyond their uncertainty
//    (a Wald test at `wald_alpha`, with the covariance that includes the
//    wheel noise: BIC alone counts frames as independent, and a candidate
//    can then "explain" a little of the random walk of the wheels — seen as
//    a carpet drift of 0.2 mm/m with an interval that holds zero) — and if
//    it explains at least `min_explained_m` of the gap, sqrt(gap_before^2 -
//    gap_after^2): a real camera's frames carry systematic errors of a few
//    hundredths of a millimetre that no robot effect causes (measured: a
//    rendered session with nothing hidden passed BIC and Wald with a "tag
//    offset" of 0.027 mm that explained 0.022 mm). Repeat until no
//    candidate passes all three.
// 4. Cross-validation by run: the candidate that passed the three gates is
//    named only if it also predicts runs it was not fitted on better. Each
//    fold's runs are held out, the model is fitted without and with the
//    candidate on the other runs, and the held-out runs are replayed
//    (replay.h: start anchored on the start rest, the ticks dead-reckoned to
//    the end). Held-out RMS = RMS over held-out runs of each replay's RMS
//    position error. Named only if it falls by more than
//    `cv_min_relative_gain` (5 %) and `cv_min_gain_m` (0.01 mm): with
//    nothing hidden, adding a candidate moved it by -16.5 % to +5.3 % (36
//    trials: a held-out replay is anchored on its start rest alone, so its
//    RMS is noisy; the one above 5 % failed the Wald gate), while every
//    hidden effect gained 46-97 % through the stand-in camera and 9.9 % (a
//    lens error, whose held-out replays are dominated by their anchoring
//    noise) to 99 % on rendered video. CV is the fourth gate, not the only
//    one: chance must pass BIC, Wald and size first. Leave one
//    run out when there are at most `max_leave_one_out_runs` (8) runs, else
//    `k_folds` (5) folds, run j in fold j mod k. The gates above judge the
//    fit on the data it saw; a structure that is real must also carry over
//    to a run it did not see, and an effect that only bends the fit to one
//    run's peculiarity does not. A one-run session cannot be cross-validated:
//    the three gates decide, and explain.json says so. If the best candidate
//    fails, the next one that passed the gates is tried.
//
// 5. Unexplained: what remains after the last step is tested against what
//    the model's own noise leaves (the camera's stated noise and the wheel
//    noise, after the fit absorbs what it can: TrajectoryFitResult::
//    expected_gap_m). Statistic: F = gap^2 / expected_gap^2, against the
//    chi-square quantile chi2_{2 N_eff}(1 - alpha) / (2 N_eff), N_eff the
//    frames discounted for lag-one autocorrelation as in the BIC. The
//    remainder is significant when F exceeds it and the excess,
//    sqrt(gap^2 - expected_gap^2), is at least `unexplained_min_excess_m`
//    (0.1 mm: on rendered video with nothing hidden the camera's noise in
//    motion, larger than the rest scatter it states, left an excess of
//    0.053 mm). Then the segments (contiguous frames of one motion in one
//    run) whose RMS is at least twice the expected gap, and the 3 others
//    that carry most of the excess (frames x excess mean square), are
//    reported with run, time span, motion and size — where to look —
//    instead of being forced onto the nearest candidate. A single segment
//    far above the others is reported even when the whole is not
//    significant: its RMS at least 3 times the expected gap, its own
//    chi-square significant at alpha / (number of segments), its excess at
//    least unexplained_min_excess_m.
//
// Pure function of recorded data; I/O lives in rig/ (odocal explain).
#ifndef ODOCAL_CALIBRATION_EXPLAIN_H_
#define ODOCAL_CALIBRATION_EXPLAIN_H_

#include <optional>
#include <limits>
#include <string>
#include <vector>

#include "odocal/base/status.h"
#include "odocal/calibration/measured_session.h"
#include "odocal/calibration/replay.h"
#include "odocal/calibration/trajectory_fit.h"

namespace odocal::calibration {

struct ExplainOptions {
  TrajectoryFitOptions fit;  // its `effects` are ignored: explain chooses them
  std::vector<Effect> candidates{kAllEffects.begin(), kAllEffects.end()};
  double min_score = 10.0;
  // The smallest part of the gap worth naming an effect for (RMS, metres).
  double min_explained_m = 0.05e-3;
  double wald_alpha = 1e-3;
  int max_effects = 4;
  // Sine of the angle below which a candidate is "indistinguishable" (measured:
  // slip vs track 0.0007 at one turn rate, 0.03 with spins at 30 and 120 deg/s).
  double alias_tolerance = 0.01;
  // Cross-validation by run (step 4 above); false: the three gates decide.
  bool cross_validate = true;
  int max_leave_one_out_runs = 8;
  int k_folds = 5;
  double cv_min_relative_gain = 0.05;
  double cv_min_gain_m = 0.01e-3;
  ReplayOptions replay;
  // The final model's parameters also get sigma_between_runs (the delete-one
  // jackknife over runs, AddRunJackknife): on a real robot the model's sigma
  // is several times too small (docs/realdata.md, "How sure").
  bool jackknife_final = true;
  // Worker threads for the candidates' fits of a round, the folds of the
  // cross-validation and the jackknife's refits (0: one per core). The
  // result is the same whatever the number.
  int threads = 0;
  // Unexplained remainder (step 5 above).
  double unexplained_alpha = 1e-3;
  double unexplained_min_excess_m = 0.1e-3;
  double unexplained_segment_ratio = 2.0;  // when the whole is significant
  double unexplained_local_ratio = 3.0;    // a single segment alone
  int unexplained_min_frames = 5;          // shorter segments are not reported
  int unexplained_max_reported = 8;

  bool IsValid(std::string* why) const;
};

// Where the residuals of a fit are large.
struct ResidualSummary {
  struct Group {
    std::string label;  // "straight", "turn", "rest", or a run name
    int n = 0;
    double rms_m = 0.0;
  };
  std::vector<Group> by_motion;
  std::vector<Group> by_run;
  // The largest position errors: run name, time, motion, size.
  struct Worst {
    std::string run;
    double t_s = 0.0;
    MotionKind motion = MotionKind::kRest;
    double error_m = 0.0;
  };
  std::vector<Worst> worst;
};

ResidualSummary SummariseResiduals(const MeasuredSession& session, const TrajectoryFitResult& fit);

// Cross-validation by run of one candidate against the model without it.
struct CrossValidation {
  // "leave_one_run_out", "k_fold", or "none" (not possible: `note` says why).
  std::string method = "none";
  int folds = 0;
  int heldout_runs = 0;  // replayed without and with the candidate
  double heldout_rms_before_m = 0.0;
  double heldout_rms_after_m = 0.0;
  bool improved = false;  // by the margins of ExplainOptions
  std::string note;
  bool possible() const { return method != "none"; }
};

struct CandidateTrial {
  Effect effect = Effect::kTagOffset;
  bool fitted = false;  // false: aliased or without signal, not fitted
  double score = 0.0;
  double gap_m = 0.0;
  // How much of the gap it explains: sqrt(gap_before^2 - gap_after^2).
  double explained_m = 0.0;
  // Wald statistic of its parameters against zero, and the chi-square
  // quantile it must exceed.
  double wald = 0.0;
  double wald_threshold = 0.0;
  AliasReport alias;
  // Only for a candidate that passed the other gates.
  std::optional<CrossValidation> cross_validation;
};

struct ExplainStep {
  Effect effect = Effect::kTagOffset;
  std::vector<ParameterEstimate> params;  // the effect's, fitted with the others
  double gap_after_m = 0.0;
  double score = 0.0;
  CrossValidation cross_validation;
  std::vector<CandidateTrial> trials;  // every candidate of this round
  // Does the effect hold from run to run? The largest |value| /
  // sigma_between_runs over its size parameters (not a direction such as
  // carpet_drift's grain, nor the lens's camera-tilt nuisance): above 1.96
  // the runs' disagreement puts its 95 % interval away from zero. NaN when
  // the final model was not jackknifed (fewer than 3 runs).
  double between_runs_z = std::numeric_limits<double>::quiet_NaN();
  bool holds_across_runs() const { return between_runs_z > 1.959963985; }
};

// A structured remainder no candidate explains, and where it is.
struct UnexplainedSegment {
  std::string run;
  int run_index = 0;
  double t_from_s = 0.0;  // camera stamps of its first and last frame
  double t_to_s = 0.0;
  std::string motion;  // "straight", "turn", "rest" or "curve" (a straight-kind
                       // segment whose measured heading turns by more than 15 deg)
  int frames = 0;
  double size_m = 0.0;  // RMS |model - camera| over its frames
};

struct UnexplainedReport {
  double gap_m = 0.0;
  double expected_gap_m = 0.0;     // camera noise and wheel noise after the fit
  double wheel_noise_gap_m = 0.0;  // its wheel part
  double excess_m = 0.0;           // sqrt(gap^2 - expected^2), 0 if below
  double ratio = 0.0;              // F = gap^2 / expected^2
  double threshold = 0.0;          // chi2_{2 N_eff}(1 - alpha) / (2 N_eff)
  double n_eff = 0.0;
  bool significant = false;  // the whole remainder
  std::vector<UnexplainedSegment> where;
  bool any() const { return !where.empty(); }
};

// Step 5 on a fit: the remainder and where it is.
UnexplainedReport FindUnexplained(const MeasuredSession& session, const TrajectoryFitResult& fit,
                                  const ExplainOptions& options = {});

struct ExplainResult {
  StatusCode status = StatusCode::kInvalidArgument;
  std::string message;

  TrajectoryFitResult base;
  TrajectoryFitResult final_fit;
  ResidualSummary base_residuals;
  ResidualSummary final_residuals;
  std::vector<ExplainStep> steps;
  // The last round's candidates that were not kept (with their scores).
  std::vector<CandidateTrial> rejected;
  // Candidates the final data cannot tell from the fitted model.
  std::vector<AliasReport> aliased;
  // What remains that no candidate explains.
  UnexplainedReport unexplained;

  double gap_before_m() const { return base.gap_m; }
  double gap_after_m() const { return final_fit.gap_m; }
  std::vector<std::string> EffectsAdded() const;
  bool ok() const { return status == StatusCode::kOk; }
  std::string BriefReport() const;
};

ExplainResult Explain(const MeasuredSession& session, const ExplainOptions& options = {});

// Step 4 alone: cross-validates adding `candidate` to the model of `current`
// (a fit of `session`) by run.
CrossValidation CrossValidateCandidate(const MeasuredSession& session,
                                       const TrajectoryFitResult& current, Effect candidate,
                                       const ExplainOptions& options = {});
// ...and of each of `candidates` to the model of `current_fit`, on folds fitted
// without a candidate once for all of them.
std::vector<CrossValidation> CrossValidateCandidates(const MeasuredSession& session,
                                                     const TrajectoryFitResult& current_fit,
                                                     const std::vector<Effect>& candidates,
                                                     const ExplainOptions& options = {});

}  // namespace odocal::calibration

#endif  // ODOCAL_CALIBRATION_EXPLAIN_H_
