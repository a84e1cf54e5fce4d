#include "motion_stub.h"

#include <math.h>

#include "tick.h"

/* The motion code works in float, which is what an 8-bit part computes
 * with. Parameters arrive as olf_f64_t (binary64 bits on AVR): converted with
 * olf_f64_to_float. Run amounts and poses are the target's double (a float
 * on avr-gcc 5). */

#define TWO_PI 6.28318530718f
#define HALF_PI 1.57079632679f
#define PI_F 3.14159265359f

/* How long the stub's runs last: a fixed part plus a little per millimetre
 * of path and per full turn, so a 4 m UMBmark square takes about a second. */
#define RUN_BASE_MS 300u
#define RUN_MS_PER_M 100.0f
#define RUN_MS_PER_TURN 200.0f

static motion_calibration_t calibration;

static struct {
  int active;
  int stop_requested;
  uint32_t start_ms;
  uint32_t duration_ms;
  uint8_t procedure;
  float sign;        /* +1 counter-clockwise, -1 clockwise */
  float amount_mm;
  uint32_t count;
  float path_mm;     /* total signed path length */
  float turn_rad;    /* total signed heading change */
} run;

void motion_params_applied(void* user, const olf_params_t* params) {
  const float ticks = (float)params->ticks_per_rev;
  (void)user;
  /* This is where a real firmware picks up a calibration: the odometry and
   * the speed loops use mm per tick, not diameters. */
  calibration.left_mm_per_tick = PI_F * olf_f64_to_float(params->left_wheel_diameter_mm) / ticks;
  calibration.right_mm_per_tick = PI_F * olf_f64_to_float(params->right_wheel_diameter_mm) / ticks;
  calibration.track_mm = olf_f64_to_float(params->track_mm);
}

const motion_calibration_t* motion_calibration(void) { return &calibration; }

int motion_start_run(void* user, const olf_run_cmd_t* cmd) {
  float turns;
  (void)user;
  if (run.active) return 0; /* the library says BUSY first; belt and braces */
  run.procedure = cmd->procedure;
  run.sign = cmd->direction == OLF_DIR_CCW ? 1.0f : -1.0f;
  run.amount_mm = (float)cmd->amount_mm;
  run.count = cmd->count;
  switch (cmd->procedure) {
    case OLF_PROC_STRAIGHT:
      run.path_mm = run.amount_mm;
      run.turn_rad = 0.0f;
      break;
    case OLF_PROC_SPIN:
      run.path_mm = 0.0f;
      run.turn_rad = run.sign * TWO_PI * (float)run.count;
      break;
    case OLF_PROC_UMBMARK:
      run.path_mm = 4.0f * run.amount_mm;
      run.turn_rad = run.sign * TWO_PI;
      break;
    case OLF_PROC_OUT_AND_BACK:
      run.path_mm = 2.0f * run.amount_mm * (float)run.count;
      run.turn_rad = run.sign * PI_F * 2.0f * (float)run.count;
      break;
    default:
      return 0;
  }
  turns = fabsf(run.turn_rad) / TWO_PI;
  run.duration_ms = RUN_BASE_MS + (uint32_t)(fabsf(run.path_mm) * (RUN_MS_PER_M / 1000.0f) +
                                             turns * RUN_MS_PER_TURN);
  run.start_ms = bsp_millis();
  run.stop_requested = 0;
  run.active = 1;
  /* Your motion code here: enable the motor drivers, start the profile. */
  return 1;
}

void motion_stop(void* user) {
  (void)user;
  /* Your motion code here: brake now; report once the robot stands still. */
  run.stop_requested = 1;
}

/* The nominal pose after `fraction` (0..1) of the run: the path a perfect
 * robot drives. Corners are turned on the spot and take no time here. */
static void nominal_pose(float fraction, float* x, float* y, float* heading, float* path) {
  const float a = run.amount_mm;
  *x = 0.0f;
  *y = 0.0f;
  *heading = 0.0f;
  *path = fraction * run.path_mm;
  switch (run.procedure) {
    case OLF_PROC_STRAIGHT:
      *x = *path;
      break;
    case OLF_PROC_SPIN:
      *heading = fraction * run.turn_rad;
      break;
    case OLF_PROC_UMBMARK: {
      /* Square: legs along +x, then turning by sign * 90 degrees. */
      const float s = *path;
      uint8_t leg = (uint8_t)(s / a);
      float along;
      if (leg > 3u) leg = 3u;
      along = s - (float)leg * a;
      *heading = run.sign * HALF_PI * (float)leg;
      *x = (leg == 1u || leg == 2u) ? a : 0.0f;
      *y = (leg >= 2u) ? run.sign * a : 0.0f;
      *x += along * cosf(*heading);
      *y += along * sinf(*heading);
      if (fraction >= 1.0f) *heading = run.turn_rad;
      break;
    }
    case OLF_PROC_OUT_AND_BACK: {
      const float s = *path;
      uint32_t leg = (uint32_t)(s / a);
      float along;
      if (leg >= 2u * run.count) leg = 2u * run.count - 1u;
      along = s - (float)leg * a;
      *x = (leg & 1u) ? a - along : along;
      *heading = run.sign * PI_F * (float)leg;
      if (fraction >= 1.0f) *heading = run.turn_rad;
      break;
    }
    default:
      break;
  }
}

static void sample(uint32_t now_ms, float fraction, olf_telemetry_t* t) {
  float x, y, heading, path, half_turn;
  nominal_pose(fraction, &x, &y, &heading, &path);
  /* Wheel paths: the centre's path, each wheel off by the heading change
   * times half the track (left is the inside of a counter-clockwise turn). */
  half_turn = heading * calibration.track_mm * 0.5f;
  t->t_ms = now_ms;
  t->left_ticks = (int32_t)lroundf((path - half_turn) / calibration.left_mm_per_tick);
  t->right_ticks = (int32_t)lroundf((path + half_turn) / calibration.right_mm_per_tick);
  t->x_mm = x;
  t->y_mm = y;
  t->heading_rad = heading;
}

void motion_poll(olf_ctx_t* ctx, uint32_t now_ms) {
  olf_telemetry_t t;
  uint32_t elapsed;
  float fraction;
  if (!run.active) return;
  elapsed = now_ms - run.start_ms;
  fraction = elapsed >= run.duration_ms ? 1.0f : (float)elapsed / (float)run.duration_ms;
  sample(now_ms, fraction, &t);
  if (run.stop_requested) {
    run.active = 0;
    olf_run_complete(ctx, OLF_RUN_STOPPED, &t);
  } else if (fraction >= 1.0f) {
    run.active = 0;
    olf_run_complete(ctx, OLF_RUN_COMPLETED, &t);
  } else {
    (void)olf_emit_telemetry(ctx, &t);
  }
}
