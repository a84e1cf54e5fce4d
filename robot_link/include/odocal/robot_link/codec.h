// Host-side framing of the odolink protocol (see docs/protocol.md):
//   wire frame = 0x00, COBS(version u8, type u8, seq u16 LE, body_len u8, body, CRC-16 BE), 0x00
// CRC-16/CCITT-FALSE and CRC-32 come from Boost.CRC here, so the robot's
// bitwise loops are checked against an independent implementation.
#ifndef ODOCAL_ROBOT_LINK_CODEC_H_
#define ODOCAL_ROBOT_LINK_CODEC_H_

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace odocal::robot_link {

using Bytes = std::vector<uint8_t>;

uint16_t Crc16CcittFalse(std::span<const uint8_t> data);
uint32_t Crc32(std::span<const uint8_t> data);

// COBS without delimiter. Decode returns nullopt for malformed input.
Bytes CobsEncode(std::span<const uint8_t> data);
std::optional<Bytes> CobsDecode(std::span<const uint8_t> encoded);

struct Frame {
  uint8_t version = 0;
  uint8_t type = 0;
  uint16_t seq = 0;
  Bytes body;
};

// The complete wire bytes of a frame, both delimiters included.
Bytes EncodeFrame(const Frame& frame);

// Hex dump "00 0a 01 ..." for messages and docs.
std::string ToHex(std::span<const uint8_t> data);

// Byte-at-a-time decoder that resynchronises on every 0x00.
class FrameDecoder {
 public:
  struct Counters {
    uint64_t frames = 0;
    uint64_t crc_errors = 0;
    uint64_t framing_errors = 0;  // COBS errors, runts, oversize
  };
  // Returns a frame when `byte` completes one that passes its CRC.
  std::optional<Frame> Feed(uint8_t byte);
  const Counters& counters() const { return counters_; }
  void Reset() { buffer_.clear(); }

 private:
  Bytes buffer_;
  bool overflow_ = false;
  Counters counters_;
};

// Little-endian writer/reader for message bodies.
class ByteWriter {
 public:
  ByteWriter& U8(uint8_t v);
  ByteWriter& U16(uint16_t v);
  ByteWriter& U32(uint32_t v);
  ByteWriter& F64(double v);
  ByteWriter& Str8(const std::string& s);  // length u8, then the bytes
  Bytes Take() { return std::move(bytes_); }

 private:
  Bytes bytes_;
};

class ByteReader {
 public:
  explicit ByteReader(std::span<const uint8_t> data) : data_(data) {}
  // Each returns false once the data is exhausted; values are then zero.
  bool U8(uint8_t* v);
  bool U16(uint16_t* v);
  bool U32(uint32_t* v);
  bool I32(int32_t* v);
  bool F64(double* v);
  bool Str8(std::string* s);
  bool AtEnd() const { return at_ == data_.size(); }
  size_t remaining() const { return data_.size() - at_; }

 private:
  std::span<const uint8_t> data_;
  size_t at_ = 0;
};

}  // namespace odocal::robot_link

#endif  // ODOCAL_ROBOT_LINK_CODEC_H_
