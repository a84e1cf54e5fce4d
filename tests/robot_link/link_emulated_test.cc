// The firmware library on real microcontroller code, in emulation, driven by
// the real odocal binary over a pseudo-terminal: the ATmega328P (8-bit, 16-bit
// int, 32-bit double, 2 KiB RAM) under simavr and the LM3S6965 Cortex-M3 under
// QEMU, each with its own board support (UART interrupt, tick, parameters in
// EEPROM / a flash page pair). Shown here for both:
//  - the protocol's documented byte examples, byte for byte (the robot's name
//    aside), and the storage record written to the part, byte for byte;
//  - odocal robot info / get / set / push / rollback, the robot's own range
//    checks at their exact bounds, and a set surviving a power cycle;
//  - pushes through a line corrupting 1 % of the bytes, and power cuts at
//    random instants of a push: afterwards the robot holds the old set or the
//    new one, never a mix (counts: ODOCAL_EMU_PUSHES / ODOCAL_EMU_KILLS; the
//    full 200 / 50 run is bench/firmware/emulated_pushes.sh).
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <random>
#include <sstream>
#include <thread>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "emulated_target.h"
#include "link_test_util.h"
#include "odocal/test_util/test_util.h"
#include "odolink/olf.h"
#include "protocol_examples.h"

