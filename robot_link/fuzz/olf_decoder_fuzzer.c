/* libFuzzer target for the robot-side decoder and request handlers.
 *
 * Input byte 0 picks the mode:
 *   even: the rest is fed to olf_feed() as raw line bytes (framing, COBS,
 *         CRC, overflow, resync);
 *   odd:  the rest is split at 0xFF bytes into payloads (version, type,
 *         seq, body) that the harness frames correctly (length byte, CRC,
 *         COBS), so the request handlers see deep input, not CRC failures.
 *   bit 1 set: storage writes fail (persist errors on commit/set/rollback);
 *   bit 2 set (framed mode): "assisted" requests, so the fuzzer reaches the
 *         commit and persistence paths it could never guess its way into:
 *         for PARAM_GET/PARAM_SET/STAGE_PUT the first body byte picks a
 *         table name that the harness writes out; for COMMIT an odd first
 *         body byte is replaced by the CRC-32 of the staged set.
 * After every frame the harness may finish a running run and emit telemetry.
 *
 * Invariants checked (abort, which libFuzzer reports as a crash):
 *   - every byte sequence the library writes decodes as COBS and passes its
 *     CRC and length check;
 *   - the active and previous sets are always within the table ranges;
 *   - ASan/UBSan: no out-of-bounds access, no undefined behaviour.
 */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "odolink/olf.h"

static uint8_t g_storage[OLF_STORAGE_SIZE];
static int g_storage_fails;
static int g_run_started;

static void on_write(void* user, const uint8_t* data, size_t len) {
  uint8_t decoded[OLF_MAX_ENCODED];
  size_t start = 0, i;
  (void)user;
  /* Split at delimiters and check every frame. */
  for (i = 0; i <= len; ++i) {
    if (i == len || data[i] == 0) {
      if (i > start) {
        int n = olf_cobs_decode(data + start, i - start, decoded, sizeof decoded);
        uint16_t crc;
        if (n < (int)(OLF_HEADER_SIZE + OLF_CRC_SIZE)) abort();
        crc = (uint16_t)((decoded[n - 2] << 8) | decoded[n - 1]);
        if (olf_crc16(decoded, (size_t)n - 2) != crc) abort();
        if (decoded[4] != n - (int)OLF_HEADER_SIZE - (int)OLF_CRC_SIZE) abort();
      }
      start = i + 1;
    }
  }
}

static int on_start(void* user, const olf_run_cmd_t* cmd) {
  (void)user;
  (void)cmd;
  g_run_started = 1;
  return 1;
}
static void on_stop(void* user) { (void)user; }
static void on_params(void* user, const olf_params_t* p) {
  (void)user;
  if (!olf_params_valid(p)) abort();
}
static int st_read(void* user, uint32_t off, uint8_t* d, uint32_t n) {
  (void)user;
  if (off + n > sizeof g_storage) abort();
  memcpy(d, g_storage + off, n);
  return 1;
}
static int st_write(void* user, uint32_t off, const uint8_t* d, uint32_t n) {
  (void)user;
  if (off + n > sizeof g_storage) abort();
  if (g_storage_fails) return 0;
  memcpy(g_storage + off, d, n);
  return 1;
}

/* Rewrites an assisted request into `out` (see the top comment); returns
 * the new length. */
static size_t assist(const olf_ctx_t* ctx, const uint8_t* p, size_t n, uint8_t* out,
                     size_t cap) {
  const uint8_t type = n > 1 ? p[1] : 0;
  if (n < 5 || cap < n + OLF_MAX_NAME + 4) return 0;
  memcpy(out, p, 4);
  if (type == OLF_MSG_PARAM_GET || type == OLF_MSG_PARAM_SET || type == OLF_MSG_STAGE_PUT) {
    const char* name = olf_param_table()[p[4] % OLF_PARAM_COUNT].name;
    const size_t len = strlen(name);
    out[4] = (uint8_t)len;
    memcpy(out + 5, name, len);
    memcpy(out + 5 + len, p + 5, n - 5);
    return n + len;
  }
  if (type == OLF_MSG_COMMIT && (p[4] & 1)) {
    const uint32_t crc = olf_params_crc(&ctx->staged);
    out[4] = (uint8_t)crc;
    out[5] = (uint8_t)(crc >> 8);
    out[6] = (uint8_t)(crc >> 16);
    out[7] = (uint8_t)(crc >> 24);
    memcpy(out + 8, p + 5, n - 5);
    return n + 3;
  }
  memcpy(out, p, n);
  return n;
}

