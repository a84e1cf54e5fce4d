#include "odocal/calibration/umbmark.h"

#include <cmath>
#include <iomanip>
#include <limits>
#include <memory>
#include <ostream>
#include <sstream>

#include <Eigen/Dense>
#include <boost/math/distributions/students_t.hpp>
#include <ceres/ceres.h>

#include "odocal/base/format.h"
#include "odocal/base/units.h"
#include "odocal/calibration/procedures.h"
#include "odocal/calibration/statistics.h"

namespace odocal::calibration {
namespace {

bool AllFinite(const std::vector<ReturnError>& runs) {
  for (const ReturnError& e : runs) {
    if (!std::isfinite(e.x_m) || !std::isfinite(e.y_m)) return false;
    if (e.heading_rad && !std::isfinite(*e.heading_rad)) return false;
  }
  return true;
}

bool AllHaveHeading(const std::vector<ReturnError>& runs) {
  for (const ReturnError& e : runs)
    if (!e.heading_rad) return false;
  return !runs.empty();
}

CentreOfGravity ComputeCentre(const std::vector<ReturnError>& runs) {
  CentreOfGravity cg;
  cg.n = static_cast<int>(runs.size());
  std::vector<double> xs, ys, hs;
  for (const ReturnError& e : runs) {
    xs.push_back(e.x_m);
    ys.push_back(e.y_m);
    if (e.heading_rad) hs.push_back(*e.heading_rad);
  }
  cg.x_m = Mean(xs);
  cg.y_m = Mean(ys);
  cg.sigma_x_m = StandardError(xs);
  cg.sigma_y_m = StandardError(ys);
  if (hs.size() == runs.size()) {
    cg.heading_rad = Mean(hs);
    cg.sigma_heading_rad = StandardError(hs);
  }
  return cg;
}

Result<FirstOrderEstimate> FromAlphaBeta(double alpha, double beta, double side_m, double track_m, const char* axis) {
  const auto fail = [](std::string why) {
    return Result<FirstOrderEstimate>::Error(StatusCode::kInvalidArgument, std::move(why));
  };
  // (b/2)/R with R = (L/2)/sin(beta/2): finite for beta = 0.
  const double half_track_over_r = track_m * std::sin(beta / 2.0) / side_m;
  if (std::abs(half_track_over_r) >= 1.0 || std::abs(beta) >= M_PI)
    return fail(std::string("beta from ") + axis + " = " + Fixed(beta * kRadToDeg, 3) +
                " deg per leg: the veer radius R is not larger than half the track, so Ed is "
                "meaningless (are the return errors in mm and the side and track right?)");
  if (alpha >= M_PI / 2.0 || alpha <= -M_PI / 2.0)
    return fail(std::string("alpha from ") + axis + " = " + Fixed(alpha * kRadToDeg, 3) +
                " deg: the robot would not turn at all or turn twice; check the return errors");
  FirstOrderEstimate e;
  e.alpha_rad = alpha;
  e.beta_rad = beta;
  e.R_m = beta == 0.0 ? std::numeric_limits<double>::infinity()
                      : (side_m / 2.0) / std::sin(beta / 2.0);
  e.Ed = (1.0 + half_track_over_r) / (1.0 - half_track_over_r);
  e.Eb = (M_PI / 2.0) / (M_PI / 2.0 - alpha);
  e.c_left = CorrectionLeft(e.Ed);
  e.c_right = CorrectionRight(e.Ed);
  return Result<FirstOrderEstimate>::Ok(e);
}

// The first-order alpha and beta (Borenstein & Feng 1996, eq. 11-12 and their
// y counterparts), derived for our frame in docs/calibration.md:
//   x_cw = -2L(alpha + beta)   x_ccw = 2L(beta - alpha)
//   y_cw = -2L(alpha + beta)   y_ccw = 2L(alpha - beta)
double AlphaFromX(double x_cw, double x_ccw, double L) { return -(x_cw + x_ccw) / (4.0 * L); }
double BetaFromX(double x_cw, double x_ccw, double L) { return (x_ccw - x_cw) / (4.0 * L); }
double AlphaFromY(double y_cw, double y_ccw, double L) { return (y_ccw - y_cw) / (4.0 * L); }
double BetaFromY(double y_cw, double y_ccw, double L) { return -(y_cw + y_ccw) / (4.0 * L); }

// Adds sigmas to a first-order estimate from the standard errors of the two
// centre coordinates it was computed from.
void PropagateFirstOrder(double cw, double ccw, std::optional<double> sigma_cw,
                         std::optional<double> sigma_ccw, double L, double b,
                         double (*alpha_of)(double, double, double),
                         double (*beta_of)(double, double, double), FirstOrderEstimate* e) {
  if (!sigma_cw || !sigma_ccw) return;
  const std::vector<double> x = {cw, ccw};
  const std::vector<double> s = {*sigma_cw, *sigma_ccw};
  auto ed = [&](const std::vector<double>& v) {
    const double beta = beta_of(v[0], v[1], L);
    const double k = b * std::sin(beta / 2.0) / L;
    return (1.0 + k) / (1.0 - k);
  };
  auto eb = [&](const std::vector<double>& v) {
    return (M_PI / 2.0) / (M_PI / 2.0 - alpha_of(v[0], v[1], L));
  };
  e->sigma_alpha_rad =
      PropagateIndependent([&](const std::vector<double>& v) { return alpha_of(v[0], v[1], L); },
                           x, s);
  e->sigma_beta_rad =
      PropagateIndependent([&](const std::vector<double>& v) { return beta_of(v[0], v[1], L); },
                           x, s);
  e->sigma_Ed = PropagateIndependent(ed, x, s);
  e->sigma_Eb = PropagateIndependent(eb, x, s);
}

// Residual of one direction's centre of gravity against the exact square.
class SquareResidual {
 public:
  SquareResidual(Direction direction, const UmbmarkInput& input, double mean_scale,
                 const CentreOfGravity& cg, double sigma_x, double sigma_y,
                 std::optional<double> sigma_heading)
      : plan_(PlanPrimitives(RunSpec::Umbmark(direction, input.side_m))),
        planned_heading_(direction == Direction::kCcw ? 2.0 * M_PI : -2.0 * M_PI),
        track_m_(input.track_m),
        mean_scale_(mean_scale),
        cg_(cg),
        sigma_x_(sigma_x),
        sigma_y_(sigma_y),
        sigma_heading_(sigma_heading) {}