namespace odocal::robot_link {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using test_util::CommandResult;
using test_util::RunCommand;
using testing::EmulatedTarget;
using testing::FaultyPty;
using testing::TargetKind;

std::vector<TargetKind> Targets() {
  return {
      TargetKind{"avr", "odocal-avr", {ODOCAL_AVR_BOARD, "--elf", ODOCAL_AVR_ELF, "--eeprom", "{image}"}, 0},
      TargetKind{"lm3s6965", "odocal-lm3s6965", {ODOCAL_QEMU_LAUNCHER, ODOCAL_LM3S_ELF, "{image}"},
                 ODOCAL_LM3S_SLOT_A_OFFSET},
  };
}

int EnvCount(const char* name, int fallback) {
  const char* v = std::getenv(name);
  return v != nullptr ? std::atoi(v) : fallback;
}

std::string Robot(const std::string& args, const std::string& port) {
  return test_util::OdocalBinary() + " robot " + args + " --port " + port;
}

// `odocal robot get` parsed: name -> value.
std::map<std::string, double> Get(const std::string& port) {
  const CommandResult r = RunCommand(Robot("get", port));
  EXPECT_EQ(r.exit_code, 0) << r.err;
  std::map<std::string, double> values;
  std::istringstream lines(r.out);
  std::string name, eq, value;
  while (lines >> name >> eq >> value) values[name] = std::stod(value);
  return values;
}

ParamSet GetSet(const std::string& port) {
  std::map<std::string, double> v = Get(port);
  return ParamSet{v["left_wheel_diameter_mm"], v["right_wheel_diameter_mm"], v["track_mm"],
                  static_cast<uint32_t>(v["ticks_per_rev"])};
}

std::string PushArgs(const ParamSet& s) {
  std::ostringstream o;
  o.precision(17);
  o << "push left_wheel_diameter_mm=" << s.left_wheel_diameter_mm
    << " right_wheel_diameter_mm=" << s.right_wheel_diameter_mm << " track_mm=" << s.track_mm
    << " ticks_per_rev=" << s.ticks_per_rev;
  return o.str();
}

// Sets no float can hold (an 8-bit target keeps them as binary64 bytes).
ParamSet NthSet(std::mt19937& rng) {
  std::uniform_real_distribution<double> d(60.0, 80.0), t(200.0, 400.0);
  std::uniform_int_distribution<uint32_t> k(500, 20000);
  return ParamSet{d(rng), d(rng), t(rng), k(rng)};
}

class LinkEmulated : public ::testing::TestWithParam<TargetKind> {
 protected:
  void SetUp() override {
    dir_ = fs::path(::testing::TempDir()) /
           ("odocal_emu_" + GetParam().name + "_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    image_ = (dir_ / "storage.bin").string();
    Boot();
  }
  void TearDown() override {
    target_.reset();
    fs::remove_all(dir_);
  }
  void Boot() {
    target_.reset();
    Result<std::unique_ptr<EmulatedTarget>> t = EmulatedTarget::Start(GetParam(), image_);
    ASSERT_TRUE(t.ok()) << t;
    target_ = std::move(*t);
  }
  const std::string& port() const { return target_->pty(); }

  fs::path dir_;
  std::string image_;
  std::unique_ptr<EmulatedTarget> target_;
};

// Reads one whole frame (00 ... 00) as the robot sent it.
Bytes ReadRawFrame(Transport& t, std::chrono::milliseconds timeout) {
  Bytes got;
  uint8_t b;
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  bool content = false;
  while (std::chrono::steady_clock::now() < deadline) {
    const IoResult r = t.Read(std::span<uint8_t>(&b, 1), std::chrono::milliseconds(50));
    if (r.status != IoStatus::kOk || r.bytes == 0) continue;
    got.push_back(b);
    if (b != 0) content = true;
    if (b == 0 && content) return got;
  }
  return got;
}

// The golden reply with the robot's own name (HELLO carries it).
std::string ExpectedHex(const std::string& name, const std::string& robot_name) {
  const std::string golden = Golden().at(name);
  if (name != "reply HELLO") return golden;
  Bytes wire;
  std::istringstream in(golden);
  std::string h;
  while (in >> h) wire.push_back(static_cast<uint8_t>(std::stoul(h, nullptr, 16)));
  FrameDecoder decoder;
  std::optional<Frame> frame;
  for (uint8_t b : wire) {
    if (auto f = decoder.Feed(b)) frame = f;
  }
  EXPECT_TRUE(frame.has_value());
  // body: type, version, count, table crc, active crc, boot source, name length, name.
  Bytes body(frame->body.begin(), frame->body.begin() + 12);
  body.push_back(static_cast<uint8_t>(robot_name.size()));
  body.insert(body.end(), robot_name.begin(), robot_name.end());
  frame->body = body;
  return ToHex(EncodeFrame(*frame));
}

TEST_P(LinkEmulated, ProtocolExamplesByteForByteAndTheRecordOnThePart) {
  Result<std::unique_ptr<SerialTransport>> link = SerialTransport::Open(port());
  ASSERT_TRUE(link.ok()) << link;
  Transport& t = **link;
  for (const Example& e : PushConversation()) {
    ASSERT_EQ(t.Write(EncodeFrame(e.request)).status, IoStatus::kOk);
    const Bytes reply = ReadRawFrame(t, std::chrono::seconds(3));
    if (e.reply_name.empty()) continue;
    EXPECT_EQ(ToHex(reply), ExpectedHex(e.reply_name, GetParam().robot_name)) << e.reply_name;
  }
  // The record as the part stores it: slot A, generation 1, byte for byte.
  std::ifstream image(image_, std::ios::binary);
  image.seekg(static_cast<std::streamoff>(GetParam().slot_a_offset));
  Bytes record(OLF_STORAGE_RECORD_SIZE);
  image.read(reinterpret_cast<char*>(record.data()), static_cast<std::streamsize>(record.size()));
  ASSERT_TRUE(image.good()) << image_;
  EXPECT_EQ(ToHex(record), Golden().at("storage slot A after commit"));

  // A run: the documented RUN_START reply, then telemetry and RUN_COMPLETE.
  uint16_t seq = 100;
  ByteWriter rate;
  rate.U16(10);
  ASSERT_EQ(t.Write(EncodeFrame(testing::Request(OLF_MSG_TELEMETRY_RATE, seq++, rate.Take()))).status, IoStatus::kOk);
  EXPECT_FALSE(ReadRawFrame(t, std::chrono::seconds(3)).empty());
  ByteWriter run;
  run.U8(OLF_PROC_STRAIGHT).U8(OLF_DIR_CCW).F64(200.0).U32(0);
  const Frame start = testing::Request(OLF_MSG_RUN_START, 12, run.Take());
  ASSERT_EQ(t.Write(EncodeFrame(start)).status, IoStatus::kOk);
  EXPECT_EQ(ToHex(ReadRawFrame(t, std::chrono::seconds(3))), Golden().at("reply RUN_START"));
  FrameDecoder decoder;
  int telemetry = 0;
  std::optional<Frame> complete;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  uint8_t buf[128];
  while (!complete && std::chrono::steady_clock::now() < deadline) {
    const IoResult r = t.Read(buf, std::chrono::milliseconds(100));
    for (size_t i = 0; r.status == IoStatus::kOk && i < r.bytes; ++i) {
      if (std::optional<Frame> f = decoder.Feed(buf[i])) {
        if (f->type == OLF_MSG_TELEMETRY) ++telemetry;
        if (f->type == OLF_MSG_RUN_COMPLETE) complete = f;
      }
    }
  }
  ASSERT_TRUE(complete.has_value()) << "no RUN_COMPLETE within 10 s";
  EXPECT_GE(telemetry, 1);
  ASSERT_GE(complete->body.size(), 3u);
  EXPECT_EQ(complete->body[0] | (complete->body[1] << 8), 1);  // run id 1
  EXPECT_EQ(complete->body[2], OLF_RUN_COMPLETED);
}

TEST_P(LinkEmulated, CliInfoGetSetPushRollbackAndThePartsOwnRangeChecks) {
  CommandResult r = RunCommand(Robot("info", port()));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("robot: " + GetParam().robot_name));
  EXPECT_TRUE(GetSet(port()).SameBits(ParamSet{72.0, 72.0, 270.0, 4096}));

