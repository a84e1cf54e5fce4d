/*
 * olf: the robot side of the odolink serial protocol, as a portable C99
 * library that robot firmware compiles in (the odocal virtual robot runs the
 * same code behind a pseudo-terminal, so what is tested is what ships).
 *
 * What it does: byte-in / bytes-out framing (COBS + CRC-16), requests with
 * idempotent retries, the parameter table, and the staged / active / previous
 * parameter sets with all-or-nothing persistence through a storage callback.
 * What it does not do: motion. It calls the firmware's callbacks (start a run,
 * stop, parameters applied) and offers olf_emit_telemetry() and
 * olf_run_complete() for the firmware's main loop.
 *
 * Constraints: no heap, no OS calls, no floating-point maths beyond range
 * checks, fixed buffers inside olf_ctx_t (about 500 B on AVR, 600 B on a
 * 32-bit part; the caller owns it, typically as a static). Not reentrant: call every olf_* function on one
 * context from the same execution context (main loop, not an ISR; an ISR
 * should only queue received bytes).
 *
 * Units: parameters in millimetres and encoder ticks, as their names say;
 * poses in millimetres and radians in the odometry frame (REP-103: x forward,
 * y left, heading counter-clockwise positive, origin = pose at run start).
 *
 * Portability: C99 with <stdint.h>; `int` may be 16 bits, nothing is read
 * unaligned, the wire is little-endian whatever the CPU is. Parameters are
 * IEEE-754 binary64 on the wire and in storage, bit for bit, on every target:
 * where the compiler's `double` is binary64 they are plain doubles; where it is
 * 32 bits (avr-gcc) they are held as binary64 bit patterns (olf_f64_t below),
 * compared exactly, and turned into a float only for the firmware's maths.
 */
#ifndef ODOLINK_OLF_H_
#define ODOLINK_OLF_H_

#include <float.h>
#include <stddef.h>
#include <stdint.h>

#include "odolink/olf_wire.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ---- Checksums (bitwise loops: small flash footprint, no table) -------- */

/* CRC-16/CCITT-FALSE: poly 0x1021, init 0xFFFF, no reflection, no xorout.
 * Check value ("123456789") 0x29B1. Protects every frame. */
uint16_t olf_crc16(const uint8_t* data, size_t len);
/* CRC-32 (IEEE 802.3, zlib): reflected poly 0xEDB88320, init and xorout
 * 0xFFFFFFFF. Check value 0xCBF43926. Protects whole parameter sets and the
 * storage records. */
uint32_t olf_crc32(const uint8_t* data, size_t len);

/* ---- COBS (Consistent Overhead Byte Stuffing) -------------------------- */

/* Encodes `len` bytes into `out` (no 0x00 in the output, no delimiter
 * appended). Returns the encoded length, or 0 if `out_cap` is too small.
 * In place is allowed when len < 254 and out <= in - 1: the output never
 * overtakes the input. */
size_t olf_cobs_encode(const uint8_t* in, size_t len, uint8_t* out, size_t out_cap);
/* Decodes one COBS block (without its delimiter); in place (out == in) is
 * allowed. Returns the decoded length,
 * or -1 if the block is malformed (contains 0x00, a code runs past the end)
 * or does not fit in `out_cap`. */
int olf_cobs_decode(const uint8_t* in, size_t len, uint8_t* out, size_t out_cap);

/* ---- Numbers ---------------------------------------------------------- */

/* olf_f64_t: an IEEE-754 binary64 value. OLF_SOFT_F64 is 1 where `double` is
 * not binary64 (avr-gcc before 10 makes it 32 bits); then the value is kept as
 * its bit pattern, which the library copies and range-checks exactly, so a
 * pushed set and its checksum survive the round trip bit for bit (and an
 * 8-bit CPU does no 64-bit arithmetic to move it). A build may
 * force OLF_SOFT_F64=1 on any target (the host tests do, to run this path);
 * the library and the code including this header must agree. */
#ifndef OLF_SOFT_F64
#if FLT_RADIX == 2 && DBL_MANT_DIG == 53 && DBL_MAX_EXP == 1024
#define OLF_SOFT_F64 0
#else
#define OLF_SOFT_F64 1
#endif
#endif

#if OLF_SOFT_F64
typedef struct {
  /* The binary64 encoding, little-endian, exactly as on the wire. A struct,
   * so that arithmetic on it does not compile. */
  uint8_t le[8];
} olf_f64_t;
#else
typedef double olf_f64_t;
#endif

