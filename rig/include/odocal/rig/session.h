// Session files: everything an operator knows about a recorded calibration
// session, and nothing more — the camera's calibration file, a rough guess of
// where the camera hangs, the tag on the robot, the robot's nominal
// parameters, and the run plan with each run's video and time span.
// Never truth: batch and measure read only this.
//
// session.yaml, millimetres and degrees, paths relative to the file:
//   camera_file: camera.yaml
//   camera_mount_guess: {x_mm, y_mm, height_mm, roll_deg, pitch_deg, yaw_deg}
//   tag: {family, id, size_mm, height_mm, offset_mm: {x, y}}
//   robot: {nominal: {left_wheel_diameter_mm, right_wheel_diameter_mm, track_mm, ticks_per_rev}}
//   runs:
//     - {name, procedure, direction, side_mm | distance_mm | turns, repeats, reference,
//        video, timestamps, telemetry, start_s, end_s}
#ifndef ODOCAL_RIG_SESSION_H_
#define ODOCAL_RIG_SESSION_H_

#include <optional>
#include <string>
#include <vector>

#include "odocal/calibration/procedures.h"
#include "odocal/calibration/robot_model.h"
#include "odocal/vision/camera_model.h"
#include "odocal/vision/tag.h"

namespace odocal::rig {

struct SessionRun {
  std::string name;
  calibration::RunSpec spec;
  std::string video;       // resolved path
  std::string timestamps;  // resolved path; empty: frame index / fps
  std::string telemetry;   // resolved path; empty when not recorded
  double start_s = 0.0;    // the run's span in video time
  double end_s = 0.0;
};

struct Session {
  std::string path;
  std::string camera_file;  // resolved path
  vision::Intrinsics intrinsics;
  vision::CameraMount camera_mount_guess;
  vision::TagSpec tag;
  calibration::WheelParams nominal;
  std::vector<SessionRun> runs;
};

std::optional<Session> LoadSession(const std::string& path, std::string* error);
// Writes `session` to `path` with paths relative to its directory, and the
// intrinsics to session.camera_file (OpenCV FileStorage YAML; camera_io.h).
std::optional<std::string> WriteSession(const Session& session, const std::string& path);

}  // namespace odocal::rig

#endif  // ODOCAL_RIG_SESSION_H_
