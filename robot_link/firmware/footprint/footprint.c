/* What the library costs a firmware: built twice per target, once using every
 * entry point with the thinnest callbacks (this file), once with
 * -DOLF_FOOTPRINT_BASELINE (the same program without the library). The
 * difference in flash (text + data) and RAM (data + bss, the context
 * included: it is a static here as in a real firmware) is what
 * footprint_check.cmake holds to the budget. */
#include <stdint.h>

#ifndef OLF_FOOTPRINT_BASELINE
#include <string.h>

#include "odolink/olf.h"

static olf_ctx_t ctx;
#endif

static volatile uint8_t io; /* stands for a UART data register */

#ifndef OLF_FOOTPRINT_BASELINE
static void write_bytes(void* user, const uint8_t* data, size_t len) {
  (void)user;
  while (len--) io = *data++;
}
static int start_run(void* user, const olf_run_cmd_t* cmd) {
  (void)user;
  return cmd->procedure != 0;
}
static void stop(void* user) { (void)user; }
static void params_applied(void* user, const olf_params_t* params) {
  (void)user;
#if OLF_SOFT_F64
  { /* Library code where double is 32 bits, so counted; its bytes, no float maths. */
    const float track = olf_f64_to_float(params->track_mm);
    uint8_t bytes[sizeof track];
    memcpy(bytes, &track, sizeof track);
    io = bytes[0];
  }
#else
  /* Where double is binary64 the conversions are the compiler's (libgcc's
   * soft double on a part without FPU): the firmware's cost, not counted. */
  io = (uint8_t)params->ticks_per_rev;
#endif
}
static int storage_read(void* user, uint32_t offset, uint8_t* data, uint32_t len) {
  (void)user;
  (void)offset;
  while (len--) *data++ = io;
  return 1;
}
static int storage_write(void* user, uint32_t offset, const uint8_t* data, uint32_t len) {
  (void)user;
  (void)offset;
  while (len--) io = *data++;
  return 1;
}
#endif

int main(void) {
#ifndef OLF_FOOTPRINT_BASELINE
  olf_config_t config;
  olf_telemetry_t sample = {0, 0, 0, 0.0, 0.0, 0.0};
  config.robot_name = "robot";
#if OLF_SOFT_F64
  config.defaults.left_wheel_diameter_mm = olf_f64_from_float(72.0f);
  config.defaults.right_wheel_diameter_mm = olf_f64_from_float(72.0f);
  config.defaults.track_mm = olf_f64_from_float(270.0f);
#else
  config.defaults.left_wheel_diameter_mm = 72.0;
  config.defaults.right_wheel_diameter_mm = 72.0;
  config.defaults.track_mm = 270.0;
#endif
  config.defaults.ticks_per_rev = 4096;
  config.storage.read = storage_read;
  config.storage.write = storage_write;
  config.storage.user = 0;
  config.callbacks.write = write_bytes;
  config.callbacks.start_run = start_run;
  config.callbacks.stop = stop;
  config.callbacks.params_applied = params_applied;
  config.callbacks.user = 0;
  olf_init(&ctx, &config);
#endif
  for (;;) {
    const uint8_t byte = io;
#ifndef OLF_FOOTPRINT_BASELINE
    olf_feed(&ctx, byte);
    sample.t_ms += 1;
    olf_emit_telemetry(&ctx, &sample);
    if (byte == 0x55) olf_run_complete(&ctx, OLF_RUN_COMPLETED, &sample);
#else
    io = (uint8_t)(byte + 1);
#endif
  }
}
