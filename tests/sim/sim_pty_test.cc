// The virtual robot behind the firmware library on a real pseudo-terminal:
// a host drives a UMBMark square over the link, and the robot that moves is
// the simulator, with true parameters the host never sees.
#include <chrono>
#include <cmath>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "odocal/calibration/procedures.h"
#include "odocal/robot_link/client.h"
#include "odocal/robot_link/firmware_host.h"
#include "odocal/robot_link/serial_transport.h"
#include "odocal/sim/sim_motion_backend.h"
#include "odocal/test_util/robots.h"
#include "odocal/test_util/test_util.h"

namespace odocal::sim {
namespace {

using namespace std::chrono_literals;
using robot_link::Client;
using robot_link::FirmwareHost;
using robot_link::ParamSet;
using robot_link::RunCommand;
using robot_link::SerialTransport;

robot_link::FirmwareHostOptions HostOptions(const std::string& storage, const calibration::WheelParams& n) {
  robot_link::FirmwareHostOptions o;
  o.storage_path = storage;
  o.time_scale = 100.0;  // robot seconds per wall second
  o.robot.defaults = ParamSet{n.left_wheel_diameter_m * 1e3, n.right_wheel_diameter_m * 1e3,
                              n.track_m * 1e3, static_cast<uint32_t>(n.ticks_per_rev)};
  return o;
}

TEST(SimOverPty, HostDrivesTheSimulatedRobotAndItsParametersPersist) {
  const double Ed = 1.002, Eb = 1.01;
  const RobotConfig config = test_util::ExactRobot(Ed, Eb);
  const std::string storage = test_util::MakeTempDir("odocal_simpty_") + "/flash.bin";
  const ParamSet pushed{69.93, 70.07, 303.0, 2048};
  const calibration::WheelParams pushed_m{0.06993, 0.07007, 0.303, 2048};  // the same, in metres
  {
    SimMotionBackend backend(config);
    auto host = FirmwareHost::Start(HostOptions(storage, config.nominal), backend);
    ASSERT_TRUE(host.ok()) << host.message;
    auto port = SerialTransport::Open((*host.value)->device_path());
    ASSERT_TRUE(port.ok()) << port.message;
    Client client(**port.value);
    ASSERT_TRUE(client.Hello().ok());
    const auto params = client.GetParams();
    ASSERT_TRUE(params.ok()) << params.message;
    EXPECT_NEAR(params.value->track_mm, 300.0, 1e-9);

    std::vector<robot_link::TelemetrySample> telemetry;
    client.SetTelemetryCallback([&](const robot_link::TelemetrySample& s) { telemetry.push_back(s); });
    ASSERT_TRUE(client.SetTelemetryRate(50).ok());
    const calibration::RunSpec square = calibration::RunSpec::Umbmark(calibration::Direction::kCw, 0.5);
    const calibration::Pose2 start = backend.TruePose();
    const auto run = client.StartRun(RunCommand::FromRunSpec(square));
    ASSERT_TRUE(run.ok()) << run.message;
    const auto done = client.WaitRunComplete(*run.value, 30s);
    ASSERT_TRUE(done.ok()) << done.message;
    EXPECT_EQ(done.value->status, robot_link::RunStatus::kCompleted);
    EXPECT_GT(telemetry.size(), 10u);
    // The firmware believes it closed the square (to a tick)...
    EXPECT_LT(std::hypot(done.value->x_mm, done.value->y_mm), 0.3);
    // ...while the true robot ended where the model of the true parameters says.
    const calibration::Pose2 end_in_start = start.inverse() * backend.TruePose();
    const calibration::Pose2 predicted = calibration::PredictReturnError(
        square, calibration::WheelScalesFromFactors(Ed, Eb), 0.3);
    EXPECT_THAT(end_in_start, test_util::IsNearPose(predicted, 1e-6, 1e-6));

    const auto report = client.PushParams(pushed);
    ASSERT_TRUE(report.ok()) << report.message;
    EXPECT_THAT(backend.BelievedParams(), test_util::IsNearWheelParams(pushed_m, 1e-9))
        << "the robot uses the pushed set";
  }
  // Power off, power on: the robot boots from its storage.
  SimMotionBackend backend(config);
  auto host = FirmwareHost::Start(HostOptions(storage, config.nominal), backend);
  ASSERT_TRUE(host.ok()) << host.message;
  auto port = SerialTransport::Open((*host.value)->device_path());
  ASSERT_TRUE(port.ok());
  Client client(**port.value);
  const auto params = client.GetParams();
  ASSERT_TRUE(params.ok()) << params.message;
  EXPECT_TRUE(params.value->SameBits(pushed));
  EXPECT_THAT(backend.BelievedParams(), test_util::IsNearWheelParams(pushed_m, 1e-9));
}

}  // namespace
}  // namespace odocal::sim
