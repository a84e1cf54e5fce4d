// The firmware library's protocol behaviour, through the host client over an
// in-process loopback: handshake, parameters, the atomic update and its
// refusals, rollback, idempotent retries, runs.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "link_test_util.h"
#include "odocal/robot_link/client.h"
#include "odocal/robot_link/firmware_host.h"

namespace odocal::robot_link {
namespace {

using ::testing::HasSubstr;
using testing::RawExchange;
using testing::Request;

class LinkFirmwareTest : public ::testing::Test {
 protected:
  LinkFirmwareTest() : link_(options_, backend_, &storage_), client_(link_, ClientOptionsFor()) {}
  static ClientOptions ClientOptionsFor() {
    ClientOptions o;
    o.first_seq = 100;
    return o;
  }
  ParamSet Active() { return link_.robot().active(); }

  RobotOptions options_;
  FakeMotionBackend backend_;
  MemoryStorage storage_;
  LoopbackTransport link_;
  Client client_;
};

TEST_F(LinkFirmwareTest, HelloReportsNameVersionAndTable) {
  Result<RobotInfo> info = client_.Hello();
  ASSERT_TRUE(info.ok()) << info;
  EXPECT_EQ(info.value->robot_name, "odocal-virtual");
  EXPECT_EQ(info.value->protocol_version, static_cast<int>(OLF_PROTOCOL_VERSION));
  EXPECT_EQ(info.value->param_count, 4);
  EXPECT_EQ(info.value->table_crc, ParamTableCrc());
  EXPECT_EQ(info.value->table_crc, olf_param_table_crc());  // host table == firmware table
  EXPECT_EQ(info.value->boot_source, BootSource::kDefaults);
  EXPECT_EQ(info.value->active_set_crc, options_.defaults.Checksum());
}

TEST_F(LinkFirmwareTest, ReadsEveryParameterByNameWithItsType) {
  Result<ParamSet> all = client_.GetParams();
  ASSERT_TRUE(all.ok()) << all;
  // Bitwise: the wire carries IEEE-754 bytes, so a round trip is exact.
  EXPECT_TRUE(all.value->SameBits(options_.defaults)) << *all.value;
  for (size_t i = 0; i < ParamTable().size(); ++i) {
    Result<ParamValue> v = client_.GetParam(ParamTable()[i].name);
    ASSERT_TRUE(v.ok()) << v;
    EXPECT_EQ(v.value->index(), options_.defaults.Get(i).index()) << ParamTable()[i].name;
    EXPECT_EQ(FormatValue(*v.value), FormatValue(options_.defaults.Get(i)));
  }
  Result<ParamValue> missing = client_.GetParam("wheel_base_in");
  EXPECT_EQ(missing.status, StatusCode::kNack);
  EXPECT_THAT(missing.message, HasSubstr("unknown parameter"));
}

TEST_F(LinkFirmwareTest, SetParamCommitsOneValueAndRejectsOutOfRange) {
  Result<ParamSet> set = client_.SetParam("track_mm", 281.25);
  ASSERT_TRUE(set.ok()) << set;
  ParamSet expected = options_.defaults;
  expected.track_mm = 281.25;
  EXPECT_TRUE(Active().SameBits(expected));
  EXPECT_TRUE(backend_.params().SameBits(expected));  // the motion code was told

  for (double bad : {0.0, -5.0, 1e9, std::nan("")}) {
    Result<ParamSet> r = client_.SetParam("left_wheel_diameter_mm", bad);
    EXPECT_EQ(r.status, StatusCode::kNack) << bad;
    EXPECT_THAT(r.message, HasSubstr("out of range"));
  }
  EXPECT_EQ(client_.SetParam("ticks_per_rev", 72.0).status, StatusCode::kInvalidArgument);
  EXPECT_TRUE(Active().SameBits(expected));
}

TEST_F(LinkFirmwareTest, PushVerifiesAndRollbackSwapsSets) {
  const ParamSet next{72.31, 71.87, 268.5, 4000};
  Result<PushReport> pushed = client_.PushParams(next);
  ASSERT_TRUE(pushed.ok()) << pushed;
  EXPECT_TRUE(pushed.value->active.SameBits(next));
  EXPECT_TRUE(Active().SameBits(next));
  Result<ParamSet> previous = client_.GetParams(OLF_SET_PREVIOUS);
  ASSERT_TRUE(previous.ok());
  EXPECT_TRUE(previous.value->SameBits(options_.defaults));

  Result<ParamSet> back = client_.Rollback();
  ASSERT_TRUE(back.ok()) << back;
  EXPECT_TRUE(back.value->SameBits(options_.defaults));
  EXPECT_TRUE(Active().SameBits(options_.defaults));
  Result<ParamSet> again = client_.Rollback();  // rolls the rollback back
  ASSERT_TRUE(again.ok());
  EXPECT_TRUE(Active().SameBits(next));
}

TEST_F(LinkFirmwareTest, RollbackWithoutPreviousSetIsRefused) {
  Result<ParamSet> r = client_.Rollback();
  EXPECT_EQ(r.status, StatusCode::kNack);
  EXPECT_THAT(r.message, HasSubstr("no previous"));
}

TEST_F(LinkFirmwareTest, CommitRefusesIncompleteStageAndWrongChecksum) {
  const ParamSet next{70.0, 70.5, 300.0, 2048};
  ASSERT_TRUE(RawExchange(link_, Request(OLF_MSG_STAGE_BEGIN, 1)));
  ByteWriter put;
  put.Str8("track_mm").U8(OLF_TYPE_F64).F64(next.track_mm);
  ASSERT_TRUE(RawExchange(link_, Request(OLF_MSG_STAGE_PUT, 2, put.Take())));
  std::optional<Frame> r =
      RawExchange(link_, Request(OLF_MSG_COMMIT, 3, ByteWriter().U32(next.Checksum()).Take()));
  ASSERT_TRUE(r);
  EXPECT_EQ(r->type, OLF_MSG_NACK);
  EXPECT_EQ(r->body.at(1), OLF_ERR_STAGE_INCOMPLETE);

  uint16_t seq = 4;
  for (size_t i = 0; i < ParamTable().size(); ++i) {
    ASSERT_EQ(RawExchange(link_, Request(OLF_MSG_STAGE_PUT, seq++, ParamBody(i, next.Get(i))))->type,
              OLF_MSG_ACK);
  }
  r = RawExchange(link_,
                  Request(OLF_MSG_COMMIT, seq++, ByteWriter().U32(next.Checksum() ^ 1u).Take()));
  ASSERT_TRUE(r);
  EXPECT_EQ(r->type, OLF_MSG_NACK);
  EXPECT_EQ(r->body.at(1), OLF_ERR_CHECKSUM);
  EXPECT_TRUE(Active().SameBits(options_.defaults));

  r = RawExchange(link_, Request(OLF_MSG_COMMIT, seq++, ByteWriter().U32(next.Checksum()).Take()));
  ASSERT_TRUE(r);
  EXPECT_EQ(r->type, OLF_MSG_ACK);
  EXPECT_TRUE(Active().SameBits(next));
}

TEST_F(LinkFirmwareTest, RepeatedSequenceNumberIsAnsweredFromCacheNotReExecuted) {
  const ParamSet a{70.0, 70.0, 300.0, 2048};
  ASSERT_TRUE(client_.PushParams(a).ok());
  ASSERT_TRUE(RawExchange(link_, Request(OLF_MSG_STAGE_BEGIN, 7)));
  // Stage b by hand, commit it, then retransmit the identical commit frame
  // (its reply was "lost"): a re-execution would count a second commit.
  const ParamSet b{71.0, 71.0, 301.0, 1024};
  uint16_t seq = 8;
  for (size_t i = 0; i < ParamTable().size(); ++i) {
    ASSERT_TRUE(RawExchange(link_, Request(OLF_MSG_STAGE_PUT, seq++, ParamBody(i, b.Get(i)))));
  }
  const Frame commit = Request(OLF_MSG_COMMIT, seq, ByteWriter().U32(b.Checksum()).Take());
  const uint32_t commits_before = link_.robot().ctx().counters.commits;
  std::optional<Frame> first = RawExchange(link_, commit);
  std::optional<Frame> second = RawExchange(link_, commit);
  ASSERT_TRUE(first && second);
  EXPECT_EQ(first->type, OLF_MSG_ACK);
  EXPECT_EQ(second->body, first->body);
  EXPECT_EQ(link_.robot().ctx().counters.commits, commits_before + 1);
  EXPECT_EQ(link_.robot().ctx().counters.retries_answered_from_cache, 1u);

  // Same for a run start: two identical frames, one run.
  ByteWriter run;
  run.U8(OLF_PROC_STRAIGHT).U8(OLF_DIR_CCW).F64(500.0).U32(0);
  const Frame start = Request(OLF_MSG_RUN_START, 500, run.Take());
  ASSERT_EQ(RawExchange(link_, start)->type, OLF_MSG_ACK);
  ASSERT_EQ(RawExchange(link_, start)->type, OLF_MSG_ACK);
  EXPECT_EQ(backend_.runs_started(), 1);

  // A HELLO (a new session) in between: the same frame is a new request now,
  // executed, and refused because the first run is still going.
  const uint32_t cached = link_.robot().ctx().counters.retries_answered_from_cache;
  ASSERT_EQ(RawExchange(link_, Request(OLF_MSG_HELLO, 500))->type, OLF_MSG_ACK);
  ASSERT_EQ(RawExchange(link_, Request(OLF_MSG_HELLO, 500))->type, OLF_MSG_ACK);
  std::optional<Frame> again = RawExchange(link_, start);
  ASSERT_TRUE(again);
  EXPECT_EQ(again->type, OLF_MSG_NACK);
  EXPECT_EQ(again->body.at(1), OLF_ERR_BUSY);
  EXPECT_EQ(link_.robot().ctx().counters.retries_answered_from_cache, cached);
  EXPECT_EQ(backend_.runs_started(), 1);
}

TEST_F(LinkFirmwareTest, OtherProtocolVersionIsRefusedWithTheRobotsVersion) {
  std::optional<Frame> r = RawExchange(link_, Request(OLF_MSG_HELLO, 1, {}, 2));
  ASSERT_TRUE(r);
  EXPECT_EQ(r->type, OLF_MSG_NACK);
  ASSERT_EQ(r->body.size(), 3u);
  EXPECT_EQ(r->body[1], OLF_ERR_BAD_VERSION);
  EXPECT_EQ(r->body[2], OLF_PROTOCOL_VERSION);
}

TEST_F(LinkFirmwareTest, ParametersCannotChangeDuringARun) {
  ASSERT_TRUE(client_.Hello().ok());
  Result<uint16_t> run = client_.StartRun(RunCommand::FromRunSpec(
      calibration::RunSpec::Umbmark(calibration::Direction::kCcw, 1.0)));
  ASSERT_TRUE(run.ok()) << run;
  EXPECT_EQ(client_.StartRun(RunCommand::FromRunSpec(calibration::RunSpec::Straight(1.0))).status,
            StatusCode::kNack);
  Result<PushReport> push = client_.PushParams(ParamSet{70.0, 70.0, 300.0, 2048});
  EXPECT_EQ(push.status, StatusCode::kNack);
  EXPECT_THAT(push.message, HasSubstr("run is in progress"));
  EXPECT_TRUE(Active().SameBits(options_.defaults));

  // Drive the run to its end in robot time and read the completion event.
  for (int i = 0; i < 10000 && link_.robot().running(); ++i) link_.robot().Tick(0.01);
  ASSERT_FALSE(link_.robot().running());
  Result<RunComplete> done = client_.WaitRunComplete(*run.value, std::chrono::seconds(2));
  ASSERT_TRUE(done.ok()) << done;
  EXPECT_EQ(done.value->status, RunStatus::kCompleted);
  // A closed square in perfect odometry ends where it started.
  EXPECT_NEAR(done.value->x_mm, 0.0, 1e-6);
  EXPECT_NEAR(done.value->y_mm, 0.0, 1e-6);
  EXPECT_TRUE(client_.PushParams(ParamSet{70.0, 70.0, 300.0, 2048}).ok());
}

TEST_F(LinkFirmwareTest, InvalidProceduresAreRefused) {
  RunCommand c;
  c.procedure = calibration::Procedure::kSpin;
  c.count = 0;
  Result<uint16_t> r = client_.StartRun(c);
  EXPECT_EQ(r.status, StatusCode::kNack);
  EXPECT_THAT(r.message, HasSubstr("invalid procedure"));
  c.procedure = calibration::Procedure::kUmbmark;
  c.amount_mm = std::nan("");
  EXPECT_EQ(client_.StartRun(c).status, StatusCode::kNack);
  EXPECT_EQ(backend_.runs_started(), 0);
}

TEST(LinkFirmwareStorage, FailedPersistKeepsTheOldSetInRamAndOnReboot) {
  RobotOptions options;
  FakeMotionBackend backend;
  MemoryStorage storage;
  const ParamSet a{70.0, 70.0, 300.0, 2048};
  {
    LoopbackTransport link(options, backend, &storage);
    Client client(link);
    ASSERT_TRUE(client.PushParams(a).ok());
    storage.SetPowerBudget(0);  // flash refuses every write from now on
    Result<PushReport> r = client.PushParams(ParamSet{80.0, 80.0, 310.0, 1000});
    EXPECT_EQ(r.status, StatusCode::kNack);
    EXPECT_THAT(r.message, HasSubstr("storage"));
    EXPECT_TRUE(link.robot().active().SameBits(a));
  }
  storage.SetPowerBudget(std::nullopt);
  LoopbackTransport rebooted(options, backend, &storage);
  EXPECT_TRUE(rebooted.robot().active().SameBits(a));
  EXPECT_NE(rebooted.robot().ctx().boot_source, OLF_BOOT_DEFAULTS);
}

}  // namespace
}  // namespace odocal::robot_link
