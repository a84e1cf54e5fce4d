// The real odocal binary against the virtual robot on a real pty:
// `odocal robot info|get|set|push|rollback --port DEV`, and its one-line
// errors with distinct exit codes.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "link_test_util.h"
#include "odocal/robot_link/firmware_host.h"
#include "odocal/test_util/test_util.h"

namespace odocal::robot_link {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;
using test_util::RunCommand;

std::string Robot(const std::string& args) { return test_util::OdocalBinary() + " robot " + args; }

int Lines(const std::string& s) { return static_cast<int>(std::count(s.begin(), s.end(), '\n')); }

class LinkCliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    FirmwareHostOptions o;
    o.robot.robot_name = "cli-bot";
    Result<std::unique_ptr<FirmwareHost>> h = FirmwareHost::Start(o, backend_);
    ASSERT_TRUE(h.ok()) << h;
    host_ = std::move(*h.value);
    port_ = " --port " + host_->device_path();
  }
  FakeMotionBackend backend_;
  std::unique_ptr<FirmwareHost> host_;
  std::string port_;
};

TEST_F(LinkCliTest, InfoGetSetPushRollback) {
  test_util::CommandResult r = RunCommand(Robot("info" + port_));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("robot: cli-bot"));
  EXPECT_THAT(r.out, HasSubstr("protocol_version: 1"));

  r = RunCommand(Robot("get" + port_));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("track_mm = 270\n"));
  EXPECT_THAT(r.out, HasSubstr("ticks_per_rev = 4096\n"));

  r = RunCommand(Robot("set" + port_ + " track_mm=275.25"));  // as push writes it
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("track_mm = 275.25\n"));
  r = RunCommand(Robot("set" + port_ + " track_mm 281.5"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("track_mm = 281.5\n"));

  r = RunCommand(Robot("push" + port_ +
                       " left_wheel_diameter_mm=72.125 right_wheel_diameter_mm=71.875"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("verified: checksum"));
  const ParamSet pushed{72.125, 71.875, 281.5, 4096};
  EXPECT_TRUE(host_->active().SameBits(pushed)) << host_->active();

  r = RunCommand(Robot("get" + port_ + " left_wheel_diameter_mm"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out, "left_wheel_diameter_mm = 72.125\n");

  r = RunCommand(Robot("rollback" + port_));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(host_->active().SameBits(ParamSet{72.0, 72.0, 281.5, 4096})) << host_->active();
}

TEST_F(LinkCliTest, BadInputIsRefusedBeforeTouchingTheRobot) {
  const ParamSet before = host_->active();
  test_util::CommandResult r = RunCommand(Robot("set" + port_ + " track_mm banana"));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_THAT(r.err, HasSubstr("bad value 'banana' for track_mm"));
  r = RunCommand(Robot("set" + port_ + " track_mm=280 281"));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_THAT(r.err, HasSubstr("not both"));
  r = RunCommand(Robot("set" + port_ + " track_mm"));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_THAT(r.err, HasSubstr("no value for 'track_mm'"));
  r = RunCommand(Robot("push" + port_ + " wheel_base=3"));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_THAT(r.err, HasSubstr("unknown parameter 'wheel_base'"));
  r = RunCommand(Robot("set" + port_ + " track_mm 0.5"));  // the robot's range check
  EXPECT_EQ(r.exit_code, 7);
  EXPECT_THAT(r.err, HasSubstr("value out of range"));
  EXPECT_TRUE(host_->active().SameBits(before));
}

TEST(LinkCliErrors, WrongDevicePath) {
  test_util::CommandResult r = RunCommand(Robot("info --port /dev/ttyUSB_odocal_missing"));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(Lines(r.err), 1) << r.err;
  EXPECT_THAT(r.err, HasSubstr("cannot open /dev/ttyUSB_odocal_missing: No such file"));
}

TEST(LinkCliErrors, RobotNotAnswering) {
  Result<Pty> silent = OpenPty();
  ASSERT_TRUE(silent.ok());
  test_util::CommandResult r = RunCommand(
      Robot("get --port " + silent.value->slave_path + " --timeout-ms 30 --attempts 2"));
  EXPECT_EQ(r.exit_code, 3);
  EXPECT_EQ(Lines(r.err), 1) << r.err;
  EXPECT_THAT(r.err, HasSubstr("robot not answering"));
}

TEST(LinkCliErrors, OtherProtocolVersion) {
  testing::FakePeer peer([](const Frame& req) {
    return EncodeFrame(Frame{3, OLF_MSG_ACK, req.seq, Bytes{req.type, 3}});
  });
  test_util::CommandResult r = RunCommand(Robot("push --port " + peer.path() + " track_mm=300"));
  EXPECT_EQ(r.exit_code, 5);
  EXPECT_EQ(Lines(r.err), 1) << r.err;
  EXPECT_THAT(r.err, HasSubstr("speaks protocol version 3"));
  EXPECT_THAT(r.out, Not(HasSubstr("verified")));
}

TEST(LinkCliErrors, CrcFailures) {
  testing::FakePeer peer([](const Frame& req) {
    Bytes out = EncodeFrame(Frame{OLF_PROTOCOL_VERSION, OLF_MSG_ACK, req.seq, Bytes{req.type}});
    out[2] ^= 0x11;
    return out;
  });
  test_util::CommandResult r =
      RunCommand(Robot("info --port " + peer.path() + " --timeout-ms 30 --attempts 2"));
  EXPECT_EQ(r.exit_code, 4);
  EXPECT_EQ(Lines(r.err), 1) << r.err;
  EXPECT_THAT(r.err, HasSubstr("failed their CRC"));
}

}  // namespace
}  // namespace odocal::robot_link
