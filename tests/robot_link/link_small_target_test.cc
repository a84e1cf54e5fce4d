// The firmware library as an 8-bit target builds it, run on the host: this
// binary links the library compiled with OLF_SOFT_F64=1, the path avr-gcc
// takes because its `double` is 32 bits. There, parameters are binary64 wire
// bytes and run amounts and telemetry are floats. What broke (or would have)
// on the small target, each pinned here against an independent truth:
//  - a 32-bit double cannot hold a pushed diameter: the set's CRC-32 would no
//    longer match what the host computed, so the commit would be refused;
//  - range checks done in float accept values just past a bound;
//  - the soft conversions must round exactly as the hardware does.
// The wire is built and checked here by hand (Boost.CRC, std::bit_cast), not
// by the host codec: the host library cannot be linked next to this build.
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <boost/crc.hpp>
#include <gtest/gtest.h>

#include "odolink/olf.h"

static_assert(OLF_SOFT_F64 == 1, "this test must be built against the soft-f64 library");

namespace {

using Bytes = std::vector<uint8_t>;

uint64_t Bits(double d) { return std::bit_cast<uint64_t>(d); }

olf_f64_t F64(double d) {
  olf_f64_t v;
  const uint64_t b = Bits(d);
  for (int i = 0; i < 8; ++i) v.le[i] = static_cast<uint8_t>(b >> (8 * i));
  return v;
}

double Double(const olf_f64_t& v) {
  uint64_t b = 0;
  for (int i = 0; i < 8; ++i) b |= static_cast<uint64_t>(v.le[i]) << (8 * i);
  return std::bit_cast<double>(b);
}

void PutLe(Bytes* out, uint64_t v, int n) {
  for (int i = 0; i < n; ++i) out->push_back(static_cast<uint8_t>(v >> (8 * i)));
}

uint16_t Crc16(const Bytes& b) {
  boost::crc_optimal<16, 0x1021, 0xFFFF, 0, false, false> crc;
  crc.process_bytes(b.data(), b.size());
  return crc.checksum();
}

uint32_t Crc32(const Bytes& b) {
  boost::crc_32_type crc;
  crc.process_bytes(b.data(), b.size());
  return crc.checksum();
}

// COBS written out plainly, independently of the library's.
Bytes CobsEncode(const Bytes& in) {
  Bytes out(1, 0);
  size_t code_at = 0;
  for (uint8_t b : in) {
    if (b == 0) {
      out[code_at] = static_cast<uint8_t>(out.size() - code_at);
      code_at = out.size();
      out.push_back(0);
    } else {
      out.push_back(b);
    }
  }
  out[code_at] = static_cast<uint8_t>(out.size() - code_at);
  return out;
}

Bytes CobsDecode(const Bytes& in) {
  Bytes out;
  for (size_t i = 0; i < in.size();) {
    const uint8_t code = in[i++];
    for (uint8_t k = 1; k < code && i < in.size(); ++k) out.push_back(in[i++]);
    if (code != 0xFF && i < in.size()) out.push_back(0);
  }
  return out;
}

struct Reply {
  uint8_t type = 0;
  uint16_t seq = 0;
  Bytes body;
};

// One robot: the library with in-memory storage, frames out captured.
class SoftRobot {
 public:
  SoftRobot() : storage_(OLF_STORAGE_SIZE, 0xFF) { Boot(); }

  void Boot() {
    olf_config_t c{};
    c.robot_name = "soft";
    c.defaults.left_wheel_diameter_mm = F64(72.0);
    c.defaults.right_wheel_diameter_mm = F64(72.0);
    c.defaults.track_mm = F64(270.0);
    c.defaults.ticks_per_rev = 4096;
    c.storage = {&SoftRobot::Read, &SoftRobot::Write, this};
    c.callbacks = {&SoftRobot::Out, &SoftRobot::Start, nullptr, nullptr, this};
    olf_init(&ctx_, &c);
  }

