#include "odocal/calibration/segment.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "odocal/base/format.h"
#include "odocal/base/units.h"

namespace odocal::calibration {
namespace {

constexpr double kTwoPi = 2.0 * M_PI;
// Heading is read in steps of this much, so that frame noise does not add up.
constexpr double kHeadingStepRad = DegToRad(5.0);
// A heading step is "in place" when the centre moved less than this per
// radian: a turning radius under 120 mm (an in-place turn seen by a tag off
// the axle, not a circle or a square's corner driven as an arc).
constexpr double kInPlaceRadiusM = 0.12;
// A spin drives less than this at a steady heading (a square, a straight,
// an out-and-back drive metres).
constexpr double kSpinStraightM = 0.1;

RunSpec Recorded() {
  RunSpec spec;
  spec.procedure = Procedure::kRecorded;
  return spec;
}

RunSpec Infer(const MotionSegment& s) {
  const double excursion_m = s.excursion_m;
  const double turns_real = std::abs(s.turned_rad) / kTwoPi;
  const int turns = static_cast<int>(std::lround(turns_real));
  const bool whole_turns = turns >= 1 && std::abs(turns_real - turns) < 0.17;  // +-60 deg
  const Direction dir = s.turned_rad < 0.0 ? Direction::kCw : Direction::kCcw;
  // Nothing but turning (the tracked point, off the axle, draws a circle):
  // a spin, whatever the offset.
  if (s.straight_m < kSpinStraightM && s.in_place_fraction > 0.8) {
    return whole_turns ? RunSpec::Spin(turns, dir) : Recorded();
  }
  // The tracked point may sit off the axle and at a yaw to the robot's
  // axis: the distance driven is the displacement, forward when the point
  // moved ahead of where it looked (within 90 deg).
  const Pose2 net = s.start_rest.mean.inverse() * s.end_rest.mean;
  if (std::abs(s.turned_rad) < DegToRad(30.0) && s.returned_m > 0.8 * excursion_m)
    return RunSpec::Straight(net.x() < 0.0 ? -s.returned_m : s.returned_m);
  const bool closed = s.returned_m < 0.25 * excursion_m;
  if (closed && whole_turns && turns == 1 && s.in_place_fraction > 0.5)
    return RunSpec::Umbmark(dir, excursion_m / std::sqrt(2.0));
  if (closed && whole_turns && s.in_place_fraction <= 0.5)
    return RunSpec::Circle(excursion_m / 2.0, turns, dir);
  if (closed && turns_real < 0.17 && s.in_place_fraction > 0.5 && s.first_turn_rad != 0.0) {
    // Each repeat turns +180 and -180 in place: count the in-place turning.
    const int repeats = std::max(1, static_cast<int>(std::lround(s.in_place_turning_rad / kTwoPi)));
    return RunSpec::OutAndBack(excursion_m, repeats,
                               s.first_turn_rad < 0.0 ? Direction::kCw : Direction::kCcw);
  }
  return Recorded();
}

// The farthest the plan takes the axle midpoint from the start (m): the
// straights' ends, and arcs in small steps.
double PlannedExcursion(const std::vector<Primitive>& plan) {
  double x = 0.0, y = 0.0, heading = 0.0, farthest = 0.0;
  for (const Primitive& p : plan) {
    const int steps = p.kind == Primitive::Kind::kArc ? 64 : 1;
    Primitive step = p;
    step.amount = p.amount / steps;
    for (int i = 0; i < steps; ++i) {
      AdvanceArc(step.LeftTravel(1.0), step.RightTravel(1.0), 1.0, &x, &y, &heading);
      farthest = std::max(farthest, std::hypot(x, y));
    }
  }
  return farthest;
}

}  // namespace

std::vector<MotionSegment> SegmentMotion(const std::vector<PoseSample>& samples,
                                         const RestOptions& rest_options, const SeenTurningOptions& unwrap) {
  const RestSummary summary = FindRests(samples, rest_options);
  std::vector<MotionSegment> out;
  for (size_t k = 0; k + 1 < summary.rests.size(); ++k) {
    MotionSegment s;
    s.start_rest = summary.rests[k];
    s.end_rest = summary.rests[k + 1];
    // The motion: the start rest's mean, the valid samples between, the end
    // rest's mean.
    std::vector<Pose2> poses = {s.start_rest.mean};
    std::vector<HeadingSighting> sightings = {{s.start_rest.t_end_s, s.start_rest.mean.heading()}};
    for (const PoseSample& p : samples)
      if (p.valid && p.t_s > s.start_rest.t_end_s && p.t_s < s.end_rest.t_begin_s) {
        poses.push_back(p.pose);
        sightings.push_back({p.t_s, p.pose.heading()});
      }
    poses.push_back(s.end_rest.mean);
    sightings.push_back({s.end_rest.t_begin_s, s.end_rest.mean.heading()});
    const Eigen::Vector2d origin = s.start_rest.mean.translation();
    double heading = 0.0, excursion = 0.0;
    // The anchor of the current heading step and of the path.
    double anchor_heading = 0.0;
    Eigen::Vector2d anchor_position = origin, path_anchor = origin;
    double turning = 0.0, in_place = 0.0;
    bool first_turn_done = false;
    for (size_t i = 1; i < poses.size(); ++i) {
      heading += WrapAngle(poses[i].heading() - poses[i - 1].heading());
      const Eigen::Vector2d p = poses[i].translation();
      excursion = std::max(excursion, (p - origin).norm());
      if ((p - path_anchor).norm() > 0.01) {
        s.path_m += (p - path_anchor).norm();
        path_anchor = p;
      }
      const double step = heading - anchor_heading;
      if (std::abs(step) >= kHeadingStepRad) {
        const bool still = (p - anchor_position).norm() < kInPlaceRadiusM * std::abs(step);
        turning += std::abs(step);
        if (still) {
          in_place += std::abs(step);
          if (!first_turn_done) {
            if (s.first_turn_rad == 0.0 || std::signbit(step) == std::signbit(s.first_turn_rad))
              s.first_turn_rad += step;
            else
              first_turn_done = true;
          }
        } else if (s.first_turn_rad != 0.0) {
          first_turn_done = true;
        }
        anchor_heading = heading;
        anchor_position = p;
      } else if ((p - anchor_position).norm() > 0.05) {
        // Driven on at a steady heading: the next turn starts from here.
        s.straight_m += (p - anchor_position).norm();
        anchor_heading = heading;
        anchor_position = p;
        if (s.first_turn_rad != 0.0) first_turn_done = true;
      }
    }
    s.turned_rad = heading;
    s.returned_m = (s.end_rest.mean.translation() - origin).norm();
    s.in_place_fraction = turning > 0.0 ? in_place / turning : 0.0;
    s.in_place_turning_rad = in_place;
    s.excursion_m = excursion;
    s.seen = TrackSeenTurning(sightings, unwrap);
    // Out of view across a gap the heading is known only modulo a turn,
    // and the path, the turning in place and the straights are partial.
    s.readable = s.seen.whole();
    s.inferred = s.readable ? Infer(s) : Recorded();
    out.push_back(s);
  }
  return out;
}

std::string Describe(const RunSpec& spec) {
  std::string text(ToString(spec.procedure));
  std::string dir(" ");
  dir += ToString(spec.direction);
  switch (spec.procedure) {
    case Procedure::kUmbmark:
      return text + dir + Format(", side %.0f mm", spec.side_m * kMToMm);
    case Procedure::kStraight:
      return text + Format(" %.0f mm", spec.distance_m * kMToMm);
    case Procedure::kSpin:
      return text + dir + ", " + std::to_string(spec.turns) + (spec.turns == 1 ? " turn" : " turns");
    case Procedure::kOutAndBack:
      return text + dir + Format(" %.0f mm", spec.distance_m * kMToMm) + ", " + std::to_string(spec.repeats) +
             (spec.repeats == 1 ? " repeat" : " repeats");
    case Procedure::kCircle:
      return text + dir + Format(", radius %.0f mm", spec.radius_m * kMToMm) + ", " + std::to_string(spec.turns) +
             (spec.turns == 1 ? " turn" : " turns");
    case Procedure::kRecorded:
      return "a motion that is none of the procedures";
  }
  return text;
}

std::string DescribeSeen(const MotionSegment& segment) {
  if (segment.readable) return Describe(segment.inferred);
  return Format("a motion out of view for %.1f s of %.1f s", segment.seen.unseen_s,
                segment.end_rest.t_begin_s - segment.start_rest.t_end_s);
}

bool SegmentMatches(const RunSpec& planned, const RunSpec& inferred, double size_tolerance) {
  if (planned.procedure == Procedure::kRecorded) return true;  // any path
  if (planned.procedure != inferred.procedure) return false;
  auto near = [&](double a, double b) { return std::abs(std::abs(a) - std::abs(b)) <= size_tolerance * std::abs(a); };
  switch (planned.procedure) {
    case Procedure::kUmbmark:
      return planned.direction == inferred.direction && near(planned.side_m, inferred.side_m);
    case Procedure::kStraight:
      return std::signbit(planned.distance_m) == std::signbit(inferred.distance_m) &&
             near(planned.distance_m, inferred.distance_m);
    case Procedure::kSpin:
      return planned.direction == inferred.direction && planned.turns == inferred.turns;
    case Procedure::kOutAndBack:
      return planned.direction == inferred.direction && planned.repeats == inferred.repeats &&
             near(planned.distance_m, inferred.distance_m);
    case Procedure::kCircle:
      return planned.direction == inferred.direction && planned.turns == inferred.turns &&
             near(planned.radius_m, inferred.radius_m);
    case Procedure::kRecorded:
      return true;
  }
  return false;
}

std::optional<std::string> SegmentContradicts(const RunSpec& planned, const MotionSegment& segment,
                                              double size_tolerance) {
  if (planned.procedure == Procedure::kRecorded) return std::nullopt;
  // As the station's heading check: a square's heading error after a
  // badly calibrated run is a few degrees; a wrong direction or number of
  // turns is a quarter turn or more.
  constexpr double kHeadingToleranceRad = DegToRad(60.0);
  // The tracked point may sit this far off the axle (the tag's offset).
  constexpr double kOffsetM = 0.15;
  const std::vector<Primitive> plan = PlanPrimitives(planned);
  if (auto why = ContradictsPlan(segment.seen, plan, kHeadingToleranceRad)) return why;
  const Pose2 end = PlannedEnd(plan);
  const double planned_displacement_m = std::hypot(end.x(), end.y());
  const double reach_m = PlannedExcursion(plan);
  if (std::abs(segment.returned_m - planned_displacement_m) > size_tolerance * reach_m + kOffsetM)
    return Format("the robot ended %.0f mm from where it started, the plan %.0f mm", segment.returned_m * kMToMm,
                  planned_displacement_m * kMToMm);
  if (segment.excursion_m > (1.0 + size_tolerance) * reach_m + kOffsetM)
    return Format("the camera saw the robot %.0f mm from the start, the plan goes no farther than %.0f mm",
                  segment.excursion_m * kMToMm, reach_m * kMToMm);
  return std::nullopt;
}

namespace {

// What pairing segment i with run j costs: nothing when it is the run, a
// near miss when it is the run's procedure driven another way (direction,
// size, turns), a full disagreement otherwise -- as much as a run missing
// or a segment extra. So a run missing next to a square driven the wrong
// way reads as that, not as the square missing and its neighbour replaced
// by a square (two full disagreements).
constexpr int kNearMiss = 1, kWrong = 2, kGap = 2;

// The segments, the plan, and the least costs of aligning their beginnings.
struct Alignment {
  const std::vector<MotionSegment>& segments;
  const std::vector<RunSpec>& planned;
  const std::vector<std::string>& names;
  double size_tolerance;
  // cost[i][j]: the least cost aligning the first i segments with the first
  // j runs.
  std::vector<std::vector<int>> cost;

