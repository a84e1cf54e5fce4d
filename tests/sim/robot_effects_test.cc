// The robot-side hidden effects of the virtual robot (turn_slip,
// encoder_backlash, carpet_drift), each against an analytic truth that does
// not share the simulator's code path.
#include <cmath>

#include <gtest/gtest.h>

#include "odocal/calibration/pose2.h"
#include "odocal/sim/virtual_robot.h"
#include "odocal/test_util/robots.h"

namespace odocal::sim {
namespace {

using calibration::Direction;
using calibration::Pose2;
using calibration::RunSpec;
using calibration::WrapAngle;

// A perfect robot (Ed = Eb = 1) whose turns run at a constant rate: the
// acceleration is so large that the ramps last a fraction of a control step.
RobotConfig ConstantRateRobot() {
  RobotConfig c = test_util::ExactRobot(1.0, 1.0);
  c.limits.turn_accel_rad_s2 = 1e7;
  c.limits.accel_m_s2 = 1e7;
  return c;
}

TEST(TurnSlip, ASpinAtConstantRateTurnsOneMinusFOmegaOfThePlan) {
  const double f = 0.03;
  for (double omega : {0.5, 1.0, 2.0}) {
    RobotConfig c = ConstantRateRobot();
    c.effects.turn_slip = TurnSlipEffect{f};
    VirtualRobot robot(c);
    RunSpec spec = RunSpec::Spin(1, Direction::kCcw);
    spec.turn_rate_rad_s = omega;
    const RunRecord run = robot.Execute(spec);
    // Planned: one full turn; achieved (1 - f omega) of it.
    const double expected = WrapAngle(2.0 * M_PI * (1.0 - f * omega));
    EXPECT_NEAR(run.TrueEndInStartFrame().heading(), expected, 2e-4) << "omega " << omega;
    EXPECT_NEAR(run.TrueEndInStartFrame().translation().norm(), 0.0, 1e-4);
  }
}

TEST(TurnSlip, StraightsDoNotSlip) {
  RobotConfig c = ConstantRateRobot();
  c.effects.turn_slip = TurnSlipEffect{0.05};
  VirtualRobot robot(c);
  const RunRecord run = robot.Execute(RunSpec::Straight(2.0));
  EXPECT_NEAR(run.TrueEndInStartFrame().x(), 2.0, 1e-4);
  EXPECT_NEAR(run.TrueEndInStartFrame().heading(), 0.0, 1e-5);
}

// One spin in place turns by (left + right travel) / track. After a reversal
// the reversing wheel loses `ticks` of travel, so the spin falls short by
// ticks * metres_per_tick / track, and only after a reversal.
TEST(EncoderBacklash, EachReversalLosesExactlyTicksOfTravel) {
  const double ticks = 12.0;
  RobotConfig c = ConstantRateRobot();
  c.effects.encoder_backlash = EncoderBacklashEffect{ticks};
  VirtualRobot robot(c);
  const double lost_rad = ticks * c.truth.LeftMetresPerTick() / c.truth.track_m;

  // The robot starts as if it last moved forward: a ccw spin reverses the left wheel.
  const RunRecord first = robot.Execute(RunSpec::Spin(1, Direction::kCcw));
  EXPECT_NEAR(first.TrueEndInStartFrame().heading(), -lost_rad, 1e-5);
  // The left wheel's lash is already taken up backwards: no loss.
  const RunRecord second = robot.Execute(RunSpec::Spin(1, Direction::kCcw));
  EXPECT_NEAR(second.TrueEndInStartFrame().heading(), 0.0, 1e-5);
  // A cw spin reverses both wheels (the left forward again, the right
  // backwards): both fall short, the cw turn by twice the loss.
  const RunRecord third = robot.Execute(RunSpec::Spin(1, Direction::kCw));
  EXPECT_NEAR(third.TrueEndInStartFrame().heading(), 2.0 * lost_rad, 1e-5);
  EXPECT_NEAR(third.TrueEndInStartFrame().translation().norm(), 0.0, 1e-4);
}

TEST(EncoderBacklash, AnOutAndBackLosesTicksAtEveryReversal) {
  const double ticks = 10.0, d = 1.0;
  RobotConfig c = ConstantRateRobot();
  VirtualRobot clean(c);
  const Pose2 without = clean.Execute(RunSpec::OutAndBack(d, 1)).TrueEndInStartFrame();
  c.effects.encoder_backlash = EncoderBacklashEffect{ticks};
  VirtualRobot robot(c);
  const Pose2 with = robot.Execute(RunSpec::OutAndBack(d, 1)).TrueEndInStartFrame();
  // Reversals: turn +180 (left wheel back), forward (left forward again),
  // turn -180 (right back). Loss of h = ticks * m_per_tick at each:
  //  1. the +180 turn falls short by h / b: heading pi - h/b;
  //  2. the return straight starts with the left wheel still while the right
  //     rolls h: a pivot about the left wheel, +h/b, back to heading pi,
  //     moving the axle midpoint by h/2;
  //  3. the -180 turn, now the right wheel back, falls short by h / b.
  // Net heading: +h/b; net position: the h/2 of the pivot.
  const double h = ticks * c.truth.LeftMetresPerTick();
  const double b = c.truth.track_m;
  EXPECT_NEAR(WrapAngle(with.heading() - without.heading()), h / b, 2e-5);
  EXPECT_NEAR((with.translation() - without.translation()).norm(), 0.5 * h, 0.1 * h);
}

TEST(CarpetDrift, AStraightAlongTheGrainEndsRateTimesLengthToTheLeft) {
  const double rate = 0.01, L = 2.0;
  for (auto [grain_deg, factor] : {std::pair{0.0, 1.0}, std::pair{180.0, -1.0},
                                   std::pair{90.0, 0.0}, std::pair{60.0, 0.5}}) {
    RobotConfig c = ConstantRateRobot();
    c.effects.carpet_drift = CarpetDriftEffect{grain_deg * M_PI / 180.0, rate};
    VirtualRobot robot(c);
    const Pose2 end = robot.Execute(RunSpec::Straight(L)).TrueEndInStartFrame();
    EXPECT_NEAR(end.y(), factor * rate * L, 1e-5) << "grain " << grain_deg;
    EXPECT_NEAR(end.x(), L, 1e-4);
    EXPECT_NEAR(end.heading(), 0.0, 1e-6) << "drift translates, it does not turn";
  }
}

TEST(CarpetDrift, NoneDuringInPlaceTurns) {
  RobotConfig c = ConstantRateRobot();
  c.effects.carpet_drift = CarpetDriftEffect{0.0, 0.02};
  VirtualRobot robot(c);
  const Pose2 end = robot.Execute(RunSpec::Spin(2, Direction::kCcw)).TrueEndInStartFrame();
  EXPECT_NEAR(end.translation().norm(), 0.0, 1e-5);
}

// A straight at constant speed v travels (1 - k v) of its planned length;
// twice as fast, twice the loss.
TEST(SpeedSlip, AStraightAtConstantSpeedLosesKVOfItsLength) {
  const double k = 0.04, L = 2.0;
  for (double v : {0.1, 0.2, 0.4}) {
    RobotConfig c = ConstantRateRobot();
    c.effects.speed_slip = SpeedSlipEffect{k};
    VirtualRobot robot(c);
    RunSpec spec = RunSpec::Straight(L);
    spec.speed_m_s = v;
    const Pose2 end = robot.Execute(spec).TrueEndInStartFrame();
    EXPECT_NEAR(end.x(), L * (1.0 - k * v), 1e-4) << "v " << v;
    EXPECT_NEAR(end.heading(), 0.0, 1e-6);
  }
}

// A spin at omega: each wheel at omega b / 2 turns (1 - k omega b / 2) of the plan.
TEST(SpeedSlip, ASpinLosesKTimesItsWheelSpeed) {
  const double k = 0.04, omega = 2.0;
  RobotConfig c = ConstantRateRobot();
  c.effects.speed_slip = SpeedSlipEffect{k};
  VirtualRobot robot(c);
  RunSpec spec = RunSpec::Spin(1, Direction::kCcw);
  spec.turn_rate_rad_s = omega;
  const Pose2 end = robot.Execute(spec).TrueEndInStartFrame();
  const double wheel_speed = omega * c.truth.track_m / 2.0;
  EXPECT_NEAR(end.heading(), WrapAngle(2.0 * M_PI * (1.0 - k * wheel_speed)), 2e-4);
}

// A circle of radius R: without effects the robot comes back to its start
// (one arc primitive, both wheels forward); with arc_scale c each wheel rolls
// (1 - c / R) of its share, so the circle is the same but the robot stops
// short by 2 pi c / R of the turn.
TEST(ArcScale, ACircleStopsShortByCOverROfTheTurn) {
  const double R = 0.4, c = 0.002;
  RobotConfig plain = ConstantRateRobot();
  plain.noise.random_encoder_phase = false;
  VirtualRobot robot(plain);
  const Pose2 closed = robot.Execute(RunSpec::Circle(R, 1, Direction::kCcw)).TrueEndInStartFrame();
  EXPECT_NEAR(closed.translation().norm(), 0.0, 2e-4);
  EXPECT_NEAR(WrapAngle(closed.heading()), 0.0, 2e-4);
  RobotConfig scaled = plain;
  scaled.effects.arc_scale = ArcScaleEffect{c};
  VirtualRobot robot2(scaled);
  const Pose2 end = robot2.Execute(RunSpec::Circle(R, 1, Direction::kCcw)).TrueEndInStartFrame();
  const double short_rad = 2.0 * M_PI * c / R;
  EXPECT_NEAR(WrapAngle(end.heading()), -short_rad, 2e-4);
  // On the circle: (R sin(-d), R (1 - cos(-d))) from the start.
  EXPECT_NEAR(end.x(), -R * std::sin(short_rad), 2e-4);
  EXPECT_NEAR(end.y(), R * (1.0 - std::cos(short_rad)), 2e-4);
  // A straight is not an arc.
  const Pose2 straight = robot2.Execute(RunSpec::Straight(1.0)).TrueEndInStartFrame();
  EXPECT_NEAR(straight.x(), 1.0, 2e-4);
}

// The rolling radius r (1 + a sin(phi)) averages out over whole wheel turns:
// a straight of n whole turns of the left wheel ends where it would without
// it; half a turn from phi = 0 rolls r (pi + 2 a) instead of r pi.
TEST(EccentricWheel, WholeTurnsAverageOutHalfATurnRollsTwoAMore) {
  const double a = 0.03;
  RobotConfig c = ConstantRateRobot();
  c.noise.random_encoder_phase = false;
  const double circumference = M_PI * c.truth.left_wheel_diameter_m;
  auto straight_end = [&](double length, bool eccentric) {
    RobotConfig cc = c;
    if (eccentric) cc.effects.eccentric_wheel = EccentricWheelEffect{true, a, 0.0};
    VirtualRobot robot(cc);
    return robot.Execute(RunSpec::Straight(length)).TrueEndInStartFrame();
  };
  const Pose2 whole = straight_end(3.0 * circumference, true);
  const Pose2 plain = straight_end(3.0 * circumference, false);
  EXPECT_NEAR(WrapAngle(whole.heading() - plain.heading()), 0.0, 2e-4 * a / 0.03);
  const Pose2 half = straight_end(0.5 * circumference, true);
  const Pose2 half_plain = straight_end(0.5 * circumference, false);
  // The left wheel rolls 2 a r further: the robot turns right by that over the track.
  const double extra = 2.0 * a * c.truth.left_wheel_diameter_m / 2.0;
  EXPECT_NEAR(WrapAngle(half_plain.heading() - half.heading()), extra / c.truth.track_m,
              0.05 * extra / c.truth.track_m);
}

}  // namespace
}  // namespace odocal::sim
