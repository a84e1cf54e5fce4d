// COBS and CRC as properties: check values, seeded random round trips, the
// firmware's bitwise CRC loops against Boost.CRC, the firmware's COBS against
// the host's, and resynchronisation after garbage.
#include <algorithm>
#include <cstring>
#include <random>
#include <string>

#include <boost/crc.hpp>
#include <gtest/gtest.h>

#include "odocal/robot_link/codec.h"
#include "odolink/olf.h"

namespace odocal::robot_link {
namespace {

Bytes RandomBytes(std::mt19937& rng, size_t n, double zero_fraction) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::uniform_int_distribution<int> byte(1, 255);
  Bytes b(n);
  for (auto& x : b) x = u(rng) < zero_fraction ? 0 : static_cast<uint8_t>(byte(rng));
  return b;
}

TEST(LinkCrc, CheckValuesOfTheCatalogue) {
  const std::string s = "123456789";
  const auto* p = reinterpret_cast<const uint8_t*>(s.data());
  EXPECT_EQ(olf_crc16(p, s.size()), 0x29B1);
  EXPECT_EQ(Crc16CcittFalse(std::span(p, s.size())), 0x29B1);
  EXPECT_EQ(olf_crc32(p, s.size()), 0xCBF43926u);
  EXPECT_EQ(Crc32(std::span(p, s.size())), 0xCBF43926u);
}

TEST(LinkCrc, FirmwareBitwiseLoopsMatchBoostCrcOnRandomData) {
  std::mt19937 rng(42);
  std::uniform_int_distribution<size_t> len(0, 600);
  for (int i = 0; i < 3000; ++i) {
    const Bytes b = RandomBytes(rng, len(rng), 0.1);
    boost::crc_optimal<16, 0x1021, 0xFFFF, 0, false, false> crc16;
    crc16.process_bytes(b.data(), b.size());
    boost::crc_32_type crc32;
    crc32.process_bytes(b.data(), b.size());
    ASSERT_EQ(olf_crc16(b.data(), b.size()), crc16.checksum()) << "case " << i;
    ASSERT_EQ(olf_crc32(b.data(), b.size()), crc32.checksum()) << "case " << i;
  }
}

TEST(LinkCrc, Crc16DetectsEverySingleBitFlipOfAFrame) {
  std::mt19937 rng(7);
  const Bytes b = RandomBytes(rng, 60, 0.2);
  const uint16_t good = olf_crc16(b.data(), b.size());
  for (size_t i = 0; i < b.size() * 8; ++i) {
    Bytes c = b;
    c[i / 8] ^= static_cast<uint8_t>(1u << (i % 8));
    ASSERT_NE(olf_crc16(c.data(), c.size()), good) << "bit " << i;
  }
}

TEST(LinkCobs, RoundTripsAndNeverEmitsZero) {
  std::mt19937 rng(1234);
  std::uniform_int_distribution<size_t> len(0, 700);
  // Lengths at the 254-byte block boundary are where COBS encoders go wrong.
  std::vector<size_t> lengths = {0, 1, 253, 254, 255, 256, 508, 509};
  for (int i = 0; i < 2000; ++i) lengths.push_back(len(rng));
  for (size_t n : lengths) {
    for (double zeros : {0.0, 0.05, 0.5, 1.0}) {
      const Bytes b = RandomBytes(rng, n, zeros);
      const Bytes enc = CobsEncode(b);
      ASSERT_EQ(std::count(enc.begin(), enc.end(), 0), 0);
      ASSERT_LE(enc.size(), n + n / 254 + 1);
      const std::optional<Bytes> dec = CobsDecode(enc);
      ASSERT_TRUE(dec.has_value());
      ASSERT_EQ(*dec, b) << "n=" << n << " zeros=" << zeros;

      // The firmware's encoder and decoder against the host's.
      std::vector<uint8_t> fw_enc(n + n / 254 + 2);
      const size_t fw_n = olf_cobs_encode(b.data(), b.size(), fw_enc.data(), fw_enc.size());
      ASSERT_GT(fw_n, 0u);
      fw_enc.resize(fw_n);
      ASSERT_EQ(CobsDecode(fw_enc), b);
      std::vector<uint8_t> fw_dec(n + 1);
      const int m = olf_cobs_decode(enc.data(), enc.size(), fw_dec.data(), fw_dec.size());
      ASSERT_EQ(m, static_cast<int>(n));
      fw_dec.resize(n);
      ASSERT_EQ(fw_dec, b);
    }
  }
}

TEST(LinkCobs, RejectsMalformedBlocks) {
  const Bytes runs_past_end = {0x05, 0x11, 0x22};
  EXPECT_FALSE(CobsDecode(runs_past_end).has_value());
  uint8_t out[16];
  EXPECT_EQ(olf_cobs_decode(runs_past_end.data(), runs_past_end.size(), out, sizeof out), -1);
  const Bytes has_zero = {0x03, 0x11, 0x00};
  EXPECT_FALSE(CobsDecode(has_zero).has_value());
  EXPECT_EQ(olf_cobs_decode(has_zero.data(), has_zero.size(), out, sizeof out), -1);
  // Too small an output buffer is an error, not an overflow.
  const Bytes long_block = CobsEncode(Bytes(40, 0x55));
  EXPECT_EQ(olf_cobs_decode(long_block.data(), long_block.size(), out, sizeof out), -1);
  EXPECT_EQ(olf_cobs_encode(Bytes(40, 0x55).data(), 40, out, sizeof out), 0u);
}

TEST(LinkFraming, DecoderResynchronisesAfterGarbage) {
  std::mt19937 rng(99);
  const Frame sent{OLF_PROTOCOL_VERSION, OLF_MSG_HELLO, 0x1234, Bytes{1, 0, 2, 0, 3}};
  const Bytes wire = EncodeFrame(sent);
  int decoded = 0;
  FrameDecoder decoder;
  for (int i = 0; i < 200; ++i) {
    // Garbage with and without zeros, including runs longer than any frame.
    const Bytes garbage = RandomBytes(rng, std::uniform_int_distribution<size_t>(0, 400)(rng),
                                      i % 2 ? 0.02 : 0.0);
    Bytes stream = garbage;
    stream.insert(stream.end(), wire.begin(), wire.end());
    for (uint8_t b : stream) {
      if (std::optional<Frame> f = decoder.Feed(b)) {
        EXPECT_EQ(f->seq, sent.seq);
        EXPECT_EQ(f->body, sent.body);
        ++decoded;
      }
    }
  }
  // Garbage could, with probability ~2^-16 per stray frame, pass the CRC; with
  // this seed it does not, and every real frame after it gets through.
  EXPECT_EQ(decoded, 200);
  EXPECT_GT(decoder.counters().crc_errors + decoder.counters().framing_errors, 0u);
}

TEST(LinkFraming, DuplicatedTrailingZeroIsCaughtByTheLengthByte) {
  // Without the body length in the header, a frame whose CRC-16 ends in 0x00
  // still passes the CRC when that zero is duplicated (see olf_wire.h). Find
  // such a frame and duplicate the COBS byte that encodes the zero.
  int checked = 0;
  for (uint16_t seq = 0; seq < 4000; ++seq) {
    const Bytes wire = EncodeFrame(Frame{OLF_PROTOCOL_VERSION, OLF_MSG_PARAMS_READ, seq, {1}});
    const std::optional<Bytes> payload = CobsDecode(std::span(wire).subspan(1, wire.size() - 2));
    ASSERT_TRUE(payload);
    if (payload->back() != 0) continue;
    Bytes damaged = wire;
    damaged.insert(damaged.end() - 1, damaged[damaged.size() - 2]);
    FrameDecoder decoder;
    for (uint8_t b : damaged) EXPECT_FALSE(decoder.Feed(b).has_value()) << "seq " << seq;
    // The same damage without the length check would have passed the CRC:
    const std::optional<Bytes> bad = CobsDecode(std::span(damaged).subspan(1, damaged.size() - 2));
    ASSERT_TRUE(bad);
    EXPECT_EQ(Crc16CcittFalse(std::span(bad->data(), bad->size() - 2)),
              (bad->at(bad->size() - 2) << 8) | bad->back());
    ++checked;
  }
  EXPECT_GT(checked, 5);
}

TEST(LinkFraming, FirmwareAnswersAfterGarbageAndIgnoresCorruptFrames) {
  Bytes out;
  olf_config_t config{};
  config.robot_name = "resync";
  config.defaults = olf_params_t{72.0, 72.0, 270.0, 4096};
  config.callbacks.user = &out;
  config.callbacks.write = [](void* user, const uint8_t* data, size_t len) {
    auto* o = static_cast<Bytes*>(user);
    o->insert(o->end(), data, data + len);
  };
  static olf_ctx_t ctx;  // ~1 KiB, as firmware would hold it
  olf_init(&ctx, &config);

  std::mt19937 rng(5);
  Bytes hello = EncodeFrame(Frame{OLF_PROTOCOL_VERSION, OLF_MSG_HELLO, 1, {}});
  Bytes corrupt = hello;
  corrupt[3] ^= 0x40;
  const Bytes garbage = RandomBytes(rng, 500, 0.0);  // longer than the rx buffer
  olf_feed_bytes(&ctx, garbage.data(), garbage.size());
  olf_feed_bytes(&ctx, corrupt.data(), corrupt.size());
  EXPECT_TRUE(out.empty());
  EXPECT_EQ(ctx.counters.crc_errors, 1u);
  EXPECT_EQ(ctx.counters.framing_errors, 1u);  // the overflowing garbage
  olf_feed_bytes(&ctx, hello.data(), hello.size());
  FrameDecoder decoder;
  int replies = 0;
  for (uint8_t b : out) {
    if (std::optional<Frame> f = decoder.Feed(b)) {
      EXPECT_EQ(f->type, OLF_MSG_ACK);
      EXPECT_EQ(f->seq, 1);
      ++replies;
    }
  }
  EXPECT_EQ(replies, 1);
}

}  // namespace
}  // namespace odocal::robot_link
