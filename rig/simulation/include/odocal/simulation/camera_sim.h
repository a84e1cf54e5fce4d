// The virtual camera recording a simulated session: every run rendered
// through the scenario's camera, written as H.264 video with its frame
// timestamps, and the per-frame truth beside it (for tests and benchmarks).
//
// Camera-side hidden effects act here: tag_offset (the tag sits elsewhere on
// the robot than the operator's tag spec says), camera_latency (frames are
// stamped `latency` before the telemetry clock), lens_distortion (the lens's
// k1 differs from the calibration file's), rolling_shutter (rendered as the
// camera's rolling shutter: the image rows exposed one after another).
#ifndef ODOCAL_SIMULATION_CAMERA_SIM_H_
#define ODOCAL_SIMULATION_CAMERA_SIM_H_

#include <optional>
#include <string>
#include <vector>

#include "odocal/config/scenario.h"
#include "odocal/simulation/simulation.h"
#include "odocal/vision/floor_reference.h"
#include "odocal/vision/renderer.h"

namespace odocal::simulation {

struct RecordedRun {
  std::string video;       // <run>.mp4
  std::string timestamps;  // <run>.timestamps.csv: frame,t_s (video clock)
  std::string frames;      // <run>.frames.csv: per-frame truth
  double start_s = 0.0;    // first and last timestamp (video clock)
  double end_s = 0.0;
  int frames_written = 0;
  int frames_visible = 0;  // frames where the whole tag is in the image
};

// Records every run of `result` (in parallel across cores). `progress`
// prints a line per finished run on stderr. The first run's error (the renderer's,
// the video's, the frames file's).
Status RecordRuns(const config::Scenario& scenario, const SimulationResult& result, const std::string& dir,
                  bool progress, std::vector<RecordedRun>* recorded);

// What an operator would write down for where the camera hangs: positions to
// 100 mm, yaw to 90 deg, "level" for roll and pitch.
vision::CameraMount OperatorMountGuess(const vision::CameraMount& truth);

// The scenario's floor tags as the renderer draws them (printed by the same
// printer as the robot tag: camera.tag.print_scale); none without
// camera.floor_tags. Shared by the recorded and the live virtual camera.
std::vector<vision::FloorTagPlacement> FloorTagPlacements(const config::CameraScenario& camera);

// What the operator writes down for the scenario's floor tags: each at its
// stated size, and the tape's readings between consecutive tags (and back to
// the first from the last of three or more): the true distance plus the
// tape's error, read to 0.1 mm, with the tape's sigma. `true_mm` (may be
// null) gets each reading's true distance. Shared by simulate's session.yaml
// and `station --scenario`.
vision::FloorReference TapedFloorReference(const config::CameraScenario::FloorTags& floor_tags,
                                           std::vector<double>* true_mm = nullptr);

}  // namespace odocal::simulation

#endif  // ODOCAL_SIMULATION_CAMERA_SIM_H_
