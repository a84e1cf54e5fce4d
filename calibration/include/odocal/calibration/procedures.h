// The calibration procedures as a robot's firmware plans them: a list of
// primitives (straight by a believed distance, turn in place by a believed
// angle), each executed until the robot's own odometry says it is done.
//
// Procedures (seeds: UMBMark tutorial; CVRA odometry calibration):
//   umbmark       square of side L; first leg along the start heading;
//                 cw turns right (-90 deg), ccw turns left (+90 deg).
//   straight      one straight of distance_m.
//   spin          `turns` full turns in place; ccw positive.
//   out_and_back  CVRA wheel-ratio path, `repeats` times: forward d,
//                 turn +180 deg, forward d, turn -180 deg (ccw; cw mirrors).
//   circle        `turns` full circles of radius radius_m, both wheels
//                 forward (ccw turns left); planned as one arc primitive.
//                 For the curvature effects (explain's arc_scale): UMBMark
//                 and CVRA have no model for it, batch leaves it out.
//   recorded      any path, driven by whoever drove it (a pose log's run):
//                 no plan is assumed, the recorded ticks drive the model.
//
// The closed-form prediction below is the model every estimator fits; the
// virtual robot (odocal::sim) integrates the same plan in time, with encoder
// quantization and noise, and is the referee for it.
#ifndef ODOCAL_CALIBRATION_PROCEDURES_H_
#define ODOCAL_CALIBRATION_PROCEDURES_H_

#include <cmath>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "odocal/calibration/arc.h"
#include "odocal/calibration/pose2.h"
#include "odocal/calibration/robot_model.h"

namespace odocal::calibration {

enum class Procedure { kUmbmark, kStraight, kSpin, kOutAndBack, kRecorded, kCircle };
enum class Direction { kCw, kCcw };
// How the end of a run is referenced: by the camera (free floor) or by
// pushing the robot flush against a wall that restores its start heading.
enum class Reference { kCamera, kWall };

std::string_view ToString(Procedure procedure);
std::string_view ToString(Direction direction);
std::string_view ToString(Reference reference);
std::optional<Procedure> ParseProcedure(std::string_view name);
std::optional<Direction> ParseDirection(std::string_view name);
std::optional<Reference> ParseReference(std::string_view name);

struct RunSpec {
  Procedure procedure = Procedure::kUmbmark;
  Direction direction = Direction::kCw;
  double side_m = 0.0;      // umbmark
  double distance_m = 0.0;  // straight, out_and_back
  int turns = 0;            // spin, circle
  double radius_m = 0.0;    // circle: of the axle midpoint's path
  int repeats = 1;          // out_and_back
  Reference reference = Reference::kCamera;
  // Per-run motion limits; unset means the robot's defaults.
  std::optional<double> speed_m_s;
  std::optional<double> turn_rate_rad_s;

  static RunSpec Umbmark(Direction direction, double side_m);
  static RunSpec Straight(double distance_m);
  static RunSpec Spin(int turns, Direction direction);
  static RunSpec OutAndBack(double distance_m, int repeats, Direction direction = Direction::kCcw);
  static RunSpec Circle(double radius_m, int turns, Direction direction);

  // `why` names the offending key as a scenario file spells it.
  bool IsValid(std::string* why) const;
};

struct Primitive {
  enum class Kind { kStraight, kTurn, kArc };
  Kind kind = Kind::kStraight;
  double amount = 0.0;  // metres (straight) or radians, CCW positive (turn, arc)
  double radius_m = 0.0;  // arc: of the axle midpoint's path, forward

  static Primitive Straight(double distance_m) { return {Kind::kStraight, distance_m}; }
  static Primitive Turn(double angle_rad) { return {Kind::kTurn, angle_rad}; }
  static Primitive Arc(double angle_rad, double radius_m) {
    return {Kind::kArc, angle_rad, radius_m};
  }
  // The arc's path length (m); 0 for the others.
  double ArcLength() const { return kind == Kind::kArc ? std::abs(amount) * radius_m : 0.0; }
  // Believed wheel travel for this primitive with the firmware's track.
  double LeftTravel(double believed_track_m) const;
  double RightTravel(double believed_track_m) const;
};

// Empty for kRecorded: its path is whatever the ticks say.
// kCircle: one arc primitive of 2 pi turns.
std::vector<Primitive> PlanPrimitives(const RunSpec& spec);

// The robot's believed end pose after the plan (what odometry aims for).
Pose2 PlannedEnd(const std::vector<Primitive>& plan);

// True end pose of `plan` in the true start frame, for a robot whose true
// wheel travel is r_left/r_right times the believed and whose true track is
// `track_ratio` times the believed `believed_track_m`. Exact (arcs), T may be
// a ceres::Jet. Output: x, y (m) and heading (rad, not wrapped).
template <typename T>
void PredictTrueEnd(const std::vector<Primitive>& plan, const T& r_left, const T& r_right,
                    const T& track_ratio, double believed_track_m, T end[3]) {
  end[0] = T(0.0);
  end[1] = T(0.0);
  end[2] = T(0.0);
  const T true_track = track_ratio * believed_track_m;
  for (const Primitive& p : plan) {
    AdvanceArc(r_left * p.LeftTravel(believed_track_m), r_right * p.RightTravel(believed_track_m),
               true_track, &end[0], &end[1], &end[2]);
  }
}

// The return error of a run, true - odometry, expressed in the start frame:
// the true end pose relative to the planned end (the two coincide for closed
// paths such as the UMBMark square).
Pose2 PredictReturnError(const RunSpec& spec, const WheelScales& scales, double believed_track_m);

}  // namespace odocal::calibration

#endif  // ODOCAL_CALIBRATION_PROCEDURES_H_
