// The Monte Carlo coverage of the trajectory fit's 95 % intervals of Ed and Eb:
// seeded sessions of one 2 m UMBMark square each way (wheel noise, encoder
// phase and camera noise redrawn with the seed), each fitted, each interval
// checked against the simulator's truth. trajectory_fit_test runs a suite-sized
// number of trials; bench/coverage_bench.cc the full size (docs/performance.md,
// "Statistical checks at full size").
#ifndef ODOCAL_TESTS_CALIBRATION_COVERAGE_TRIALS_H_
#define ODOCAL_TESTS_CALIBRATION_COVERAGE_TRIALS_H_

#include <cstdint>
#include <vector>

#include "explain_fixtures.h"
#include "odocal/calibration/trajectory_fit.h"

namespace odocal::testing {

struct CoverageTrials {
  int trials = 0;
  int failed_fits = 0;
  int ed_in = 0, eb_in = 0;  // trials whose 95 % interval holds the truth
  // The mean over the trials of z^2, z = (value - truth) / sigma: 1 when the
  // sigmas are right, chi-square with `trials` degrees of freedom over
  // `trials` if the errors are normal.
  double ed_mean_z2 = 0.0, eb_mean_z2 = 0.0;
};

// Trials with seeds seed0, seed0 + 1, ...
inline CoverageTrials RunCoverageTrials(int trials, std::uint64_t seed0,
                                        const calibration::TrajectoryFitOptions& options = {}) {
  using calibration::Direction;
  using calibration::RunSpec;
  std::vector<RunSpec> squares;
  for (Direction d : {Direction::kCw, Direction::kCcw}) squares.push_back(RunSpec::Umbmark(d, 2.0));
  CoverageTrials t;
  t.trials = trials;
  for (int i = 0; i < trials; ++i) {
    const SessionUnderTest s = MakeSession(squares, {}, seed0 + static_cast<std::uint64_t>(i));
    const calibration::TrajectoryFitResult fit = calibration::FitTrajectory(s.session, options);
    if (!fit.ok()) {
      ++t.failed_fits;
      continue;
    }
    const calibration::ParameterEstimate* ed = fit.Find("Ed");
    const calibration::ParameterEstimate* eb = fit.Find("Eb");
    t.ed_in += ed->lower95() <= s.truth.Ed && s.truth.Ed <= ed->upper95();
    t.eb_in += eb->lower95() <= s.truth.Eb && s.truth.Eb <= eb->upper95();
    const double z_ed = (ed->value - s.truth.Ed) / ed->sigma;
    const double z_eb = (eb->value - s.truth.Eb) / eb->sigma;
    t.ed_mean_z2 += z_ed * z_ed / trials;
    t.eb_mean_z2 += z_eb * z_eb / trials;
  }
  return t;
}

}  // namespace odocal::testing

#endif  // ODOCAL_TESTS_CALIBRATION_COVERAGE_TRIALS_H_
