// Pose2: a rigid transform of the plane, SE(2).
//
// Frames follow REP-103: x forward, y left, headings counter-clockwise positive.
// Units are SI inside odocal: metres and radians.
//
// A Pose2 is named for what it maps: T_world_robot is the robot's pose in the
// world frame, so p_world = T_world_robot * p_robot and
// T_world_tag = T_world_robot * T_robot_tag.
#ifndef ODOCAL_CALIBRATION_POSE2_H_
#define ODOCAL_CALIBRATION_POSE2_H_

#include <iosfwd>

#include <Eigen/Core>

namespace odocal::calibration {

// Wraps an angle to (-pi, pi].
double WrapAngle(double angle_rad);

class Pose2 {
 public:
  Pose2() = default;
  static Pose2 Identity() { return Pose2(); }
  static Pose2 FromXYHeading(double x_m, double y_m, double heading_rad) {
    return Pose2(x_m, y_m, heading_rad);
  }

  double x() const { return x_m_; }
  double y() const { return y_m_; }
  // Always wrapped to (-pi, pi].
  double heading() const { return heading_rad_; }
  Eigen::Vector2d translation() const { return {x_m_, y_m_}; }

  Pose2 inverse() const;
  Pose2 operator*(const Pose2& rhs) const;
  Eigen::Vector2d operator*(const Eigen::Vector2d& p) const;

 private:
  Pose2(double x_m, double y_m, double heading_rad);
  double x_m_ = 0.0;
  double y_m_ = 0.0;
  double heading_rad_ = 0.0;
};

std::ostream& operator<<(std::ostream& os, const Pose2& pose);

// The pose reached from `start` after an exact arc on which the left and right
// wheels roll `left_m` and `right_m` on a track `track_m` (constant curvature,
// which holds whenever both wheels follow proportional profiles).
Pose2 ArcStep(const Pose2& start, double left_m, double right_m, double track_m);

}  // namespace odocal::calibration

#endif  // ODOCAL_CALIBRATION_POSE2_H_
