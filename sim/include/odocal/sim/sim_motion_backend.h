// The virtual robot behind the firmware library: implements robot_link's
// MotionBackend with sim::VirtualRobot, so a host talking to the pty drives
// the same firmware logic (plan, encoders, odometry with the believed
// parameters) as every estimator test, with true parameters it cannot see.
//
// Units at this boundary: millimetres and radians (the link's); SI inside.
#ifndef ODOCAL_SIM_SIM_MOTION_BACKEND_H_
#define ODOCAL_SIM_SIM_MOTION_BACKEND_H_

#include <mutex>

#include "odocal/robot_link/firmware_host.h"
#include "odocal/sim/virtual_robot.h"

namespace odocal::sim {

class SimMotionBackend final : public robot_link::MotionBackend {
 public:
  explicit SimMotionBackend(const RobotConfig& config);

  bool StartRun(const robot_link::RunCommand& command) override;
  robot_link::StepResult Step(double dt_s) override;
  void Stop() override;
  void SetParams(const robot_link::ParamSet& params) override;
  void Idle(double dt_s) override;

  // Thread-safe views for the virtual camera and tests (truth).
  calibration::Pose2 TruePose() const;
  // The robot's clock: every dt the host stepped or idled by, the clock its
  // telemetry is stamped with (the virtual camera stamps frames with it).
  double RobotTime() const;
  // The true pose and the robot's clock read together (a frame shows the
  // pose at the time it is stamped with).
  struct TimedPose {
    double t_s = 0.0;
    calibration::Pose2 pose;
  };
  TimedPose TrueTimedPose() const;
  calibration::WheelParams BelievedParams() const;

 private:
  mutable std::mutex mutex_;
  VirtualRobot robot_;
  bool running_ = false;
  bool stopped_ = false;
  double pending_s_ = 0.0;
  double clock_s_ = 0.0;
  std::int64_t start_left_ = 0;
  std::int64_t start_right_ = 0;
};

// The RunSpec a link command asks for (the inverse of RunCommand::FromRunSpec).
calibration::RunSpec RunSpecFromCommand(const robot_link::RunCommand& command);

}  // namespace odocal::sim

#endif  // ODOCAL_SIM_SIM_MOTION_BACKEND_H_
