#include "odocal/sim/sim_motion_backend.h"

#include "odocal/base/units.h"

namespace odocal::sim {

calibration::RunSpec RunSpecFromCommand(const robot_link::RunCommand& command) {
  calibration::RunSpec spec;
  spec.procedure = command.procedure;
  spec.direction = command.direction;
  switch (command.procedure) {
    case calibration::Procedure::kUmbmark: spec.side_m = command.amount_mm * kMmToM; break;
    case calibration::Procedure::kStraight: spec.distance_m = command.amount_mm * kMmToM; break;
    case calibration::Procedure::kSpin: spec.turns = static_cast<int>(command.count); break;
    case calibration::Procedure::kOutAndBack:
      spec.distance_m = command.amount_mm * kMmToM;
      spec.repeats = static_cast<int>(command.count);
      break;
    case calibration::Procedure::kRecorded: break;  // nothing to drive: an empty plan
    case calibration::Procedure::kCircle: break;    // not on the wire (client refuses it)
  }
  if (command.speed_mm_s > 0.0) spec.speed_m_s = command.speed_mm_s * kMmToM;
  if (command.turn_rate_deg_s > 0.0) spec.turn_rate_rad_s = DegToRad(command.turn_rate_deg_s);
  return spec;
}

SimMotionBackend::SimMotionBackend(const RobotConfig& config) : robot_(config) {}

bool SimMotionBackend::StartRun(const robot_link::RunCommand& command) {
  const calibration::RunSpec spec = RunSpecFromCommand(command);
  if (!spec.IsValid(nullptr)) return false;
  std::lock_guard<std::mutex> lock(mutex_);
  robot_.StartRun(spec);
  const TelemetrySample t = robot_.Telemetry();
  start_left_ = t.left_ticks;
  start_right_ = t.right_ticks;
  running_ = true;
  stopped_ = false;
  pending_s_ = 0.0;
  return true;
}

robot_link::StepResult SimMotionBackend::Step(double dt_s) {
  std::lock_guard<std::mutex> lock(mutex_);
  robot_link::StepResult out;
  clock_s_ += dt_s;
  if (running_ && !stopped_) {
    pending_s_ += dt_s;
    const double period = robot_.control_period_s();
    while (pending_s_ >= period && running_) {
      pending_s_ -= period;
      running_ = robot_.Step();
    }
  }
  const TelemetrySample t = robot_.Telemetry();
  out.sample.left_ticks = static_cast<int32_t>(t.left_ticks - start_left_);
  out.sample.right_ticks = static_cast<int32_t>(t.right_ticks - start_right_);
  out.sample.x_mm = t.odometry.x() * kMToMm;
  out.sample.y_mm = t.odometry.y() * kMToMm;
  out.sample.heading_rad = t.odometry.heading();
  if (stopped_) {
    out.finished = true;
    out.status = robot_link::RunStatus::kStopped;
    stopped_ = false;
  } else if (!running_) {
    out.finished = true;
    out.status = robot_link::RunStatus::kCompleted;
  }
  return out;
}

void SimMotionBackend::Stop() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!running_) return;
  robot_.Stop();
  running_ = false;
  stopped_ = true;
}

void SimMotionBackend::SetParams(const robot_link::ParamSet& params) {
  calibration::WheelParams p;
  p.left_wheel_diameter_m = params.left_wheel_diameter_mm * kMmToM;
  p.right_wheel_diameter_m = params.right_wheel_diameter_mm * kMmToM;
  p.track_m = params.track_mm * kMmToM;
  p.ticks_per_rev = params.ticks_per_rev;
  std::lock_guard<std::mutex> lock(mutex_);
  robot_.SetBelievedParams(p);
}

calibration::Pose2 SimMotionBackend::TruePose() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return robot_.true_pose();
}

double SimMotionBackend::RobotTime() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return clock_s_;
}

SimMotionBackend::TimedPose SimMotionBackend::TrueTimedPose() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return {clock_s_, robot_.true_pose()};
}

void SimMotionBackend::Idle(double dt_s) {
  std::lock_guard<std::mutex> lock(mutex_);
  clock_s_ += dt_s;
}

calibration::WheelParams SimMotionBackend::BelievedParams() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return robot_.believed_params();
}

}  // namespace odocal::sim