  Reply Request(uint8_t type, const Bytes& body) {
    Bytes payload{OLF_PROTOCOL_VERSION, type};
    PutLe(&payload, ++seq_, 2);
    payload.push_back(static_cast<uint8_t>(body.size()));
    payload.insert(payload.end(), body.begin(), body.end());
    const uint16_t crc = Crc16(payload);
    payload.push_back(static_cast<uint8_t>(crc >> 8));
    payload.push_back(static_cast<uint8_t>(crc));
    Bytes wire{0};
    const Bytes enc = CobsEncode(payload);
    wire.insert(wire.end(), enc.begin(), enc.end());
    wire.push_back(0);
    out_.clear();
    olf_feed_bytes(&ctx_, wire.data(), wire.size());
    // One reply: strip the delimiters, decode, check the CRC.
    Bytes block;
    for (uint8_t b : out_) {
      if (b != 0) block.push_back(b);
    }
    const Bytes frame = CobsDecode(block);
    Reply r;
    if (frame.size() < OLF_HEADER_SIZE + OLF_CRC_SIZE) return r;
    const Bytes covered(frame.begin(), frame.end() - 2);
    EXPECT_EQ(Crc16(covered), (frame[frame.size() - 2] << 8) | frame.back());
    r.type = frame[1];
    r.seq = static_cast<uint16_t>(frame[2] | (frame[3] << 8));
    r.body.assign(frame.begin() + OLF_HEADER_SIZE, frame.end() - 2);
    return r;
  }

  static Bytes Name(const std::string& name) {
    Bytes b;
    b.push_back(static_cast<uint8_t>(name.size()));
    for (char c : name) b.push_back(static_cast<uint8_t>(c));
    return b;
  }
  static Bytes ParamBody(const std::string& name, double value) {
    Bytes b = Name(name);
    b.push_back(OLF_TYPE_F64);
    PutLe(&b, Bits(value), 8);
    return b;
  }
  static Bytes TicksBody(uint32_t ticks) {
    Bytes b = Name("ticks_per_rev");
    b.push_back(OLF_TYPE_U32);
    PutLe(&b, ticks, 4);
    return b;
  }

  // The error code of a NACK, or 0 for an ACK.
  uint8_t Set(const std::string& name, double value) {
    const Reply r = Request(OLF_MSG_PARAM_SET, ParamBody(name, value));
    return r.type == OLF_MSG_NACK ? r.body.at(1) : 0;
  }

  const olf_ctx_t& ctx() const { return ctx_; }
  const Bytes& storage() const { return storage_; }
  const olf_run_cmd_t& last_run() const { return last_run_; }

 private:
  static int Read(void* user, uint32_t offset, uint8_t* data, uint32_t len) {
    auto* self = static_cast<SoftRobot*>(user);
    std::memcpy(data, self->storage_.data() + offset, len);
    return 1;
  }
  static int Write(void* user, uint32_t offset, const uint8_t* data, uint32_t len) {
    auto* self = static_cast<SoftRobot*>(user);
    std::memcpy(self->storage_.data() + offset, data, len);
    return 1;
  }
  static void Out(void* user, const uint8_t* data, size_t len) {
    auto* self = static_cast<SoftRobot*>(user);
    self->out_.insert(self->out_.end(), data, data + len);
  }
  static int Start(void* user, const olf_run_cmd_t* cmd) {
    static_cast<SoftRobot*>(user)->last_run_ = *cmd;
    return 1;
  }

