// Scenario files: the virtual world a simulation runs in (robot with nominal
// and true parameters, the run plan, hidden effects). YAML, millimetres and
// degrees at the edge; parsed here into typed sim/calibration options.
//
// Parsing is strict: an unknown key, a missing required key, a value of the
// wrong type or out of range is an error that names the file, the line and
// the key path (e.g. `S.yaml:12: runs[1].procedure: unknown procedure 'spiral'`).
#ifndef ODOCAL_CONFIG_SCENARIO_H_
#define ODOCAL_CONFIG_SCENARIO_H_

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "odocal/base/status.h"
#include "odocal/calibration/procedures.h"
#include "odocal/sim/virtual_robot.h"
#include "odocal/vision/camera_model.h"
#include "odocal/vision/renderer.h"
#include "odocal/vision/tag.h"

namespace odocal::config {

// The virtual camera of a scenario: what the camera is (intrinsics, its true
// pose over the floor) and how it records (frame rate, exposure, noise, blur,
// H.264 quality).
struct CameraScenario {
  vision::Intrinsics intrinsics;
  vision::CameraMount mount;
  double fps = 30.0;
  vision::RenderOptions render;  // noise, blur, exposure; seeded from the scenario
  // How the video is stored: x264 at this CRF (0 lossless), preset and key
  // frame interval. A camera without a codec of its own (no `crf`, `codec`
  // or `profile`) is stored every frame intra-coded at CRF 18 with the
  // ultrafast preset: its artefacts are then independent from frame to frame
  // and a rest's mean is within 0.010 mm / 0.009 deg of the lossless one, at
  // a sixth of the bytes and a sixth of the coding time of inter-coded CRF 6
  // (bench/codec, docs/vision.md "The codec of simulate"). A camera that
  // records H.264 itself (`crf: N`, `codec: {h264: N}`, a profile) is
  // inter-coded as such a camera would (veryfast, x264's key frame interval).
  int crf = 18;
  std::string x264_preset = "ultrafast";
  int keyint = 1;  // 0: x264's default (250)
  // The tag as printed is tag_print_scale x the size the operator states
  // (tag.size_mm): the renderer draws the printed one, the session file keeps
  // the stated one (`camera.tag.print_scale`).
  double tag_print_scale = 1.0;
  // Tags lying on the floor, a length reference (`camera.floor_tags`):
  // printed by the same printer (tag_print_scale), measured with a tape
  // whose reading between consecutive tags is off by tape_error_mm; the
  // session file gets the tape's readings with tape_sigma_mm.
  struct FloorTags {
    std::string family = "tag36h11";
    double size_mm = 80.0;  // as stated
    struct Tag {
      int id = 0;
      double x_mm = 0.0, y_mm = 0.0, yaw_deg = 0.0;
    };
    std::vector<Tag> tags;
    double tape_sigma_mm = 0.3;
    double tape_error_mm = 0.0;
  };
  std::optional<FloorTags> floor_tags;
  // Every run in one continuous video (`camera.one_video: true`), as a
  // camera left recording through a whole plan: the session file then names
  // that video for every run and no start_s/end_s, and batch finds the runs
  // in it (measure/segment_runs.h).
  bool one_video = false;
};

struct Scenario {
  std::string path;
  std::uint64_t seed = 1;
  sim::RobotConfig robot;
  std::vector<calibration::RunSpec> runs;
  // Both present, or both absent: without them, simulate writes no video.
  std::optional<vision::TagSpec> tag;
  std::optional<CameraScenario> camera;
};

// kNotFound or kBadFile, with one line naming the file (and key), when the file
// is missing or malformed.
Result<Scenario> LoadScenario(const std::string& path);

// A stable name for the i-th run (0-based): "run01_umbmark_cw".
std::string RunName(int index, const calibration::RunSpec& spec);

}  // namespace odocal::config

#endif  // ODOCAL_CONFIG_SCENARIO_H_
