#include "odocal/sim/virtual_robot.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <utility>

namespace odocal::sim {
namespace {

using calibration::Pose2;
using calibration::Primitive;
using calibration::RunSpec;
using calibration::WheelParams;
using calibration::WrapAngle;

// Position along a trapezoidal (or triangular) velocity profile.
double TrapezoidPosition(double total, double speed, double accel, double t) {
  const double t_accel_full = speed / accel;
  if (total < speed * t_accel_full) {  // never reaches cruise speed
    const double t_half = std::sqrt(total / accel);
    if (t <= t_half) return 0.5 * accel * t * t;
    const double td = std::min(t, 2.0 * t_half) - t_half;
    return 0.5 * total + accel * t_half * td - 0.5 * accel * td * td;
  }
  const double d_accel = 0.5 * speed * t_accel_full;
  const double t_cruise = (total - 2.0 * d_accel) / speed;
  if (t <= t_accel_full) return 0.5 * accel * t * t;
  if (t <= t_accel_full + t_cruise) return d_accel + speed * (t - t_accel_full);
  const double td = std::min(t - t_accel_full - t_cruise, t_accel_full);
  return d_accel + speed * t_cruise + speed * td - 0.5 * accel * td * td;
}

double TrapezoidDuration(double total, double speed, double accel) {
  const double t_accel_full = speed / accel;
  if (total < speed * t_accel_full) return 2.0 * std::sqrt(total / accel);
  return 2.0 * t_accel_full + (total - speed * t_accel_full) / speed;
}

// One control step of a primitive, as the hidden wheel effects see it.
struct WheelStep {
  double left_shaft_ticks;  // each shaft's angle mid-step, in ticks
  double right_shaft_ticks;
  double curvature;  // 1/m, of the arc being driven (0: none)
  double dt_s;       // the control period
};

// The robot-side effects on a step's ground travel (m) of each wheel:
// eccentric_wheel, oval_wheel, speed_slip and arc_scale.
void ApplyWheelEffects(const RobotConfig& config, const WheelStep& step, double* true_left_m, double* true_right_m) {
  double& true_left = *true_left_m;
  double& true_right = *true_right_m;
  // eccentric_wheel (once a turn), oval_wheel (twice): the rolling radius
  // at the wheel's angle mid-step (the shaft angle; backlash is ignored here).
  for (const auto& [wheel_effect, cycles] :
       {std::pair{&config.effects.eccentric_wheel, 1.0}, std::pair{&config.effects.oval_wheel, 2.0}}) {
    if (!*wheel_effect) continue;
    const EccentricWheelEffect& e = **wheel_effect;
    const double shaft = e.left ? step.left_shaft_ticks : step.right_shaft_ticks;
    const double phi = 2.0 * M_PI * shaft / config.truth.ticks_per_rev;
    (e.left ? true_left : true_right) *= 1.0 + e.amplitude * std::sin(cycles * phi + e.phase_rad);
  }
  if (config.effects.speed_slip) {
    // speed_slip: each wheel loses k |v| of its travel.
    const double k = config.effects.speed_slip->fraction_at_1m_s;
    true_left *= 1.0 - k * std::abs(true_left) / step.dt_s;
    true_right *= 1.0 - k * std::abs(true_right) / step.dt_s;
  }
  if (config.effects.arc_scale && step.curvature != 0.0) {
    // arc_scale: on an arc both wheels lose c |kappa| of their travel.
    const double scale = 1.0 - config.effects.arc_scale->fraction_at_1_per_m * step.curvature;
    true_left *= scale;
    true_right *= scale;
  }
}

}  // namespace

bool RobotConfig::IsValid(std::string* why) const {
  auto fail = [why](const std::string& message) {
    if (why) *why = message;
    return false;
  };
  std::string inner;
  if (!nominal.IsValid(&inner)) return fail("robot.nominal." + inner);
  WheelParams truth_checked = truth;
  truth_checked.ticks_per_rev = nominal.ticks_per_rev;
  if (!truth_checked.IsValid(&inner)) return fail("robot.true." + inner);
  if (!(limits.speed_m_s > 0.0)) return fail("robot.speed_mm_s must be positive");
  if (!(limits.accel_m_s2 > 0.0)) return fail("robot.accel_mm_s2 must be positive");
  if (!(limits.turn_rate_rad_s > 0.0)) return fail("robot.turn_rate_deg_s must be positive");
  if (!(limits.turn_accel_rad_s2 > 0.0)) return fail("robot.turn_accel_deg_s2 must be positive");
  if (!(noise.wheel_sigma_m_per_sqrt_m >= 0.0))
    return fail("robot.noise.wheel_mm_per_sqrt_m must not be negative");
  if (!(control_rate_hz > 0.0)) return fail("robot.control_rate_hz must be positive");
  if (!(telemetry_rate_hz > 0.0) || telemetry_rate_hz > control_rate_hz)
    return fail("robot.telemetry_rate_hz must be positive and at most the control rate");
  if (!(rest_s >= 0.0)) return fail("robot.rest_s must not be negative");
  if (!(pause_s >= 0.0)) return fail("robot.pause_s must not be negative");
  return true;
}

VirtualRobot::VirtualRobot(const RobotConfig& config)
    : config_(config), believed_(config.nominal), rng_(config.seed) {
  if (config_.truth.ticks_per_rev <= 0) config_.truth.ticks_per_rev = config_.nominal.ticks_per_rev;
  std::string why;
  assert(config_.IsValid(&why));
  T_world_robot_ = config_.start_pose;
  if (config_.noise.random_encoder_phase) {
    std::uniform_real_distribution<double> phase(0.0, 1.0);
    left_shaft_ticks_ = phase(rng_);
    right_shaft_ticks_ = phase(rng_);
  } else {
    // Exactly between two counts: quantization is then symmetric.
    left_shaft_ticks_ = 0.5;
    right_shaft_ticks_ = 0.5;
  }
}

void VirtualRobot::SetBelievedParams(const WheelParams& params) { believed_ = params; }

VirtualRobot::Segment VirtualRobot::MakeRest(double duration_s) {
  Segment s;
  s.kind = Segment::Kind::kRest;
  s.duration_s = duration_s;
  return s;
}

VirtualRobot::Segment VirtualRobot::MakePrimitive(const Primitive& primitive,
                                                  const RunSpec& spec) const {
  Segment s;
  s.kind = Segment::Kind::kPrimitive;
  s.left_m = primitive.LeftTravel(believed_.track_m);
  s.right_m = primitive.RightTravel(believed_.track_m);
  s.lead_total = std::abs(primitive.amount);
  s.is_turn = primitive.kind == Primitive::Kind::kTurn;
  if (primitive.kind == Primitive::Kind::kArc) {
    // Led by the path length at the robot's speed: the firmware drives both
    // wheels on one profile, scaled to their shares of the arc, and stops
    // when its odometry has covered it.
    s.lead_total = primitive.ArcLength();
    s.curvature = 1.0 / primitive.radius_m;
  }
  if (primitive.kind != Primitive::Kind::kTurn) {
    s.lead_speed = spec.speed_m_s.value_or(config_.limits.speed_m_s);
    s.lead_accel = config_.limits.accel_m_s2;
  } else {
    s.lead_speed = spec.turn_rate_rad_s.value_or(config_.limits.turn_rate_rad_s);
    s.lead_accel = config_.limits.turn_accel_rad_s2;
  }
  s.duration_s = TrapezoidDuration(s.lead_total, s.lead_speed, s.lead_accel);
  return s;
}

void VirtualRobot::StartRun(const RunSpec& spec) {
  current_spec_ = spec;
  segments_.clear();
  odometry_ = Pose2::Identity();
  run_start_pose_ = T_world_robot_;
  segments_.push_back(MakeRest(config_.rest_s));
  const std::vector<Primitive> plan = calibration::PlanPrimitives(spec);
  for (size_t i = 0; i < plan.size(); ++i) {
    if (i > 0) segments_.push_back(MakeRest(config_.pause_s));
    segments_.push_back(MakePrimitive(plan[i], spec));
  }
  if (spec.reference == calibration::Reference::kWall) {
    Segment wall;
    wall.kind = Segment::Kind::kWallAlign;
    segments_.push_back(MakeRest(config_.pause_s));
    segments_.push_back(wall);  // its rotation is known only when it starts
  }
  segments_.push_back(MakeRest(config_.rest_s));
}

void VirtualRobot::Stop() {
  segments_.clear();
  moving_ = false;
}

double VirtualRobot::GroundTicks(double shaft_ticks, int* last_direction, double* dead_left) {
  if (shaft_ticks == 0.0) return 0.0;
  const int direction = shaft_ticks > 0.0 ? 1 : -1;
  if (direction != *last_direction) {
    // The shaft reversed: the gear lash must be taken up before the wheel
    // follows. The encoder (on the motor shaft) counts all of it.
    *last_direction = direction;
    *dead_left = config_.effects.encoder_backlash ? config_.effects.encoder_backlash->ticks : 0.0;
  }
  const double consumed = std::min(std::abs(shaft_ticks), *dead_left);
  *dead_left -= consumed;
  return shaft_ticks - direction * consumed;
}

Pose2 VirtualRobot::MoveOnFloor(const Pose2& start, double true_left_m, double true_right_m,
                                Motion motion) const {
  const double track = config_.truth.track_m;
  double left = true_left_m, right = true_right_m;
  if (motion == Motion::kTurn && config_.effects.turn_slip) {
    // turn_slip: the rotation is (1 - f |omega|) of what the wheels imply, omega
    // being the wheel-implied rate of this control step; the (tiny) forward
    // travel of an in-place turn is kept.
    const double ds = 0.5 * (left + right);
    const double dtheta = (right - left) / track;
    const double omega = std::abs(dtheta) / control_period_s();
    const double achieved = dtheta * (1.0 - config_.effects.turn_slip->fraction_at_1rad_s * omega);
    left = ds - 0.5 * achieved * track;
    right = ds + 0.5 * achieved * track;
  }
  Pose2 end = calibration::ArcStep(start, left, right, track);
  if (motion == Motion::kStraight && config_.effects.carpet_drift) {
    // carpet_drift: to the robot's left by rate * cos(heading - grain) per
    // metre travelled forward (backwards travel drifts the other way).
    const CarpetDriftEffect& drift = *config_.effects.carpet_drift;
    const double ds = 0.5 * (left + right);
    const double mid = start.heading() + 0.5 * WrapAngle(end.heading() - start.heading());
    const double lateral = drift.rate_m_per_m * std::cos(mid - drift.grain_rad) * ds;
    end = Pose2::FromXYHeading(end.x() - lateral * std::sin(mid), end.y() + lateral * std::cos(mid),
                               end.heading());
  }
  return end;
}

void VirtualRobot::AdvanceWheels(double true_left_m, double true_right_m, double left_ticks,
                                 double right_ticks, Motion motion) {
  T_world_robot_ = MoveOnFloor(T_world_robot_, true_left_m, true_right_m, motion);
  left_shaft_ticks_ += left_ticks;
  right_shaft_ticks_ += right_ticks;
  IntegrateOdometry();
}

void VirtualRobot::IntegrateOdometry() {
  const std::int64_t left = static_cast<std::int64_t>(std::floor(left_shaft_ticks_));
  const std::int64_t right = static_cast<std::int64_t>(std::floor(right_shaft_ticks_));
  const double dl = (left - left_count_) * believed_.LeftMetresPerTick();
  const double dr = (right - right_count_) * believed_.RightMetresPerTick();
  left_count_ = left;
  right_count_ = right;
  if (dl == 0.0 && dr == 0.0) return;
  // The midpoint rule most firmware uses; its error is third order in the
  // heading step, far below a tick at control rate.
  const double ds = 0.5 * (dl + dr);
  const double dtheta = (dr - dl) / believed_.track_m;
  const double mid = odometry_.heading() + 0.5 * dtheta;
  odometry_ = Pose2::FromXYHeading(odometry_.x() + ds * std::cos(mid),
                                   odometry_.y() + ds * std::sin(mid),
                                   odometry_.heading() + dtheta);
}

bool VirtualRobot::Step() {
  if (segments_.empty()) return false;
  const double dt = control_period_s();
  time_s_ += dt;
  Segment& seg = segments_.front();
  const double true_left_per_tick = M_PI * config_.truth.left_wheel_diameter_m /
                                    config_.truth.ticks_per_rev;
  const double true_right_per_tick = M_PI * config_.truth.right_wheel_diameter_m /
                                     config_.truth.ticks_per_rev;
  switch (seg.kind) {
    case Segment::Kind::kRest:
      moving_ = false;
      seg.elapsed_s += dt;
      break;
    case Segment::Kind::kPrimitive: {
      moving_ = true;
      seg.elapsed_s = std::min(seg.elapsed_s + dt, seg.duration_s);
      const double fraction =
          seg.elapsed_s >= seg.duration_s
              ? 1.0
              : TrapezoidPosition(seg.lead_total, seg.lead_speed, seg.lead_accel, seg.elapsed_s) /
                    seg.lead_total;
      const double df = fraction - seg.done_fraction;
      seg.done_fraction = fraction;
      // The servo turns each shaft by its setpoint increment, in ticks.
      const double left_ticks = df * seg.left_m / believed_.LeftMetresPerTick();
      const double right_ticks = df * seg.right_m / believed_.RightMetresPerTick();
      // encoder_backlash: only the shaft motion past the lash moves the wheel.
      double true_left = GroundTicks(left_ticks, &left_direction_, &left_dead_ticks_) *
                         true_left_per_tick;
      double true_right = GroundTicks(right_ticks, &right_direction_, &right_dead_ticks_) *
                          true_right_per_tick;
      const WheelStep step{left_shaft_ticks_ + 0.5 * left_ticks, right_shaft_ticks_ + 0.5 * right_ticks, seg.curvature,
                           dt};
      ApplyWheelEffects(config_, step, &true_left, &true_right);
      const double sigma = config_.noise.wheel_sigma_m_per_sqrt_m;
      if (sigma > 0.0) {
        true_left += sigma * std::sqrt(std::abs(true_left)) * normal_(rng_);
        true_right += sigma * std::sqrt(std::abs(true_right)) * normal_(rng_);
      }
      AdvanceWheels(true_left, true_right, left_ticks, right_ticks,
                    seg.is_turn ? Motion::kTurn : Motion::kStraight);
      break;
    }
    case Segment::Kind::kWallAlign: {
      moving_ = true;
      if (seg.duration_s == 0.0) {
        // Pushed flush: the wall turns the robot back to its start heading.
        seg.rotation_rad =
            calibration::WrapAngle(T_world_robot_.heading() - run_start_pose_.heading());
        seg.duration_s = std::max(dt, std::abs(seg.rotation_rad) / config_.limits.turn_rate_rad_s);
      }
      const double step_fraction = std::min(dt, seg.duration_s - seg.elapsed_s) / seg.duration_s;
      seg.elapsed_s += dt;
      // The wheels roll with the rotation; the encoders count it.
      const double arc = seg.rotation_rad * step_fraction * config_.truth.track_m / 2.0;
      AdvanceWheels(arc, -arc, arc / true_left_per_tick, -arc / true_right_per_tick,
                    Motion::kPushed);
      break;
    }
  }
  if (seg.elapsed_s >= seg.duration_s - 1e-12) segments_.pop_front();
  if (segments_.empty()) moving_ = false;
  return !segments_.empty();
}

TelemetrySample VirtualRobot::Telemetry() const {
  TelemetrySample s;
  s.t_s = time_s_;
  s.left_ticks = left_count_;
  s.right_ticks = right_count_;
  s.odometry = odometry_;
  s.moving = moving_;
  return s;
}

RunRecord VirtualRobot::Execute(const RunSpec& spec) {
  RunRecord record;
  record.spec = spec;
  StartRun(spec);
  record.start_time_s = time_s_;
  record.true_start = T_world_robot_;
  const double telemetry_period = 1.0 / config_.telemetry_rate_hz;
  double next_telemetry = time_s_;
  auto sample = [&]() {
    record.trajectory.push_back({time_s_, T_world_robot_});
    if (time_s_ >= next_telemetry - 1e-9) {
      record.telemetry.push_back(Telemetry());
      next_telemetry += telemetry_period;
    }
  };
  sample();
  while (Step()) sample();
  sample();
  record.end_time_s = time_s_;
  record.true_end = T_world_robot_;
  record.odometry_end = odometry_;
  return record;
}

}  // namespace odocal::sim