  // What pairing segment i with run j costs (kNearMiss, kWrong or nothing).
  int PairCost(size_t i, size_t j) const {
    if (!segments[i].readable) return SegmentContradicts(planned[j], segments[i], size_tolerance) ? kWrong : 0;
    if (SegmentMatches(planned[j], segments[i].inferred, size_tolerance)) return 0;
    return planned[j].procedure == segments[i].inferred.procedure ? kNearMiss : kWrong;
  }
  // Segment i's time between its rests, as the problems name it.
  std::string Span(size_t i) const {
    return Format("%.1f-%.1f s", segments[i].start_rest.t_end_s, segments[i].end_rest.t_begin_s);
  }
  // Run j by name and procedure, as the problems name it.
  std::string Run(size_t j) const {
    return "run '" + (j < names.size() ? names[j] : std::to_string(j + 1)) + "' (" + Describe(planned[j]) + ")";
  }
};

// The table of least costs, filled by the edit-distance recurrence.
Alignment Align(const std::vector<MotionSegment>& segments, const std::vector<RunSpec>& planned,
                const std::vector<std::string>& names, double size_tolerance) {
  const size_t n = segments.size(), m = planned.size();
  Alignment a{segments, planned, names, size_tolerance,
              std::vector<std::vector<int>>(n + 1, std::vector<int>(m + 1, 0))};
  std::vector<std::vector<int>>& cost = a.cost;
  for (size_t i = 0; i <= n; ++i) cost[i][0] = kGap * static_cast<int>(i);
  for (size_t j = 0; j <= m; ++j) cost[0][j] = kGap * static_cast<int>(j);
  for (size_t i = 1; i <= n; ++i)
    for (size_t j = 1; j <= m; ++j)
      cost[i][j] =
          std::min({cost[i - 1][j - 1] + a.PairCost(i - 1, j - 1), cost[i - 1][j] + kGap, cost[i][j - 1] + kGap});
  return a;
}

// One least-cost alignment: its disagreements and the segment of each run.
struct Reading {
  std::vector<std::string> problems;  // from the end
  std::vector<int> segment_of_run;
};

// Every least-cost alignment (a few: ties are rare, and a recording that
// allows many readings is said to), walked back from the end. The first is
// the answer; the others, when their disagreements differ, are readings
// the recording cannot rule out.
struct ReadingWalk {
  static constexpr size_t kMaxReadings = 4;
  static constexpr int kMaxSteps = 100000;

