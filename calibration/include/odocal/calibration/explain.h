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
//
// Pure function of recorded data; I/O lives in rig/ (odocal explain).
#ifndef ODOCAL_CALIBRATION_EXPLAIN_H_
#define ODOCAL_CALIBRATION_EXPLAIN_H_

#include <string>
#include <vector>

#include "odocal/calibration/measured_session.h"
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
};

struct ExplainStep {
  Effect effect = Effect::kTagOffset;
  std::vector<ParameterEstimate> params;  // the effect's, fitted with the others
  double gap_after_m = 0.0;
  double score = 0.0;
  std::vector<CandidateTrial> trials;  // every candidate of this round
};

struct ExplainResult {
  enum class Status { kOk, kInvalidInput, kNoConvergence };
  Status status = Status::kInvalidInput;
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

  double gap_before_m() const { return base.gap_m; }
  double gap_after_m() const { return final_fit.gap_m; }
  std::vector<std::string> EffectsAdded() const;
  bool ok() const { return status == Status::kOk; }
  std::string BriefReport() const;
};

ExplainResult Explain(const MeasuredSession& session, const ExplainOptions& options = {});

}  // namespace odocal::calibration

#endif  // ODOCAL_CALIBRATION_EXPLAIN_H_
