// The virtual camera's clock: every frame is stamped with a time the robot's
// clock really had, at least a frame period after the last frame, and shows
// the pose of that time (frames stamped ahead of the robot made explain see a
// camera latency that no camera had).
#include <atomic>
#include <chrono>
#include <cmath>
#include <fstream>
#include <memory>
#include <thread>

#include <gtest/gtest.h>

#include "odocal/config/scenario.h"
#include "odocal/sim/sim_motion_backend.h"
#include "odocal/simulation/sim_camera_source.h"
#include "odocal/test_util/test_util.h"

namespace odocal {
namespace {

config::Scenario SmallScenario() {
  const std::string dir = test_util::MakeTempDir("odocal_sim_camera_");
  std::ofstream(dir + "/scenario.yaml")
      << "seed: 3\nrobot:\n"
      << "  nominal: {left_wheel_diameter_mm: 70.0, right_wheel_diameter_mm: 70.0, track_mm: 300.0, "
         "ticks_per_rev: 2048}\n"
      << "  true: {left_wheel_diameter_mm: 70.0, right_wheel_diameter_mm: 70.0, track_mm: 300.0}\n"
      << "  start_pose: {x_mm: 0, y_mm: 0, heading_deg: 0}\n"
      << "runs:\n  - {procedure: spin, direction: ccw, turns: 1}\n"
      << "tag: {family: tag36h11, id: 5, size_mm: 80, height_mm: 150, offset_mm: {x: 0, y: 0}}\n"
      << "camera:\n  width: 320\n  height: 240\n  fx: 300\n  fy: 300\n  cx: 160\n  cy: 120\n"
      << "  pose: {x_mm: 0, y_mm: 0, height_mm: 1500, roll_deg: 0, pitch_deg: 0, yaw_deg: 0}\n"
      << "  fps: 30\n";
  const auto scenario = config::LoadScenario(dir + "/scenario.yaml");
  if (!scenario) ADD_FAILURE() << scenario.message;
  return scenario ? *scenario : config::Scenario{};
}

// The small scenario's robot and its virtual camera.
struct VirtualCamera {
  config::Scenario scenario = SmallScenario();
  std::unique_ptr<sim::SimMotionBackend> backend;
  std::unique_ptr<simulation::SimCameraSource> camera;
  std::string error;
  VirtualCamera() {
    if (!scenario.camera || !scenario.tag) return;
    backend = std::make_unique<sim::SimMotionBackend>(scenario.robot);
    auto created = simulation::SimCameraSource::Create(*scenario.camera, *scenario.tag, *backend);
    if (created) camera = std::move(*created);
    error = created.message;
  }
};

// The robot's host ticks its clock by 10 ms of robot time every 2 ms of wall
// time (5x real time), slower than the camera is asked for frames.
TEST(SimCameraSource, FramesAreStampedWithTimesTheRobotsClockHadAFramePeriodApart) {
  VirtualCamera v;
  ASSERT_TRUE(v.camera) << v.error;
  sim::SimMotionBackend& backend = *v.backend;
  auto& camera = v.camera;
  std::string error;
  std::atomic<bool> stop{false};
  std::thread host([&] {
    while (!stop) {
      backend.Idle(0.010);
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
  });
  std::vector<double> stamps;
  for (int i = 0; i < 20; ++i) {
    const auto frame = camera->Grab();
    ASSERT_TRUE(frame) << frame.message;
    const double clock_after = backend.RobotTime();
    EXPECT_LE(frame->t_s, clock_after + 1e-12) << "frame " << i << " stamped ahead of the robot's clock";
    // A reading of the clock (a multiple of its 10 ms tick), not an extrapolation.
    EXPECT_NEAR(frame->t_s / 0.010, std::round(frame->t_s / 0.010), 1e-6) << "frame " << i;
    stamps.push_back(frame->t_s);
  }
  stop = true;
  host.join();
  for (size_t i = 1; i < stamps.size(); ++i)
    EXPECT_GE(stamps[i] - stamps[i - 1], 1.0 / 30.0 - 1e-9) << "frames " << i - 1 << " and " << i;
}

// A host that does not tick (a test stepping the robot by hand): the camera
// does not hang; its frames take the next period's stamps.
TEST(SimCameraSource, AClockThatStandsStillDoesNotHangTheCamera) {
  VirtualCamera v;
  ASSERT_TRUE(v.camera) << v.error;
  auto& camera = v.camera;  // the robot (v.backend) is never stepped
  const auto first = camera->Grab();
  ASSERT_TRUE(first) << first.message;
  const auto t0 = std::chrono::steady_clock::now();
  const auto second = camera->Grab();
  ASSERT_TRUE(second) << second.message;
  EXPECT_LT(std::chrono::steady_clock::now() - t0, simulation::SimCameraSource::kMaxWait * 4);
  EXPECT_NEAR(second->t_s - first->t_s, 1.0 / 30.0, 1e-9);
}

}  // namespace
}  // namespace odocal
