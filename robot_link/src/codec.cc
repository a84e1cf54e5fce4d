#include "odocal/robot_link/codec.h"

#include <cassert>
#include <cstdio>
#include <cstring>

#include <boost/crc.hpp>

#include "odolink/olf_wire.h"

namespace odocal::robot_link {

uint16_t Crc16CcittFalse(std::span<const uint8_t> data) {
  boost::crc_optimal<16, 0x1021, 0xFFFF, 0, false, false> crc;
  crc.process_bytes(data.data(), data.size());
  return crc.checksum();
}

uint32_t Crc32(std::span<const uint8_t> data) {
  boost::crc_32_type crc;
  crc.process_bytes(data.data(), data.size());
  return crc.checksum();
}

Bytes CobsEncode(std::span<const uint8_t> data) {
  // Blocks of up to 254 non-zero bytes, each led by (length + 1); a block of
  // fewer than 254 bytes stands for "these bytes, then a zero".
  Bytes out;
  out.reserve(data.size() + data.size() / 254 + 2);
  size_t code_at = 0;
  out.push_back(0);
  uint8_t code = 1;
  for (uint8_t b : data) {
    if (b == 0) {
      out[code_at] = code;
      code_at = out.size();
      out.push_back(0);
      code = 1;
      continue;
    }
    out.push_back(b);
    if (++code == 0xFF) {
      out[code_at] = code;
      code_at = out.size();
      out.push_back(0);
      code = 1;
    }
  }
  out[code_at] = code;
  return out;
}

std::optional<Bytes> CobsDecode(std::span<const uint8_t> encoded) {
  Bytes out;
  size_t i = 0;
  while (i < encoded.size()) {
    const uint8_t code = encoded[i++];
    if (code == 0) return std::nullopt;
    for (uint8_t k = 1; k < code; ++k) {
      if (i >= encoded.size() || encoded[i] == 0) return std::nullopt;
      out.push_back(encoded[i++]);
    }
    if (code != 0xFF && i < encoded.size()) out.push_back(0);
  }
  return out;
}

Bytes EncodeFrame(const Frame& frame) {
  assert(frame.body.size() <= OLF_MAX_PAYLOAD - OLF_HEADER_SIZE);
  Bytes payload;
  payload.reserve(OLF_HEADER_SIZE + frame.body.size() + OLF_CRC_SIZE);
  payload.push_back(frame.version);
  payload.push_back(frame.type);
  payload.push_back(static_cast<uint8_t>(frame.seq));
  payload.push_back(static_cast<uint8_t>(frame.seq >> 8));
  payload.push_back(static_cast<uint8_t>(frame.body.size()));
  payload.insert(payload.end(), frame.body.begin(), frame.body.end());
  const uint16_t crc = Crc16CcittFalse(payload);
  payload.push_back(static_cast<uint8_t>(crc >> 8));
  payload.push_back(static_cast<uint8_t>(crc));
  Bytes wire;
  wire.push_back(0);  // flushes any partial garbage at the receiver
  const Bytes encoded = CobsEncode(payload);
  wire.insert(wire.end(), encoded.begin(), encoded.end());
  wire.push_back(0);
  return wire;
}

std::string ToHex(std::span<const uint8_t> data) {
  std::string s;
  char buf[4];
  for (size_t i = 0; i < data.size(); ++i) {
    std::snprintf(buf, sizeof buf, "%02x", data[i]);
    if (i > 0) s += ' ';
    s += buf;
  }
  return s;
}

std::optional<Frame> FrameDecoder::Feed(uint8_t byte) {
  if (byte != 0) {
    if (overflow_) return std::nullopt;
    if (buffer_.size() >= OLF_MAX_ENCODED) {
      overflow_ = true;
      buffer_.clear();
      return std::nullopt;
    }
    buffer_.push_back(byte);
    return std::nullopt;
  }
  if (overflow_) {
    overflow_ = false;
    ++counters_.framing_errors;
    return std::nullopt;
  }
  if (buffer_.empty()) return std::nullopt;  // back-to-back delimiters
  std::optional<Bytes> payload = CobsDecode(buffer_);
  buffer_.clear();
  if (!payload || payload->size() < OLF_HEADER_SIZE + OLF_CRC_SIZE) {
    ++counters_.framing_errors;
    return std::nullopt;
  }
  const size_t n = payload->size();
  const uint16_t crc = static_cast<uint16_t>(((*payload)[n - 2] << 8) | (*payload)[n - 1]);
  if (Crc16CcittFalse(std::span(payload->data(), n - 2)) != crc) {
    ++counters_.crc_errors;
    return std::nullopt;
  }
  if ((*payload)[4] != n - OLF_HEADER_SIZE - OLF_CRC_SIZE) {
    ++counters_.framing_errors;
    return std::nullopt;
  }
  ++counters_.frames;
  Frame f;
  f.version = (*payload)[0];
  f.type = (*payload)[1];
  f.seq = static_cast<uint16_t>((*payload)[2] | ((*payload)[3] << 8));
  f.body.assign(payload->begin() + OLF_HEADER_SIZE, payload->end() - OLF_CRC_SIZE);
  return f;
}

ByteWriter& ByteWriter::U8(uint8_t v) {
  bytes_.push_back(v);
  return *this;
}
ByteWriter& ByteWriter::U16(uint16_t v) {
  for (int i = 0; i < 2; ++i) bytes_.push_back(static_cast<uint8_t>(v >> (8 * i)));
  return *this;
}
ByteWriter& ByteWriter::U32(uint32_t v) {
  for (int i = 0; i < 4; ++i) bytes_.push_back(static_cast<uint8_t>(v >> (8 * i)));
  return *this;
}
ByteWriter& ByteWriter::F64(double v) {
  uint64_t bits;
  std::memcpy(&bits, &v, sizeof bits);
  for (int i = 0; i < 8; ++i) bytes_.push_back(static_cast<uint8_t>(bits >> (8 * i)));
  return *this;
}
ByteWriter& ByteWriter::Str8(const std::string& s) {
  bytes_.push_back(static_cast<uint8_t>(s.size()));
  bytes_.insert(bytes_.end(), s.begin(), s.end());
  return *this;
}

namespace {
template <typename T>
bool ReadLe(std::span<const uint8_t> data, size_t* at, T* out) {
  *out = T{};
  if (data.size() - *at < sizeof(T)) {
    *at = data.size();
    return false;
  }
  uint64_t v = 0;
  for (size_t i = 0; i < sizeof(T); ++i) v |= static_cast<uint64_t>(data[*at + i]) << (8 * i);
  *at += sizeof(T);
  if constexpr (sizeof(T) == 8) {
    std::memcpy(out, &v, 8);
  } else {
    *out = static_cast<T>(v);
  }
  return true;
}
}  // namespace

bool ByteReader::U8(uint8_t* v) { return ReadLe(data_, &at_, v); }
bool ByteReader::U16(uint16_t* v) { return ReadLe(data_, &at_, v); }
bool ByteReader::U32(uint32_t* v) { return ReadLe(data_, &at_, v); }
bool ByteReader::I32(int32_t* v) {
  uint32_t u;
  const bool ok = ReadLe(data_, &at_, &u);
  *v = static_cast<int32_t>(u);
  return ok;
}
bool ByteReader::F64(double* v) { return ReadLe(data_, &at_, v); }
bool ByteReader::Str8(std::string* s) {
  uint8_t n;
  s->clear();
  if (!U8(&n) || remaining() < n) {
    at_ = data_.size();
    return false;
  }
  s->assign(reinterpret_cast<const char*>(data_.data() + at_), n);
  at_ += n;
  return true;
}

}  // namespace odocal::robot_link
