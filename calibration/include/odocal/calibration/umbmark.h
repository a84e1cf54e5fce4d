// UMBMark: the bidirectional square test of Borenstein & Feng (1996),
// "Measurement and correction of systematic odometry errors in mobile robots",
// IEEE Trans. Robotics and Automation 12(6), and the seed tutorial
// (shared/seeds/umbmark-calibration-tutorial.md).
//
// Input: the return errors of n clockwise and n counter-clockwise squares of
// side L, each true - odometry in the run's start frame (x along the start
// heading, y to the left, heading counter-clockwise), metres and radians.
//
// Output:
//  - the centres of gravity and E_max,syst (the paper's eq. 6-7);
//  - the first-order alpha/beta from x and from y, and R, Ed, Eb, c_L, c_R
//    (eq. 11-18; signs derived in docs/calibration.md, alpha being the turn
//    deficit, true turn = 90 deg - alpha, beta the CCW veer per leg);
//  - a coupled estimate: Ed and Eb fitted by least squares to the exact
//    (arc-by-arc) model of the square, with x, y and, where every run has one,
//    the final heading. To first order alpha and beta separate; at second
//    order the veer leaks into the turn estimate, which the coupled fit removes.
#ifndef ODOCAL_CALIBRATION_UMBMARK_H_
#define ODOCAL_CALIBRATION_UMBMARK_H_

#include <iosfwd>
#include <optional>
#include <string>
#include <vector>

#include "odocal/base/solver_settings.h"
#include "odocal/base/status.h"
#include "odocal/calibration/pose2.h"
#include "odocal/calibration/procedures.h"

namespace odocal::calibration {

// One run's return error: true - odometry, in the run's start frame.
struct ReturnError {
  double x_m = 0.0;
  double y_m = 0.0;
  std::optional<double> heading_rad;

  static ReturnError FromMmDeg(double x_mm, double y_mm,
                               std::optional<double> heading_deg = std::nullopt);
};

std::ostream& operator<<(std::ostream& os, const ReturnError& e);

struct UmbmarkInput {
  double side_m = 0.0;   // L: the commanded side of the square
  double track_m = 0.0;  // b: the track the robot's firmware used (nominal)
  std::vector<ReturnError> cw;
  std::vector<ReturnError> ccw;

  // `why` names the offending field as the command line spells it.
  bool IsValid(std::string* why) const;

  // Pools one square: its return error (true - odometry in its start frame)
  // under its direction; the first square sets side_m. kInvalidArgument when
  // the run is not a UMBMark square or its side differs from the pooled ones.
  Status AddRun(const RunSpec& spec, const Pose2& return_error);
};

struct UmbmarkOptions {
  // (r_L + r_R) / 2 of the robot: 1 once distance is calibrated. With another
  // value, Eb is still b_true / b_nominal; the turn scale is Eb / mean_scale.
  double mean_scale = 1.0;
  // Fit the final headings too, when every run has one.
  bool use_heading = true;
  // Weights of the coupled fit when runs are not repeated (no spread to learn
  // from); only their ratio matters then.
  double default_position_sigma_m = 1e-3;
  double default_heading_sigma_rad = 1e-3;
  // Floors on the standard errors learned from the spread of repeated runs.
  double min_position_sigma_m = 1e-6;
  double min_heading_sigma_rad = 1e-7;
  // The coupled fit of Ed and Eb (two parameters, Ceres with dense QR): run to
  // the limits of double precision, since the answer is a ratio near 1 and
  // the problem is tiny.
  SolverSettings solver{.max_iterations = 100, .function_tolerance = 1e-16,
                        .gradient_tolerance = 1e-20, .parameter_tolerance = 1e-14};

  bool IsValid(std::string* why) const;
};

struct CentreOfGravity {
  int n = 0;
  double x_m = 0.0;
  double y_m = 0.0;
  std::optional<double> heading_rad;  // when every run has a heading
  // Standard errors of the mean, from the spread of the runs (n >= 2).
  std::optional<double> sigma_x_m;
  std::optional<double> sigma_y_m;
  std::optional<double> sigma_heading_rad;

  double radius_m() const;
};

struct FirstOrderEstimate {
  double alpha_rad = 0.0;  // turn deficit: the robot turns 90 deg - alpha
  double beta_rad = 0.0;   // veer per leg, counter-clockwise positive
  double R_m = 0.0;        // radius of the veer (infinite for beta = 0)
  double Ed = 1.0;
  double Eb = 1.0;
  double c_left = 1.0;
  double c_right = 1.0;
  std::optional<double> sigma_alpha_rad;
  std::optional<double> sigma_beta_rad;
  std::optional<double> sigma_Ed;
  std::optional<double> sigma_Eb;
};

struct CoupledEstimate {
  double Ed = 1.0;
  double Eb = 1.0;
  // From the spread of repeated runs, propagated through the fit.
  std::optional<double> sigma_Ed;
  std::optional<double> sigma_Eb;
  std::optional<double> correlation;
  // Student's t quantile for a two-sided 95 % interval, value +- t95 * sigma
  // (the sigmas were learned from a few runs).
  std::optional<double> t95;
  // 1/sigma of each residual of the fit, cw then ccw: x, y[, heading].
  std::vector<double> residual_weights;
  bool used_heading = false;
  int iterations = 0;
  // RMS of the weighted residuals at the solution (about 1 when the model and
  // the learned sigmas agree; near 0 for exact data).
  double rms_weighted_residual = 0.0;
};

struct UmbmarkSummary {
  StatusCode status = StatusCode::kInvalidArgument;
  std::string message;

  CentreOfGravity cw;
  CentreOfGravity ccw;
  double emax_syst_m = 0.0;  // max of the two centres' distances from the origin
  FirstOrderEstimate from_x;
  FirstOrderEstimate from_y;
  CoupledEstimate coupled;

  // What follows from the coupled estimate.
  double track_corrected_m = 0.0;  // b * Eb
  double turn_scale = 1.0;         // multiply commanded turns by this if the track is kept
  double c_left = 1.0;             // multiply left wheel travel per tick (diameter) by this
  double c_right = 1.0;

  bool ok() const { return status == StatusCode::kOk; }
  std::string BriefReport() const;
};

UmbmarkSummary EstimateUmbmark(const UmbmarkInput& input, const UmbmarkOptions& options = {});

// The first-order forms alone, for one axis; kInvalidArgument when beta is
// so large that R is not larger than half the track (Ed would be meaningless)
// or alpha a quarter turn.
Result<FirstOrderEstimate> FirstOrderFromX(double x_cw_m, double x_ccw_m, double side_m, double track_m);
Result<FirstOrderEstimate> FirstOrderFromY(double y_cw_m, double y_ccw_m, double side_m, double track_m);

// Borenstein's correction factors for a wheel-diameter ratio Ed: multiply each
// wheel's travel per tick (its diameter) by these; they keep the mean.
double CorrectionLeft(double Ed);
double CorrectionRight(double Ed);

}  // namespace odocal::calibration

#endif  // ODOCAL_CALIBRATION_UMBMARK_H_
