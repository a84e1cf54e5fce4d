#include "odocal/sim/trajectory.h"

#include <algorithm>
#include <cassert>

namespace odocal::sim {

calibration::Pose2 PoseAt(const RunRecord& run, double t_s) {
  const std::vector<TruthSample>& samples = run.trajectory;
  assert(!samples.empty());
  if (t_s <= samples.front().t_s) return samples.front().T_world_robot;
  if (t_s >= samples.back().t_s) return samples.back().T_world_robot;
  const auto after = std::lower_bound(
      samples.begin(), samples.end(), t_s,
      [](const TruthSample& s, double t) { return s.t_s < t; });
  const TruthSample& b = *after;
  const TruthSample& a = *(after - 1);
  const double u = (t_s - a.t_s) / (b.t_s - a.t_s);
  const calibration::Pose2& pa = a.T_world_robot;
  const calibration::Pose2& pb = b.T_world_robot;
  return calibration::Pose2::FromXYHeading(
      pa.x() + u * (pb.x() - pa.x()), pa.y() + u * (pb.y() - pa.y()),
      pa.heading() + u * calibration::WrapAngle(pb.heading() - pa.heading()));
}

}  // namespace odocal::sim