  explicit ReadingWalk(const Alignment& alignment)
      : a(alignment), current{{}, std::vector<int>(alignment.planned.size(), -1)} {}

  // Walks back from cell (i, j) along every move that keeps the least cost.
  void Walk(size_t i, size_t j) {
    if (truncated) return;
    if (++steps > kMaxSteps) {
      truncated = true;
      return;
    }
    if (i == 0 && j == 0) {
      Keep();
      return;
    }
    if (i > 0 && j > 0) WalkPaired(i, j);
    if (i > 0 && a.cost[i][j] == a.cost[i - 1][j] + kGap) WalkExtraSegment(i, j);
    if (j > 0 && a.cost[i][j] == a.cost[i][j - 1] + kGap) WalkMissingRun(i, j);
  }

  // At the start: keeps the current reading unless one with its problems is kept.
  void Keep() {
    Reading r = current;
    std::reverse(r.problems.begin(), r.problems.end());
    for (const Reading& seen : readings)
      if (seen.problems == r.problems) return;
    if (readings.size() == kMaxReadings) {
      truncated = true;
      return;
    }
    readings.push_back(std::move(r));
  }

  // Segment i-1 as run j-1 (when that keeps the least cost): a match, or a
  // problem saying how they differ.
  void WalkPaired(size_t i, size_t j) {
    const int c = a.PairCost(i - 1, j - 1);
    if (a.cost[i][j] != a.cost[i - 1][j - 1] + c) return;
    if (c == 0) {
      current.segment_of_run[j - 1] = static_cast<int>(i - 1);
    } else {
      const MotionSegment& seg = a.segments[i - 1];
      current.problems.push_back(a.Run(j - 1) + ": the segment at " + a.Span(i - 1) +
                                 (seg.readable
                                      ? " is " + Describe(seg.inferred)
                                      : Format(" (out of view %.1f s of %.1f s) contradicts it: ", seg.seen.unseen_s,
                                               seg.end_rest.t_begin_s - seg.start_rest.t_end_s) +
                                            *SegmentContradicts(a.planned[j - 1], seg, a.size_tolerance)));
    }
    Walk(i - 1, j - 1);
    if (c == 0)
      current.segment_of_run[j - 1] = -1;
    else
      current.problems.pop_back();
  }

