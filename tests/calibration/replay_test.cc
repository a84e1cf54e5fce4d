// Replaying runs against the simulator's truth: with the true parameters the
// replay meets the camera at its noise level; with the nominal ones it misses
// by the error the exact square model predicts; a camera-side effect replayed
// with its parameters vanishes.
#include "odocal/calibration/replay.h"

#include <cmath>
#include <cstdio>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

// The sessions come from the virtual robot and the stand-in camera, which
// live in rig (Simulate, MeasureWithStandInCamera): hence the rig link.
#include "explain_fixtures.h"

namespace odocal::testing {
namespace {

using calibration::Direction;
using calibration::EffectParams;
using calibration::ReplayModel;
using calibration::ReplayRun;
using calibration::RunReplay;
using calibration::RunSpec;
using calibration::WheelScales;

WheelScales TrueScales() {
  const config::Scenario scenario = MakeScenario(IdentifyingPlan(), {}, 1);
  return calibration::WheelScalesFrom(scenario.robot.nominal, scenario.robot.truth);
}

TEST(Replay, TrueParametersMeetTheCameraNominalOnesMissByTheSquareError) {
  const std::vector<RunSpec> plan = {RunSpec::Umbmark(Direction::kCw, 2.0),
                                     RunSpec::Umbmark(Direction::kCcw, 2.0)};
  const SessionUnderTest s = MakeSession(plan, {}, 3);
  const WheelScales truth = TrueScales();
  for (size_t i = 0; i < plan.size(); ++i) {
    const calibration::MeasuredRun& run = s.session.runs[i];
    const RunReplay right = ReplayRun(run, s.session.believed, {truth, {}});
    const RunReplay nominal = ReplayRun(run, s.session.believed, {WheelScales{}, {}});
    ASSERT_TRUE(right.ok()) << right.message;
    ASSERT_TRUE(nominal.ok()) << nominal.message;
    // The analytic return error (exact square model, procedures.h).
    const double analytic =
        calibration::PredictReturnError(plan[i], truth, s.session.believed.track_m)
            .translation()
            .norm();
    std::printf("[figure] replay %s: true set final %.3f mm (RMS %.3f mm); nominal set final "
                "%.2f mm, exact square model %.2f mm; distance %.3f m\n",
                run.name.c_str(), right.final_position_error_m * 1e3,
                right.rms_position_error_m * 1e3, nominal.final_position_error_m * 1e3,
                analytic * 1e3, right.distance_m);
    // Noise level of a replay (its start is anchored on the start rest
    // alone, not fitted to the run): the start heading from 30 frames at
    // 0.3 deg (0.055 deg) and 9 m of wheel noise at 0.05 mm/sqrt(m) (0.04 deg)
    // tilt the whole square; measured over seeds 3-12: RMS 1.7-3.9 mm, final
    // 0.5-3.5 mm.
    EXPECT_LT(right.final_position_error_m, 5e-3);
    EXPECT_LT(right.rms_position_error_m, 5e-3);
    EXPECT_GT(analytic, 15e-3);  // Ed 1.003, Eb 1.015 on a 2 m square: 20 mm
    EXPECT_NEAR(nominal.final_position_error_m, analytic, 4e-3);
    // Wheel travel from the ticks: 8 m of legs and four quarter turns of the
    // wheels about the axle midpoint (2 pi * 0.15 m).
    EXPECT_NEAR(right.distance_m, 8.0 + M_PI * s.session.believed.track_m, 0.02);
    EXPECT_NEAR(nominal.final_error_fraction(), analytic / right.distance_m, 1e-3);
  }
}

TEST(Replay, ATagOffsetReplayedWithItsParametersVanishes) {
  sim::Effects effects;
  effects.tag_offset = sim::TagOffsetEffect{0.030, -0.015};
  const SessionUnderTest s = MakeSession(IdentifyingPlan(), effects, 3);
  ReplayModel without{TrueScales(), {}};
  ReplayModel with = without;
  with.effects.values[EffectParams::kTagX] = 0.030;
  with.effects.values[EffectParams::kTagY] = -0.015;
  for (const calibration::MeasuredRun& run : s.session.runs) {
    const RunReplay a = ReplayRun(run, s.session.believed, without);
    const RunReplay b = ReplayRun(run, s.session.believed, with);
    ASSERT_TRUE(a.ok() && b.ok()) << a.message << b.message;
    std::printf("[figure] replay %s: RMS %.3f mm without the tag offset, %.3f mm with it\n",
                run.name.c_str(), a.rms_position_error_m * 1e3, b.rms_position_error_m * 1e3);
    EXPECT_LT(b.rms_position_error_m, 5e-3);
    EXPECT_LT(b.final_position_error_m, 5e-3);
    // The tag circles the axle on every turn: 33.5 mm of offset shows.
    EXPECT_GT(a.rms_position_error_m, 5.0 * b.rms_position_error_m);
  }
}

TEST(Replay, AnchorsOnTheFirstFramesWithoutAStartRest) {
  const SessionUnderTest s = MakeSession({RunSpec::Umbmark(Direction::kCw, 2.0)}, {}, 4);
  calibration::MeasuredRun run = s.session.runs[0];
  // Drop every frame before the wheels move and the first 0.3 s of motion.
  double first_motion = 0.0;
  for (size_t k = 1; k < run.telemetry.size(); ++k)
    if (run.telemetry[k].left_ticks != run.telemetry[k - 1].left_ticks) {
      first_motion = run.telemetry[k - 1].t_s;
      break;
    }
  std::vector<calibration::CameraRecord> kept;
  for (const auto& f : run.camera)
    if (f.t_s > first_motion + 0.3) kept.push_back(f);
  run.camera = kept;
  const RunReplay r = ReplayRun(run, s.session.believed, {TrueScales(), {}});
  ASSERT_TRUE(r.ok()) << r.message;
  std::printf("[figure] replay without a start rest: final %.3f mm, RMS %.3f mm\n",
              r.final_position_error_m * 1e3, r.rms_position_error_m * 1e3);
  // Five moving frames anchor the heading far worse than a rest: 0.3 deg /
  // sqrt(5) over 2 m legs is about 2.5 mm.
  EXPECT_LT(r.rms_position_error_m, 10e-3);
  EXPECT_LT(r.final_position_error_m, 10e-3);
}

TEST(Replay, SaysWhyARunCannotBeReplayed) {
  const SessionUnderTest s = MakeSession({RunSpec::Umbmark(Direction::kCw, 2.0)}, {}, 4);
  calibration::MeasuredRun run = s.session.runs[0];
  run.camera.clear();
  RunReplay r = ReplayRun(run, s.session.believed, {});
  EXPECT_FALSE(r.ok());
  EXPECT_THAT(r.message, ::testing::HasSubstr(run.name)) << r.message;
  run.telemetry.resize(1);
  r = ReplayRun(run, s.session.believed, {});
  EXPECT_FALSE(r.ok());
  EXPECT_THAT(r.message, ::testing::HasSubstr("telemetry")) << r.message;
}

}  // namespace
}  // namespace odocal::testing
