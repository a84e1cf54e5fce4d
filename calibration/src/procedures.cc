#include "odocal/calibration/procedures.h"

#include <cmath>

namespace odocal::calibration {

std::string_view ToString(Procedure procedure) {
  switch (procedure) {
    case Procedure::kUmbmark: return "umbmark";
    case Procedure::kStraight: return "straight";
    case Procedure::kSpin: return "spin";
    case Procedure::kOutAndBack: return "out_and_back";
    case Procedure::kRecorded: return "recorded";
    case Procedure::kCircle: return "circle";
  }
  return "?";
}

std::string_view ToString(Direction direction) {
  return direction == Direction::kCw ? "cw" : "ccw";
}

std::string_view ToString(Reference reference) {
  return reference == Reference::kWall ? "wall" : "camera";
}

std::optional<Procedure> ParseProcedure(std::string_view name) {
  for (Procedure p : {Procedure::kUmbmark, Procedure::kStraight, Procedure::kSpin,
                      Procedure::kOutAndBack, Procedure::kRecorded, Procedure::kCircle}) {
    if (ToString(p) == name) return p;
  }
  return std::nullopt;
}

std::optional<Direction> ParseDirection(std::string_view name) {
  if (name == "cw") return Direction::kCw;
  if (name == "ccw") return Direction::kCcw;
  return std::nullopt;
}

std::optional<Reference> ParseReference(std::string_view name) {
  if (name == "camera") return Reference::kCamera;
  if (name == "wall") return Reference::kWall;
  return std::nullopt;
}

RunSpec RunSpec::Umbmark(Direction direction, double side_m) {
  RunSpec s;
  s.procedure = Procedure::kUmbmark;
  s.direction = direction;
  s.side_m = side_m;
  return s;
}

RunSpec RunSpec::Straight(double distance_m) {
  RunSpec s;
  s.procedure = Procedure::kStraight;
  s.distance_m = distance_m;
  return s;
}

RunSpec RunSpec::Spin(int turns, Direction direction) {
  RunSpec s;
  s.procedure = Procedure::kSpin;
  s.turns = turns;
  s.direction = direction;
  return s;
}

RunSpec RunSpec::OutAndBack(double distance_m, int repeats, Direction direction) {
  RunSpec s;
  s.procedure = Procedure::kOutAndBack;
  s.distance_m = distance_m;
  s.repeats = repeats;
  s.direction = direction;
  return s;
}

RunSpec RunSpec::Circle(double radius_m, int turns, Direction direction) {
  RunSpec s;
  s.procedure = Procedure::kCircle;
  s.radius_m = radius_m;
  s.turns = turns;
  s.direction = direction;
  return s;
}

bool RunSpec::IsValid(std::string* why) const {
  auto fail = [why](const std::string& message) {
    if (why) *why = message;
    return false;
  };
  auto positive = [](double v) { return std::isfinite(v) && v > 0.0; };
  switch (procedure) {
    case Procedure::kUmbmark:
      if (!positive(side_m)) return fail("side_mm must be a positive number");
      break;
    case Procedure::kStraight:
      // Negative: backwards (the station's default plan drives back to where it started).
      if (!std::isfinite(distance_m) || distance_m == 0.0) return fail("distance_mm must be a non-zero number");
      break;
    case Procedure::kSpin:
      if (turns <= 0) return fail("turns must be a positive integer");
      break;
    case Procedure::kOutAndBack:
      if (!positive(distance_m)) return fail("distance_mm must be a positive number");
      if (repeats <= 0) return fail("repeats must be a positive integer");
      break;
    case Procedure::kRecorded:
      break;  // no size: the ticks say where it went
    case Procedure::kCircle:
      if (!positive(radius_m)) return fail("radius_mm must be a positive number");
      if (turns <= 0) return fail("turns must be a positive integer");
      break;
  }
  if (reference == Reference::kWall && procedure != Procedure::kOutAndBack &&
      procedure != Procedure::kSpin) {
    return fail("reference: wall applies to out_and_back and spin runs only");
  }
  if (speed_m_s && !positive(*speed_m_s)) return fail("speed_mm_s must be a positive number");
  if (turn_rate_rad_s && !positive(*turn_rate_rad_s))
    return fail("turn_rate_deg_s must be a positive number");
  return true;
}

// An arc (and a turn, radius 0) rolls the axle midpoint |angle| r forward and
// the wheels b/2 either side of it: the inner wheel less, the outer more.
double Primitive::LeftTravel(double believed_track_m) const {
  if (kind == Kind::kStraight) return amount;
  return ArcLength() - amount * believed_track_m / 2.0;
}

double Primitive::RightTravel(double believed_track_m) const {
  if (kind == Kind::kStraight) return amount;
  return ArcLength() + amount * believed_track_m / 2.0;
}

std::vector<Primitive> PlanPrimitives(const RunSpec& spec) {
  const double sign = spec.direction == Direction::kCcw ? 1.0 : -1.0;
  std::vector<Primitive> plan;
  switch (spec.procedure) {
    case Procedure::kUmbmark:
      for (int leg = 0; leg < 4; ++leg) {
        plan.push_back(Primitive::Straight(spec.side_m));
        plan.push_back(Primitive::Turn(sign * M_PI / 2.0));
      }
      break;
    case Procedure::kStraight:
      plan.push_back(Primitive::Straight(spec.distance_m));
      break;
    case Procedure::kSpin:
      plan.push_back(Primitive::Turn(sign * 2.0 * M_PI * spec.turns));
      break;
    case Procedure::kOutAndBack:
      for (int i = 0; i < spec.repeats; ++i) {
        plan.push_back(Primitive::Straight(spec.distance_m));
        plan.push_back(Primitive::Turn(sign * M_PI));
        plan.push_back(Primitive::Straight(spec.distance_m));
        plan.push_back(Primitive::Turn(-sign * M_PI));
      }
      break;
    case Procedure::kRecorded:
      break;
    case Procedure::kCircle:
      plan.push_back(Primitive::Arc(sign * 2.0 * M_PI * spec.turns, spec.radius_m));
      break;
  }
  return plan;
}

Pose2 PlannedEnd(const std::vector<Primitive>& plan) {
  double x = 0.0, y = 0.0, heading = 0.0;
  for (const Primitive& p : plan) {
    // Any positive track gives the same believed path.
    AdvanceArc(p.LeftTravel(1.0), p.RightTravel(1.0), 1.0, &x, &y, &heading);
  }
  return Pose2::FromXYHeading(x, y, heading);
}

Pose2 PredictReturnError(const RunSpec& spec, const WheelScales& scales,
                         double believed_track_m) {
  const std::vector<Primitive> plan = PlanPrimitives(spec);
  double end[3];
  PredictTrueEnd(plan, scales.r_left, scales.r_right, scales.Eb, believed_track_m, end);
  const Pose2 planned = PlannedEnd(plan);
  const Pose2 true_end = Pose2::FromXYHeading(end[0], end[1], end[2]);
  // true - odometry, both in the start frame.
  return Pose2::FromXYHeading(true_end.x() - planned.x(), true_end.y() - planned.y(),
                              true_end.heading() - planned.heading());
}

}  // namespace odocal::calibration
