// The delete-one (or delete-a-group) jackknife over runs: how far each
// parameter of a trajectory fit moves when runs are left out (trajectory_fit.h, AddRunJackknife).
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "odocal/base/parallel.h"
#include "odocal/calibration/trajectory_fit.h"

namespace odocal::calibration {

int AddRunJackknife(const MeasuredSession& session, TrajectoryFitResult* fit, int threads,
                    std::vector<RunLeftOut>* left_out, int max_groups) {
  fit->jackknife_runs = 0;
  fit->jackknife_groups = 0;
  if (left_out) left_out->assign(session.runs.size(), RunLeftOut{});
  if (!fit->ok()) return 0;
  std::vector<size_t> used;
  for (size_t i = 0; i < fit->run_used.size(); ++i)
    if (fit->run_used[i]) used.push_back(i);
  const int n = static_cast<int>(used.size());
  if (n < 3) return 0;
  // Up to max_groups refits: one run each, or for more runs used run k in
  // group k mod g (delete-a-group), so that the cost grows with the runs as
  // one fit does, not as their square.
  const int g = std::min(n, std::max(3, max_groups));
  std::vector<std::vector<size_t>> groups(g);  // positions in the session
  for (int k = 0; k < n; ++k) groups[k % g].push_back(used[k]);

  // Refit without each group; independent, so in parallel. Each starts from
  // the full fit's solution (a few runs fewer move it a little), which takes
  // a few iterations instead of a cold start's many.
  std::vector<TrajectoryFitResult> refits(g);
  ParallelFor(groups.size(), threads > 0 ? static_cast<unsigned>(threads) : 0u, [&](size_t j) {
    MeasuredSession without = session;
    // Erase from the back so the positions of the group stay valid.
    for (auto it = groups[j].rbegin(); it != groups[j].rend(); ++it)
      without.runs.erase(without.runs.begin() + static_cast<std::ptrdiff_t>(*it));
    const TrajectoryFitResult warm = WarmStartWithout(*fit, groups[j]);
    refits[j] = FitTrajectory(without, fit->options, &warm);
    // Only the parameters are kept: the residuals of every refit at once
    // would hold the whole session g times.
    refits[j].residuals.clear();
    refits[j].residuals.shrink_to_fit();
  });

  int failed = 0;
  for (const TrajectoryFitResult& r : refits) failed += r.ok() ? 0 : 1;
  if (left_out)
    for (size_t k = 0; k < used.size(); ++k) {
      const TrajectoryFitResult& r = refits[k % g];  // the refit without run k's group
      RunLeftOut& o = (*left_out)[used[k]];
      o.refitted = true;
      o.scales = r.scales;
      o.determines_wheels = r.ok();
      if (!r.ok()) o.message = "the fit failed (" + r.message + ")";
      for (const char* key : {"Ed", "Es", "Eb", "turn_gain"}) {
        const ParameterEstimate* p = r.Find(key);
        if (o.determines_wheels && p != nullptr && !p->identifiable) {
          o.determines_wheels = false;
          o.message = std::string("the fit does not determine ") + key;
        }
      }
    }
  fit->jackknife_runs = n;
  fit->jackknife_groups = g;
  for (ParameterEstimate& p : fit->parameters) {
    p.sigma_between_runs = std::numeric_limits<double>::quiet_NaN();
    if (failed > 0 || !p.identifiable) continue;
    std::vector<double> values;
    for (const TrajectoryFitResult& r : refits) {
      const ParameterEstimate* q = r.Find(p.name);
      if (q == nullptr || !q->identifiable) break;
      values.push_back(q->value);
    }
    if (static_cast<int>(values.size()) != g) continue;
    double mean = 0.0;
    for (double v : values) mean += v;
    mean /= g;
    double sum = 0.0;
    for (double v : values) sum += (v - mean) * (v - mean);
    p.sigma_between_runs = std::sqrt((g - 1.0) / g * sum);
    // What every run shares, their disagreement cannot show: the camera's
    // length scale moves Es and Eb 1:1 in all runs alike (measured_session.h).
    if (p.name == "Es" || p.name == "Eb")
      p.sigma_between_runs = std::hypot(p.sigma_between_runs, p.value * session.camera_scale_sigma);
  }
  return failed;
}

TrajectoryFitResult WarmStartWithout(const TrajectoryFitResult& fit,
                                     const std::vector<size_t>& removed) {
  TrajectoryFitResult warm;
  warm.status = fit.status;
  warm.scales = fit.scales;
  warm.effects = fit.effects;
  warm.run_used = fit.run_used;
  warm.start_poses = fit.start_poses;
  // Erase from the back so the positions still to erase stay valid.
  for (auto it = removed.rbegin(); it != removed.rend(); ++it) {
    const auto at = static_cast<std::ptrdiff_t>(*it);
    warm.run_used.erase(warm.run_used.begin() + at);
    warm.start_poses.erase(warm.start_poses.begin() + at);
  }
  return warm;
}

}  // namespace odocal::calibration
