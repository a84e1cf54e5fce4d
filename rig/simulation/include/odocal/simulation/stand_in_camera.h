// A MeasuredSession — what the estimators consume — from a simulation,
// without rendering or measuring videos: a stand-in camera.
//
// The camera pipeline (measure/measure.h: videos -> tag -> camera plane ->
// poses -> rests) measures recorded sessions; this stand-in serves where a
// known truth and speed matter more than the images: `odocal explain` on an
// `odocal simulate` output directory, and the tests of the trajectory fit,
// replay and explain. It takes the telemetry as the robot sent it and makes
// camera poses from the simulator's true trajectory (30 fps, seeded
// per-frame noise, an optional home-area visibility window, and — for tests
// only — the camera-side effects a real camera would add). From truth.json
// it reads only the nominal parameters and the run plan, never `truth`, the
// true poses or any effect. It fills the same MeasuredSession as
// SessionMeasurement::ToMeasuredSession (measure.h) does.
//
// Frames: the stand-in camera measures in the simulator's world frame
// (REP-103). Units: SI inside, mm/deg in the files.
#ifndef ODOCAL_SIMULATION_STAND_IN_CAMERA_H_
#define ODOCAL_SIMULATION_STAND_IN_CAMERA_H_

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "odocal/base/status.h"
#include "odocal/base/units.h"
#include "odocal/calibration/measured_session.h"
#include "odocal/simulation/simulation.h"

namespace odocal::simulation {

struct StandInCameraOptions {
  double fps = 30.0;
  // Per-frame noise of the measured pose (white, Gaussian), also stated in
  // each CameraRecord for weighting.
  double sigma_position_m = 1e-3;
  double sigma_heading_rad = DegToRad(0.3);
  std::uint64_t seed = 1;
  // Home-area camera: frames are valid only while the robot is within this
  // radius of home_centre_m. Unset: the whole floor is seen.
  std::optional<double> home_radius_m;
  Eigen::Vector2d home_centre_m = Eigen::Vector2d::Zero();
  // Where the camera looks (the lens model needs it).
  calibration::FloorCamera camera =
      calibration::FloorCamera::Overhead(Eigen::Vector2d(1.0, 0.0), 2.5);
  // Camera-side effects of the stand-in, for tests of the explain workflow
  // (the CLI never sets them: in a simulated station a scenario's camera-side
  // effects are rendered into the video, camera_sim.h, and the camera
  // pipeline measures them).
  double tag_x_m = 0.0;  // tag centre in the robot frame; measured as if at the axle
  double tag_y_m = 0.0;
  double latency_s = 0.0;  // a frame captured at telemetry time t is stamped t - latency
  double k1_delta = 0.0;   // the lens's true k1 minus camera.distortion[0]
  double tracker_yaw_rad = 0.0;  // the tag turned on the robot: heading measured + yaw
  // A rolling shutter reading the rows top to bottom in this time: a frame
  // whose tag centre is at image row fraction f shows the pose at its
  // capture time + (f - 1/2) rolling_shutter_s (sim::RollingShutterEffect).
  double rolling_shutter_s = 0.0;
  // The image's vertical field of view: each frame's image_row_fraction is
  // the tag centre's row through a pinhole `camera` with this field (its
  // rows along the camera's y axis, the middle row on the optical axis),
  // whatever rolling_shutter_s is. The default, 85 deg, sees +/-2.3 m from
  // the default camera's 2.5 m (the explain tests' squares of 2 m both ways);
  // a tag beyond it gets a fraction outside [0, 1] and stays valid.
  double vertical_fov_rad = DegToRad(85.0);

  bool IsValid(std::string* why) const;
};

// One run as recorded by the simulator: its telemetry and its true poses
// (at any rate; interpolated to the camera's frames).
struct SimulatedRunRecord {
  std::string name;
  calibration::RunSpec spec;
  std::vector<calibration::TelemetryRecord> telemetry;
  std::vector<double> truth_t_s;
  std::vector<calibration::Pose2> truth_poses;
};

// The true pose at time t_s (robot clock), linear between the recorded
// samples with the heading unwrapped between them; the first and last pose
// outside them.
calibration::Pose2 TruthAt(const SimulatedRunRecord& run, double t_s);

// The stand-in camera looking at recorded runs.
calibration::MeasuredSession MeasureWithStandInCamera(const calibration::WheelParams& believed,
                                                      const std::vector<SimulatedRunRecord>& runs,
                                                      const StandInCameraOptions& options);

// The runs of an in-memory simulation (full control-rate trajectory).
std::vector<SimulatedRunRecord> SimulatedRunRecordsOf(const SimulationResult& result);

// From an `odocal simulate --out DIR` directory. An error of one line naming
// the file when it is missing (kNotFound) or malformed (kBadFile), or the
// options are invalid (kInvalidArgument).
Result<calibration::MeasuredSession> LoadSimulatedSession(const std::string& dir, const StandInCameraOptions& options);

}  // namespace odocal::simulation

#endif  // ODOCAL_SIMULATION_STAND_IN_CAMERA_H_