  r = RunCommand(Robot("set track_mm 281.5", port()));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  // Exactly at the bounds, and one binary64 step past them: what a 32-bit
  // float check would have let through.
  r = RunCommand(Robot("set track_mm 10000", port()));
  EXPECT_EQ(r.exit_code, 0) << r.err;
  r = RunCommand(Robot("set track_mm 10000.000000000002", port()));
  EXPECT_EQ(r.exit_code, 7) << r.out << r.err;
  EXPECT_THAT(r.err, HasSubstr("value out of range"));
  r = RunCommand(Robot("set ticks_per_rev 16777217", port()));
  EXPECT_EQ(r.exit_code, 7) << r.out << r.err;
  r = RunCommand(Robot("set track_mm 281.5", port()));
  ASSERT_EQ(r.exit_code, 0) << r.err;

  const ParamSet pushed{71.83215000000001, 72.004998779296879, 281.5, 4096};
  r = RunCommand(Robot(PushArgs(pushed), port()));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("verified: checksum"));
  EXPECT_TRUE(GetSet(port()).SameBits(pushed)) << GetSet(port());

  r = RunCommand(Robot("rollback", port()));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(GetSet(port()).SameBits(ParamSet{72.0, 72.0, 281.5, 4096})) << GetSet(port());
}

TEST_P(LinkEmulated, APushedSetSurvivesAPowerCycle) {
  const ParamSet pushed{70.123456789, 73.987654321, 301.000000001, 2048};
  CommandResult r = RunCommand(Robot(PushArgs(pushed), port()));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  target_->Kill();
  Boot();
  EXPECT_TRUE(GetSet(port()).SameBits(pushed)) << GetSet(port());
  r = RunCommand(Robot("rollback", port()));  // the previous set persisted too
  ASSERT_EQ(r.exit_code, 0) << r.err;
  target_->Kill();
  Boot();
  EXPECT_TRUE(GetSet(port()).SameBits(ParamSet{72.0, 72.0, 270.0, 4096})) << GetSet(port());
}

