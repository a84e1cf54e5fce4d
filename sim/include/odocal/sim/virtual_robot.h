// The virtual robot: a differential-drive robot whose true wheel diameters
// and track differ from the nominal ones its firmware believes, running the
// firmware logic of a real one.
//
// Firmware logic: a run is planned as primitives (calibration::PlanPrimitives);
// each primitive is a setpoint for each wheel in encoder ticks, computed with
// the believed parameters and followed on a trapezoidal profile by an ideal
// position servo, so the robot stops where its own odometry says the primitive
// is done. Encoders count whole ticks; odometry integrates tick deltas with the
// believed parameters (midpoint rule, as firmware does). The floor moves the
// robot by the true parameters (exact arcs per control step), plus seeded
// random-walk noise on each wheel's ground travel.
//
// Frames: world and robot REP-103 (x forward, y left, z up, CCW positive).
// T_world_robot is the robot's true pose in the world. Units: SI.
#ifndef ODOCAL_SIM_VIRTUAL_ROBOT_H_
#define ODOCAL_SIM_VIRTUAL_ROBOT_H_

#include <cstdint>
#include <deque>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "odocal/calibration/pose2.h"
#include "odocal/calibration/procedures.h"
#include "odocal/calibration/robot_model.h"
#include "odocal/sim/effects.h"

namespace odocal::sim {

struct MotionLimits {
  double speed_m_s = 0.25;
  double accel_m_s2 = 0.5;
  double turn_rate_rad_s = M_PI / 3.0;  // 60 deg/s
  double turn_accel_rad_s2 = 2.0 * M_PI / 3.0;
};

struct NoiseModel {
  // Standard deviation of a wheel's accumulated ground travel after 1 m of
  // travel (random walk; grows with the square root of the distance).
  double wheel_sigma_m_per_sqrt_m = 0.0;
  // Encoders start at a random fraction of a tick instead of exactly on one.
  bool random_encoder_phase = false;
};

struct RobotConfig {
  calibration::WheelParams nominal;  // what the firmware believes at power-on
  calibration::WheelParams truth;    // what the floor answers to
  calibration::Pose2 start_pose;     // T_world_robot at power-on
  MotionLimits limits;
  NoiseModel noise;
  double control_rate_hz = 1000.0;
  double telemetry_rate_hz = 50.0;
  double rest_s = 1.0;   // standstill before and after each run
  double pause_s = 0.3;  // standstill between primitives
  std::uint64_t seed = 1;
  // Hidden effects; the robot-side ones act here (turn_slip,
  // encoder_backlash, carpet_drift), the camera-side ones in rendering.
  Effects effects;

  bool IsValid(std::string* why) const;
};

struct TelemetrySample {
  double t_s = 0.0;
  std::int64_t left_ticks = 0;
  std::int64_t right_ticks = 0;
  calibration::Pose2 odometry;  // believed pose in the run's start frame
  bool moving = false;
};

struct TruthSample {
  double t_s = 0.0;
  calibration::Pose2 T_world_robot;
};

struct RunRecord {
  calibration::RunSpec spec;
  double start_time_s = 0.0;
  double end_time_s = 0.0;
  calibration::Pose2 true_start;  // T_world_robot at the start
  calibration::Pose2 true_end;
  calibration::Pose2 odometry_end;  // the robot's belief at the end
  std::vector<TelemetrySample> telemetry;
  std::vector<TruthSample> trajectory;  // every control step

  // The true end pose in the true start frame.
  calibration::Pose2 TrueEndInStartFrame() const { return true_start.inverse() * true_end; }
};

class VirtualRobot {
 public:
  explicit VirtualRobot(const RobotConfig& config);

  // Runs a whole procedure in simulated time and returns what happened.
  RunRecord Execute(const calibration::RunSpec& spec);

  // The incremental interface, for firmware loops driven in real time.
  // StartRun resets odometry; Step advances one control period and returns
  // false once the run (with its rests) is over.
  void StartRun(const calibration::RunSpec& spec);
  bool Step();
  bool running() const { return !segments_.empty(); }
  // An immediate stop: the run ends where the robot is.
  void Stop();

  // The firmware's parameter set; a push changes what the next run believes.
  void SetBelievedParams(const calibration::WheelParams& params);
  const calibration::WheelParams& believed_params() const { return believed_; }
  const calibration::WheelParams& true_params() const { return config_.truth; }

  double time_s() const { return time_s_; }
  double control_period_s() const { return 1.0 / config_.control_rate_hz; }
  const calibration::Pose2& true_pose() const { return T_world_robot_; }
  const calibration::Pose2& odometry() const { return odometry_; }
  TelemetrySample Telemetry() const;

 private:
  struct Segment {
    enum class Kind { kRest, kPrimitive, kWallAlign };
    Kind kind = Kind::kRest;
    double duration_s = 0.0;
    // kPrimitive: believed travel of each wheel (m) and its profile.
    double left_m = 0.0;
    double right_m = 0.0;
    double lead_total = 0.0;  // |distance| or |angle| of the leading quantity
    double lead_speed = 0.0;
    double lead_accel = 0.0;
    bool is_turn = false;  // an in-place turn (turn_slip acts), else a straight or an arc
    double curvature = 0.0;  // |1/radius| of an arc primitive (arc_scale), else 0
    double elapsed_s = 0.0;
    double done_fraction = 0.0;
    // kWallAlign: the true rotation to undo (rad).
    double rotation_rad = 0.0;
  };

  static Segment MakeRest(double duration_s);
  Segment MakePrimitive(const calibration::Primitive& primitive,
                        const calibration::RunSpec& spec) const;
  // Moves the robot on the floor (with the effects that apply to `motion`)
  // and turns the encoder shafts.
  enum class Motion { kStraight, kTurn, kPushed };
  void AdvanceWheels(double true_left_m, double true_right_m, double left_ticks,
                     double right_ticks, Motion motion);
  // The robot-side hidden effects of one control step of a primitive: the
  // shaft ticks that move ground after encoder_backlash, and the true pose
  // after turn_slip and carpet_drift.
  double GroundTicks(double shaft_ticks, int* last_direction, double* dead_left);
  calibration::Pose2 MoveOnFloor(const calibration::Pose2& start, double true_left_m,
                                 double true_right_m, Motion motion) const;
  void IntegrateOdometry();

  RobotConfig config_;
  calibration::WheelParams believed_;
  std::mt19937_64 rng_;
  std::normal_distribution<double> normal_{0.0, 1.0};

  double time_s_ = 0.0;
  calibration::Pose2 T_world_robot_;
  calibration::Pose2 odometry_;
  // Encoder shafts in (continuous) ticks; the counts are their floors.
  double left_shaft_ticks_ = 0.0;
  double right_shaft_ticks_ = 0.0;
  std::int64_t left_count_ = 0;
  std::int64_t right_count_ = 0;
  bool moving_ = false;
  // encoder_backlash state per wheel: the direction the shaft last moved
  // (+1 forward; a robot starts as if it last moved forward) and the dead
  // ticks still to pass before the wheel moves again.
  int left_direction_ = 1;
  int right_direction_ = 1;
  double left_dead_ticks_ = 0.0;
  double right_dead_ticks_ = 0.0;

  calibration::RunSpec current_spec_;
  std::deque<Segment> segments_;
  calibration::Pose2 run_start_pose_;
};

}  // namespace odocal::sim

#endif  // ODOCAL_SIM_VIRTUAL_ROBOT_H_
