// The OptiOdom data set as odocal sessions (`odocal import optiodom`).
//
// Converts the OptiOdom data set (Sousa, Petry, Costa et al., J. Intell.
// Robot. Syst. 2022, MIT licence) into pose-log sessions (session.h,
// docs/formats.md). Its layout:
//   diff/<category>/<set>/<set>_metadata.csv   rows `key,values...`:
//       type (diff; the data set's omni3, omni4 and tricycle sets are refused),
//       ngear, encRes (ticks per wheel turn = encRes x ngear), Li (track, m),
//       Di (right, left wheel diameters, m), N (runs), L (square side, m, or empty)
//   diff/<category>/<set>/<set>_run-NN.csv     no header, one row per 50 ms cycle:
//       time_s, x_m, y_m, theta_rad, right_ticks_this_cycle, left_ticks_this_cycle
// The motion capture is already at the robot centre and synchronised with
// the cycles, so the tracker offset is zero and the clocks are one.
//
// DIR is one set (written straight into SESSION_DIR) or any folder above
// sets (each into SESSION_DIR/<category>/<set>/). Square sets become UMBMark
// runs (side L; cw when the net heading change is negative), the others
// `recorded` runs; run names carry the category (`ivanjko_run04`).
#ifndef ODOCAL_CONFIG_OPTIODOM_H_
#define ODOCAL_CONFIG_OPTIODOM_H_

#include <filesystem>
#include <optional>
#include <string>

#include "odocal/base/status.h"

namespace odocal::config {

// Whether `dir` is one OptiOdom set (a folder <set> holding <set>_metadata.csv).
bool IsOptiodomSet(const std::filesystem::path& dir);

// The robot type the set's metadata names (`diff` when it names none, as the
// oldest sets do; also `diff` when the metadata cannot be read, so that the
// import then reports why).
std::string OptiodomRobotType(const std::filesystem::path& set_dir);

// Converts the set in `set_dir` (of `category`: square, circular, ...) into a
// pose-log session in `out_dir` (session.yaml, poses and telemetry per run,
// SOURCE.md with the attribution). The number of runs, or kBadFile with one
// line naming the file (also for a set of another robot type; kIoError when
// the output cannot be written).
Result<int> ImportOptiodomSet(const std::filesystem::path& set_dir, const std::string& category,
                              const std::filesystem::path& out_dir);

}  // namespace odocal::config

#endif  // ODOCAL_CONFIG_OPTIODOM_H_