/* Round to nearest (ties to even), as a hardware conversion would: what the
 * firmware's float maths uses. Exact where float can hold the value. */
float olf_f64_to_float(olf_f64_t value);
/* Exact: every float is a binary64 value. */
olf_f64_t olf_f64_from_float(float value);

/* ---- Parameters ------------------------------------------------------- */

/* The parameter set, in the firmware's units. The table below maps names and
 * wire types onto these fields; the canonical serialization (for checksums
 * and storage) is the table order, f64 as 8 bytes and u32 as 4 bytes, LE. */
typedef struct {
  olf_f64_t left_wheel_diameter_mm;
  olf_f64_t right_wheel_diameter_mm;
  olf_f64_t track_mm;
  uint32_t ticks_per_rev;
} olf_params_t;

#define OLF_PARAM_COUNT 4u
#define OLF_PARAMS_SERIALIZED_SIZE 28u

typedef struct {
  const char* name;
  uint8_t type;      /* enum olf_param_type */
  size_t offset;     /* offsetof(olf_params_t, field) */
  /* Inclusive; NaN is always out of range. Both are exact in binary32 too, so
   * a target with a 32-bit double checks the same bounds (tested). */
  double min_value;
  double max_value;
} olf_param_desc_t;

const olf_param_desc_t* olf_param_table(void);
/* Index of `name` (not NUL-terminated, `len` bytes) or -1. */
int olf_param_find(const char* name, size_t len);
/* Canonical bytes of a set; `out` holds OLF_PARAMS_SERIALIZED_SIZE bytes. */
void olf_params_serialize(const olf_params_t* params, uint8_t* out);
void olf_params_deserialize(const uint8_t* in, olf_params_t* params);
/* CRC-32 of the canonical bytes: the checksum a commit must quote. */
uint32_t olf_params_crc(const olf_params_t* params);
/* CRC-32 over the table's names and types (what the host checks in Hello to
 * know it talks to a firmware with the same parameter table). */
uint32_t olf_param_table_crc(void);
/* 1 if every value is within its table range. */
int olf_params_valid(const olf_params_t* params);

/* ---- Storage (flash, EEPROM, a file) ---------------------------------- */

/* Two slots of OLF_STORAGE_SLOT_SIZE bytes at offsets 0 and
 * OLF_STORAGE_SLOT_SIZE. A record is written whole into the slot that does not
 * hold the current record, with a generation number one higher and a CRC-32 at
 * its end; on boot the valid record with the highest generation wins. A power
 * cut at any byte therefore leaves the old record intact and the new one
 * either complete or failing its CRC: the old set or the new, never a mix.
 * Write-new-then-switch, with the switch being the generation number. */
#define OLF_STORAGE_SLOT_SIZE 128u
#define OLF_STORAGE_SIZE (2u * OLF_STORAGE_SLOT_SIZE)
#define OLF_STORAGE_RECORD_SIZE 70u

typedef struct {
  /* Both return 1 on success, 0 on failure. `write` may fail part-way (power
   * cut); the library then reports OLF_ERR_STORAGE and keeps the old set. */
  int (*read)(void* user, uint32_t offset, uint8_t* data, uint32_t len);
  int (*write)(void* user, uint32_t offset, const uint8_t* data, uint32_t len);
  void* user;
} olf_storage_t;

enum olf_boot_source { OLF_BOOT_DEFAULTS = 0, OLF_BOOT_SLOT_A = 1, OLF_BOOT_SLOT_B = 2 };

/* ---- Runs ------------------------------------------------------------- */

/* Runs and telemetry use the target's `double` (a float on AVR): they are
 * commands and measurements, not values that must survive bit for bit. */
typedef struct {
  uint16_t run_id;
  uint8_t procedure; /* enum olf_procedure */
  uint8_t direction; /* enum olf_direction */
  double amount_mm;  /* side (umbmark), distance (straight, out_and_back) */
  uint32_t count;    /* turns (spin), repeats (out_and_back) */
  /* The run's speeds; 0: the robot's own default. Optional on the wire (a
   * 14-byte RUN_START body carries none). */
  uint16_t speed_mm_s;          /* straights */
  uint16_t turn_rate_ddeg_s;    /* in-place turns, 0.1 deg/s */
} olf_run_cmd_t;