// Through a line that corrupts 1 % of the bytes both ways: every push either
// reports success and the robot holds the new set, or fails and the robot
// holds the old or the new set. Read back over a clean line each time.
// 8 pushes here (~60 bytes corrupted, ~2 s a push); the 200 of
// bench/firmware/emulated_pushes.sh are in docs/protocol.md.
TEST_P(LinkEmulated, PushesThroughALineCorruptingOnePercentOfTheBytes) {
  const int pushes = EnvCount("ODOCAL_EMU_PUSHES", GetParam().name == "avr" ? 8 : 6);
  FaultOptions faults;
  faults.seed = 2026;
  faults.corrupt_probability = 0.01;
  Result<std::unique_ptr<FaultyPty>> noisy = FaultyPty::Start(port(), faults);
  ASSERT_TRUE(noisy.ok()) << noisy;
  std::mt19937 rng(14);
  ParamSet current{72.0, 72.0, 270.0, 4096};
  int succeeded = 0, failed_old = 0, failed_new = 0, wrong = 0;
  for (int i = 0; i < pushes; ++i) {
    const ParamSet next = NthSet(rng);
    const CommandResult r = RunCommand(Robot(PushArgs(next), (*noisy)->path()));
    (*noisy)->Pause();
    const ParamSet held = GetSet(port());
    (*noisy)->Resume();
    const bool is_new = held.SameBits(next), is_old = held.SameBits(current);
    if (r.exit_code == 0 && is_new) {
      ++succeeded;
    } else if (r.exit_code != 0 && (is_old || is_new)) {
      ++(is_new ? failed_new : failed_old);
    } else {
      ++wrong;
      ADD_FAILURE() << "push " << i << " (exit " << r.exit_code << ": " << r.err << ") left " << held;
    }
    if (is_new) current = next;
  }
  std::printf("[emulated %s] %d pushes at 1 %% corruption: %d verified, %d failed cleanly (old set), "
              "%d failed after committing (new set), %d wrong or mixed; %llu bytes corrupted\n",
              GetParam().name.c_str(), pushes, succeeded, failed_old, failed_new, wrong,
              static_cast<unsigned long long>((*noisy)->counters().corrupted));
  EXPECT_EQ(wrong, 0);
  EXPECT_GT(succeeded, pushes / 2);  // retries carry most pushes through
  EXPECT_GT((*noisy)->counters().corrupted, 0u);
}

