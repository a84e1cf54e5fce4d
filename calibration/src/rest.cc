#include "odocal/calibration/rest.h"

#include <algorithm>
#include <cmath>
#include <ostream>
#include <utility>

#include "odocal/calibration/statistics.h"

namespace odocal::calibration {
namespace {

// Mean of a set of poses: positions averaged, headings averaged as offsets
// from the first (rests never span a wrap-around in practice, and this is
// exact for small spreads wherever the heading is).
RestWindow Summarize(const std::vector<PoseSample>& samples, size_t begin, size_t end) {
  RestWindow w;
  std::vector<Eigen::Vector3d> values;
  const double reference = samples[begin].pose.heading();
  for (size_t i = begin; i < end; ++i) {
    if (!samples[i].valid) continue;
    const Pose2& p = samples[i].pose;
    values.emplace_back(p.x(), p.y(), WrapAngle(p.heading() - reference));
  }
  w.n = static_cast<int>(values.size());
  w.t_begin_s = samples[begin].t_s;
  w.t_end_s = samples[end - 1].t_s;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& v : values) mean += v;
  mean /= w.n;
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (const auto& v : values) scatter += (v - mean) * (v - mean).transpose();
  if (w.n >= 2) w.covariance = scatter / ((w.n - 1.0) * w.n);
  w.mean = Pose2::FromXYHeading(mean.x(), mean.y(), reference + mean.z());
  return w;
}

}  // namespace

