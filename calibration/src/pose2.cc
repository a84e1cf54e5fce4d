#include "odocal/calibration/pose2.h"

#include <cmath>
#include <ostream>

#include "odocal/base/units.h"
#include "odocal/calibration/arc.h"

namespace odocal::calibration {

double WrapAngle(double angle_rad) {
  double wrapped = std::remainder(angle_rad, 2.0 * M_PI);  // in [-pi, pi]
  if (wrapped <= -M_PI) wrapped += 2.0 * M_PI;
  return wrapped;
}

Pose2::Pose2(double x_m, double y_m, double heading_rad)
    : x_m_(x_m), y_m_(y_m), heading_rad_(WrapAngle(heading_rad)) {}

Pose2 Pose2::inverse() const {
  const double c = std::cos(heading_rad_);
  const double s = std::sin(heading_rad_);
  return Pose2(-c * x_m_ - s * y_m_, s * x_m_ - c * y_m_, -heading_rad_);
}

Pose2 Pose2::operator*(const Pose2& rhs) const {
  const Eigen::Vector2d t = *this * rhs.translation();
  return Pose2(t.x(), t.y(), heading_rad_ + rhs.heading_rad_);
}

Eigen::Vector2d Pose2::operator*(const Eigen::Vector2d& p) const {
  const double c = std::cos(heading_rad_);
  const double s = std::sin(heading_rad_);
  return {x_m_ + c * p.x() - s * p.y(), y_m_ + s * p.x() + c * p.y()};
}

std::ostream& operator<<(std::ostream& os, const Pose2& pose) {
  return os << "Pose2(x=" << pose.x() * kMToMm << " mm, y=" << pose.y() * kMToMm
            << " mm, heading=" << RadToDeg(pose.heading()) << " deg)";
}

Pose2 ArcStep(const Pose2& start, double left_m, double right_m, double track_m) {
  double x = start.x(), y = start.y(), heading = start.heading();
  AdvanceArc(left_m, right_m, track_m, &x, &y, &heading);
  return Pose2::FromXYHeading(x, y, heading);
}

}  // namespace odocal::calibration
