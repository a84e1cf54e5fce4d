// Sessions for the explain tests: a realistic mis-calibrated robot runs a
// plan on the virtual robot (robot-side effects act there), and the stand-in
// camera measures it (camera-side effects act there). The truth stays here.
#ifndef ODOCAL_TESTS_RIG_EXPLAIN_FIXTURES_H_
#define ODOCAL_TESTS_RIG_EXPLAIN_FIXTURES_H_

#include <cmath>
#include <vector>

#include "odocal/calibration/measured_session.h"
#include "odocal/config/scenario.h"
#include "odocal/sim/effects.h"
#include "odocal/simulation/simulation.h"
#include "odocal/simulation/stand_in_camera.h"
#include "odocal/test_util/robots.h"

namespace odocal::testing {

inline constexpr double kTrueEd = 1.003;
inline constexpr double kTrueEb = 1.015;

// The plan that makes every effect identifiable: squares both ways (straights
// in four headings: drift; the whole field of view: lens), spins at two turn
// rates in both directions (slip vs track; tag offset; latency), an
// out-and-back (wheel reversals between straights: backlash).
inline std::vector<calibration::RunSpec> IdentifyingPlan() {
  using calibration::Direction;
  using calibration::RunSpec;
  RunSpec slow = RunSpec::Spin(1, Direction::kCcw);
  slow.turn_rate_rad_s = 30.0 * M_PI / 180.0;
  RunSpec fast = RunSpec::Spin(2, Direction::kCw);
  fast.turn_rate_rad_s = 120.0 * M_PI / 180.0;
  return {RunSpec::Umbmark(Direction::kCw, 2.0), RunSpec::Umbmark(Direction::kCcw, 2.0), slow, fast,
          RunSpec::OutAndBack(1.0, 1)};
}

inline config::Scenario MakeScenario(const std::vector<calibration::RunSpec>& plan,
                             const sim::Effects& effects, std::uint64_t seed) {
  config::Scenario s;
  s.seed = seed;
  s.robot.nominal = test_util::NominalParams();
  s.robot.truth = test_util::TrueParamsFor(s.robot.nominal, kTrueEd, kTrueEb);
  s.robot.noise.wheel_sigma_m_per_sqrt_m = 0.05e-3;  // the scenario default
  s.robot.noise.random_encoder_phase = true;
  s.robot.control_rate_hz = 500.0;
  s.robot.rest_s = 1.0;
  s.robot.pause_s = 0.3;
  s.robot.seed = seed;
  s.robot.effects = effects;
  s.runs = plan;
  return s;
}

struct SessionUnderTest {
  calibration::MeasuredSession session;
  calibration::ErrorFactors truth;
};

// Simulates the plan and measures it with the stand-in camera, which carries
// the camera-side effects of `effects`.
inline SessionUnderTest MakeSession(const std::vector<calibration::RunSpec>& plan,
                                    const sim::Effects& effects, std::uint64_t seed,
                                    simulation::StandInCameraOptions camera = {}) {
  const config::Scenario scenario = MakeScenario(plan, effects, seed);
  const simulation::SimulationResult sim = simulation::Simulate(scenario);
  camera.seed = seed * 7919 + 1;
  if (effects.tag_offset) {
    camera.tag_x_m = effects.tag_offset->x_m;
    camera.tag_y_m = effects.tag_offset->y_m;
  }
  if (effects.camera_latency) camera.latency_s = effects.camera_latency->latency_s;
  if (effects.lens_distortion) camera.k1_delta = effects.lens_distortion->k1_delta;
  if (effects.tracker_yaw) camera.tracker_yaw_rad = effects.tracker_yaw->yaw_rad;
  if (effects.rolling_shutter) camera.rolling_shutter_s = effects.rolling_shutter->readout_s;
  SessionUnderTest out;
  out.session = simulation::MeasureWithStandInCamera(scenario.robot.nominal, simulation::SimulatedRunRecordsOf(sim), camera);
  out.truth = sim.truth;
  return out;
}

}  // namespace odocal::testing

#endif  // ODOCAL_TESTS_RIG_EXPLAIN_FIXTURES_H_
