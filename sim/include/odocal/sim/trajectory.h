// The true pose of a simulated robot at any time of a run, interpolated
// between the control-rate samples the virtual robot records (1 kHz: linear
// interpolation is exact to far below a micrometre at calibration speeds).
#ifndef ODOCAL_SIM_TRAJECTORY_H_
#define ODOCAL_SIM_TRAJECTORY_H_

#include "odocal/calibration/pose2.h"
#include "odocal/sim/virtual_robot.h"

namespace odocal::sim {

// T_world_robot at time t_s; clamped to the run's first and last sample.
calibration::Pose2 PoseAt(const RunRecord& run, double t_s);

}  // namespace odocal::sim

#endif  // ODOCAL_SIM_TRAJECTORY_H_