typedef struct {
  uint32_t t_ms;      /* robot clock */
  int32_t left_ticks; /* encoder counts since run start */
  int32_t right_ticks;
  double x_mm;        /* odometry pose in the run's start frame */
  double y_mm;
  double heading_rad;
} olf_telemetry_t;

/* ---- Context ----------------------------------------------------------- */

typedef struct {
  /* Bytes out (a UART, a pty). Called synchronously from olf_feed() and the
   * emit functions with one whole frame, delimiters included. */
  void (*write)(void* user, const uint8_t* data, size_t len);
  /* Start motion; return 0 to refuse (the host gets OLF_ERR_REJECTED). */
  int (*start_run)(void* user, const olf_run_cmd_t* cmd);
  /* Immediate stop. The firmware must still call olf_run_complete() (status
   * OLF_RUN_STOPPED) once the robot stands still: that ends the run. */
  void (*stop)(void* user);
  /* The active set changed (boot, commit, set, rollback). */
  void (*params_applied)(void* user, const olf_params_t* params);
  void* user;
} olf_callbacks_t;

typedef struct {
  const char* robot_name;          /* up to OLF_MAX_NAME bytes are sent */
  olf_params_t defaults;           /* used when storage holds no valid record */
  olf_storage_t storage;           /* read/write may be NULL: nothing persists */
  olf_callbacks_t callbacks;
} olf_config_t;

typedef struct {
  uint32_t frames_ok;
  uint32_t crc_errors;
  uint32_t framing_errors; /* COBS errors, overflows, runt frames */
  uint32_t retries_answered_from_cache;
  uint32_t commits;
  uint32_t storage_failures;
} olf_counters_t;

typedef struct {
  olf_config_t config;

  /* Receive: encoded bytes until the 0x00 delimiter, then decoded in place
   * (COBS never writes ahead of where it reads). */
  uint8_t rx[OLF_MAX_ENCODED];
  size_t rx_len;
  int rx_overflow; /* drop everything until the next delimiter */

  /* Transmit: a payload is built at tx + 3 and COBS-encoded in place to
   * tx + 1 (the encoder writes at most one byte ahead of where it reads, for
   * payloads under 254 bytes), framed by delimiters at both ends. The last
   * reply, encoded, is kept for idempotent retries. */
  uint8_t tx[OLF_MAX_ENCODED + 2];
  uint8_t cached_reply[OLF_MAX_ENCODED + 2];
  size_t cached_reply_len;
  uint16_t cached_seq;
  uint16_t cached_request_crc;
  int has_cached_reply;

  /* Parameter sets. */
  olf_params_t active;
  olf_params_t staged;
  uint32_t staged_mask; /* bit i set: parameter i staged */
  olf_params_t previous;
  int has_previous;
  uint32_t storage_generation;
  int storage_slot; /* slot of the current record, -1 if none */
  int boot_source;  /* enum olf_boot_source */

  /* Runs and events. */
  uint8_t state; /* enum olf_run_state */
  uint16_t run_id;
  uint16_t last_run_id;
  uint8_t last_run_status;
  olf_telemetry_t last_run_end;
  uint16_t telemetry_rate_hz;
  uint32_t last_telemetry_ms;
  int telemetry_sent;
  uint16_t event_seq;

  olf_counters_t counters;
} olf_ctx_t;

/* Copies `config` (robot_name must stay valid), loads the persisted set (or
 * the defaults), then calls params_applied. Also the reboot path. */
void olf_init(olf_ctx_t* ctx, const olf_config_t* config);
/* One received byte. Complete frames are handled right here (replies go out
 * through callbacks.write before this returns). */
void olf_feed(olf_ctx_t* ctx, uint8_t byte);
void olf_feed_bytes(olf_ctx_t* ctx, const uint8_t* data, size_t len);

/* Sends a telemetry event if a run is in progress and the configured rate
 * allows one now (sample.t_ms is the clock). Returns 1 if sent. */
int olf_emit_telemetry(olf_ctx_t* ctx, const olf_telemetry_t* sample);
/* The run ended (status: enum olf_run_status) at odometry pose `end`. Sends
 * the run-complete event, remembers it for OLF_MSG_STATUS, returns to idle. */
void olf_run_complete(olf_ctx_t* ctx, uint8_t status, const olf_telemetry_t* end);

#ifdef __cplusplus
}
#endif

#endif /* ODOLINK_OLF_H_ */
