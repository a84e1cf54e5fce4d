/* A stand-in for the robot's motion code: no motors, but every run the
 * library accepts "drives" for a plausible time along its nominal path, sends
 * telemetry while it lasts and completes (or stops) like real motion would.
 *
 * The callbacks below are exactly the integration points of a real firmware:
 * replace their bodies with the motor control, keep the shape. */
#ifndef ODOLINK_AVR_MOTION_STUB_H_
#define ODOLINK_AVR_MOTION_STUB_H_

#include <stdint.h>

#include "odolink/olf.h"

/* olf_callbacks_t.start_run: accepts every command (the library has already
 * validated procedure, direction, amount and count). */
int motion_start_run(void* user, const olf_run_cmd_t* cmd);
/* olf_callbacks_t.stop: the run ends with OLF_RUN_STOPPED at the next
 * motion_poll(). */
void motion_stop(void* user);
/* olf_callbacks_t.params_applied: what the motion code uses from the set. */
void motion_params_applied(void* user, const olf_params_t* params);

/* From the main loop: telemetry while a run lasts, then its completion. */
void motion_poll(olf_ctx_t* ctx, uint32_t now_ms);

/* The calibration as the motion code holds it (mm per encoder tick, per
 * wheel, and the track), for anyone curious (the board's main loop, a
 * debugger). */
typedef struct {
  float left_mm_per_tick;
  float right_mm_per_tick;
  float track_mm;
} motion_calibration_t;
const motion_calibration_t* motion_calibration(void);

#endif /* ODOLINK_AVR_MOTION_STUB_H_ */
