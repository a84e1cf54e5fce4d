// What was recorded of a calibration session, as estimators see it: for each
// run, the robot's telemetry (robot clock) and the camera's measured poses
// (video clock, as stamped), the rests before and after, and the return error.
// Pure data: produced by rig/ from videos and telemetry files, or by tests
// from the simulator; consumed by the estimators (UMBMark, CVRA, trajectory
// least squares, explain). Nothing here is truth.
//
// Frames: the camera's measurement frame is the tag plane's world frame
// (REP-103); poses are of the robot (axle midpoint), computed from the tag
// with the operator's tag offset. Units: SI.
#ifndef ODOCAL_CALIBRATION_MEASURED_SESSION_H_
#define ODOCAL_CALIBRATION_MEASURED_SESSION_H_

#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "odocal/calibration/floor_camera.h"
#include "odocal/calibration/pose2.h"
#include "odocal/calibration/procedures.h"
#include "odocal/calibration/rest.h"
#include "odocal/calibration/robot_model.h"
#include "odocal/calibration/run_flag.h"

namespace odocal::calibration {

struct TelemetryRecord {
  double t_s = 0.0;  // robot clock
  std::int64_t left_ticks = 0;
  std::int64_t right_ticks = 0;
  Pose2 odometry;  // the robot's belief, in the run's start frame
};

struct CameraRecord {
  double t_s = 0.0;  // video timestamp
  bool valid = false;  // the tag was measured in this frame
  Pose2 T_world_robot;
  // Per-frame standard deviations of the measurement (from the detector's
  // corner noise), for weighting.
  double sigma_position_m = 0.0;
  double sigma_heading_rad = 0.0;
  // The image row of the tag's centre as a fraction of the image, v / (H - 1)
  // in [0, 1] (0: the top row), for the rolling_shutter candidate: a rolling
  // shutter exposes that row at the stamp + (fraction - 1/2) * readout. NaN
  // when unknown (pose logs): such a frame feels no rolling shutter.
  double image_row_fraction = std::numeric_limits<double>::quiet_NaN();
  bool has_image_row() const { return !std::isnan(image_row_fraction); }
};

struct MeasuredRun {
  std::string name;
  RunSpec spec;
  std::vector<TelemetryRecord> telemetry;
  std::vector<CameraRecord> camera;
  std::optional<RestWindow> start_rest;
  std::optional<RestWindow> end_rest;
  // true - odometry in the start frame (the rests' relative pose, with the
  // odometry's own end belief removed), when both rests were measured.
  std::optional<RelativePose> return_error;
  // Why a number is missing or doubtful (run_flag.h): "no_start_rest",
  // "tag_out_of_view_mid_run:1.2s", ...; a fatal one leaves no usable return error.
  std::vector<RunFlag> flags;
};

struct MeasuredSession {
  WheelParams believed;  // the parameters the robot's firmware used
  // The camera's geometry over the tag plane, when known (the lens candidate needs it).
  std::optional<FloorCamera> camera;
  // Relative 1-sigma of the camera's length scale: every distance it
  // measures is (1 + e) times the truth, e common to the session (the tag's
  // printed size, the camera height estimated from the tag's apparent
  // size). Ed and the turn gain Eb/Es do not feel it; Es and Eb do, 1:1.
  double camera_scale_sigma = 0.0;
  std::vector<MeasuredRun> runs;
};

// One frame's pose noise, measured where the truth is constant: the scatter
// of the valid frames of each run's start and end rest about that rest's
// mean, pooled (rests of fewer than 3 valid frames are skipped). Position
// per axis; heading about a circular reference.
struct RestScatter {
  double sigma_position_m = 0.0;
  double sigma_heading_rad = 0.0;
  int dof = 0;  // pooled degrees of freedom; 0: nothing measured
};
RestScatter PooledRestScatter(const std::vector<const MeasuredRun*>& runs);

}  // namespace odocal::calibration

#endif  // ODOCAL_CALIBRATION_MEASURED_SESSION_H_
