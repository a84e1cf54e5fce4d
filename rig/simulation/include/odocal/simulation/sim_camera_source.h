// The virtual camera live: frames rendered from the simulated robot's true
// pose as the station asks for them.
#ifndef ODOCAL_SIMULATION_SIM_CAMERA_SOURCE_H_
#define ODOCAL_SIMULATION_SIM_CAMERA_SOURCE_H_

#include <chrono>
#include <memory>
#include <optional>
#include <string>

#include "odocal/base/status.h"
#include "odocal/config/scenario.h"
#include "odocal/media/frame_source.h"
#include "odocal/sim/sim_motion_backend.h"
#include "odocal/vision/renderer.h"
#include "odocal/vision/tag.h"

namespace odocal::simulation {

// The virtual camera: renders the simulated robot's true pose when asked, at
// most at the camera's frame rate in robot time: a caller asking sooner waits
// until the robot's clock has moved a frame period (at most kMaxWait of wall
// time), and each frame is stamped with the robot time of the pose it shows.
// Frames are
// rendered without motion blur: the station averages rest frames only; the
// frames taken while moving serve tracking and the camera-plane estimate.
// `tag` is the stated tag: it is drawn as printed (camera.tag.print_scale),
// with the scenario's floor tags (camera.floor_tags) on the floor.
class SimCameraSource final : public media::FrameSource {
 public:
  // kInvalidArgument naming what the renderer refused.
  static Result<std::unique_ptr<SimCameraSource>> Create(const config::CameraScenario& camera,
                                                         const vision::TagSpec& tag,
                                                         const sim::SimMotionBackend& backend);
  // Never fails: the virtual camera always renders a frame.
  Result<media::CameraFrame> Grab() override;
  std::string Describe() const override { return "virtual camera"; }
  std::optional<double> NominalFps() const override { return fps_; }

  // The longest a Grab waits for the robot's clock (wall time).
  static constexpr std::chrono::milliseconds kMaxWait{500};

 private:
  SimCameraSource(std::unique_ptr<vision::Renderer> renderer, double fps,
                  const sim::SimMotionBackend& backend)
      : renderer_(std::move(renderer)), fps_(fps), backend_(backend) {}
  std::unique_ptr<vision::Renderer> renderer_;
  double fps_;
  const sim::SimMotionBackend& backend_;
  std::optional<double> last_t_s_;
};

}  // namespace odocal::simulation

#endif  // ODOCAL_SIMULATION_SIM_CAMERA_SOURCE_H_