  olf_ctx_t ctx_{};
  Bytes storage_;
  Bytes out_;
  uint16_t seq_ = 0;
  olf_run_cmd_t last_run_{};
};

TEST(SmallTarget, SoftConversionsRoundExactlyAsTheHardwareDoes) {
  std::mt19937_64 rng(7);
  std::uniform_int_distribution<uint64_t> any;
  std::uniform_int_distribution<int> exponent(1023 - 160, 1023 + 140);  // around float's range
  int checked = 0;
  auto check = [&](double d) {
    const float soft = olf_f64_to_float(F64(d));
    const float hard = static_cast<float>(d);
    if (std::isnan(hard)) {
      EXPECT_TRUE(std::isnan(soft)) << d;
    } else {
      EXPECT_EQ(std::bit_cast<uint32_t>(soft), std::bit_cast<uint32_t>(hard))
          << std::hexfloat << d << " -> " << soft << " vs " << hard;
    }
    ++checked;
  };
  for (int i = 0; i < 200000; ++i) {
    uint64_t b = any(rng);
    b = (b & ~(uint64_t{0x7FF} << 52)) | (static_cast<uint64_t>(exponent(rng)) << 52);
    check(std::bit_cast<double>(b));
  }
  // Ties, carries and the edges of float's range.
  for (double d : {0.0, -0.0, 1.0, 1.0 + 0x1p-24, 1.0 + 0x1p-23 + 0x1p-24, 0x1.fffffffp127,
                   0x1.ffffffp127, 0x1.fffffefp127, 0x1p-126, 0x1p-149, 0x1p-150, 0x1.0000001p-150,
                   0x1.8p-149, 0x1.fffffep-127, 0x1p-1074, 1e300, -1e300,
                   std::numeric_limits<double>::infinity(), std::numeric_limits<double>::quiet_NaN(),
                   71.83215, 270.0000000000001}) {
    check(d);
    check(-d);
  }
  EXPECT_GT(checked, 200000);

  std::uniform_int_distribution<uint32_t> any32;
  for (int i = 0; i < 200000; ++i) {
    const float f = std::bit_cast<float>(any32(rng));
    const double soft = Double(olf_f64_from_float(f));
    if (std::isnan(f)) {
      EXPECT_TRUE(std::isnan(soft));
    } else {
      EXPECT_EQ(Bits(soft), Bits(static_cast<double>(f))) << std::hexfloat << f;
    }
  }
}

TEST(SmallTarget, APushedSetSurvivesBitForBitThroughCommitStorageAndReboot) {
  SoftRobot robot;
  // None of these is a float: a 32-bit double would round every one.
  const double left = 71.832150000000013, right = 72.004998779296879, track = 269.87654321;
  ASSERT_NE(static_cast<double>(static_cast<float>(left)), left);
  ASSERT_EQ(robot.Request(OLF_MSG_STAGE_BEGIN, {}).type, OLF_MSG_ACK);
  ASSERT_EQ(robot.Request(OLF_MSG_STAGE_PUT, SoftRobot::ParamBody("left_wheel_diameter_mm", left)).type, OLF_MSG_ACK);
  ASSERT_EQ(robot.Request(OLF_MSG_STAGE_PUT, SoftRobot::ParamBody("right_wheel_diameter_mm", right)).type, OLF_MSG_ACK);
  ASSERT_EQ(robot.Request(OLF_MSG_STAGE_PUT, SoftRobot::ParamBody("track_mm", track)).type, OLF_MSG_ACK);
  ASSERT_EQ(robot.Request(OLF_MSG_STAGE_PUT, SoftRobot::TicksBody(8192)).type, OLF_MSG_ACK);
  // The checksum the host computes: canonical bytes, binary64 LE.
  Bytes canonical;
  PutLe(&canonical, Bits(left), 8);
  PutLe(&canonical, Bits(right), 8);
  PutLe(&canonical, Bits(track), 8);
  PutLe(&canonical, 8192, 4);
  const uint32_t crc = Crc32(canonical);
  Bytes commit;
  PutLe(&commit, crc, 4);
  const Reply done = robot.Request(OLF_MSG_COMMIT, commit);
  ASSERT_EQ(done.type, OLF_MSG_ACK) << "error " << int(done.body.size() > 1 ? done.body[1] : 0);

  // In storage, the new record holds the very bytes (slot A: the first commit).
  const Bytes& st = robot.storage();
  const Bytes stored(st.begin() + 10, st.begin() + 38);
  EXPECT_EQ(stored, canonical);

  // After a reboot, PARAMS_READ active answers the same bytes and checksum.
  robot.Boot();
  EXPECT_EQ(robot.ctx().boot_source, OLF_BOOT_SLOT_A);
  const Reply read = robot.Request(OLF_MSG_PARAMS_READ, {OLF_SET_ACTIVE});
  ASSERT_EQ(read.type, OLF_MSG_ACK);
  // body: type, set, mask u32, crc u32, count, then (type, value) per parameter.
  EXPECT_EQ(uint32_t(read.body[6] | read.body[7] << 8 | read.body[8] << 16 | uint32_t(read.body[9]) << 24), crc);
  Bytes values;
  size_t at = 11;
  for (int i = 0; i < 4; ++i) {
    const size_t n = read.body[at] == OLF_TYPE_F64 ? 8 : 4;
    values.insert(values.end(), read.body.begin() + at + 1, read.body.begin() + at + 1 + n);
    at += 1 + n;
  }
  EXPECT_EQ(values, canonical);
  // And the firmware's float for its maths is the nearest float.
  EXPECT_FLOAT_EQ(olf_f64_to_float(robot.ctx().active.track_mm), static_cast<float>(track));
}

TEST(SmallTarget, RangeChecksAreExactAtTheBounds) {
  SoftRobot robot;
  const double inf = std::numeric_limits<double>::infinity();
  EXPECT_EQ(robot.Set("left_wheel_diameter_mm", 2000.0), 0);
  // Within float's rounding of 2000 but above it: refused.
  EXPECT_EQ(robot.Set("left_wheel_diameter_mm", std::nextafter(2000.0, inf)), OLF_ERR_OUT_OF_RANGE);
  EXPECT_EQ(robot.Set("left_wheel_diameter_mm", 1.0), 0);
  EXPECT_EQ(robot.Set("left_wheel_diameter_mm", std::nextafter(1.0, 0.0)), OLF_ERR_OUT_OF_RANGE);
  EXPECT_EQ(robot.Set("track_mm", std::numeric_limits<double>::quiet_NaN()), OLF_ERR_OUT_OF_RANGE);
  EXPECT_EQ(robot.Set("track_mm", -std::numeric_limits<double>::quiet_NaN()), OLF_ERR_OUT_OF_RANGE);
  EXPECT_EQ(robot.Set("track_mm", inf), OLF_ERR_OUT_OF_RANGE);
  EXPECT_EQ(robot.Set("track_mm", -0.0), OLF_ERR_OUT_OF_RANGE);
  EXPECT_EQ(robot.Set("track_mm", -300.0), OLF_ERR_OUT_OF_RANGE);
  EXPECT_EQ(robot.Set("track_mm", 10000.0), 0);
  // ticks_per_rev in integers: 2^24 + 1 is 2^24 in a float.
  EXPECT_EQ(robot.Request(OLF_MSG_PARAM_SET, SoftRobot::TicksBody(16777216)).type, OLF_MSG_ACK);
  const Reply over = robot.Request(OLF_MSG_PARAM_SET, SoftRobot::TicksBody(16777217));
  ASSERT_EQ(over.type, OLF_MSG_NACK);
  EXPECT_EQ(over.body.at(1), OLF_ERR_OUT_OF_RANGE);
  // The table's bounds are floats too, so a 32-bit double checks the same ones.
  for (unsigned i = 0; i < OLF_PARAM_COUNT; ++i) {
    const olf_param_desc_t& d = olf_param_table()[i];
    EXPECT_EQ(static_cast<double>(static_cast<float>(d.min_value)), d.min_value) << d.name;
    EXPECT_EQ(static_cast<double>(static_cast<float>(d.max_value)), d.max_value) << d.name;
  }
}

TEST(SmallTarget, RunAmountsAreCheckedOnTheWireAndArriveAsTheNearestFloat) {
  SoftRobot robot;
  auto start = [&](uint8_t procedure, double amount) {
    Bytes b{procedure, OLF_DIR_CCW};
    PutLe(&b, Bits(amount), 8);
    PutLe(&b, 1, 4);
    const Reply r = robot.Request(OLF_MSG_RUN_START, b);
    if (r.type == OLF_MSG_ACK) {
      olf_telemetry_t end{};
      olf_run_complete(const_cast<olf_ctx_t*>(&robot.ctx()), OLF_RUN_COMPLETED, &end);
      return uint8_t{0};
    }
    return r.body.at(1);
  };
  EXPECT_EQ(start(OLF_PROC_STRAIGHT, 1234.5678), 0);
  EXPECT_FLOAT_EQ(static_cast<float>(robot.last_run().amount_mm), 1234.5678f);
  EXPECT_EQ(start(OLF_PROC_STRAIGHT, -100000.0), 0);
  EXPECT_EQ(start(OLF_PROC_STRAIGHT, std::nextafter(100000.0, 1e9)), OLF_ERR_BAD_PROCEDURE);
  EXPECT_EQ(start(OLF_PROC_STRAIGHT, 0.0), OLF_ERR_BAD_PROCEDURE);
  EXPECT_EQ(start(OLF_PROC_STRAIGHT, -0.0), OLF_ERR_BAD_PROCEDURE);
  EXPECT_EQ(start(OLF_PROC_UMBMARK, -500.0), OLF_ERR_BAD_PROCEDURE);
  EXPECT_EQ(start(OLF_PROC_UMBMARK, std::numeric_limits<double>::quiet_NaN()), OLF_ERR_BAD_PROCEDURE);
  EXPECT_EQ(start(OLF_PROC_UMBMARK, 1e-300), 0);  // tiny but positive, as with a real double
}

TEST(SmallTarget, TheLargestMessageFitsTheBuffers) {
  // STATUS's reply is the largest message: header 5 + 47 body bytes.
  SoftRobot robot;
  const Reply status = robot.Request(OLF_MSG_STATUS, {});
  ASSERT_EQ(status.type, OLF_MSG_ACK);
  EXPECT_EQ(OLF_HEADER_SIZE + status.body.size(), OLF_LARGEST_MESSAGE);
  // A HELLO with the longest name the protocol allows.
  EXPECT_LE(OLF_HEADER_SIZE + 1 + 2 + 8 + 2 + OLF_MAX_NAME, OLF_LARGEST_MESSAGE);
}

}  // namespace
