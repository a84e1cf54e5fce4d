// What a batch of measured sessions says about the robot's wheels: which
// runs are usable, UMBMark over the pooled squares (Borenstein & Feng 1996),
// CVRA's wheel ratio, distance scale and track factor from the camera's
// return errors (each run's estimate, then their mean and standard error),
// the corrected parameters they give, and the full-trajectory least squares
// over every run with telemetry. No I/O: report/session_estimate_json.h
// writes the result for report.json.
//
// Return errors are true - odometry in the run's start frame (measure.h);
// units SI.
#ifndef ODOCAL_MEASURE_ESTIMATE_SESSION_H_
#define ODOCAL_MEASURE_ESTIMATE_SESSION_H_

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "odocal/calibration/robot_model.h"
#include "odocal/calibration/trajectory_fit.h"
#include "odocal/calibration/umbmark.h"
#include "odocal/measure/measure.h"

namespace odocal::measure {

// One CVRA quantity over the runs that measured it.
struct PooledCvra {
  std::vector<double> values;     // one per run, in the runs' order
  std::vector<std::string> runs;  // their names
  double mean = 0.0;
  std::optional<double> standard_error;  // nullopt with fewer than two runs
  // The distance scale only: the camera's own length scale (relative 1-sigma,
  // SessionMeasurement::camera_scale_sigma), common to every run, which no
  // number of runs averages away.
  double camera_scale_sigma = 0.0;
};

struct SessionEstimate {
  // UMBMark over the usable squares (equal cw and ccw counts), when it
  // succeeded; `umbmark_input` holds the squares it used.
  std::optional<calibration::UmbmarkInput> umbmark_input;
  std::optional<calibration::UmbmarkSummary> umbmark;
  // CVRA from the camera: the wheel ratio Ed from out-and-backs, the distance
  // scale from straights, the track factor from spins.
  std::optional<PooledCvra> ratio, scale, track;
  // How runs were pooled: runs left out for the estimator's own reasons
  // (a square of another side, unequal cw/ccw counts, a wall reference) and
  // estimators that could not run. A run without a usable return error (a
  // fatal flag) is left out without a note: its flags in report.json say why.
  std::vector<std::string> notes;

  bool any() const { return umbmark || ratio || scale || track; }
};

// The UMBMark and CVRA estimates over every usable run of `sessions` (a run
// with a return error and no fatal flag). The nominal parameters are the
// first session's.
SessionEstimate EstimateSession(const std::vector<SessionMeasurement>& sessions);

// The corrected parameters: UMBMark, when present, sets the ratio and the
// track (it measures both on the same squares); CVRA's scale always applies;
// CVRA's ratio and track fill in without UMBMark. Only when estimate.any().
calibration::WheelParams CorrectedParams(const calibration::WheelParams& nominal,
                                         const SessionEstimate& estimate);

// The full-trajectory least squares (trajectory_fit.h, base model with the
// pose source's clock offset) over every run with telemetry and measured
// poses. Sessions recorded with other believed parameters than the first
// are left out with a note; a fit that fails adds a note. nullopt without
// such runs or when the fit fails.
// `left_out`, when given, receives the jackknife's fits without each pooled
// run (PoolTrajectoryRuns' order; calibration::AddRunJackknife).
std::optional<calibration::TrajectoryFitResult> FitSessionTrajectories(
    const std::vector<SessionMeasurement>& sessions, std::vector<std::string>* notes,
    std::vector<calibration::RunLeftOut>* left_out = nullptr);

// The runs FitSessionTrajectories pools: every run with telemetry of the
// sessions recorded with the first session's believed parameters (the
// others are left out with a note in `notes`). `origin`, when given,
// receives each pooled run's (session index, run index) in `sessions`.
calibration::MeasuredSession PoolTrajectoryRuns(const std::vector<SessionMeasurement>& sessions,
                                                std::vector<std::string>* notes,
                                                std::vector<std::pair<size_t, size_t>>* origin = nullptr);

// The options FitSessionTrajectories fits with (the base model and the pose
// source's clock offset).
calibration::TrajectoryFitOptions SessionTrajectoryFitOptions();

// Whether a fit determines every wheel parameter (Ed, Es, Eb and the turn
// gain identifiable): what `--estimator trajectory` needs to export.
bool DeterminesWheels(const calibration::TrajectoryFitResult& fit);

// How many runs of `sessions` have a usable return error.
int CountUsableRuns(const std::vector<SessionMeasurement>& sessions);

}  // namespace odocal::measure

#endif  // ODOCAL_MEASURE_ESTIMATE_SESSION_H_
