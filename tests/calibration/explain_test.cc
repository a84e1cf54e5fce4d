// The explain workflow on sessions where an effect is hidden from it: the
// virtual robot (robot-side effects) and the stand-in camera (camera-side
// effects) know the truth; the workflow sees only telemetry and camera poses.
#include "odocal/calibration/explain.h"

#include <cmath>
#include <cstdio>
#include <optional>
#include <string>
#include <vector>

#include <boost/math/distributions/chi_squared.hpp>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "explain_fixtures.h"

namespace odocal::testing {
namespace {

using calibration::Direction;
using calibration::ExplainResult;
using calibration::ParameterEstimate;
using calibration::RunSpec;

struct HiddenEffect {
  std::string name;
  sim::Effects effects;
  // The parameters the workflow must recover: name as fitted, true value.
  std::vector<std::pair<std::string, double>> truth;
  // Extra runs the effect needs to be told apart (beside IdentifyingPlan).
  std::vector<RunSpec> extra_runs;
  // The stand-in camera, when not the default (1 mm, 0.3 deg).
  std::optional<simulation::StandInCameraOptions> camera;
};

// A camera of 0.3 mm and 0.1 deg (a whole-field video camera measures about
// that; the default stand-in's 1 mm and 0.3 deg are a poor one).
simulation::StandInCameraOptions PreciseCamera() {
  simulation::StandInCameraOptions camera;
  camera.sigma_position_m = 0.3e-3;
  camera.sigma_heading_rad = 0.1 * M_PI / 180.0;
  return camera;
}

// Speed slip at one speed is a scale error: an out-and-back at 100 mm/s
// beside the plan's 250 mm/s.
std::vector<RunSpec> SlowOutAndBack() {
  RunSpec slow = RunSpec::OutAndBack(1.0, 1);
  slow.speed_m_s = 0.1;
  return {slow};
}

// arc_scale on arcs of one curvature is a scale of both wheels there: circles
// both ways beside the plan's straights (which pin Es) and spins (Eb).
std::vector<RunSpec> Circles() {
  return {RunSpec::Circle(0.4, 1, Direction::kCcw), RunSpec::Circle(0.4, 1, Direction::kCw)};
}

// Realistic magnitudes: a tag mounted 30 mm ahead and 15 mm right of the
// axle; 80 ms of video latency; 3 % turn slip at 1 rad/s; a k1 off by 0.01;
// 12 ticks of gear lash (0.4 deg of motor shaft with 2048 ticks at the wheel
// is ~1.3 mm of wheel travel); 10 mm/m of carpet drift along a grain at 30 deg;
// a tag turned 2 deg on the robot; 4 % of slip per m/s of wheel speed (1 % at
// 250 mm/s); 2 mm of arc scale (0.5 % of travel lost on a circle of 0.4 m;
// the real OptiOdom circles of 0.32 m lose 0.25 %); a rolling shutter reading
// its rows in 20 ms (a webcam's; the squares cross the image top to bottom:
// rows 0.03 to 0.97). The rolling shutter shows only in motion, by up to
// 250 mm/s x 10 ms = 2.5 mm (1.2 mm RMS), in a pattern much like a turn of
// the whole run about its start: a held-out replay, anchored on its start
// rest, turns by that rest's heading noise (0.3 deg / sqrt(30 frames): 1.9 mm
// at 2 m with the default camera), so cross-validation named it on 3 of
// seeds 3-8 with that camera and on 7 of seeds 3-10 with PreciseCamera (the
// 8th gained 4.9 %, under the 5 % margin); BIC and Wald passed on all.
// An eccentric left wheel: 2 % of its radius (0.7 mm of run-out on a 70 mm
// wheel) at a phase of 30 deg; the model's left_sin, left_cos are a cos(phase)
// and a sin(phase). Its heading ripples by 0.7 mm / 300 mm = 2.3 mrad, about
// what the default camera's 31 still frames give a held-out run's start
// heading (0.3 deg / sqrt(31) = 0.94 mrad): with that camera the replays'
// anchors decide cross-validation (seed 3: an anchor 2 sigma off turned a
// held-out run from 1.4 to 4.0 mm), so it is tested with PreciseCamera.
std::vector<HiddenEffect> HiddenEffects() {
  std::vector<HiddenEffect> list(11);
  list[0] = {"tag_offset", {}, {{"x_m", 0.030}, {"y_m", -0.015}}, {}, std::nullopt};
  list[0].effects.tag_offset = sim::TagOffsetEffect{0.030, -0.015};
  list[1] = {"camera_latency", {}, {{"latency_s", 0.080}}, {}, std::nullopt};
  list[1].effects.camera_latency = sim::CameraLatencyEffect{0.080};
  list[2] = {"turn_slip", {}, {{"fraction_at_1rad_s", 0.03}}, {}, std::nullopt};
  list[2].effects.turn_slip = sim::TurnSlipEffect{0.03};
  list[3] = {"lens_distortion", {}, {{"k1", 0.01}}, {}, std::nullopt};
  list[3].effects.lens_distortion = sim::LensDistortionEffect{0.01};
  list[4] = {"encoder_backlash", {}, {{"ticks", 12.0}}, {}, std::nullopt};
  list[4].effects.encoder_backlash = sim::EncoderBacklashEffect{12.0};
  list[5] = {"carpet_drift", {}, {{"grain_rad", 30.0 * M_PI / 180.0}, {"rate_m_per_m", 0.010}}, {}, std::nullopt};
  list[5].effects.carpet_drift = sim::CarpetDriftEffect{30.0 * M_PI / 180.0, 0.010};
  list[6] = {"tracker_yaw", {}, {{"yaw_rad", 2.0 * M_PI / 180.0}}, {}, std::nullopt};
  list[6].effects.tracker_yaw = sim::TrackerYawEffect{2.0 * M_PI / 180.0};
  list[7] = {"speed_slip", {}, {{"fraction_at_1m_s", 0.04}}, SlowOutAndBack(), std::nullopt};
  list[7].effects.speed_slip = sim::SpeedSlipEffect{0.04};
  list[8] = {"arc_scale", {}, {{"fraction_at_1_per_m", 0.002}}, Circles(), std::nullopt};
  list[8].effects.arc_scale = sim::ArcScaleEffect{0.002};
  list[9] = {"rolling_shutter", {}, {{"readout_s", 0.020}}, {}, PreciseCamera()};
  list[9].effects.rolling_shutter = sim::RollingShutterEffect{0.020};
  const double phase = 30.0 * M_PI / 180.0;
  list[10] = {"eccentric_wheel",
              {},
              {{"left_sin", 0.02 * std::cos(phase)}, {"left_cos", 0.02 * std::sin(phase)}},
              {},
              PreciseCamera()};
  list[10].effects.eccentric_wheel = sim::EccentricWheelEffect{true, 0.02, phase};
  return list;
}

const ParameterEstimate* FindParam(const std::vector<ParameterEstimate>& params,
                                   const std::string& name) {
  for (const ParameterEstimate& p : params)
    if (p.name == name) return &p;
  return nullptr;
}

double Error(const calibration::TrajectoryFitResult& fit, const char* name, double truth) {
  return std::abs(fit.Find(name)->value - truth);
}

class EachEffect : public ::testing::TestWithParam<int> {};

TEST_P(EachEffect, IsNamedRecoveredAndClosesTheGap) {
  const HiddenEffect hidden = HiddenEffects()[GetParam()];
  std::vector<RunSpec> plan = IdentifyingPlan();
  plan.insert(plan.end(), hidden.extra_runs.begin(), hidden.extra_runs.end());
  const SessionUnderTest s =
      MakeSession(plan, hidden.effects, 3, hidden.camera.value_or(simulation::StandInCameraOptions{}));
  const ExplainResult r = calibration::Explain(s.session);
  ASSERT_TRUE(r.ok()) << r.message;
  std::printf("%s", r.BriefReport().c_str());

  ASSERT_EQ(r.EffectsAdded(), std::vector<std::string>{hidden.name});
  for (const auto& [name, truth] : hidden.truth) {
    const ParameterEstimate* p = FindParam(r.steps[0].params, name);
    ASSERT_NE(p, nullptr) << name;
    ASSERT_TRUE(p->identifiable) << name;
    std::printf("[figure] %-16s %-20s truth %.6g  fitted %.6g  95%% [%.6g, %.6g]\n",
                hidden.name.c_str(), name.c_str(), truth, p->value, p->lower95(), p->upper95());
    EXPECT_GE(truth, p->lower95()) << name;
    EXPECT_LE(truth, p->upper95()) << name;
    // ...an interval that measures: within +/-20 % of the effect's size (the
    // widest in docs/explain.md's stand-in camera table is encoder backlash's
    // +/-9 %).
    EXPECT_LT(p->upper95() - p->lower95(), 0.4 * std::abs(truth)) << name;
  }
  const calibration::CrossValidation& cv = r.steps[0].cross_validation;
  std::printf("[figure] %-16s held-out RMS %.3f mm -> %.3f mm (%s, %d folds)\n",
              hidden.name.c_str(), cv.heldout_rms_before_m * 1e3, cv.heldout_rms_after_m * 1e3,
              cv.method.c_str(), cv.folds);
  EXPECT_TRUE(cv.improved);
  // A real effect holds from run to run: the runs' disagreement keeps it
  // away from zero.
  std::printf("[figure] %-16s %.1f sigma from zero between runs\n", hidden.name.c_str(),
              r.steps[0].between_runs_z);
  EXPECT_TRUE(r.steps[0].holds_across_runs()) << r.steps[0].between_runs_z;
  EXPECT_FALSE(r.unexplained.any()) << "once named, nothing is left";
  // The camera's noise floor, or with a precise camera the model's own noise
  // (camera and wheels: 0.452 mm against the camera's 0.424 mm at 0.3 mm).
  const double floor = hidden.camera ? r.final_fit.expected_gap_m() : r.final_fit.noise_floor_m;
  std::printf("[figure] %-16s gap %.3f mm -> %.3f mm (noise floor %.3f mm)\n", hidden.name.c_str(),
              r.gap_before_m() * 1e3, r.gap_after_m() * 1e3, floor * 1e3);
  EXPECT_TRUE(r.gap_after_m() <= r.gap_before_m() / 10.0 || r.gap_after_m() <= 1.05 * floor)
      << "gap " << r.gap_before_m() << " -> " << r.gap_after_m();

  // The calibration itself: Ed and Eb with and without the effect.
  const double ed_before = Error(r.base, "Ed", s.truth.Ed), ed_after = Error(r.final_fit, "Ed", s.truth.Ed);
  const double eb_before = Error(r.base, "Eb", s.truth.Eb), eb_after = Error(r.final_fit, "Eb", s.truth.Eb);
  std::printf("[figure] %-16s |Ed - truth| %.2e -> %.2e   |Eb - truth| %.2e -> %.2e\n",
              hidden.name.c_str(), ed_before, ed_after, eb_before, eb_after);
  const double sigma_ed = r.final_fit.Find("Ed")->sigma, sigma_eb = r.final_fit.Find("Eb")->sigma;
  std::printf("[figure] %-16s sigma Ed %.2e, Eb %.2e\n", hidden.name.c_str(), sigma_ed, sigma_eb);
  // Sigmas that measure: over these effects Ed's is 2.3-2.4e-5 and Eb's
  // 6.0e-5 to 1.75e-4 (turn_slip); bounded at about twice the largest, so
  // the sigma-scaled checks below keep their meaning.
  EXPECT_LT(sigma_ed, 5e-5);
  EXPECT_LT(sigma_eb, 4e-4);
  // Closer in the sum of both errors (each in its own sigma); where the base
  // model was not biased the two agree to a small part of a sigma (an
  // eccentric wheel, whose ripple averages out over whole turns, leaves the
  // base model unbiased; its four parameters moved Eb by 0.16 sigma).
  EXPECT_LE(ed_after / sigma_ed + eb_after / sigma_eb, ed_before / sigma_ed + eb_before / sigma_eb + 0.2);
  EXPECT_LE(ed_after, 1.96 * sigma_ed * 1.5);
  EXPECT_LE(eb_after, 1.96 * sigma_eb * 1.5);
}

INSTANTIATE_TEST_SUITE_P(Explain, EachEffect,
                         ::testing::Range(0, static_cast<int>(HiddenEffects().size())),
                         [](const ::testing::TestParamInfo<int>& info) {
                           return HiddenEffects()[info.param].name;
                         });

TEST(Explain, NoEffectHiddenNamesNothing) {
  for (std::uint64_t seed : {3, 11, 12}) {
    const SessionUnderTest s = MakeSession(IdentifyingPlan(), {}, seed);
    const ExplainResult r = calibration::Explain(s.session);
    ASSERT_TRUE(r.ok()) << r.message;
    EXPECT_TRUE(r.EffectsAdded().empty()) << r.BriefReport();
    EXPECT_LE(r.gap_before_m(), 1.05 * r.base.noise_floor_m);
    EXPECT_FALSE(r.unexplained.any()) << r.BriefReport();
    EXPECT_FALSE(r.unexplained.significant);
    std::printf("[figure] none (seed %lu): gap %.3f mm, noise floor %.3f mm, best rejected score",
                static_cast<unsigned long>(seed), r.gap_before_m() * 1e3,
                r.base.noise_floor_m * 1e3);
    for (const auto& t : r.rejected)
      if (t.fitted) std::printf(" %s %.1f (Wald %.1f)", std::string(ToString(t.effect)).c_str(), t.score, t.wald);
    std::printf("\n");
  }
}

TEST(Explain, TwoEffectsAreBothNamedInOrderOfImportance) {
  // Drift leaves a 7.6 mm gap, slip 1.6 mm: drift first.
  sim::Effects effects;
  effects.carpet_drift = sim::CarpetDriftEffect{-60.0 * M_PI / 180.0, 0.008};
  effects.turn_slip = sim::TurnSlipEffect{0.03};
  const SessionUnderTest s = MakeSession(IdentifyingPlan(), effects, 5);
  const ExplainResult r = calibration::Explain(s.session);
  ASSERT_TRUE(r.ok()) << r.message;
  std::printf("%s", r.BriefReport().c_str());
  ASSERT_EQ(r.EffectsAdded(), (std::vector<std::string>{"carpet_drift", "turn_slip"}));
  const ParameterEstimate* rate = FindParam(r.steps[0].params, "rate_m_per_m");
  const ParameterEstimate* slip = FindParam(r.steps[1].params, "fraction_at_1rad_s");
  EXPECT_NEAR(rate->value, 0.008, 1.96 * rate->sigma);
  EXPECT_NEAR(slip->value, 0.03, 1.96 * slip->sigma);
  // Sigmas that measure: 1.96 sigma within 20 % of each effect's size, as in
  // EachEffect (on rendered video, docs/explain.md has this drift to +/-0.19
  // mm/m and a slip of 0.01 to +/-0.0002).
  EXPECT_LT(1.96 * rate->sigma, 0.2 * 0.008);
  EXPECT_LT(1.96 * slip->sigma, 0.2 * 0.03);
  // Importance: how much of the gap each closes (each step's score is
  // relative to the model before it, so scores of different steps do not
  // compare).
  EXPECT_GT(r.gap_before_m() - r.steps[0].gap_after_m,
            r.steps[0].gap_after_m - r.steps[1].gap_after_m);
  EXPECT_LE(r.gap_after_m(), 1.05 * r.final_fit.noise_floor_m);
  std::printf("[figure] drift+slip: gap %.3f -> %.3f -> %.3f mm\n", r.gap_before_m() * 1e3,
              r.steps[0].gap_after_m * 1e3, r.steps[1].gap_after_m * 1e3);
}

// Slip at a single turn rate is a track error: on squares at one rate the
// workflow must not name it, must say it cannot tell, and name the runs.
TEST(Explain, SlipAtOneTurnRateIsReportedAsAliasedWithTheTrack) {
  sim::Effects effects;
  effects.turn_slip = sim::TurnSlipEffect{0.03};
  const SessionUnderTest s = MakeSession(
      {RunSpec::Umbmark(Direction::kCw, 2.0), RunSpec::Umbmark(Direction::kCcw, 2.0)}, effects, 5);
  const ExplainResult r = calibration::Explain(s.session);
  ASSERT_TRUE(r.ok()) << r.message;
  std::printf("%s", r.BriefReport().c_str());
  EXPECT_TRUE(r.EffectsAdded().empty());
  const calibration::AliasReport* slip = nullptr;
  for (const auto& a : r.aliased)
    if (a.effect == calibration::Effect::kTurnSlip) slip = &a;
  ASSERT_NE(slip, nullptr) << "turn_slip must be reported as indistinguishable";
  EXPECT_LT(slip->separation, 0.01);
  EXPECT_NE(std::find(slip->looks_like.begin(), slip->looks_like.end(), "Eb"), slip->looks_like.end());
  EXPECT_THAT(slip->distinguishing_runs, ::testing::HasSubstr("two different turn rates"));
  // ...and the track it fitted carries the slip: 1 - 0.03 * 60 deg/s is a
  // turn gain of 0.969, i.e. Eb about 1.015 / 0.969.
  EXPECT_GT(r.final_fit.Find("Eb")->value, s.truth.Eb + 0.02);
  // With the second turn rate in the plan the same slip is named.
  const SessionUnderTest both = MakeSession(IdentifyingPlan(), effects, 5);
  const calibration::AliasReport separated =
      calibration::CheckAliasing(calibration::FitTrajectory(both.session), calibration::Effect::kTurnSlip);
  std::printf("[figure] slip vs track separation: %.4f (one rate) vs %.4f (two rates)\n",
              slip->separation, separated.separation);
  EXPECT_FALSE(separated.aliased);
}

// Circles in the plan do not make the base model look wrong: with nothing
// hidden, nothing is named and nothing is left unexplained.
TEST(ArcScale, CirclesWithNothingHiddenNameNothing) {
  std::vector<RunSpec> plan = IdentifyingPlan();
  for (const RunSpec& c : Circles()) plan.push_back(c);
  for (std::uint64_t seed : {3, 11}) {
    const SessionUnderTest s = MakeSession(plan, {}, seed);
    const ExplainResult r = calibration::Explain(s.session);
    ASSERT_TRUE(r.ok()) << r.message;
    EXPECT_TRUE(r.EffectsAdded().empty()) << r.BriefReport();
    EXPECT_FALSE(r.unexplained.any()) << r.BriefReport();
    for (const auto& t : r.rejected)
      if (t.effect == calibration::Effect::kArcScale && t.fitted)
        std::printf("[figure] circles, nothing hidden (seed %lu): arc_scale score %.1f, Wald %.1f\n",
                    static_cast<unsigned long>(seed), t.score, t.wald);
  }
}

// Without arcs the effect leaves no trace: every step of a straight is below
// the arc threshold and a spin's wheels turn opposite ways. It must be
// reported as carrying no signal, not named, and the straights' scale (Es)
// must not have absorbed anything.
TEST(ArcScale, WithoutArcsThereIsNoSignal) {
  sim::Effects effects;
  effects.arc_scale = sim::ArcScaleEffect{0.002};
  const SessionUnderTest s = MakeSession(IdentifyingPlan(), effects, 3);
  for (const calibration::MeasuredRun& run : s.session.runs)
    for (double kappa : calibration::ArcCurvatures(run, s.session.believed))
      ASSERT_EQ(kappa, 0.0) << run.name;
  const ExplainResult r = calibration::Explain(s.session);
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_TRUE(r.EffectsAdded().empty()) << r.BriefReport();
  const calibration::AliasReport* arc = nullptr;
  for (const auto& a : r.aliased)
    if (a.effect == calibration::Effect::kArcScale) arc = &a;
  ASSERT_NE(arc, nullptr) << r.BriefReport();
  EXPECT_TRUE(arc->no_signal);
  EXPECT_FALSE(r.unexplained.any()) << r.BriefReport();
}

// The curvature the model sees on a simulated circle is the planned one (the
// believed wheels and track make the ticks' arc), on a straight none.
TEST(ArcScale, CurvatureOfACircleIsItsPlannedOne) {
  const SessionUnderTest s =
      MakeSession({RunSpec::Circle(0.4, 1, Direction::kCw), RunSpec::Straight(1.0)}, {}, 3);
  // Within 1 % but in the first and last steps (a tick of quantization on a
  // few ticks of the speed ramps): within 5 %.
  int arc_steps = 0, within_1_percent = 0;
  for (double kappa : calibration::ArcCurvatures(s.session.runs[0], s.session.believed)) {
    if (kappa == 0.0) continue;
    ++arc_steps;
    EXPECT_NEAR(kappa, -1.0 / 0.4, 0.05 / 0.4);  // cw: negative
    if (std::abs(kappa + 1.0 / 0.4) < 0.01 / 0.4) ++within_1_percent;
  }
  EXPECT_GT(arc_steps, 100);
  EXPECT_GE(within_1_percent, 0.95 * arc_steps);
  for (double kappa : calibration::ArcCurvatures(s.session.runs[1], s.session.believed))
    EXPECT_EQ(kappa, 0.0);
}

// The tracker's clock may run ahead of the telemetry's as well as behind:
// camera_latency is a clock offset of either sign.
TEST(Explain, CameraLatencyIsAClockOffsetOfEitherSign) {
  sim::Effects effects;
  effects.camera_latency = sim::CameraLatencyEffect{-0.040};
  const SessionUnderTest s = MakeSession(IdentifyingPlan(), effects, 4);
  const ExplainResult r = calibration::Explain(s.session);
  ASSERT_TRUE(r.ok()) << r.message;
  ASSERT_EQ(r.EffectsAdded(), std::vector<std::string>{"camera_latency"}) << r.BriefReport();
  const ParameterEstimate* p = FindParam(r.steps[0].params, "latency_s");
  ASSERT_NE(p, nullptr);
  std::printf("[figure] camera_latency -40 ms: fitted %.2f ms [%.2f, %.2f]\n", p->value * 1e3,
              p->lower95() * 1e3, p->upper95() * 1e3);
  EXPECT_GE(-0.040, p->lower95());
  EXPECT_LE(-0.040, p->upper95());
}

// An effect outside every candidate's family (an oval wheel: its rolling
// radius varies twice a turn, where eccentric_wheel's does once) must come
// out as unexplained, not be forced onto the nearest candidate.
TEST(Unexplained, AnOvalWheelIsNotMisnamed) {
  // 3 % of a 70 mm wheel: 1 mm of run-out. A camera of 0.3 mm (the stand-in's
  // 1 mm hides most of it).
  sim::Effects effects;
  effects.oval_wheel = sim::EccentricWheelEffect{true, 0.03, 0.0};
  simulation::StandInCameraOptions camera;
  camera.sigma_position_m = 0.3e-3;
  camera.sigma_heading_rad = 0.1 * M_PI / 180.0;
  for (std::uint64_t seed : {3, 5}) {
    const SessionUnderTest s = MakeSession(IdentifyingPlan(), effects, seed, camera);
    const ExplainResult r = calibration::Explain(s.session);
    ASSERT_TRUE(r.ok()) << r.message;
    std::printf("%s", r.BriefReport().c_str());
    EXPECT_TRUE(r.EffectsAdded().empty());
    EXPECT_TRUE(r.unexplained.significant);
    ASSERT_TRUE(r.unexplained.any());
    // Listed by contribution: first where the wheel rolls (a rest after
    // motion may carry the error accumulated before it, but less of it).
    EXPECT_NE(r.unexplained.where.front().motion, "rest");
    std::printf(
        "[figure] oval wheel 3 %% (seed %lu): gap %.3f mm, expected %.3f mm, F %.2f "
        "(threshold %.2f), %zu segments reported\n",
        static_cast<unsigned long>(seed), r.unexplained.gap_m * 1e3, r.unexplained.expected_gap_m * 1e3,
        r.unexplained.ratio, r.unexplained.threshold, r.unexplained.where.size());
  }
  // Nothing hidden, the same camera: nothing named, nothing unexplained.
  const SessionUnderTest clean = MakeSession(IdentifyingPlan(), {}, 3, camera);
  const ExplainResult r = calibration::Explain(clean.session);
  EXPECT_TRUE(r.EffectsAdded().empty()) << r.BriefReport();
  EXPECT_FALSE(r.unexplained.any()) << r.BriefReport();
}

// The margin of the cross-validation: with nothing hidden, adding any
// candidate changes the held-out RMS by chance (measured on seeds 3, 11-14:
// -16.5 % to +5.3 %); every hidden effect above gains 46-97 %. Chance rarely
// passes the margin, and what does must still pass the fit's gates (Wald):
// it is never named.
TEST(CrossValidation, ChanceRarelyPassesTheMarginAndNeverAllGates) {
  const calibration::ExplainOptions options;
  int trials = 0, over = 0;
  for (std::uint64_t seed : {11, 12}) {
    const SessionUnderTest s = MakeSession(IdentifyingPlan(), {}, seed);
    const auto base = calibration::FitTrajectory(s.session);
    ASSERT_TRUE(base.ok());
    // Every candidate on the same folds (their fits without it made once).
    const auto& effects = calibration::kAllEffects;
    const std::vector<calibration::Effect> all(effects.begin(), effects.end());
    const std::vector<calibration::CrossValidation> cvs =
        calibration::CrossValidateCandidates(s.session, base, all, options);
    ASSERT_EQ(cvs.size(), all.size());
    for (size_t i = 0; i < all.size(); ++i) {
      const calibration::Effect e = all[i];
      const calibration::CrossValidation& cv = cvs[i];
      ASSERT_EQ(cv.method, "leave_one_run_out");
      ASSERT_EQ(cv.heldout_runs, 5);
      const double gain = 1.0 - cv.heldout_rms_after_m / cv.heldout_rms_before_m;
      std::printf("[figure] nothing hidden (seed %lu), %-16s held-out RMS %.3f -> %.3f mm "
                  "(%+.1f %%)\n",
                  static_cast<unsigned long>(seed), std::string(ToString(e)).c_str(),
                  cv.heldout_rms_before_m * 1e3, cv.heldout_rms_after_m * 1e3, 100.0 * gain);
      ++trials;
      if (!cv.improved) continue;
      ++over;
      calibration::TrajectoryFitOptions o;
      o.effects = {e};
      const auto with = calibration::FitTrajectory(s.session, o, &base);
      const double threshold = boost::math::quantile(boost::math::complement(
          boost::math::chi_squared(calibration::EffectTestedIndices(e).size()), options.wald_alpha));
      EXPECT_LT(with.Wald(e), threshold) << ToString(e) << " passes CV by chance and Wald too";
    }
  }
  EXPECT_LE(over, trials / 8) << over << " of " << trials << " chance trials pass the margin";
}

// One run cannot be cross-validated by run: the fit's gates decide, and the
// result says so.
TEST(CrossValidation, ASingleRunFallsBackToTheOtherGates) {
  sim::Effects effects;
  effects.tag_offset = sim::TagOffsetEffect{0.030, -0.015};
  const SessionUnderTest s = MakeSession({RunSpec::Umbmark(Direction::kCw, 2.0)}, effects, 3);
  const ExplainResult r = calibration::Explain(s.session);
  ASSERT_TRUE(r.ok()) << r.message;
  std::printf("%s", r.BriefReport().c_str());
  ASSERT_EQ(r.EffectsAdded(), std::vector<std::string>{"tag_offset"});
  EXPECT_FALSE(r.steps[0].cross_validation.possible());
  EXPECT_THAT(r.steps[0].cross_validation.note, ::testing::HasSubstr("one run"));
}

// A drift on one run only (a patch of carpet the others did not cross) is
// not a property of the robot: fitted on all runs it passes the fit's gates,
// but it does not predict the runs it was not fitted on.
TEST(CrossValidation, APeculiarityOfOneRunIsNotNamed) {
  sim::Effects drift;
  drift.carpet_drift = sim::CarpetDriftEffect{30.0 * M_PI / 180.0, 0.010};
  SessionUnderTest s = MakeSession(IdentifyingPlan(), {}, 3);
  const SessionUnderTest drifted = MakeSession(IdentifyingPlan(), drift, 3);
  s.session.runs[0] = drifted.session.runs[0];  // the cw square
  const ExplainResult r = calibration::Explain(s.session);
  ASSERT_TRUE(r.ok()) << r.message;
  std::printf("%s", r.BriefReport().c_str());
  const calibration::CandidateTrial* trial = nullptr;
  for (const auto& t : r.steps.empty() ? r.rejected : r.steps[0].trials)
    if (t.effect == calibration::Effect::kCarpetDrift) trial = &t;
  ASSERT_NE(trial, nullptr);
  ASSERT_TRUE(trial->cross_validation.has_value()) << "drift must pass the fit's gates";
  EXPECT_FALSE(trial->cross_validation->improved);
  for (const std::string& e : r.EffectsAdded()) EXPECT_NE(e, "carpet_drift");
  // ...and it is reported where it is: the cw square's straights.
  ASSERT_TRUE(r.unexplained.any());
  EXPECT_TRUE(r.unexplained.significant);
  for (const calibration::UnexplainedSegment& w : r.unexplained.where)
    EXPECT_EQ(w.run, s.session.runs[0].name) << w.motion << " " << w.t_from_s;
}

// The readout is told from the latency only by moving frames at different
// rows: at one row it is a latency (aliased with it once the latency is
// fitted), at the middle row it changes nothing, and without image rows
// (a pose log) explain cannot form it and says what would tell.
TEST(RollingShutter, AtOneRowItIsALatencyAtTheMiddleNothingWithoutRowsNotFormed) {
  sim::Effects latency;
  latency.camera_latency = sim::CameraLatencyEffect{0.080};
  const SessionUnderTest s = MakeSession(IdentifyingPlan(), latency, 3);
  auto with_rows = [&](double row) {
    calibration::MeasuredSession session = s.session;
    for (calibration::MeasuredRun& run : session.runs)
      for (calibration::CameraRecord& f : run.camera) f.image_row_fraction = row;
    return session;
  };
  calibration::TrajectoryFitOptions o;
  o.effects = {calibration::Effect::kCameraLatency};
  const auto whole_field = calibration::FitTrajectory(s.session, o);
  const auto one_row = calibration::FitTrajectory(with_rows(0.8), o);
  const auto middle = calibration::FitTrajectory(with_rows(0.5), o);
  ASSERT_TRUE(whole_field.ok() && one_row.ok() && middle.ok());
  const auto separated = calibration::CheckAliasing(whole_field, calibration::Effect::kRollingShutter);
  const auto aliased = calibration::CheckAliasing(one_row, calibration::Effect::kRollingShutter);
  const auto nothing = calibration::CheckAliasing(middle, calibration::Effect::kRollingShutter);
  std::printf("[figure] rolling_shutter vs camera_latency separation: %.4f (rows 0.03-0.97), "
              "%.2g (one row)\n", separated.separation, aliased.separation);
  EXPECT_FALSE(separated.aliased);
  EXPECT_TRUE(aliased.aliased);
  EXPECT_FALSE(aliased.no_signal);
  EXPECT_THAT(aliased.looks_like, ::testing::Contains("camera_latency"));
  EXPECT_THAT(aliased.distinguishing_runs, ::testing::HasSubstr("different image rows"));
  EXPECT_TRUE(nothing.no_signal);

  const SessionUnderTest clean = MakeSession(IdentifyingPlan(), {}, 3);
  calibration::MeasuredSession pose_log = clean.session;
  for (calibration::MeasuredRun& run : pose_log.runs)
    for (calibration::CameraRecord& f : run.camera) f.image_row_fraction = NAN;
  const ExplainResult r = calibration::Explain(pose_log);
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_TRUE(r.EffectsAdded().empty()) << r.BriefReport();
  const calibration::AliasReport* rs = nullptr;
  for (const auto& a : r.aliased)
    if (a.effect == calibration::Effect::kRollingShutter) rs = &a;
  ASSERT_NE(rs, nullptr) << r.BriefReport();
  EXPECT_TRUE(rs->no_signal);
  EXPECT_THAT(rs->distinguishing_runs, ::testing::HasSubstr("image row"));
}

}  // namespace
}  // namespace odocal::testing
