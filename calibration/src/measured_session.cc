#include "odocal/calibration/measured_session.h"

#include <cmath>

namespace odocal::calibration {

RestScatter PooledRestScatter(const std::vector<const MeasuredRun*>& runs) {
  double sum_p = 0.0, sum_h = 0.0;
  RestScatter out;
  for (const MeasuredRun* run : runs) {
    for (const auto& rest : {run->start_rest, run->end_rest}) {
      if (!rest) continue;
      std::vector<Pose2> poses;
      for (const CameraRecord& c : run->camera)
        if (c.valid && c.t_s >= rest->t_begin_s && c.t_s <= rest->t_end_s)
          poses.push_back(c.T_world_robot);
      if (poses.size() < 3) continue;
      Eigen::Vector2d mean = Eigen::Vector2d::Zero();
      for (const Pose2& p : poses) mean += p.translation();
      mean /= static_cast<double>(poses.size());
      const double h0 = poses.front().heading();
      double mean_h = 0.0;
      for (const Pose2& p : poses) mean_h += WrapAngle(p.heading() - h0);
      mean_h /= static_cast<double>(poses.size());
      for (const Pose2& p : poses) {
        sum_p += (p.translation() - mean).squaredNorm() / 2.0;
        sum_h += std::pow(WrapAngle(p.heading() - h0) - mean_h, 2);
      }
      out.dof += static_cast<int>(poses.size()) - 1;
    }
  }
  if (out.dof > 0) {
    out.sigma_position_m = std::sqrt(sum_p / out.dof);
    out.sigma_heading_rad = std::sqrt(sum_h / out.dof);
  }
  return out;
}

}  // namespace odocal::calibration