  // Segment i-1 in no run: an extra segment.
  void WalkExtraSegment(size_t i, size_t j) {
    current.problems.push_back("extra segment at " + a.Span(i - 1) + " (" + DescribeSeen(a.segments[i - 1]) +
                               "): not in the plan");
    Walk(i - 1, j);
    current.problems.pop_back();
  }

  // Run j-1 with no segment: where it should have been.
  void WalkMissingRun(size_t i, size_t j) {
    const size_t n = a.segments.size();
    const double after = i > 0 ? a.segments[i - 1].end_rest.t_begin_s : 0.0;
    const double before = i < n ? a.segments[i].start_rest.t_end_s : std::numeric_limits<double>::infinity();
    current.problems.push_back(a.Run(j - 1) + ": missing (no motion segment for it" +
                               (std::isfinite(before) ? Format(" between %.1f s and %.1f s)", after, before)
                                                      : Format(" after %.1f s)", after)));
    Walk(i, j - 1);
    current.problems.pop_back();
  }

  const Alignment& a;
  std::vector<Reading> readings;
  bool truncated = false;
  int steps = 0;
  Reading current;
};

}  // namespace

PlanMatch MatchSegmentsToPlan(const std::vector<MotionSegment>& segments, const std::vector<RunSpec>& planned,
                              const std::vector<std::string>& names, double size_tolerance) {
  const Alignment alignment = Align(segments, planned, names, size_tolerance);
  ReadingWalk walk(alignment);
  walk.Walk(segments.size(), planned.size());
  const std::vector<Reading>& readings = walk.readings;
  PlanMatch match;
  match.segment_of_run = readings.front().segment_of_run;
  match.problems = readings.front().problems;
  for (size_t k = 1; k < readings.size(); ++k) match.other_readings.push_back(readings[k].problems);
  match.more_readings = walk.truncated;
  match.status = match.problems.empty() ? StatusCode::kOk : StatusCode::kFailed;
  return match;
}

}  // namespace odocal::calibration