static void feed_framed(olf_ctx_t* ctx, const uint8_t* p, size_t n) {
  uint8_t payload[OLF_MAX_PAYLOAD + OLF_CRC_SIZE];
  uint8_t wire[OLF_MAX_ENCODED + 2];
  size_t len, enc;
  uint16_t crc;
  if (n < 4 || n - 4 > OLF_MAX_PAYLOAD - OLF_HEADER_SIZE) return;
  memcpy(payload, p, 4);            /* version, type, seq */
  payload[4] = (uint8_t)(n - 4);    /* body length */
  memcpy(payload + 5, p + 4, n - 4);
  len = n + 1;
  crc = olf_crc16(payload, len);
  payload[len] = (uint8_t)(crc >> 8);
  payload[len + 1] = (uint8_t)crc;
  wire[0] = 0;
  enc = olf_cobs_encode(payload, len + 2, wire + 1, sizeof wire - 2);
  if (enc == 0) abort();
  wire[enc + 1] = 0;
  olf_feed_bytes(ctx, wire, enc + 2);
}

static void check(const olf_ctx_t* ctx) {
  if (!olf_params_valid(&ctx->active)) abort();
  if (ctx->has_previous && !olf_params_valid(&ctx->previous)) abort();
  if (ctx->rx_len > sizeof ctx->rx) abort();
}

int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static olf_ctx_t ctx;
  olf_config_t config;
  olf_telemetry_t t;
  size_t i, start;
  uint32_t now = 0;
  if (size < 1) return 0;
  memset(&config, 0, sizeof config);
  memset(g_storage, 0xFF, sizeof g_storage);
  g_storage_fails = (data[0] & 2) != 0;
  g_run_started = 0;
  config.robot_name = "fuzz";
  config.defaults.left_wheel_diameter_mm = 72.0;
  config.defaults.right_wheel_diameter_mm = 72.0;
  config.defaults.track_mm = 270.0;
  config.defaults.ticks_per_rev = 4096;
  config.storage.read = st_read;
  config.storage.write = st_write;
  config.callbacks.write = on_write;
  config.callbacks.start_run = on_start;
  config.callbacks.stop = on_stop;
  config.callbacks.params_applied = on_params;
  olf_init(&ctx, &config);
  memset(&t, 0, sizeof t);

  if ((data[0] & 1) == 0) {
    for (i = 1; i < size; ++i) {
      olf_feed(&ctx, data[i]);
      check(&ctx);
    }
  } else {
    start = 1;
    for (i = 1; i <= size; ++i) {
      if (i == size || data[i] == 0xFF) {
        if (data[0] & 4) {
          uint8_t assisted[OLF_MAX_PAYLOAD + OLF_MAX_NAME + 8];
          const size_t m = assist(&ctx, data + start, i - start, assisted, sizeof assisted);
          if (m > 0) feed_framed(&ctx, assisted, m);
        } else {
          feed_framed(&ctx, data + start, i - start);
        }
        check(&ctx);
        start = i + 1;
        now += 7;
        t.t_ms = now;
        olf_emit_telemetry(&ctx, &t);
        if (g_run_started && (now % 3) == 0) {
          olf_run_complete(&ctx, OLF_RUN_COMPLETED, &t);
          g_run_started = 0;
        }
      }
    }
  }
  /* A reboot must load whatever was persisted, and it must be valid. */
  olf_init(&ctx, &config);
  check(&ctx);
  return 0;
}