bool RestOptions::IsValid(std::string* why) const {
  auto fail = [why](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (!(window_s > 0.0)) return fail("window_s must be positive");
  if (!(position_tolerance_m >= 0.0)) return fail("position_tolerance_m must not be negative");
  if (!(heading_tolerance_rad >= 0.0)) return fail("heading_tolerance_rad must not be negative");
  if (!(min_duration_s >= 0.0)) return fail("min_duration_s must not be negative");
  if (!(max_gap_s >= 0.0)) return fail("max_gap_s must not be negative");
  return true;
}

std::ostream& operator<<(std::ostream& os, const RestWindow& r) {
  return os << "RestWindow(" << r.t_begin_s << "-" << r.t_end_s << " s, n=" << r.n << ", "
            << r.mean << ")";
}

namespace {

// A series, what FindRests was asked, and what its steps learn of the series.
struct RestSearch {
  const std::vector<PoseSample>& samples;
  const RestOptions& options;
  std::vector<size_t> valid;  // indices of the valid samples
  double tol_p = 0.0;         // m, a rest's spread of positions
  double tol_h = 0.0;         // rad, a rest's spread of headings
};

using SampleRange = std::pair<size_t, size_t>;  // [begin, end) sample indices

// Tolerances from the options, or where those are 0 from the data. Second
// differences are pure noise at rest and at constant velocity (only
// accelerations add to them, briefly), so their median gives the frame noise
// robustly whatever the robot did: |d2 p| is Rayleigh with scale sqrt(6)
// sigma (median 1.1774 scale), d2 heading is normal with sigma sqrt(6)
// (median |.| 0.6745 sigma sqrt(6)).
void SetTolerances(RestSearch* search) {
  const std::vector<PoseSample>& samples = search->samples;
  const std::vector<size_t>& valid = search->valid;
  const RestOptions& options = search->options;
  double tol_p = options.position_tolerance_m, tol_h = options.heading_tolerance_rad;
  if (tol_p == 0.0 || tol_h == 0.0) {
    std::vector<double> d2_p, d2_h;
    for (size_t k = 1; k + 1 < valid.size(); ++k) {
      const Pose2& a = samples[valid[k - 1]].pose;
      const Pose2& b = samples[valid[k]].pose;
      const Pose2& c = samples[valid[k + 1]].pose;
      d2_p.push_back((c.translation() - 2.0 * b.translation() + a.translation()).norm());
      d2_h.push_back(std::abs(WrapAngle(c.heading() - b.heading()) - WrapAngle(b.heading() - a.heading())));
    }
    const double sigma_p = Median(d2_p) / (std::sqrt(6.0) * 1.1774);
    const double sigma_h = Median(d2_h) / (std::sqrt(6.0) * 0.6745);
    // 4.5 sigma: a still window of a dozen frames stays inside with
    // probability above 99.9 %.
    if (tol_p == 0.0) tol_p = std::max(options.min_position_tolerance_m, 4.5 * sigma_p);
    if (tol_h == 0.0) tol_h = std::max(options.min_heading_tolerance_rad, 4.5 * sigma_h);
  }
  search->tol_p = tol_p;
  search->tol_h = tol_h;
}

// Rest flag per sample: a valid sample whose whole window, without a gap,
// stays within the tolerances of the window's median pose.
std::vector<bool> FlagRestSamples(const RestSearch& search) {
  const std::vector<PoseSample>& samples = search.samples;
  const std::vector<size_t>& valid = search.valid;
  const double half = search.options.window_s / 2.0;
  std::vector<double> spacing;
  for (size_t k = 1; k < valid.size(); ++k)
    spacing.push_back(samples[valid[k]].t_s - samples[valid[k - 1]].t_s);
  const double frame_dt = Median(spacing);
  std::vector<bool> rest(samples.size(), false);
  size_t lo = 0, hi = 0;
  for (size_t k = 0; k < valid.size(); ++k) {
    const double t = samples[valid[k]].t_s;
    while (samples[valid[lo]].t_s < t - half) ++lo;
    while (hi + 1 < valid.size() && samples[valid[hi + 1]].t_s <= t + half) ++hi;
    // A window cut short by the series' ends or by a gap is no evidence of rest.
    if (samples[valid[lo]].t_s > t - half + frame_dt) continue;
    if (samples[valid[hi]].t_s < t + half - frame_dt) continue;
    std::vector<double> xs, ys, hs;
    const double reference = samples[valid[k]].pose.heading();
    bool gap = false;
    for (size_t j = lo; j <= hi; ++j) {
      if (j > lo && samples[valid[j]].t_s - samples[valid[j - 1]].t_s > search.options.max_gap_s) gap = true;
      xs.push_back(samples[valid[j]].pose.x());
      ys.push_back(samples[valid[j]].pose.y());
      hs.push_back(WrapAngle(samples[valid[j]].pose.heading() - reference));
    }
    if (gap) continue;
    const Eigen::Vector2d centre(Median(xs), Median(ys));
    const double heading_centre = Median(hs);
    bool still = true;
    for (size_t j = 0; j < xs.size() && still; ++j) {
      still = (Eigen::Vector2d(xs[j], ys[j]) - centre).norm() <= search.tol_p &&
              std::abs(hs[j] - heading_centre) <= search.tol_h;
    }
    rest[valid[k]] = still;
  }
  return rest;
}

// Maximal runs of rest samples, split at gaps.
std::vector<SampleRange> RunsOfRest(const RestSearch& search, const std::vector<bool>& rest) {
  const std::vector<PoseSample>& samples = search.samples;
  const std::vector<size_t>& valid = search.valid;
  std::vector<SampleRange> runs;
  size_t k = 0;
  while (k < valid.size()) {
    if (!rest[valid[k]]) {
      ++k;
      continue;
    }
    size_t m = k;
    while (m + 1 < valid.size() && rest[valid[m + 1]] &&
           samples[valid[m + 1]].t_s - samples[valid[m]].t_s <= search.options.max_gap_s)
      ++m;
    runs.emplace_back(valid[k], valid[m] + 1);
    k = m + 1;
  }
  return runs;
}

// One noisy frame knocks a window's worth of frames out of a rest. Two
// pieces a short interruption apart whose means agree are one rest.
std::vector<SampleRange> MergeInterrupted(const RestSearch& search, const std::vector<SampleRange>& runs) {
  const std::vector<PoseSample>& samples = search.samples;
  std::vector<SampleRange> merged;
  for (const auto& run : runs) {
    if (!merged.empty()) {
      const auto& last = merged.back();
      const double hole = samples[run.first].t_s - samples[last.second - 1].t_s;
      const RestWindow a = Summarize(samples, last.first, last.second);
      const RestWindow b = Summarize(samples, run.first, run.second);
      if (hole <= 1.5 * search.options.window_s &&
          (a.mean.translation() - b.mean.translation()).norm() < 0.5 * search.tol_p &&
          std::abs(WrapAngle(a.mean.heading() - b.mean.heading())) < 0.5 * search.tol_h) {
        merged.back().second = run.second;
        continue;
      }
    }
    merged.push_back(run);
  }
  return merged;
}

}  // namespace

RestSummary FindRests(const std::vector<PoseSample>& samples, const RestOptions& options) {
  RestSummary summary;
  RestSearch search{samples, options, {}};
  std::vector<size_t>& valid = search.valid;
  for (size_t i = 0; i < samples.size(); ++i)
    if (samples[i].valid) valid.push_back(i);
  if (valid.size() < 3) return summary;
  SetTolerances(&search);
  summary.position_tolerance_m = search.tol_p;
  summary.heading_tolerance_rad = search.tol_h;
  const std::vector<bool> rest = FlagRestSamples(search);
  const std::vector<SampleRange> merged = MergeInterrupted(search, RunsOfRest(search, rest));
  for (const auto& [begin, end] : merged) {
    if (samples[end - 1].t_s - samples[begin].t_s >= options.min_duration_s)
      summary.rests.push_back(Summarize(samples, begin, end));
  }
  return summary;
}

std::optional<RestWindow> SummarizeRest(const std::vector<PoseSample>& samples) {
  size_t first_valid = samples.size();
  for (size_t i = 0; i < samples.size(); ++i) {
    if (samples[i].valid) {
      first_valid = i;
      break;
    }
  }
  if (first_valid == samples.size()) return std::nullopt;
  return Summarize(samples, first_valid, samples.size());
}

double RelativePose::sigma_x_m() const { return std::sqrt(covariance(0, 0)); }
double RelativePose::sigma_y_m() const { return std::sqrt(covariance(1, 1)); }
double RelativePose::sigma_heading_rad() const { return std::sqrt(covariance(2, 2)); }

RelativePose TrueMinusOdometry(const RelativePose& truth, const Pose2& odometry) {
  RelativePose r = truth;
  r.pose = Pose2::FromXYHeading(truth.pose.x() - odometry.x(), truth.pose.y() - odometry.y(),
                                WrapAngle(truth.pose.heading() - odometry.heading()));
  return r;
}

RelativePose Between(const RestWindow& start, const RestWindow& end) {
  RelativePose r;
  r.pose = start.mean.inverse() * end.mean;
  // Jacobians of T_s^-1 T_e with respect to (x, y, heading) of each mean.
  const double c = std::cos(start.mean.heading()), s = std::sin(start.mean.heading());
  const Eigen::Vector2d d = end.mean.translation() - start.mean.translation();
  Eigen::Matrix3d J_start, J_end;
  J_start << -c, -s, -s * d.x() + c * d.y(),  //
      s, -c, -c * d.x() - s * d.y(),          //
      0, 0, -1;
  J_end << c, s, 0,  //
      -s, c, 0,      //
      0, 0, 1;
  r.covariance = J_start * start.covariance * J_start.transpose() +
                 J_end * end.covariance * J_end.transpose();
  return r;
}

RelativePose Between(const RestWindow& start, const RestWindow& end, const SystematicFloor& floor) {
  RelativePose r = Between(start, end);
  r.covariance(0, 0) += floor.position_m * floor.position_m;
  r.covariance(1, 1) += floor.position_m * floor.position_m;
  r.covariance(2, 2) += floor.heading_rad * floor.heading_rad;
  return r;
}

}  // namespace odocal::calibration
