// Session files: everything an operator knows about a recorded calibration
// session, and nothing more — the camera's calibration file, a rough guess of
// where the camera hangs, the tag on the robot, the robot's nominal
// parameters, and the run plan with each run's video and time span — or,
// instead of a video, a pose log from any tracker (OptiTrack, Vicon, a laser
// scan matcher) and where the tracked body sits on the robot.
// Never truth: batch and measure read only this.
//
// session.yaml, millimetres and degrees, paths relative to the file
// (docs/formats.md):
//   camera_file: camera.yaml                      # only with video runs
//   camera_mount_guess: {x_mm, y_mm, height_mm, roll_deg, pitch_deg, yaw_deg}  # idem
//   tag: {family, id, size_mm, size_sigma_mm, height_mm, offset_mm: {x, y}}    # idem
//   floor_reference: {family, tags: [{id, size_mm}], distances: [{between: [A, B], mm, sigma_mm}],
//                     tag_height_sigma_mm}       # optional: the camera's length scale
//   tracker: {offset_mm: {x, y}, yaw_deg}         # pose runs; default zeros
//   robot: {nominal: {left_wheel_diameter_mm, right_wheel_diameter_mm, track_mm, ticks_per_rev}}
//   runs:
//     - {name, procedure, direction, side_mm | distance_mm | turns, repeats, reference,
//        video | poses, timestamps, telemetry, start_s, end_s}
//
// tracker: the tracked body's frame in the robot frame (axle midpoint,
// REP-103), T_robot_body; a pose log's T_world_body gives the robot's pose
// T_world_robot = T_world_body * T_robot_body^-1.
#ifndef ODOCAL_CONFIG_SESSION_H_
#define ODOCAL_CONFIG_SESSION_H_

#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "odocal/base/status.h"
#include "odocal/calibration/procedures.h"
#include "odocal/calibration/robot_model.h"
#include "odocal/vision/camera_model.h"
#include "odocal/vision/floor_reference.h"
#include "odocal/vision/tag.h"

namespace odocal::config {

struct SessionRun {
  std::string name;
  calibration::RunSpec spec;
  std::string video;       // resolved path; empty for a pose-log run
  std::string poses;       // resolved path of the pose log; empty for a video run
  std::string timestamps;  // resolved path; empty: frame index / fps
  std::string telemetry;   // resolved path; empty when not recorded
  double start_s = 0.0;    // the run's span in video time
  double end_s = std::numeric_limits<double>::infinity();  // unset: to the end
  // `procedure: auto`: the procedure is read from the recording (spec is
  // `recorded` until then); alone in its recording, one run per motion
  // segment found (measure/segment_runs.h).
  bool infer_procedure = false;
};

// Where the tracked body of a pose log sits on the robot: T_robot_body.
struct TrackerMount {
  double offset_x_mm = 0.0;
  double offset_y_mm = 0.0;
  double yaw_deg = 0.0;
};

struct Session {
  std::string path;
  // Whether the session names a camera (camera_file, camera_mount_guess,
  // tag): required with any video run, optional with only pose logs.
  bool has_camera = true;
  std::string camera_file;  // resolved path
  vision::Intrinsics intrinsics;
  vision::CameraMount camera_mount_guess;
  vision::TagSpec tag;
  // How well the robot tag's printed size is known (1 sigma, mm), when the
  // operator measured it; unset: MeasureOptions' print tolerance.
  std::optional<double> tag_size_sigma_mm;
  // Floor tags at measured distances: the camera's length scale without
  // trusting the robot tag's print (vision/floor_reference.h).
  std::optional<vision::FloorReference> floor_reference;
  TrackerMount tracker;
  calibration::WheelParams nominal;
  // Who and when, for the record store (docs/formats.md, "Records"): `robot.id` (a serial
  // number), `robot.odometer_km` (the distance the robot had driven), `recorded_utc` (when the
  // runs were driven, ISO 8601; empty: when they are processed).
  std::string robot_id;
  std::optional<double> odometer_km;
  std::string recorded_utc;
  std::vector<SessionRun> runs;
};

// Every file the session reads: the session file, its camera file and each run's video, pose
// log, timestamps and telemetry (each once, in that order): the session's content.
std::vector<std::string> SessionFiles(const Session& session);

// Reads a session file; kNotFound or kBadFile with one line naming the file and
// the key otherwise.
Result<Session> LoadSession(const std::string& path);
// Writes `session` to `path` with paths relative to its directory, and (with
// a camera) the intrinsics to session.camera_file (OpenCV FileStorage YAML;
// camera_file.h). `comment` lines (without '#') head the file. The camera file's or
// the session file's error (WriteCameraFile, WriteFileAtomically).
Status WriteSession(const Session& session, const std::string& path, const std::vector<std::string>& comment = {});

}  // namespace odocal::config

#endif  // ODOCAL_CONFIG_SESSION_H_
