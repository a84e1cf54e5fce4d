#include "odocal/simulation/sim_camera_source.h"

#include <algorithm>

#include "odocal/simulation/camera_sim.h"

namespace odocal::simulation {

std::unique_ptr<SimCameraSource> SimCameraSource::Create(const config::CameraScenario& camera,
                                                         const vision::TagSpec& tag,
                                                         const sim::SimMotionBackend& backend,
                                                         std::string* error) {
  // The world as it is: the tag as printed, the floor tags on the floor.
  vision::TagSpec printed = tag;
  printed.size_mm *= camera.tag_print_scale;
  vision::RenderOptions render = camera.render;
  render.floor_tags = FloorTagPlacements(camera);
  vision::RendererResult r =
      vision::Renderer::Create(vision::CameraModel(camera.intrinsics, camera.mount), printed, render);
  if (!r.ok) {
    if (error) *error = "virtual camera: " + r.message;
    return nullptr;
  }
  return std::unique_ptr<SimCameraSource>(new SimCameraSource(std::move(r.renderer), camera.fps, backend));
}

std::optional<media::CameraFrame> SimCameraSource::Grab(std::string*) {
  double t = backend_.RobotTime();
  if (last_t_s_) t = std::max(t, *last_t_s_ + 1.0 / fps_);
  last_t_s_ = t;
  vision::RenderedFrame frame = renderer_->Render(backend_.TruePose());
  return media::CameraFrame{std::move(frame.image), t};
}

}  // namespace odocal::simulation