  int num_residuals() const { return sigma_heading_ ? 3 : 2; }

  template <typename T>
  bool operator()(const T* const ed, const T* const eb, T* residual) const {
    const T r_left = 2.0 * mean_scale_ / (1.0 + ed[0]);
    const T r_right = 2.0 * mean_scale_ * ed[0] / (1.0 + ed[0]);
    T end[3];
    PredictTrueEnd(plan_, r_left, r_right, eb[0], track_m_, end);
    residual[0] = (end[0] - cg_.x_m) / sigma_x_;
    residual[1] = (end[1] - cg_.y_m) / sigma_y_;
    if (sigma_heading_) {
      residual[2] = (end[2] - planned_heading_ - *cg_.heading_rad) / *sigma_heading_;
    }
    return true;
  }

 private:
  std::vector<Primitive> plan_;
  double planned_heading_;
  double track_m_;
  double mean_scale_;
  CentreOfGravity cg_;
  double sigma_x_;
  double sigma_y_;
  std::optional<double> sigma_heading_;
};

// Sample covariance of the mean of the runs' (x, y[, heading]).
Eigen::MatrixXd CovarianceOfMean(const std::vector<ReturnError>& runs, bool with_heading) {
  const int dim = with_heading ? 3 : 2;
  const int n = static_cast<int>(runs.size());
  Eigen::MatrixXd samples(n, dim);
  for (int i = 0; i < n; ++i) {
    samples(i, 0) = runs[i].x_m;
    samples(i, 1) = runs[i].y_m;
    if (with_heading) samples(i, 2) = *runs[i].heading_rad;
  }
  const Eigen::MatrixXd centred = samples.rowwise() - samples.colwise().mean();
  return (centred.transpose() * centred) / ((n - 1.0) * n);
}

// The spread of the runs, propagated through the fit. At the solution, the
// parameters move with the measured means m as dp/dm = (Jw' Jw)^-1 Jw' W
// (implicit function theorem on the normal equations, W the residual weights),
// so Cov(p) = A Cov(m) A'. Cov(m) is the full sample covariance of each
// direction's mean: x, y and heading of one run are strongly correlated (a
// late heading error moves y and heading together), which a diagonal weight
// alone would count as independent information.
void PropagateRunSpread(const UmbmarkInput& input, bool use_heading, ceres::Problem* problem,
                        double* ed, double* eb, CoupledEstimate* coupled) {
  ceres::Problem::EvaluateOptions evaluate_options;
  evaluate_options.parameter_blocks = {ed, eb};
  ceres::CRSMatrix crs;
  if (!problem->Evaluate(evaluate_options, nullptr, nullptr, nullptr, &crs)) return;
  Eigen::MatrixXd jw = Eigen::MatrixXd::Zero(crs.num_rows, crs.num_cols);
  for (int row = 0; row < crs.num_rows; ++row) {
    for (int k = crs.rows[row]; k < crs.rows[row + 1]; ++k) jw(row, crs.cols[k]) = crs.values[k];
  }
  const int dim = use_heading ? 3 : 2;
  // Residual r = (f(p) - m) / sigma, so dr/dm = -diag(1/sigma) = -W.
  Eigen::MatrixXd cov_m = Eigen::MatrixXd::Zero(2 * dim, 2 * dim);
  cov_m.topLeftCorner(dim, dim) = CovarianceOfMean(input.cw, use_heading);
  cov_m.bottomRightCorner(dim, dim) = CovarianceOfMean(input.ccw, use_heading);
  if (jw.rows() != 2 * dim) return;
  const Eigen::MatrixXd normal = jw.transpose() * jw;
  Eigen::MatrixXd weights = Eigen::MatrixXd::Zero(2 * dim, 2 * dim);
  for (int i = 0; i < 2 * dim; ++i) weights(i, i) = coupled->residual_weights[i];
  const Eigen::MatrixXd a = normal.ldlt().solve(jw.transpose() * weights);
  const Eigen::Matrix2d cov_p = a * cov_m * a.transpose();
  coupled->sigma_Ed = std::sqrt(cov_p(0, 0));
  coupled->sigma_Eb = std::sqrt(cov_p(1, 1));
  if (cov_p(0, 0) > 0.0 && cov_p(1, 1) > 0.0)
    coupled->correlation = cov_p(0, 1) / std::sqrt(cov_p(0, 0) * cov_p(1, 1));
  // Student's t: the covariance was learned from n runs a direction.
  const int dof = static_cast<int>(input.cw.size()) - 1;
  coupled->t95 = boost::math::quantile(
      boost::math::complement(boost::math::students_t(dof), 0.025));
}

}  // namespace

ReturnError ReturnError::FromMmDeg(double x_mm, double y_mm, std::optional<double> heading_deg) {
  ReturnError e;
  e.x_m = x_mm * kMmToM;
  e.y_m = y_mm * kMmToM;
  if (heading_deg) e.heading_rad = *heading_deg / kRadToDeg;
  return e;
}

std::ostream& operator<<(std::ostream& os, const ReturnError& e) {
  os << "ReturnError(x=" << e.x_m * kMToMm << " mm, y=" << e.y_m * kMToMm << " mm";
  if (e.heading_rad) os << ", heading=" << *e.heading_rad * kRadToDeg << " deg";
  return os << ")";
}

Status UmbmarkInput::AddRun(const RunSpec& spec, const Pose2& return_error) {
  if (spec.procedure != Procedure::kUmbmark) return Status::Error(StatusCode::kInvalidArgument, "not a UMBMark square");
  if (side_m == 0.0) side_m = spec.side_m;
  if (std::abs(spec.side_m - side_m) > 1e-9)
    return Status::Error(StatusCode::kInvalidArgument, "a square of another side cannot be pooled");
  const ReturnError e{return_error.x(), return_error.y(), return_error.heading()};
  (spec.direction == Direction::kCw ? cw : ccw).push_back(e);
  return Status::Ok();
}

bool UmbmarkInput::IsValid(std::string* why) const {
  auto fail = [why](const std::string& message) {
    if (why) *why = message;
    return false;
  };
  if (!std::isfinite(side_m) || side_m <= 0.0) return fail("side-mm must be a positive number");
  if (!std::isfinite(track_m) || track_m <= 0.0)
    return fail("track-mm must be a positive number");
  if (cw.empty()) return fail("cw: no clockwise runs given");
  if (ccw.empty()) return fail("ccw: no counter-clockwise runs given");
  if (cw.size() != ccw.size()) {
    return fail("cw/ccw: " + std::to_string(cw.size()) + " clockwise but " +
                std::to_string(ccw.size()) +
                " counter-clockwise runs; UMBMark needs as many of each");
  }
  if (!AllFinite(cw)) return fail("cw: a return error is not a finite number");
  if (!AllFinite(ccw)) return fail("ccw: a return error is not a finite number");
  return true;
}

bool UmbmarkOptions::IsValid(std::string* why) const {
  auto fail = [why](const std::string& message) {
    if (why) *why = message;
    return false;
  };
  if (!(mean_scale > 0.0) || !std::isfinite(mean_scale))
    return fail("mean_scale must be positive");
  if (!(default_position_sigma_m > 0.0) || !(default_heading_sigma_rad > 0.0))
    return fail("default sigmas must be positive");
  if (!(min_position_sigma_m > 0.0) || !(min_heading_sigma_rad > 0.0))
    return fail("sigma floors must be positive");
  std::string solver_why;
  if (!solver.IsValid(&solver_why)) return fail(solver_why);
  return true;
}

double CentreOfGravity::radius_m() const { return std::hypot(x_m, y_m); }

double CorrectionLeft(double Ed) { return 2.0 / (Ed + 1.0); }
double CorrectionRight(double Ed) { return 2.0 / (1.0 / Ed + 1.0); }

Result<FirstOrderEstimate> FirstOrderFromX(double x_cw_m, double x_ccw_m, double side_m, double track_m) {
  return FromAlphaBeta(AlphaFromX(x_cw_m, x_ccw_m, side_m), BetaFromX(x_cw_m, x_ccw_m, side_m), side_m, track_m, "x");
}

Result<FirstOrderEstimate> FirstOrderFromY(double y_cw_m, double y_ccw_m, double side_m, double track_m) {
  return FromAlphaBeta(AlphaFromY(y_cw_m, y_ccw_m, side_m), BetaFromY(y_cw_m, y_ccw_m, side_m), side_m, track_m, "y");
}

namespace {

// EstimateUmbmark's steps, in order.

// The centres of gravity and the first-order estimates from x and from y,
// with their sigmas; false (and the summary says why) when either is
// meaningless.
bool EstimateFirstOrder(const UmbmarkInput& input, UmbmarkSummary* summary) {
  const double L = input.side_m;
  const double b = input.track_m;
  summary->cw = ComputeCentre(input.cw);
  summary->ccw = ComputeCentre(input.ccw);
  summary->emax_syst_m = std::max(summary->cw.radius_m(), summary->ccw.radius_m());

  const Result<FirstOrderEstimate> from_x = FirstOrderFromX(summary->cw.x_m, summary->ccw.x_m, L, b);
  const Result<FirstOrderEstimate> from_y = FirstOrderFromY(summary->cw.y_m, summary->ccw.y_m, L, b);
  for (const Result<FirstOrderEstimate>* r : {&from_x, &from_y}) {
    if (r->ok()) continue;
    summary->status = r->status;
    summary->message = r->message;
    return false;
  }
  summary->from_x = *from_x;
  summary->from_y = *from_y;
  PropagateFirstOrder(summary->cw.x_m, summary->ccw.x_m, summary->cw.sigma_x_m, summary->ccw.sigma_x_m, L, b,
                      AlphaFromX, BetaFromX, &summary->from_x);
  PropagateFirstOrder(summary->cw.y_m, summary->ccw.y_m, summary->cw.sigma_y_m, summary->ccw.sigma_y_m, L, b,
                      AlphaFromY, BetaFromY, &summary->from_y);
  return true;
}

// The coupled fit of the exact square: how it is weighted, its problem and
// its two parameters.
struct CoupledFit {
  bool repeated = false;  // weights from the spread of the runs (else from the options)
  bool use_heading = false;
  double ed = 1.0;
  double eb = 1.0;
  ceres::Problem problem;
};

// One residual block per direction against the exact square, each weighted
// by the spread of the runs when the fit is `repeated`, else by the options'
// sigmas; the weights go to the summary's coupled estimate. Ed and Eb are
// bounded to [0.5, 2].
void AddSquareResiduals(const UmbmarkInput& input, const UmbmarkOptions& options, UmbmarkSummary* summary,
                        CoupledFit* fit) {
  const bool repeated = fit->repeated;
  double* ed = &fit->ed;
  double* eb = &fit->eb;
  ceres::Problem* problem = &fit->problem;
  for (const auto& [direction, cg] :
       {std::pair{Direction::kCw, summary->cw}, std::pair{Direction::kCcw, summary->ccw}}) {
    const double sx = repeated ? std::max(*cg.sigma_x_m, options.min_position_sigma_m)
                               : options.default_position_sigma_m;
    const double sy = repeated ? std::max(*cg.sigma_y_m, options.min_position_sigma_m)
                               : options.default_position_sigma_m;
    std::optional<double> sh;
    if (fit->use_heading) {
      sh = repeated ? std::max(*cg.sigma_heading_rad, options.min_heading_sigma_rad)
                    : options.default_heading_sigma_rad;
    }
    auto* functor = new SquareResidual(direction, input, options.mean_scale, cg, sx, sy, sh);
    summary->coupled.residual_weights.push_back(1.0 / sx);
    summary->coupled.residual_weights.push_back(1.0 / sy);
    if (sh) summary->coupled.residual_weights.push_back(1.0 / *sh);
    const int num_residuals = functor->num_residuals();
    problem->AddResidualBlock(
        new ceres::AutoDiffCostFunction<SquareResidual, ceres::DYNAMIC, 1, 1>(functor, num_residuals), nullptr, ed, eb);
  }
  problem->SetParameterLowerBound(ed, 0, 0.5);
  problem->SetParameterUpperBound(ed, 0, 2.0);
  problem->SetParameterLowerBound(eb, 0, 0.5);
  problem->SetParameterUpperBound(eb, 0, 2.0);
}

}  // namespace

UmbmarkSummary EstimateUmbmark(const UmbmarkInput& input, const UmbmarkOptions& options) {
  UmbmarkSummary summary;
  std::string why;
  if (!input.IsValid(&why) || !options.IsValid(&why)) {
    summary.status = StatusCode::kInvalidArgument;
    summary.message = why;
    return summary;
  }
  const double b = input.track_m;
  if (!EstimateFirstOrder(input, &summary)) return summary;

  // Coupled fit of the exact square. Weights come from the spread of the runs
  // when there is one (then the covariance means something), else from the
  // options (then only the estimate does).
  CoupledFit fit;
  fit.repeated = summary.cw.sigma_x_m && summary.ccw.sigma_x_m;
  fit.use_heading = options.use_heading && AllHaveHeading(input.cw) && AllHaveHeading(input.ccw);
  fit.ed = summary.from_x.Ed;
  fit.eb = summary.from_x.Eb;
  AddSquareResiduals(input, options, &summary, &fit);
  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::DENSE_QR;
  ApplyTo(options.solver, &solver_options);
  ceres::Solver::Summary solver_summary;
  ceres::Solve(solver_options, &fit.problem, &solver_summary);
  if (!solver_summary.IsSolutionUsable()) {
    summary.status = StatusCode::kNoConvergence;
    summary.message = "coupled fit did not converge: " + solver_summary.message;
    return summary;
  }
  CoupledEstimate& coupled = summary.coupled;
  coupled.Ed = fit.ed;
  coupled.Eb = fit.eb;
  coupled.used_heading = fit.use_heading;
  coupled.iterations = static_cast<int>(solver_summary.iterations.size());
  coupled.rms_weighted_residual =
      std::sqrt(2.0 * solver_summary.final_cost / solver_summary.num_residuals);
  if (fit.repeated) {
    PropagateRunSpread(input, fit.use_heading, &fit.problem, &fit.ed, &fit.eb, &coupled);
  }
  summary.track_corrected_m = b * fit.eb;
  summary.turn_scale = fit.eb / options.mean_scale;
  summary.c_left = CorrectionLeft(fit.ed);
  summary.c_right = CorrectionRight(fit.ed);
  summary.status = StatusCode::kOk;
  summary.message = "ok";
  return summary;
}

std::string UmbmarkSummary::BriefReport() const {
  std::ostringstream os;
  if (!ok()) return "UMBMark: " + message;
  os << "UMBMark, " << cw.n << " cw + " << ccw.n << " ccw runs: E_max,syst = "
     << Fixed(emax_syst_m * kMToMm, 2) << " mm; Ed = " << Fixed(coupled.Ed, 6);
  if (coupled.sigma_Ed) os << " +/- " << Fixed(*coupled.sigma_Ed, 6);
  os << ", Eb = " << Fixed(coupled.Eb, 6);
  if (coupled.sigma_Eb) os << " +/- " << Fixed(*coupled.sigma_Eb, 6);
  return os.str();
}

}  // namespace odocal::calibration