// Power cuts at random instants of a push, with the part restarted on the
// same storage image each time: old set or new set, never a mix.
TEST_P(LinkEmulated, PowerCutsAtRandomInstantsOfAPush) {
  const int kills = EnvCount("ODOCAL_EMU_KILLS", 10);
  // The AVR board takes the part's 3.4 ms per EEPROM byte. QEMU's flash is a
  // file written in microseconds; 5 ms per erase and per word (a real page
  // erase takes longer) gives the cuts something to land in. Every boot of
  // this test, the restarts after a cut included, runs with it.
  struct FlashDelay {
    explicit FlashDelay(bool on) : on_(on) { if (on_) ::setenv("ODOLINK_FLASH_DELAY_MS", "5", 1); }
    ~FlashDelay() { if (on_) ::unsetenv("ODOLINK_FLASH_DELAY_MS"); }
    bool on_;
  } delay(GetParam().name == "lm3s6965");
  if (delay.on_) Boot();
  // When, after the push command starts, the part writes its storage: watch
  // the image while a push runs, and aim the cuts at that window. (A first
  // push before it, so that what is watched is a record written over an
  // existing one, as every cut below will be, not a fresh image's first.)
  std::mt19937 rng(50);
  ParamSet current = NthSet(rng);
  const CommandResult warm = RunCommand(Robot(PushArgs(current), port()));
  ASSERT_EQ(warm.exit_code, 0) << warm.err;
  current = NthSet(rng);
  using Clock = std::chrono::steady_clock;
  const std::string initial = test_util::Slurp(image_);
  std::atomic<bool> done{false};
  const auto t0 = Clock::now();
  std::thread first([&] {
    const CommandResult r = RunCommand(Robot(PushArgs(current), port()));
    EXPECT_EQ(r.exit_code, 0) << r.err;
    done = true;
  });
  std::optional<Clock::duration> write_begin, write_end;
  std::string last = initial;
  while (!done) {
    std::string now = test_util::Slurp(image_);
    if (now != last) {
      if (!write_begin) write_begin = Clock::now() - t0;
      write_end = Clock::now() - t0;
      last = std::move(now);
    }
    std::this_thread::sleep_for(std::chrono::microseconds(500));
  }
  first.join();
  ASSERT_TRUE(write_begin.has_value()) << "the first push did not change the storage image";
  const auto ms = [](Clock::duration d) {
    return static_cast<int>(std::chrono::duration_cast<std::chrono::milliseconds>(d).count());
  };
  // From a little before the first byte changes to a little after the last:
  // cuts before the write (old set, image as it was), during it (old set, the
  // new record half written) and after it (new set). A push's timing varies
  // by some milliseconds from one process to the next; the margins cover it.
  int from_ms = std::max(0, ms(*write_begin) - 40), to_ms = ms(*write_end) + 40;
  const int watched_from_ms = from_ms, watched_to_ms = to_ms;
  int old_count = 0, new_count = 0, wrong = 0, torn = 0, cuts = 0;
  // `kills` cuts, and more (up to three times as many) until one lands in
  // the write: on a loaded machine (the suite's other test beside it) a
  // push's timing drifts from the watched one by more than the margins, and
  // ten cuts all before or after the write proves nothing either way.
  for (int i = 0; i < kills || (torn == 0 && i < 3 * kills); ++i) {
    ++cuts;
    const ParamSet next = NthSet(rng);
    const int cut_ms = std::uniform_int_distribution<int>(from_ms, to_ms)(rng);
    const std::string before = test_util::Slurp(image_);
    std::thread push([&] { RunCommand(Robot(PushArgs(next), port())); });
    std::this_thread::sleep_for(std::chrono::milliseconds(cut_ms));
    target_->Kill();
    push.join();
    const bool image_changed = test_util::Slurp(image_) != before;
    Boot();
    const ParamSet held = GetSet(port());
    // The window follows what the cuts find (a loaded machine moves the
    // write by more than the margins, all one way, while this runs): a cut
    // after the write (the new set held) pulls the window's end before it,
    // one before the write (the old set, the image untouched) its start
    // after it; a window that closes opens again around the last cut.
    if (held.SameBits(current)) {
      ++old_count;
      torn += image_changed;  // the new record was being written when the power went
      if (!image_changed) from_ms = cut_ms + 1;
    } else if (held.SameBits(next)) {
      ++new_count;
      current = next;
      to_ms = cut_ms - 1;
    } else {
      ++wrong;
      ADD_FAILURE() << "cut " << i << " at " << cut_ms << " ms booted " << held;
    }
    if (from_ms >= to_ms) from_ms = std::max(0, cut_ms - 40), to_ms = cut_ms + 40;
  }
  std::printf("[emulated %s] %d power cuts from %d..%d ms of a push, ending at %d..%d ms (storage written at "
              "%d..%d ms): %d old set (%d of them with the new record half written), %d new set, %d mixed\n",
              GetParam().name.c_str(), cuts, watched_from_ms, watched_to_ms, from_ms, to_ms, ms(*write_begin),
              ms(*write_end), old_count, torn, new_count, wrong);
  EXPECT_EQ(wrong, 0);
  EXPECT_GT(torn, 0) << "no cut landed while the new record was being written";
}

INSTANTIATE_TEST_SUITE_P(Targets, LinkEmulated, ::testing::ValuesIn(Targets()),
                         [](const ::testing::TestParamInfo<TargetKind>& i) { return i.param.name; });

}  // namespace
}  // namespace odocal::robot_link
