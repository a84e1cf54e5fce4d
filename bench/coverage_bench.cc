// The trajectory fit's Monte Carlo coverage at full size (issue 26 §3: long
// statistical checks keep their size here, trajectory_fit_test runs 40
// trials): over seeded sessions of one 2 m square each way, how often the 95 %
// intervals of Ed and Eb hold the simulator's truth, and the mean z^2 of their
// errors. The full-size check: 100 trials from seed 1000, each coverage within
// 90-99 %. Exit 0 when both are, else 1. docs/performance.md, "Statistical
// checks at full size".
//   ./build/bench/coverage_bench [--trials 100] [--seed0 1000]
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>

#include "coverage_trials.h"

int main(int argc, char** argv) {
  int trials = 100;
  long long seed0 = 1000;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--trials")) {
      trials = std::atoi(argv[i + 1]);
    } else if (!std::strcmp(argv[i], "--seed0")) {
      seed0 = std::atoll(argv[i + 1]);
    } else {
      std::fprintf(stderr, "usage: coverage_bench [--trials N] [--seed0 S]\n");
      return 2;
    }
  }
  if (trials < 1 || seed0 < 0) {
    std::fprintf(stderr, "coverage_bench: --trials must be at least 1, --seed0 not negative\n");
    return 2;
  }
  using Clock = std::chrono::steady_clock;
  const Clock::time_point start = Clock::now();
  const odocal::testing::CoverageTrials t =
      odocal::testing::RunCoverageTrials(trials, static_cast<std::uint64_t>(seed0));
  const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
  const int n = t.trials - t.failed_fits;  // fitted
  auto in_bounds = [n](int in) { return in >= 0.90 * n && in <= 0.99 * n; };
  std::printf("trials %d (seeds %lld-%lld)", t.trials, seed0, seed0 + trials - 1);
  std::printf(", fits failed %d, %.1f s\n", t.failed_fits, seconds);
  const double ed_percent = 100.0 * t.ed_in / n, eb_percent = 100.0 * t.eb_in / n;
  std::printf("Ed: 95 %% interval held the truth %d of %d (%.1f %%)", t.ed_in, n, ed_percent);
  std::printf(", mean z^2 %.3f\n", t.ed_mean_z2);
  std::printf("Eb: 95 %% interval held the truth %d of %d (%.1f %%)", t.eb_in, n, eb_percent);
  std::printf(", mean z^2 %.3f\n", t.eb_mean_z2);
  const bool pass = t.failed_fits == 0 && in_bounds(t.ed_in) && in_bounds(t.eb_in);
  std::printf("%s: each coverage within 90-99 %%, no failed fit\n", pass ? "PASS" : "FAIL");
  return pass ? 0 : 1;
}
