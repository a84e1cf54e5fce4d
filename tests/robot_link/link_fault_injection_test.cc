// Pushes over a damaged line. The claims under test: every push ends either
// verified or reported failed, a push reported verified really is on the
// robot, and the robot never holds anything but its previous set or the
// target — in RAM and in what it boots from.
#include <chrono>
#include <cstdio>
#include <ostream>
#include <random>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "link_test_util.h"
#include "odocal/robot_link/client.h"
#include "odocal/robot_link/fault_injection.h"
#include "odocal/robot_link/firmware_host.h"

namespace odocal::robot_link {
namespace {

struct Tally {
  int pushes = 0;
  int verified = 0;
  int reported_failed = 0;
  int failed_robot_kept_old = 0;
  int failed_robot_has_new = 0;  // commit landed, its confirmation did not
  int wrong_or_mixed = 0;        // must stay 0
  int verified_but_not_on_robot = 0;  // must stay 0
  int boot_differs_from_ram = 0;      // must stay 0
};

Tally PushMany(int pushes, const FaultOptions& faults, uint32_t seed) {
  RobotOptions options;
  FakeMotionBackend backend;
  MemoryStorage storage;
  LoopbackTransport link(options, backend, &storage);
  FaultInjectingTransport line(link, faults);
  ClientOptions client_options;
  client_options.first_seq = 1;
  Client client(line, client_options);
  std::mt19937 rng(seed);
  Tally t;
  for (int i = 0; i < pushes; ++i) {
    const ParamSet before = link.robot().active();
    const ParamSet target = testing::RandomParamSet(rng);
    Result<PushReport> r = client.PushParams(target);
    const ParamSet after = link.robot().active();
    ++t.pushes;
    const bool is_old = after.SameBits(before);
    const bool is_new = after.SameBits(target);
    if (!is_old && !is_new) ++t.wrong_or_mixed;
    if (r.ok()) {
      ++t.verified;
      if (!is_new) ++t.verified_but_not_on_robot;
    } else {
      ++t.reported_failed;
      EXPECT_FALSE(r.message.empty());
      if (t.reported_failed <= 3) std::printf("[figures] push %d failed: %s\n", i, r.message.c_str());
      if (is_new) {
        ++t.failed_robot_has_new;
      } else {
        ++t.failed_robot_kept_old;
      }
    }
    // What would the robot come back with after a power cycle right now?
    FakeMotionBackend scratch;
    LoopbackTransport rebooted(options, scratch, &storage);
    if (!rebooted.robot().active().SameBits(after)) ++t.boot_differs_from_ram;
  }
  const auto& c = line.counters();
  std::printf(
      "[figures] %d pushes: %d verified, %d reported failed (%d robot kept old set, %d robot "
      "has new set), %d wrong/mixed, %d verified-but-absent, %d boot!=ram | line: %llu bytes, "
      "%llu corrupted, %llu dropped, %llu duplicated, %llu delayed | client: %llu requests, "
      "%llu retransmissions, %llu CRC errors seen | robot: %u CRC errors, %u framing errors, "
      "%u retries answered from cache\n",
      t.pushes, t.verified, t.reported_failed, t.failed_robot_kept_old, t.failed_robot_has_new,
      t.wrong_or_mixed, t.verified_but_not_on_robot, t.boot_differs_from_ram,
      static_cast<unsigned long long>(c.bytes), static_cast<unsigned long long>(c.corrupted),
      static_cast<unsigned long long>(c.dropped), static_cast<unsigned long long>(c.duplicated),
      static_cast<unsigned long long>(c.delayed),
      static_cast<unsigned long long>(client.counters().requests),
      static_cast<unsigned long long>(client.counters().retransmissions),
      static_cast<unsigned long long>(client.decoder_counters().crc_errors),
      link.robot().ctx().counters.crc_errors, link.robot().ctx().counters.framing_errors,
      link.robot().ctx().counters.retries_answered_from_cache);
  return t;
}

void ExpectSafe(const Tally& t, int pushes) {
  EXPECT_EQ(t.pushes, pushes);
  EXPECT_EQ(t.verified + t.reported_failed, pushes);
  EXPECT_EQ(t.wrong_or_mixed, 0);
  EXPECT_EQ(t.verified_but_not_on_robot, 0);
  EXPECT_EQ(t.boot_differs_from_ram, 0);
}

// A line damaged in one way, and what its pushes must come to besides being
// safe (ExpectSafe).
struct DamagedLine {
  std::string name;
  FaultOptions faults;
  int pushes = 0;
  uint32_t seed = 0;  // of the target parameter sets
  int min_verified = 0;
  int min_reported_failed = 0;
};
void PrintTo(const DamagedLine& c, std::ostream* os) { *os << c.name; }

FaultOptions Corrupting(uint32_t seed, double probability) {
  FaultOptions f;
  f.seed = seed;
  f.corrupt_probability = probability;
  return f;
}

FaultOptions Mixed() {
  FaultOptions f = Corrupting(77, 0.003);
  f.drop_probability = 0.003;
  f.duplicate_probability = 0.003;
  f.delay_probability = 0.0005;
  f.delay = std::chrono::milliseconds(1);
  return f;
}

class LinkFaultInjectionOnADamagedLine : public ::testing::TestWithParam<DamagedLine> {};

TEST_P(LinkFaultInjectionOnADamagedLine, EveryPushIsVerifiedOrReportedFailedNeverMixed) {
  const DamagedLine& c = GetParam();
  const Tally t = PushMany(c.pushes, c.faults, c.seed);
  ExpectSafe(t, c.pushes);
  EXPECT_GE(t.verified, c.min_verified);
  EXPECT_GE(t.reported_failed, c.min_reported_failed);
}

INSTANTIATE_TEST_SUITE_P(
    DamagedLines, LinkFaultInjectionOnADamagedLine,
    ::testing::Values(
        // With 10 attempts per request nearly all pushes get through; a
        // handful of failures would still be correct behaviour, a majority
        // would mean the retry logic is broken.
        DamagedLine{"ThousandPushesAtOnePercentByteCorruption", Corrupting(2024, 0.01), 1000, 11, 991, 0},
        DamagedLine{"DropsDuplicatesAndDelaysMixed", Mixed(), 300, 12, 291, 0},
        // 5 % corruption: most frames die. Pushes fail, and say so.
        DamagedLine{"HeavyNoiseFailsLoudly", Corrupting(5, 0.05), 100, 13, 0, 1}),
    [](const ::testing::TestParamInfo<DamagedLine>& info) { return info.param.name; });

TEST(LinkFaultInjection, CutLineIsReportedAndLeavesTheRobotAlone) {
  RobotOptions options;
  FakeMotionBackend backend;
  MemoryStorage storage;
  LoopbackTransport link(options, backend, &storage);
  // Cut in the middle of the staging requests of the first push.
  FaultOptions faults;
  faults.cut_after_bytes = 60;
  FaultInjectingTransport line(link, faults);
  Client client(line);
  Result<PushReport> r = client.PushParams(ParamSet{70.0, 70.0, 300.0, 2048});
  EXPECT_EQ(r.status, StatusCode::kLineCut);
  EXPECT_THAT(r.message, ::testing::HasSubstr("cut"));
  EXPECT_TRUE(link.robot().active().SameBits(options.defaults));
  EXPECT_EQ(link.robot().ctx().counters.commits, 0u);
}

}  // namespace
}  // namespace odocal::robot_link
