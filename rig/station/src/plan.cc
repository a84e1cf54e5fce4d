#include "odocal/station/plan.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "odocal/base/units.h"

namespace odocal::station {

using calibration::Pose2;
using calibration::RunSpec;

namespace {

// Whether a square of side L from `start` keeps the tag in view at every
// corner, arriving and leaving (as setup-check draws it).
bool SquareFits(const std::function<bool(const Eigen::Vector2d&)>& in_view, const Pose2& start,
                const Pose2& T_robot_tag, double L, double turn) {
  Pose2 pose = start;
  for (int side = 0; side < 4; ++side) {
    pose = pose * Pose2::FromXYHeading(L, 0.0, 0.0);
    for (const Pose2& at : {pose, pose * Pose2::FromXYHeading(0.0, 0.0, turn)})
      if (!in_view((at * T_robot_tag).translation())) return false;
    pose = pose * Pose2::FromXYHeading(0.0, 0.0, turn);
  }
  return true;
}

// A straight ahead of D, checked every tenth of the way.
bool StraightFits(const std::function<bool(const Eigen::Vector2d&)>& in_view, const Pose2& start,
                  const Pose2& T_robot_tag, double D) {
  for (int k = 1; k <= 10; ++k)
    if (!in_view((start * Pose2::FromXYHeading(D * k / 10.0, 0.0, 0.0) * T_robot_tag).translation())) return false;
  return true;
}

}  // namespace

std::vector<RunSpec> DefaultPlan(const std::function<bool(const Eigen::Vector2d&)>& in_view, const Pose2& start,
                                 const Pose2& T_robot_tag, const DefaultPlanOptions& options,
                                 std::string* summary) {
  std::optional<double> side, distance;
  for (double L : options.sizes_m) {
    if (!side && SquareFits(in_view, start, T_robot_tag, L, -M_PI / 2) &&
        SquareFits(in_view, start, T_robot_tag, L, M_PI / 2))
      side = L;
    if (!distance && StraightFits(in_view, start, T_robot_tag, L)) distance = L;
  }
  if (!side) {
    if (summary)
      *summary = "not even a " + std::to_string(static_cast<int>(options.sizes_m.back() * kMToMm)) +
                 " mm square keeps the tag in view from where the robot stands: move the robot to the middle of "
                 "the view, or raise the camera";
    return {};
  }
  std::vector<RunSpec> plan;
  for (int i = 0; i < options.squares_per_direction; ++i) {
    plan.push_back(RunSpec::Umbmark(calibration::Direction::kCw, *side));
    plan.push_back(RunSpec::Umbmark(calibration::Direction::kCcw, *side));
  }
  if (distance) {
    for (int i = 0; i < options.straight_pairs; ++i) {
      plan.push_back(RunSpec::Straight(*distance));
      plan.push_back(RunSpec::Straight(-*distance));
    }
  }
  for (double rate : {options.slow_turn_rate_rad_s, options.fast_turn_rate_rad_s}) {
    for (int i = 0; i < options.spins_per_rate; ++i) {
      RunSpec spin = RunSpec::Spin(options.spin_turns,
                                   i % 2 == 0 ? calibration::Direction::kCcw : calibration::Direction::kCw);
      spin.turn_rate_rad_s = rate;
      plan.push_back(spin);
    }
  }
  if (summary) {
    char text[300];
    std::snprintf(text, sizeof(text),
                  "default plan: %d+%d UMBMark squares of %.0f mm, %s, %d+%d spins of %d turns at %.0f and %.0f "
                  "deg/s (%zu runs)",
                  options.squares_per_direction, options.squares_per_direction, *side * kMToMm,
                  distance ? (std::to_string(2 * options.straight_pairs) + " straights of " +
                              std::to_string(static_cast<int>(std::lround(*distance * kMToMm))) + " mm ahead and back")
                                 .c_str()
                           : "no straight fits in view",
                  options.spins_per_rate / 2 + options.spins_per_rate % 2, options.spins_per_rate / 2,
                  options.spin_turns, RadToDeg(options.slow_turn_rate_rad_s),
                  RadToDeg(options.fast_turn_rate_rad_s), plan.size());
    *summary = text;
  }
  return plan;
}

TurnSlipResult AnalyzeTurnRates(const std::vector<SpinTrack>& spins, double z) {
  TurnSlipResult r;
  std::vector<SpinTrack> sorted = spins;
  std::sort(sorted.begin(), sorted.end(),
            [](const SpinTrack& a, const SpinTrack& b) { return a.turn_rate_rad_s < b.turn_rate_rad_s; });
  std::vector<std::vector<double>> values;
  for (const SpinTrack& s : sorted) {
    if (!(s.turn_rate_rad_s > 0.0)) continue;
    if (r.groups.empty() || s.turn_rate_rad_s > r.groups.back().turn_rate_rad_s * 1.01) {
      r.groups.push_back({s.turn_rate_rad_s, 0, 0.0, std::nullopt});
      values.emplace_back();
    }
    values.back().push_back(s.track_factor);
  }
  for (size_t g = 0; g < r.groups.size(); ++g) {
    const std::vector<double>& v = values[g];
    double mean = 0.0;
    for (double x : v) mean += x;
    mean /= v.size();
    r.groups[g].runs = static_cast<int>(v.size());
    r.groups[g].mean = mean;
    if (v.size() >= 2) {
      double ss = 0.0;
      for (double x : v) ss += (x - mean) * (x - mean);
      r.groups[g].standard_error = std::sqrt(ss / (v.size() - 1) / v.size());
    }
  }
  if (r.groups.size() < 2) return r;
  const TurnRateGroup& a = r.groups.front();
  const TurnRateGroup& b = r.groups.back();
  if (!a.standard_error || !b.standard_error) return r;
  const double w1 = a.turn_rate_rad_s, w2 = b.turn_rate_rad_s;
  auto slip = [&](double e1, double e2) { return (e2 - e1) / (e2 * w2 - e1 * w1); };
  auto at_rest = [&](double e1, double e2) { return e1 * (1.0 - slip(e1, e2) * w1); };
  const double e1 = a.mean, e2 = b.mean, s1 = *a.standard_error, s2 = *b.standard_error;
  // First-order propagation by central differences (the functions are smooth).
  auto sigma = [&](auto f) {
    const double h1 = 1e-6 * std::max(1.0, std::abs(e1)), h2 = 1e-6 * std::max(1.0, std::abs(e2));
    const double d1 = (f(e1 + h1, e2) - f(e1 - h1, e2)) / (2 * h1);
    const double d2 = (f(e1, e2 + h2) - f(e1, e2 - h2)) / (2 * h2);
    return std::hypot(d1 * s1, d2 * s2);
  };
  r.slip_per_rad_s = slip(e1, e2);
  r.slip_sigma = sigma(slip);
  r.track_factor_at_rest = at_rest(e1, e2);
  r.track_factor_at_rest_sigma = sigma(at_rest);
  r.significant = std::abs(*r.slip_per_rad_s) > z * *r.slip_sigma;
  if (r.significant) {
    char text[400];
    std::snprintf(text, sizeof(text),
                  "turn slip %.1f %% at 1 rad/s (%.2f %% at %.0f deg/s, %.2f %% at %.0f deg/s; %.1f sigma): "
                  "the track the wheels need depends on how fast the robot turns: calibrate at your operating "
                  "turn rate",
                  *r.slip_per_rad_s * 100.0, *r.slip_per_rad_s * w1 * 100.0, RadToDeg(w1),
                  *r.slip_per_rad_s * w2 * 100.0, RadToDeg(w2), std::abs(*r.slip_per_rad_s) / *r.slip_sigma);
    r.advice = text;
  }
  return r;
}

}  // namespace odocal::station
