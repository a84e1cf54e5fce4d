#include "odocal/simulation/sim_camera_source.h"

#include <algorithm>
#include <chrono>
#include <thread>

#include "odocal/simulation/camera_sim.h"

namespace odocal::simulation {

Result<std::unique_ptr<SimCameraSource>> SimCameraSource::Create(const config::CameraScenario& camera,
                                                                 const vision::TagSpec& tag,
                                                                 const sim::SimMotionBackend& backend) {
  using R = Result<std::unique_ptr<SimCameraSource>>;
  // The world as it is: the tag as printed, the floor tags on the floor.
  vision::TagSpec printed = tag;
  printed.size_mm *= camera.tag_print_scale;
  vision::RenderOptions render = camera.render;
  render.floor_tags = FloorTagPlacements(camera);
  vision::RendererResult r =
      vision::Renderer::Create(vision::CameraModel(camera.intrinsics, camera.mount), printed, render);
  if (!r.ok()) return R::Error(StatusCode::kInvalidArgument, "virtual camera: " + r.message);
  return R::Ok(std::unique_ptr<SimCameraSource>(new SimCameraSource(std::move(r.renderer), camera.fps, backend)));
}

Result<media::CameraFrame> SimCameraSource::Grab() {
  // A camera samples the world at its frame rate, and the world's clock is
  // the robot's: a frame is taken once that clock has moved a frame period
  // past the last frame, and shows the pose at the time it is stamped with
  // (both read together). The robot's host advances its clock in ticks of
  // tick x time_scale and skips a backlog after a stall, so a caller asking
  // faster than the clock moves waits here, as it would on a real camera.
  using Clock = std::chrono::steady_clock;
  sim::SimMotionBackend::TimedPose now = backend_.TrueTimedPose();
  if (last_t_s_) {
    const double due = *last_t_s_ + 1.0 / fps_ - 1e-9;
    const Clock::time_point give_up = Clock::now() + kMaxWait;
    while (now.t_s < due && Clock::now() < give_up) {
      std::this_thread::sleep_for(std::chrono::microseconds(200));
      now = backend_.TrueTimedPose();
    }
    // A host that stopped ticking (a test stepping the robot by hand): the
    // frame takes the next period's stamp rather than repeat one.
    now.t_s = std::max(now.t_s, *last_t_s_ + 1.0 / fps_);
  }
  last_t_s_ = now.t_s;
  vision::RenderedFrame frame = renderer_->Render(now.pose);
  return Result<media::CameraFrame>::Ok(media::CameraFrame{std::move(frame.image), now.t_s});
}

}  // namespace odocal::simulation
