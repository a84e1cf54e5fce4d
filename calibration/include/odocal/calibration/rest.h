// Rest windows in a series of measured poses, and return errors between them.
//
// A camera measures the robot's (or its tag's) planar pose in every frame,
// with noise and gaps (tag not seen). The return error of a run is measured
// between the rest before it and the rest after it: averaging every frame of
// a rest beats any single frame by sqrt(n).
//
// A sample is at rest when every sample within +-window/2 of it lies within
// the tolerances of that window's median. A robot starting to move makes the
// samples just before it non-rest only once it has moved by a tolerance, so
// the frames averaged are those whose own pose is still at rest: the mean is
// not biased by the first millimetres of motion.
//
// Units: SI. Poses in the measurement frame (the camera's tag plane).
#ifndef ODOCAL_CALIBRATION_REST_H_
#define ODOCAL_CALIBRATION_REST_H_

#include <iosfwd>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "odocal/base/units.h"
#include "odocal/calibration/pose2.h"

namespace odocal::calibration {

struct PoseSample {
  double t_s = 0.0;
  Pose2 pose;
  bool valid = true;  // false: no measurement in this frame (tag not seen)
};

struct RestOptions {
  // Width of the neighbourhood that must be still.
  double window_s = 0.3;
  // Tolerances around the window median; zero means "from the data": 4.5
  // times the frame noise, estimated robustly from second differences,
  // floored by the minimum below.
  double position_tolerance_m = 0.0;
  double heading_tolerance_rad = 0.0;
  double min_position_tolerance_m = 0.3e-3;
  double min_heading_tolerance_rad = DegToRad(0.05);
  // A rest shorter than this is a pause, not a rest.
  double min_duration_s = 0.5;
  // A gap (invalid samples) longer than this splits a rest.
  double max_gap_s = 0.2;

  bool IsValid(std::string* why) const;
};

struct RestWindow {
  double t_begin_s = 0.0;
  double t_end_s = 0.0;
  int n = 0;
  Pose2 mean;
  // Covariance of the mean (x, y, heading), from the spread of the frames
  // divided by n. Frames are treated as independent; sensor noise is, slow
  // vibration and errors every frame shares are not (Between with a
  // SystematicFloor, below, adds a floor for the latter).
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();

  double duration_s() const { return t_end_s - t_begin_s; }
};

std::ostream& operator<<(std::ostream& os, const RestWindow& rest);

struct RestSummary {
  std::vector<RestWindow> rests;
  double position_tolerance_m = 0.0;
  double heading_tolerance_rad = 0.0;
};

RestSummary FindRests(const std::vector<PoseSample>& samples, const RestOptions& options = {});

// The mean and covariance of the valid samples, as a rest window (for
// re-measuring a rest's frames more exactly); nullopt without valid samples.
std::optional<RestWindow> SummarizeRest(const std::vector<PoseSample>& samples);

// The pose of `end` in the frame of `start` (x along the start heading), with
// its covariance propagated from both means (x, y, heading; m and rad).
struct RelativePose {
  Pose2 pose;
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  double sigma_x_m() const;
  double sigma_y_m() const;
  double sigma_heading_rad() const;
};

RelativePose Between(const RestWindow& start, const RestWindow& end);

// What the spread of a rest's frames cannot see: errors all its frames share
// (compression artefacts, detector bias), measured against rendered truth
// (docs/vision.md). Added in quadrature to a return error's covariance.
struct SystematicFloor {
  double position_m = 0.01e-3;
  double heading_rad = DegToRad(0.005);
};

// Between(start, end) with `floor` added to the covariance: the return error
// between two camera rests, as the batch and the station report it.
RelativePose Between(const RestWindow& start, const RestWindow& end, const SystematicFloor& floor);

// A return error: the true relative pose of a run minus the odometry's own
// relative pose over it, componentwise in the start frame (true - odometry,
// UMBMark's x_abs - x_calc; docs/conventions.md). For a plan that closes the
// odometry's end is the start to within a tick on the simulator, but a real
// controller stops short (the OptiOdom robot: ~5 mm and 1-2 deg). The
// odometry is taken as exact: the covariance is the truth's.
RelativePose TrueMinusOdometry(const RelativePose& truth, const Pose2& odometry);

}  // namespace odocal::calibration

#endif  // ODOCAL_CALIBRATION_REST_H_
