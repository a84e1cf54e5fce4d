/* Checksums and COBS for the robot side. Bitwise CRC loops on purpose: a
 * 256-entry table costs 512 B / 1 KiB of flash on a small MCU, and frames are
 * short. tests/robot_link/cobs_crc_test.cc checks both against Boost.CRC. */
#include "odolink/olf.h"
#include "olf_internal.h"

uint16_t olf_crc16(const uint8_t* data, size_t len) {
  uint16_t crc = 0xFFFFu;
  size_t i;
  int bit;
  for (i = 0; i < len; ++i) {
    crc ^= (uint16_t)((uint16_t)data[i] << 8);
    for (bit = 0; bit < 8; ++bit) {
      crc = (crc & 0x8000u) ? (uint16_t)((crc << 1) ^ 0x1021u) : (uint16_t)(crc << 1);
    }
  }
  return crc;
}

uint32_t olf_crc32_update(uint32_t crc, const uint8_t* data, size_t len) {
  size_t i;
  int bit;
  for (i = 0; i < len; ++i) {
    crc ^= data[i];
    for (bit = 0; bit < 8; ++bit) {
      crc = (crc & 1u) ? ((crc >> 1) ^ 0xEDB88320u) : (crc >> 1);
    }
  }
  return crc;
}

uint32_t olf_crc32(const uint8_t* data, size_t len) {
  return olf_crc32_finish(olf_crc32_update(OLF_CRC32_START, data, len));
}

size_t olf_cobs_encode(const uint8_t* in, size_t len, uint8_t* out, size_t out_cap) {
  size_t read = 0;
  size_t write = 1;
  size_t code_pos = 0;
  uint8_t code = 1;
  if (out_cap < 1) return 0;
  while (read < len) {
    if (in[read] == 0) {
      out[code_pos] = code;
      code = 1;
      code_pos = write++;
      if (code_pos >= out_cap) return 0;
      ++read;
    } else {
      if (write >= out_cap) return 0;
      out[write++] = in[read++];
      ++code;
      if (code == 0xFF) {
        out[code_pos] = code;
        code = 1;
        code_pos = write++;
        /* A block that ends exactly at the input end still needs its code
         * byte; the check below covers it. */
        if (code_pos >= out_cap) return 0;
      }
    }
  }
  out[code_pos] = code;
  return write;
}

int olf_cobs_decode(const uint8_t* in, size_t len, uint8_t* out, size_t out_cap) {
  size_t read = 0;
  size_t write = 0;
  while (read < len) {
    uint8_t code = in[read++];
    uint8_t i;
    if (code == 0) return -1;
    for (i = 1; i < code; ++i) {
      if (read >= len || in[read] == 0 || write >= out_cap) return -1;
      out[write++] = in[read++];
    }
    /* A code below 0xFF stands for a zero, except after the last block. */
    if (code != 0xFF && read < len) {
      if (write >= out_cap) return -1;
      out[write++] = 0;
    }
  }
  return (int)write;
}
