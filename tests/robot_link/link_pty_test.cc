// End to end over a real pseudo-terminal: the firmware library runs behind the
// pty master in its own thread, the host opens the slave path with the same
// SerialTransport it uses for /dev/ttyUSB0. Plus the failures a station meets:
// cable pulled mid-run, robot not answering, wrong path, other protocol.
#include <poll.h>
#include <unistd.h>

#include <atomic>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <ostream>
#include <string>
#include <thread>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "link_test_util.h"
#include "odocal/robot_link/client.h"
#include "odocal/robot_link/firmware_host.h"
#include "odocal/robot_link/pty.h"
#include "odocal/robot_link/serial_transport.h"
#include "odocal/test_util/test_util.h"

namespace odocal::robot_link {
namespace {

using ::testing::HasSubstr;
using namespace std::chrono_literals;

FirmwareHostOptions HostOptions(const std::string& storage_path) {
  FirmwareHostOptions o;
  o.robot.robot_name = "pty-bot";
  o.storage_path = storage_path;
  o.tick = 2ms;
  o.time_scale = 10.0;  // a 4 s square takes 0.4 s
  return o;
}

std::unique_ptr<SerialTransport> Connect(const FirmwareHost& host) {
  Result<std::unique_ptr<SerialTransport>> t = SerialTransport::Open(host.device_path());
  EXPECT_TRUE(t.ok()) << t;
  return t.ok() ? std::move(*t.value) : nullptr;
}

TEST(LinkPty, ConnectRunTelemetryPushRestartReadBack) {
  const std::string dir = test_util::MakeTempDir("odocal_link_pty_");
  const std::string storage = dir + "/robot_params.bin";
  const ParamSet pushed{72.125, 71.875, 268.25, 4000};
  FakeMotionBackend backend;
  {
    Result<std::unique_ptr<FirmwareHost>> host = FirmwareHost::Start(HostOptions(storage), backend);
    ASSERT_TRUE(host.ok()) << host;
    std::unique_ptr<SerialTransport> port = Connect(**host.value);
    ASSERT_TRUE(port);
    Client client(*port);
    Result<RobotInfo> info = client.Hello();
    ASSERT_TRUE(info.ok()) << info;
    EXPECT_EQ(info.value->robot_name, "pty-bot");
    EXPECT_EQ(info.value->boot_source, BootSource::kDefaults);
    Result<ParamSet> params = client.GetParams();
    ASSERT_TRUE(params.ok()) << params;
    EXPECT_TRUE(params.value->SameBits(RobotOptions{}.defaults));

    std::vector<TelemetrySample> telemetry;
    client.SetTelemetryCallback([&](const TelemetrySample& s) { telemetry.push_back(s); });
    ASSERT_TRUE(client.SetTelemetryRate(50).ok());
    Result<uint16_t> run = client.StartRun(RunCommand::FromRunSpec(
        calibration::RunSpec::Umbmark(calibration::Direction::kCw, 0.5)));
    ASSERT_TRUE(run.ok()) << run;
    Result<RunComplete> done = client.WaitRunComplete(*run.value, 20s);
    ASSERT_TRUE(done.ok()) << done;
    EXPECT_EQ(done.value->run_id, *run.value);
    EXPECT_EQ(done.value->status, RunStatus::kCompleted);
    // The fake backend's odometry is the plan: a closed square.
    const calibration::ReturnError odometry_error{done.value->x_mm * 1e-3, done.value->y_mm * 1e-3,
                                                  done.value->heading_rad};
    // 1e-6 mm and 1e-9 rad.
    EXPECT_THAT(odometry_error, test_util::IsNearReturnError(calibration::ReturnError{0.0, 0.0, 0.0}, 1e-6,
                                                             1e-9 * 180.0 / M_PI));
    // 4 x 0.5 m at 0.4 m/s + 4 x 90 deg at 3 rad/s = 7.1 s of robot time,
    // 50 Hz: about 350 samples; the host must have seen a healthy share.
    EXPECT_GT(telemetry.size(), 100u);
    bool went_right = false;  // cw: the second leg heads to -y
    for (const TelemetrySample& s : telemetry) {
      EXPECT_EQ(s.run_id, *run.value);
      went_right |= s.y_mm < -400.0;
    }
    EXPECT_TRUE(went_right);
    for (size_t i = 1; i < telemetry.size(); ++i) {
      EXPECT_GE(telemetry[i].t_ms, telemetry[i - 1].t_ms + 20) << "rate limit broken at " << i;
    }
    std::printf("[figures] pty run: %zu telemetry samples, end pose (%.3g mm, %.3g mm, %.3g rad) "
                "at t=%u ms\n",
                telemetry.size(), done.value->x_mm, done.value->y_mm, done.value->heading_rad,
                done.value->t_ms);

    Result<PushReport> push = client.PushParams(pushed);
    ASSERT_TRUE(push.ok()) << push;
    EXPECT_TRUE((*host.value)->active().SameBits(pushed));
  }  // the virtual robot powers off
  {
    Result<std::unique_ptr<FirmwareHost>> host = FirmwareHost::Start(HostOptions(storage), backend);
    ASSERT_TRUE(host.ok()) << host;
    std::unique_ptr<SerialTransport> port = Connect(**host.value);
    ASSERT_TRUE(port);
    Client client(*port);
    Result<RobotInfo> info = client.Hello();
    ASSERT_TRUE(info.ok()) << info;
    EXPECT_NE(info.value->boot_source, BootSource::kDefaults);
    Result<ParamSet> params = client.GetParams();
    ASSERT_TRUE(params.ok()) << params;
    EXPECT_TRUE(params.value->SameBits(pushed)) << *params.value;
    Result<ParamSet> previous = client.GetParams(OLF_SET_PREVIOUS);
    ASSERT_TRUE(previous.ok()) << previous;
    EXPECT_TRUE(previous.value->SameBits(RobotOptions{}.defaults));
  }
  std::filesystem::remove_all(dir);
}

TEST(LinkPty, StopEndsARunEarly) {
  FakeMotionBackend backend;
  Result<std::unique_ptr<FirmwareHost>> host = FirmwareHost::Start(HostOptions(""), backend);
  ASSERT_TRUE(host.ok()) << host;
  std::unique_ptr<SerialTransport> port = Connect(**host.value);
  Client client(*port);
  ASSERT_TRUE(client.Hello().ok());
  Result<uint16_t> run = client.StartRun(RunCommand::FromRunSpec(calibration::RunSpec::Straight(50.0)));
  ASSERT_TRUE(run.ok()) << run;
  ASSERT_TRUE(client.Stop().ok());
  Result<RunComplete> done = client.WaitRunComplete(*run.value, 10s);
  ASSERT_TRUE(done.ok()) << done;
  EXPECT_EQ(done.value->status, RunStatus::kStopped);
  EXPECT_LT(done.value->x_mm, 50000.0);  // 50 m would take 12 s of robot time
  EXPECT_FALSE((*host.value)->running());
}

TEST(LinkPty, CableCutMidRunIsReportedAndParametersStayPut) {
  FakeMotionBackend backend;
  Result<std::unique_ptr<FirmwareHost>> host = FirmwareHost::Start(HostOptions(""), backend);
  ASSERT_TRUE(host.ok()) << host;
  std::unique_ptr<SerialTransport> port = Connect(**host.value);
  Client client(*port);
  ASSERT_TRUE(client.Hello().ok());
  const ParamSet before = (*host.value)->active();
  Result<uint16_t> run = client.StartRun(RunCommand::FromRunSpec(calibration::RunSpec::Straight(20.0)));
  ASSERT_TRUE(run.ok()) << run;
  (*host.value)->CutCable();
  Result<RunComplete> done = client.WaitRunComplete(*run.value, 10s);
  EXPECT_EQ(done.status, StatusCode::kLineCut) << done;
  EXPECT_THAT(done.message, HasSubstr("cut"));
  EXPECT_THAT(done.message, HasSubstr((*host.value)->device_path()));
  Result<PushReport> push = client.PushParams(ParamSet{70.0, 70.0, 300.0, 2048});
  EXPECT_EQ(push.status, StatusCode::kLineCut) << push;
  EXPECT_TRUE((*host.value)->active().SameBits(before));
}

TEST(LinkPty, RobotNotAnsweringTimesOutWithAClearMessage) {
  Result<Pty> silent = OpenPty();  // nobody reads the master end
  ASSERT_TRUE(silent.ok());
  Result<std::unique_ptr<SerialTransport>> port = SerialTransport::Open(silent.value->slave_path);
  ASSERT_TRUE(port.ok()) << port;
  ClientOptions o;
  o.reply_timeout = 30ms;
  o.max_attempts = 3;
  Client client(**port.value, o);
  Result<RobotInfo> info = client.Hello();
  EXPECT_EQ(info.status, StatusCode::kTimeout);
  EXPECT_THAT(info.message, HasSubstr("robot not answering"));
  EXPECT_THAT(info.message, HasSubstr("3 attempts"));
}

TEST(LinkPty, WrongDevicePathAndNonTtyAreRefusedAtOpen) {
  Result<std::unique_ptr<SerialTransport>> missing = SerialTransport::Open("/dev/ttyUSB_odocal_missing");
  EXPECT_EQ(missing.status, StatusCode::kOpenFailed);
  EXPECT_THAT(missing.message, HasSubstr("/dev/ttyUSB_odocal_missing"));
  EXPECT_THAT(missing.message, HasSubstr("No such file or directory"));
  Result<std::unique_ptr<SerialTransport>> not_tty = SerialTransport::Open("/dev/null");
  EXPECT_EQ(not_tty.status, StatusCode::kOpenFailed);
  EXPECT_THAT(not_tty.message, HasSubstr("not a tty"));
  SerialOptions odd;
  odd.baud = 12345;
  EXPECT_EQ(SerialTransport::Open("/dev/null", odd).status, StatusCode::kInvalidArgument);
}

using testing::FakePeer;

// A peer whose answer to HELLO is wrong in one way, and how the client must
// name it.
struct WrongAnswer {
  std::string name;
  std::function<Bytes(const Frame&)> reply;
  ClientOptions options;
  StatusCode expected_status;
  std::vector<std::string> expected_words;  // each must appear in the message
};
void PrintTo(const WrongAnswer& c, std::ostream* os) { *os << c.name; }

// A client that gives up after three short waits: answers that never check
// cost it 90 ms, not the default 10 x 200 ms.
ClientOptions QuickToGiveUp() {
  ClientOptions o;
  o.reply_timeout = 30ms;
  o.max_attempts = 3;
  return o;
}

std::vector<WrongAnswer> WrongAnswers() {
  return {
      // A robot from the future: answers HELLO in its own version 2 layout.
      {"AnotherProtocolVersion",
       [](const Frame& req) { return EncodeFrame(Frame{2, OLF_MSG_ACK, req.seq, Bytes{req.type, 2, 4}}); },
       ClientOptions{},
       StatusCode::kVersionMismatch,
       {"protocol version 2", "odocal speaks version 1"}},
      // A wrong baud rate or a broken cable: bytes arrive, frames do not check.
      {"RepliesFailingTheirCrc",
       [](const Frame& req) {
         Bytes out = EncodeFrame(Frame{OLF_PROTOCOL_VERSION, OLF_MSG_ACK, req.seq, Bytes{req.type}});
         out[3] ^= 0x5a;
         return out;
       },
       QuickToGiveUp(),
       StatusCode::kCrcErrors,
       {"failed their CRC"}},
  };
}

class LinkPtyWrongAnswer : public ::testing::TestWithParam<WrongAnswer> {};

TEST_P(LinkPtyWrongAnswer, IsNamedInTheStatusAndTheMessage) {
  const WrongAnswer& c = GetParam();
  FakePeer peer(c.reply);
  Result<std::unique_ptr<SerialTransport>> port = SerialTransport::Open(peer.path());
  ASSERT_TRUE(port.ok()) << port;
  Client client(**port.value, c.options);
  Result<RobotInfo> info = client.Hello();
  EXPECT_EQ(info.status, c.expected_status);
  for (const std::string& w : c.expected_words) EXPECT_THAT(info.message, HasSubstr(w));
}

INSTANTIATE_TEST_SUITE_P(Peers, LinkPtyWrongAnswer, ::testing::ValuesIn(WrongAnswers()),
                         [](const ::testing::TestParamInfo<WrongAnswer>& info) { return info.param.name; });

}  // namespace
}  // namespace odocal::robot_link
