// The delete-one jackknife over runs: how far each parameter of a trajectory
// fit moves when one run is left out (trajectory_fit.h, AddRunJackknife).
#include <algorithm>
#include <atomic>
#include <cmath>
#include <string>
#include <thread>
#include <vector>

#include "odocal/calibration/trajectory_fit.h"

namespace odocal::calibration {

int AddRunJackknife(const MeasuredSession& session, TrajectoryFitResult* fit, int threads,
                    std::vector<RunLeftOut>* left_out) {
  fit->jackknife_runs = 0;
  if (left_out) left_out->assign(session.runs.size(), RunLeftOut{});
  if (!fit->ok()) return 0;
  std::vector<size_t> used;
  for (size_t i = 0; i < fit->run_used.size(); ++i)
    if (fit->run_used[i]) used.push_back(i);
  const int n = static_cast<int>(used.size());
  if (n < 3) return 0;

  // Refit without run used[k], for every k; independent, so in parallel.
  // Each starts from the full fit's solution (one run fewer moves it a
  // little), which takes a few iterations instead of a cold start's many.
  std::vector<TrajectoryFitResult> refits(used.size());
  std::atomic<size_t> next{0};
  const auto worker = [&] {
    for (size_t k = next++; k < used.size(); k = next++) {
      const auto at = static_cast<std::ptrdiff_t>(used[k]);
      MeasuredSession without = session;
      without.runs.erase(without.runs.begin() + at);
      TrajectoryFitResult warm;
      warm.status = fit->status;
      warm.scales = fit->scales;
      warm.effects = fit->effects;
      warm.run_used = fit->run_used;
      warm.run_used.erase(warm.run_used.begin() + at);
      warm.start_poses = fit->start_poses;
      warm.start_poses.erase(warm.start_poses.begin() + at);
      refits[k] = FitTrajectory(without, fit->options, &warm);
      // Only the parameters are kept: the Jacobian and the residuals of
      // every refit at once would hold the whole session n times.
      refits[k].jacobian.resize(0, 0);
      refits[k].residuals.clear();
      refits[k].residuals.shrink_to_fit();
    }
  };
  const unsigned hardware = std::max(1u, std::thread::hardware_concurrency());
  const size_t workers = std::min<size_t>(used.size(), threads > 0 ? static_cast<size_t>(threads) : hardware);
  std::vector<std::thread> pool;
  for (size_t w = 1; w < workers; ++w) pool.emplace_back(worker);
  worker();
  for (std::thread& t : pool) t.join();

  int failed = 0;
  for (const TrajectoryFitResult& r : refits) failed += r.ok() ? 0 : 1;
  if (left_out)
    for (size_t k = 0; k < used.size(); ++k) {
      const TrajectoryFitResult& r = refits[k];
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
  for (ParameterEstimate& p : fit->parameters) {
    p.sigma_between_runs = std::numeric_limits<double>::quiet_NaN();
    if (failed > 0 || !p.identifiable) continue;
    std::vector<double> values;
    for (const TrajectoryFitResult& r : refits) {
      const ParameterEstimate* q = r.Find(p.name);
      if (q == nullptr || !q->identifiable) break;
      values.push_back(q->value);
    }
    if (static_cast<int>(values.size()) != n) continue;
    double mean = 0.0;
    for (double v : values) mean += v;
    mean /= n;
    double sum = 0.0;
    for (double v : values) sum += (v - mean) * (v - mean);
    p.sigma_between_runs = std::sqrt((n - 1.0) / n * sum);
    // What every run shares, their disagreement cannot show: the camera's
    // length scale moves Es and Eb 1:1 in all runs alike (measured_session.h).
    if (p.name == "Es" || p.name == "Eb")
      p.sigma_between_runs = std::hypot(p.sigma_between_runs, p.value * session.camera_scale_sigma);
  }
  return failed;
}

}  // namespace odocal::calibration
