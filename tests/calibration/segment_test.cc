// Runs found in one continuous recording: the virtual robot (its own time
// integration, wheel noise, accelerations, pauses between primitives) drives
// a plan run after run; a camera-like sampler sees a point 40 mm ahead of
// the axle (an unknown tag offset) at 30 Hz, with noise and lost frames. The
// segmenter reads the plan back from those poses alone, and the matcher
// names a missing run, a run driven the wrong way and an extra one.
#include <cmath>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "odocal/calibration/segment.h"
#include "odocal/sim/trajectory.h"
#include "odocal/sim/virtual_robot.h"
#include "odocal/test_util/robots.h"

namespace odocal::calibration {
namespace {

using ::testing::HasSubstr;

struct Recording {
  std::vector<PoseSample> samples;
  std::vector<std::pair<double, double>> run_times;  // true start, end of each run driven
};

// What the camera sees: frames at `fps`, each kept with probability `keep`
// (a busy machine drops frames), the tag only where `sees` says (a camera
// over the start area sees it only near the start).
struct View {
  double fps = 30.0;
  double keep = 0.95;
  std::function<bool(const Pose2&)> sees = [](const Pose2&) { return true; };
};

Recording Drive(const std::vector<RunSpec>& specs, uint32_t seed, const View& view = {}) {
  sim::RobotConfig config = test_util::ExactRobot(1.002, 1.01);
  config.rest_s = 1.0;   // a camera's plan: rests of a second either side
  config.pause_s = 0.3;
  config.noise.wheel_sigma_m_per_sqrt_m = 2e-4;
  sim::VirtualRobot robot(config);
  std::vector<sim::RunRecord> runs;
  Recording rec;
  for (const RunSpec& spec : specs) {
    runs.push_back(robot.Execute(spec));
    rec.run_times.emplace_back(runs.back().start_time_s, runs.back().end_time_s);
  }
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 1.0);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const double t_end = runs.back().end_time_s;
  size_t r = 0;
  for (double t = 0.0; t <= t_end; t += 1.0 / view.fps) {
    while (r + 1 < runs.size() && t > runs[r].end_time_s) ++r;
    const Pose2 robot_pose = sim::PoseAt(runs[r], std::clamp(t, runs[r].start_time_s, runs[r].end_time_s));
    const Pose2 tag = robot_pose * Pose2::FromXYHeading(0.04, 0.0, 0.0);
    PoseSample s;
    s.t_s = t;
    s.valid = u(rng) < view.keep && view.sees(tag);
    s.pose = Pose2::FromXYHeading(tag.x() + 1e-4 * noise(rng), tag.y() + 1e-4 * noise(rng),
                                  tag.heading() + 0.0005 * noise(rng));
    rec.samples.push_back(s);
  }
  return rec;
}

std::vector<RunSpec> TenRuns() {
  return {RunSpec::Umbmark(Direction::kCw, 1.0),  RunSpec::Umbmark(Direction::kCcw, 1.0),
          RunSpec::Straight(1.2),                 RunSpec::Spin(2, Direction::kCcw),
          RunSpec::OutAndBack(0.8, 1, Direction::kCcw), RunSpec::Umbmark(Direction::kCw, 1.0),
          RunSpec::Umbmark(Direction::kCcw, 1.0), RunSpec::Spin(1, Direction::kCw),
          RunSpec::Circle(0.5, 1, Direction::kCcw), RunSpec::Straight(0.6)};
}

std::vector<std::string> Names(size_t n) {
  std::vector<std::string> names;
  for (size_t i = 0; i < n; ++i) names.push_back("run" + std::to_string(i + 1));
  return names;
}

TEST(Segment, TenRunsAreFoundAndTheirProceduresReadFromThePoses) {
  const std::vector<RunSpec> plan = TenRuns();
  const Recording rec = Drive(plan, 3);
  const std::vector<MotionSegment> segments = SegmentMotion(rec.samples);
  ASSERT_EQ(segments.size(), plan.size());
  for (size_t k = 0; k < plan.size(); ++k) {
    const MotionSegment& s = segments[k];
    SCOPED_TRACE("run " + std::to_string(k + 1) + ": planned " + Describe(plan[k]) + ", read " +
                 Describe(s.inferred));
    std::printf("  %.1f-%.1f s: %s (turned %.1f deg, in place %.2f, returned %.3f m)\n", s.begin_s(),
                s.end_s(), Describe(s.inferred).c_str(), s.turned_rad * 180.0 / M_PI, s.in_place_fraction,
                s.returned_m);
    EXPECT_TRUE(SegmentMatches(plan[k], s.inferred));
    EXPECT_EQ(s.inferred.procedure, plan[k].procedure);
    // The segment's span holds the whole run's motion, rests either side.
    EXPECT_LE(s.begin_s(), rec.run_times[k].first + 1.0);
    EXPECT_GE(s.end_s(), rec.run_times[k].second - 1.0);
    EXPECT_LT(s.start_rest.t_end_s, rec.run_times[k].first + 1.1);
    EXPECT_GT(s.end_rest.t_begin_s, rec.run_times[k].second - 1.1);
  }
  // Sizes read from the poses alone (tag 40 mm off the axle).
  EXPECT_NEAR(segments[0].inferred.side_m, 1.0, 0.05);
  EXPECT_NEAR(segments[2].inferred.distance_m, 1.2, 0.02);
  EXPECT_EQ(segments[3].inferred.turns, 2);
  EXPECT_NEAR(segments[4].inferred.distance_m, 0.8, 0.06);
  EXPECT_EQ(segments[4].inferred.direction, Direction::kCcw);
  EXPECT_NEAR(segments[8].inferred.radius_m, 0.5, 0.05);
  const PlanMatch match = MatchSegmentsToPlan(segments, plan, Names(plan.size()));
  EXPECT_TRUE(match.ok()) << ::testing::PrintToString(match.problems);
  for (size_t k = 0; k < plan.size(); ++k) EXPECT_EQ(match.segment_of_run[k], static_cast<int>(k));
}

// The case: ten planned runs, one not driven, one driven the wrong
// way; both named, with the segment's times, nothing silently reassigned.
TEST(Segment, AMissingRunAndOneDrivenTheWrongWayAreNamed) {
  const std::vector<RunSpec> plan = TenRuns();
  std::vector<RunSpec> driven = plan;
  driven.erase(driven.begin() + 3);                      // run4, the 2-turn spin, not driven
  driven[5] = RunSpec::Umbmark(Direction::kCw, 1.0);     // run7 (ccw square) driven cw
  const Recording rec = Drive(driven, 4);
  const std::vector<MotionSegment> segments = SegmentMotion(rec.samples);
  ASSERT_EQ(segments.size(), driven.size());
  const PlanMatch match = MatchSegmentsToPlan(segments, plan, Names(plan.size()));
  EXPECT_FALSE(match.ok());
  ASSERT_EQ(match.problems.size(), 2u) << ::testing::PrintToString(match.problems);
  EXPECT_THAT(match.problems[0], HasSubstr("run 'run4' (spin ccw, 2 turns): missing"));
  EXPECT_THAT(match.problems[1], HasSubstr("run 'run7' (umbmark ccw, side 1000 mm): the segment at"));
  EXPECT_THAT(match.problems[1], HasSubstr("is umbmark cw"));
  // The others still matched where they were driven.
  EXPECT_EQ(match.segment_of_run[3], -1);
  EXPECT_EQ(match.segment_of_run[4], 3);
  EXPECT_EQ(match.segment_of_run[9], 8);
}

// Segments as the segmenter would give them: what was read, at 10 s each.
std::vector<MotionSegment> Read(const std::vector<RunSpec>& specs) {
  std::vector<MotionSegment> segments;
  for (size_t k = 0; k < specs.size(); ++k) {
    MotionSegment s;
    s.start_rest.t_begin_s = 10.0 * k;
    s.start_rest.t_end_s = 10.0 * k + 1.0;
    s.end_rest.t_begin_s = 10.0 * k + 9.0;
    s.end_rest.t_end_s = 10.0 * k + 10.0;
    s.inferred = specs[k];
    segments.push_back(s);
  }
  return segments;
}

// A run missing right after a square driven the wrong way: counting each
// disagreement alike, "the square missing and the next run's place taken by
// a square" is as good as the truth, and the walk back from the end picked
// it. A reversed square is the planned procedure driven another way: it
// costs less than a segment that is some other procedure.
TEST(Segment, AMissingRunNextToAReversedSquareIsReadAsThat) {
  const RunSpec cw = RunSpec::Umbmark(Direction::kCw, 1.0), ccw = RunSpec::Umbmark(Direction::kCcw, 1.0);
  const std::vector<RunSpec> plan = {cw, ccw, RunSpec::Straight(0.5), RunSpec::Spin(1, Direction::kCw)};
  // ccw driven cw, the straight not driven.
  const PlanMatch match =
      MatchSegmentsToPlan(Read({cw, cw, RunSpec::Spin(1, Direction::kCw)}), plan, {"a", "b", "c", "d"});
  ASSERT_EQ(match.problems.size(), 2u) << ::testing::PrintToString(match.problems);
  EXPECT_THAT(match.problems[0], HasSubstr("run 'b' (umbmark ccw, side 1000 mm): the segment at 11.0-19.0 s is umbmark cw"));
  EXPECT_THAT(match.problems[1], HasSubstr("run 'c' (straight 500 mm): missing (no motion segment for it between 19.0 s and 21.0 s)"));
  EXPECT_TRUE(match.other_readings.empty()) << ::testing::PrintToString(match.other_readings);
  EXPECT_EQ(match.segment_of_run, (std::vector<int>{0, -1, -1, 2}));
}

// Two squares driven alike where one was planned: which is the extra one
// the recording cannot tell; both readings are given, neither silently.
TEST(Segment, ReadingsAsGoodAreAllGiven) {
  const RunSpec cw = RunSpec::Umbmark(Direction::kCw, 1.0), ccw = RunSpec::Umbmark(Direction::kCcw, 1.0);
  const PlanMatch match = MatchSegmentsToPlan(Read({cw, cw, ccw}), {cw, ccw}, {"cw", "ccw"});
  EXPECT_FALSE(match.ok());
  ASSERT_EQ(match.problems.size(), 1u);
  ASSERT_EQ(match.other_readings.size(), 1u);
  ASSERT_EQ(match.other_readings[0].size(), 1u);
  const std::vector<std::string> both = {match.problems[0], match.other_readings[0][0]};
  EXPECT_THAT(both, ::testing::UnorderedElementsAre(HasSubstr("extra segment at 1.0-9.0 s (umbmark cw"),
                                                     HasSubstr("extra segment at 11.0-19.0 s (umbmark cw")));
  EXPECT_FALSE(match.more_readings);
  // Many alike: the readings are capped and said to be more.
  const PlanMatch many = MatchSegmentsToPlan(Read(std::vector<RunSpec>(8, cw)), {cw, cw}, {"x", "y"});
  EXPECT_EQ(many.other_readings.size(), 3u);
  EXPECT_TRUE(many.more_readings);
  // A recording as planned has one reading.
  const PlanMatch exact = MatchSegmentsToPlan(Read({cw, ccw}), {cw, ccw}, {"cw", "ccw"});
  EXPECT_TRUE(exact.ok());
  EXPECT_TRUE(exact.other_readings.empty());
  EXPECT_FALSE(exact.more_readings);
}

TEST(Segment, AnExtraRunIsNamedNotAssigned) {
  const std::vector<RunSpec> plan = {RunSpec::Straight(0.8), RunSpec::Spin(1, Direction::kCcw)};
  const Recording rec = Drive({RunSpec::Straight(0.8), RunSpec::Spin(3, Direction::kCw),
                               RunSpec::Spin(1, Direction::kCcw)},
                              5);
  const std::vector<MotionSegment> segments = SegmentMotion(rec.samples);
  ASSERT_EQ(segments.size(), 3u);
  const PlanMatch match = MatchSegmentsToPlan(segments, plan, {"straight", "spin"});
  ASSERT_EQ(match.problems.size(), 1u) << ::testing::PrintToString(match.problems);
  EXPECT_THAT(match.problems[0], HasSubstr("extra segment at"));
  EXPECT_THAT(match.problems[0], HasSubstr("(spin cw, 3 turns): not in the plan"));
  EXPECT_EQ(match.segment_of_run[0], 0);
  EXPECT_EQ(match.segment_of_run[1], 2);
}


// ---- A camera over the start area (issue 23) --------------------------------
// A 1.2 m x 0.8 m view around the start: the 2 m squares leave it on the
// first leg and come back on the last, the last corner turned in view.

double Rad(double deg) { return deg * M_PI / 180.0; }

View HomeArea(double keep) {
  View v;
  v.keep = keep;
  v.sees = [](const Pose2& tag) { return std::abs(tag.x()) < 0.6 && std::abs(tag.y()) < 0.4; };
  return v;
}

std::vector<HeadingSighting> Sightings(const std::vector<PoseSample>& samples, double t0, double t1) {
  std::vector<HeadingSighting> out;
  for (const PoseSample& s : samples)
    if (s.valid && s.t_s >= t0 && s.t_s <= t1) out.push_back({s.t_s, s.pose.heading()});
  return out;
}

// The false abort: the robot leaves the view heading 0, comes back
// 30 s later at -270 deg (seen as +90) and turns its last corner in view.
// Summing wrapped steps reads -6 deg; a gap it could turn half a turn in is
// not unwrapped, and nothing seen contradicts the cw square.
TEST(SeenTurning, AGapTheRobotCouldTurnHalfATurnInIsNotUnwrapped) {
  const std::vector<HeadingSighting> s = {{0.0, 0.0},          {0.5, Rad(-1)},  {30.0, Rad(-274)},
                                          {30.5, Rad(-304)}, {31.0, Rad(-334)}, {31.5, Rad(-363)}};
  SeenTurningOptions options;
  options.max_turn_rate_rad_s = Rad(180);
  const SeenTurning seen = TrackSeenTurning(s, options);
  EXPECT_FALSE(seen.whole());
  ASSERT_EQ(seen.chains.size(), 2u);
  EXPECT_NEAR(seen.unseen_s, 29.5, 1e-9);
  EXPECT_NEAR(seen.chains[1].turned_rad, Rad(-89), 1e-9);
  EXPECT_FALSE(seen.total_rad());
  const auto cw = PlanPrimitives(RunSpec::Umbmark(Direction::kCw, 2.0));
  const auto ccw = PlanPrimitives(RunSpec::Umbmark(Direction::kCcw, 2.0));
  EXPECT_EQ(ContradictsPlan(seen, cw, Rad(60)), std::nullopt);
  // Against a ccw plan the last corner was turned the wrong way in view.
  const auto why = ContradictsPlan(seen, ccw, Rad(60));
  ASSERT_TRUE(why);
  EXPECT_THAT(*why, HasSubstr("while in view at 30.0-31.5 s the camera saw the robot turn -89 deg before the end, "
                              "where the plan turns between +0 and +360 deg"));
  // Seen whole at a frame rate that bridges every gap: the total is judged.
  std::vector<HeadingSighting> dense;
  for (int i = 0; i <= 360; ++i) dense.push_back({0.1 * i, Rad(-i)});
  const SeenTurning all = TrackSeenTurning(dense, options);
  ASSERT_TRUE(all.total_rad());
  EXPECT_NEAR(*all.total_rad(), Rad(-360), 1e-9);
  EXPECT_EQ(ContradictsPlan(all, cw, Rad(60)), std::nullopt);
  EXPECT_THAT(ContradictsPlan(all, ccw, Rad(60)).value_or(""),
              HasSubstr("the camera saw the robot turn -360 deg, the plan turns +360 deg"));
}

// Start and end are always seen: an end heading a quarter turn off the plan
// is caught whatever was out of view. An out-and-back turns +180 and -180:
// its plan turns 0 net (the station once expected 360).
TEST(SeenTurning, TheEndHeadingModuloATurnIsAlwaysJudged) {
  const SeenTurning seen = TrackSeenTurning({{0.0, 0.0}, {20.0, Rad(95)}}, {});
  EXPECT_THAT(ContradictsPlan(seen, PlanPrimitives(RunSpec::Umbmark(Direction::kCw, 2.0)), Rad(60)).value_or(""),
              HasSubstr("the camera saw the robot end +95 deg from the plan's heading (modulo a turn"));
  EXPECT_NEAR(PlannedHeadings(PlanPrimitives(RunSpec::OutAndBack(1.0, 2, Direction::kCw))).back(), 0.0, 1e-12);
  const SeenTurning back = TrackSeenTurning({{0.0, 0.0}, {20.0, Rad(3)}}, {});
  EXPECT_EQ(ContradictsPlan(back, PlanPrimitives(RunSpec::OutAndBack(1.0, 2, Direction::kCw)), Rad(60)),
            std::nullopt);
}

// The virtual robot drives 2 m squares under a camera over the start, 100
// times with the frames kept at random (a busy machine drops 0-80 % of
// them): what was seen never contradicts the square driven, and the same
// sightings always contradict the square the other way (its last corner is
// turned in view).
TEST(SeenTurning, HomeAreaSquaresNeverContradictTheirPlanAndTheReverseIsCaught) {
  std::mt19937 rng(23);
  std::uniform_real_distribution<double> keep(0.2, 1.0);
  int caught = 0, judged_whole = 0;
  for (int trial = 0; trial < 100; ++trial) {
    const Direction dir = trial % 2 ? Direction::kCcw : Direction::kCw;
    const Direction other = trial % 2 ? Direction::kCw : Direction::kCcw;
    const Recording rec = Drive({RunSpec::Umbmark(dir, 2.0)}, 100 + trial, HomeArea(keep(rng)));
    // The run's motion with its last rest sighting either side.
    const auto seen_samples = Sightings(rec.samples, rec.run_times[0].first - 0.5, rec.run_times[0].second + 0.5);
    ASSERT_GE(seen_samples.size(), 2u);
    SeenTurningOptions options;
    options.max_turn_rate_rad_s = 1.25 * test_util::ExactRobot(1.0, 1.0).limits.turn_rate_rad_s;
    const SeenTurning seen = TrackSeenTurning(seen_samples, options);
    judged_whole += seen.whole();
    EXPECT_EQ(ContradictsPlan(seen, PlanPrimitives(RunSpec::Umbmark(dir, 2.0)), Rad(60)), std::nullopt)
        << "trial " << trial;
    caught += ContradictsPlan(seen, PlanPrimitives(RunSpec::Umbmark(other, 2.0)), Rad(60)).has_value();
  }
  EXPECT_EQ(judged_whole, 0);  // the robot always left the view
  EXPECT_EQ(caught, 100);
}

// One recording of squares that leave the view: the two segments are found
// at the right times, cannot be read, and are the plan's runs because
// nothing seen contradicts them; a square driven the wrong way is named.
TEST(Segment, RunsThatLeaveTheViewAreTakenFromThePlanUnlessWhatWasSeenContradictsIt) {
  const RunSpec cw = RunSpec::Umbmark(Direction::kCw, 2.0), ccw = RunSpec::Umbmark(Direction::kCcw, 2.0);
  const std::vector<RunSpec> plan = {cw, ccw, cw, ccw};
  const Recording rec = Drive(plan, 8, HomeArea(0.9));
  const std::vector<MotionSegment> segments = SegmentMotion(rec.samples);
  ASSERT_EQ(segments.size(), plan.size());
  for (size_t k = 0; k < plan.size(); ++k) {
    EXPECT_FALSE(segments[k].readable);
    EXPECT_GT(segments[k].seen.unseen_s, 10.0);
    EXPECT_THAT(DescribeSeen(segments[k]), HasSubstr("a motion out of view for"));
    EXPECT_LE(segments[k].begin_s(), rec.run_times[k].first + 1.0);
    EXPECT_GE(segments[k].end_s(), rec.run_times[k].second - 1.0);
  }
  const PlanMatch match = MatchSegmentsToPlan(segments, plan, Names(plan.size()));
  EXPECT_TRUE(match.ok()) << ::testing::PrintToString(match.problems);
  EXPECT_EQ(match.segment_of_run, (std::vector<int>{0, 1, 2, 3}));
  // Run 3 driven ccw: its last corner, turned left in view, names it.
  const Recording wrong = Drive({cw, ccw, ccw, ccw}, 9, HomeArea(0.9));
  const PlanMatch caught = MatchSegmentsToPlan(SegmentMotion(wrong.samples), plan, Names(plan.size()));
  EXPECT_FALSE(caught.ok());
  ASSERT_EQ(caught.problems.size(), 1u) << ::testing::PrintToString(caught.problems);
  EXPECT_THAT(caught.problems[0], HasSubstr("run 'run3' (umbmark cw, side 2000 mm): the segment at"));
  EXPECT_THAT(caught.problems[0], HasSubstr("contradicts it: while in view"));
  // A straight where the plan has a square: it ends 2 m from where it started.
  const Recording straight = Drive({cw, RunSpec::Straight(0.5)}, 10, HomeArea(0.9));
  const PlanMatch other = MatchSegmentsToPlan(SegmentMotion(straight.samples), {cw, ccw}, Names(2));
  EXPECT_FALSE(other.ok());
}

}  // namespace
}  // namespace odocal::calibration
