// Pose logs as a measurement source: a tracker (OptiTrack, Vicon, a laser
// scan matcher) logged the pose of a body on the robot; with the run's
// telemetry this fills the same calibration::MeasuredRun the camera pipeline
// fills from a video (measure.h): per-frame robot poses, the rests before and
// after the run, and the return error, true - odometry in the start frame.
//
// The pose log CSV (docs/formats.md): header `t_s,x_mm,y_mm,heading_deg[,valid]`,
// one row per tracker frame, strictly increasing t_s (the tracker's clock),
// the body's pose in the tracker's world frame (REP-103: x forward, y left,
// heading CCW, degrees, not wrapped necessarily), any rate, gaps allowed
// (`valid` 0, missing rows, or NaN in a row).
//
// The robot's pose is T_world_robot = T_world_body * T_robot_body^-1, with
// T_robot_body from the session's `tracker` key (session.h).
//
// What is checked, because a tracker log is easy to get subtly wrong and a
// wrong unit gives a plausible-looking number:
//   - the file's shape (header, field counts, numbers, time order): errors
//     naming file, line and column;
//   - units: the log's path length and heading change against the ticks'
//     (nominal parameters); outside [0.5, 2] is an error naming the columns;
//   - overlap in time with the telemetry: none is an error naming both files;
//   - tracker jumps (a swapped marker): frames implying a speed above
//     max(3 x the wheels' top speed, 2 m/s), or a turn rate likewise, are
//     invalid, flag `tracker_jump:N` (the longest consistent stretch is taken
//     as the robot, and frames are checked from it forwards and backwards);
//   - the clock offset between log and telemetry, by cross-correlating the
//     heading rates; reported, flagged beyond two pose periods, never applied.
//
// Units: SI inside, mm/deg in the file.
#ifndef ODOCAL_MEASURE_POSE_LOG_H_
#define ODOCAL_MEASURE_POSE_LOG_H_

#include <optional>
#include <string>
#include <vector>

#include "odocal/base/status.h"
#include "odocal/base/units.h"
#include "odocal/calibration/measured_session.h"
#include "odocal/calibration/rest.h"
#include "odocal/config/session.h"

namespace odocal::measure {

struct PoseLogRow {
  int line = 0;  // in the file, 1-based (the header is line 1)
  double t_s = 0.0;
  calibration::Pose2 T_world_body;
  bool valid = true;
  bool nan = false;  // a NaN (or infinite) field made the frame invalid
};

// Reads a pose log. kBadFile with "FILE:LINE[:COLUMN]: what" on any malformed
// header or row, or out-of-order / duplicate timestamps; kNotFound when it
// cannot be opened.
Result<std::vector<PoseLogRow>> ReadPoseLog(const std::string& path);

// Reads a telemetry CSV: header starting `t_s,left_ticks,right_ticks`, then
// optionally `x_mm,y_mm,heading_deg` (the robot's believed odometry) and any
// further columns (ignored). Cumulative ticks, robot clock. Without the
// odometry columns the odometry is dead reckoned from the ticks with
// `nominal` along exact arcs (calibration/arc.h), starting at the origin.
// kBadFile naming file and line (kNotFound when it cannot be opened).
Result<std::vector<calibration::TelemetryRecord>> ReadTelemetryCsv(const std::string& path,
                                                                   const calibration::WheelParams& nominal);

struct PoseLogOptions {
  calibration::RestOptions rest;
  // As MeasureOptions::rest_search_fraction (measure.h).
  double rest_search_fraction = 0.35;
  // The per-frame noise stated when no rest has enough frames to measure it.
  double default_sigma_position_m = 0.5e-3;
  double default_sigma_heading_rad = DegToRad(0.1);
  // Units: the pose log's path length (heading change) over the ticks'.
  double min_unit_ratio = 0.5;
  double max_unit_ratio = 2.0;
  // The checks need this much motion by the ticks to mean anything.
  double min_path_for_unit_check_m = 0.2;
  double min_turn_for_unit_check_rad = DegToRad(30.0);
  // A tracker jump: a step implying more than max(factor x the top speed by
  // the ticks, floor).
  double jump_speed_factor = 3.0;
  double jump_speed_floor_m_s = 2.0;
  // Clock offsets searched: +- this.
  double max_clock_offset_s = 3.0;

  bool IsValid(std::string* why) const;
};

// What a pose-log run's JSON entry reports beyond the MeasuredRun.
struct PoseLogStats {
  int rows = 0;          // frames logged in the run's span
  int valid = 0;         // frames measured (valid, finite, no jump)
  int nan_rows = 0;
  int jump_frames = 0;
  double pose_period_s = 0.0;  // median
  std::optional<double> clock_offset_s;  // pose clock - telemetry clock
  double path_ratio = 0.0;     // pose log / ticks (0: not checked)
  double heading_ratio = 0.0;  // idem
};

// Measures one pose-log run: fills m->camera (the tracker's frames, robot
// poses), m->telemetry, the rests and the flags. The return error and the
// per-frame sigma are set by FinishPoseLogRuns, once the session's rests are
// pooled. kBadFile (kNotFound) naming the file on bad input.
Status MeasurePoseLogRun(const config::SessionRun& run, const config::TrackerMount& tracker,
                         const calibration::WheelParams& nominal, const PoseLogOptions& options,
                         calibration::MeasuredRun* m, PoseLogStats* stats);

// Per-frame sigma of the pose-log runs `runs` (pooled scatter about their
// rest means; the stated default and a flag `default_frame_sigma` when no
// rest has 3 frames), then each run's return error: the rests' relative pose
// minus the odometry's own relative pose over the run (true - odometry, in
// the start frame), each rest's covariance floored by sigma^2 / n.
void FinishPoseLogRuns(const PoseLogOptions& options, std::vector<calibration::MeasuredRun*> runs);

}  // namespace odocal::measure

#endif  // ODOCAL_MEASURE_POSE_LOG_H_
