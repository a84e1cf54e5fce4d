/* odolink on a bare-metal Cortex-M robot: the example to copy.
 *
 * Everything a differential-drive robot needs around the olf library, in one
 * file, on top of a small board layer (bsp.h; here the LM3S6965 board in
 * targets/lm3s6965/, whose motors and encoders are simulated so this very
 * image runs under QEMU):
 *
 *   1. the encoder interrupt: quadrature decoding into signed counts;
 *   2. the parameters: params_applied() turns the active set into what the
 *      motion code uses (mm per tick per wheel, track);
 *   3. odometry: integrate the count deltas into a pose;
 *   4. runs: start_run() turns the procedure into straight and turning
 *      segments, the main loop drives them with motor commands, emits
 *      telemetry, and ends the run (completed, or stopped);
 *   5. the main loop: UART bytes into olf_feed(), motion, sleep.
 *
 * olf is not reentrant: every olf_* call happens here in the main loop; the
 * interrupts only count encoder edges and queue received bytes.
 */
#include <math.h>
#include <stdint.h>
#include <string.h>

#include "bsp.h"
#include "odolink/olf.h"

#define PI 3.14159265358979323846

/* Parameters arrive as olf_f64_t, which is a plain double on Cortex-M (the
 * compiler's double is binary64): this file does its maths in double. On a
 * target whose double is 32 bits (avr-gcc) olf_f64_t is a byte array instead;
 * convert with olf_f64_to_float() there. */
#if OLF_SOFT_F64
#error "this example expects a 64-bit double (olf_f64_t == double)"
#endif

/* Speeds when the host leaves them to the robot (RUN_START without speeds). */
#define DEFAULT_SPEED_MM_S 400u
#define DEFAULT_TURN_RATE_DDEG_S 1800u /* 180 deg/s */

/* ------------------------------------------------------------------------ */
/* 1. Encoders                                                               */
/* ------------------------------------------------------------------------ */

/* Quadrature decoding: the step for each (previous AB, new AB) pair, index
 * previous * 4 + new, with forward = 00 -> 01 -> 11 -> 10 -> 00. A jump by
 * two quarter cycles (both channels changed) means an edge was missed; it
 * counts nothing and is recorded as an error. */
static const int8_t kQuadStep[16] = {
    0, +1, -1, 0, /* from 00 */
    -1, 0, 0, +1, /* from 01 */
    +1, 0, 0, -1, /* from 10 */
    0, -1, +1, 0, /* from 11 */
};

static volatile int32_t g_enc_count[2];
static volatile uint32_t g_enc_errors;
static uint8_t g_enc_last_ab[2];

/* The encoder interrupt. On a real board this is the body of the GPIO port
 * interrupt handler for the encoder pins (both edges of A and B enabled):
 *
 *   void GPIOB_Handler(void) {
 *     uint32_t pins = GPIOB_DATA;  GPIOB_ICR = pins_that_fired;
 *     bsp_encoder_edge(BSP_WHEEL_LEFT,  (pins >> 0) & 3u);
 *     bsp_encoder_edge(BSP_WHEEL_RIGHT, (pins >> 2) & 3u);
 *   }
 *
 * A wheel mounted mirror-image (the right one, usually) counts backwards when
 * driving forward: swap its A and B here, once, and everything downstream
 * sees forward as positive. */
void bsp_encoder_edge(int wheel, unsigned ab) {
  const unsigned index = ((unsigned)g_enc_last_ab[wheel] << 2) | (ab & 3u);
  const int8_t step = kQuadStep[index];
  if (step == 0 && g_enc_last_ab[wheel] != (ab & 3u)) ++g_enc_errors;
  g_enc_count[wheel] += step;
  g_enc_last_ab[wheel] = (uint8_t)(ab & 3u);
}

/* Both counts at one instant (the encoder interrupt must not land between
 * the two reads). */
static void encoder_read(int32_t counts[2]) {
  __asm__ volatile("cpsid i" ::: "memory");
  counts[0] = g_enc_count[0];
  counts[1] = g_enc_count[1];
  __asm__ volatile("cpsie i" ::: "memory");
}

/* ------------------------------------------------------------------------ */
/* 2. Parameters                                                             */
/* ------------------------------------------------------------------------ */

/* What the motion code and the odometry use, derived from the active set. */
static struct {
  double mm_per_tick[2]; /* wheel circumference / ticks per revolution */
  double track_mm;
} g_geom;

/* olf calls this at boot and after every commit, set or rollback: the only
 * place parameters enter the robot's maths. Never during a run (olf refuses
 * parameter changes while one is in progress). */
static void on_params_applied(void* user, const olf_params_t* p) {
  (void)user;
  g_geom.mm_per_tick[BSP_WHEEL_LEFT] = PI * (double)p->left_wheel_diameter_mm / (double)p->ticks_per_rev;
  g_geom.mm_per_tick[BSP_WHEEL_RIGHT] =
      PI * (double)p->right_wheel_diameter_mm / (double)p->ticks_per_rev;
  g_geom.track_mm = (double)p->track_mm;
}

/* ------------------------------------------------------------------------ */
/* 3. Odometry                                                               */
/* ------------------------------------------------------------------------ */

static struct {
  int32_t origin[2]; /* counts at run start */
  int32_t last[2];   /* counts at the last update */
  double x_mm, y_mm, heading_rad;
} g_odo;

static void odometry_reset(void) {
  encoder_read(g_odo.origin);
  g_odo.last[0] = g_odo.origin[0];
  g_odo.last[1] = g_odo.origin[1];
  g_odo.x_mm = g_odo.y_mm = g_odo.heading_rad = 0.0;
}

/* Differential drive, midpoint heading: each wheel's travel from its count
 * delta, the mean is the forward motion, the difference over the track the
 * rotation (counter-clockwise positive, REP-103). */
static void odometry_update(void) {
  int32_t now[2];
  double dl, dr, ds, dth;
  encoder_read(now);
  dl = (double)(now[0] - g_odo.last[0]) * g_geom.mm_per_tick[0];
  dr = (double)(now[1] - g_odo.last[1]) * g_geom.mm_per_tick[1];
  g_odo.last[0] = now[0];
  g_odo.last[1] = now[1];
  ds = 0.5 * (dl + dr);
  dth = (dr - dl) / g_geom.track_mm;
  g_odo.x_mm += ds * cos(g_odo.heading_rad + 0.5 * dth);
  g_odo.y_mm += ds * sin(g_odo.heading_rad + 0.5 * dth);
  g_odo.heading_rad += dth;
}

static olf_telemetry_t odometry_sample(void) {
  olf_telemetry_t s;
  s.t_ms = bsp_millis();
  s.left_ticks = g_odo.last[0] - g_odo.origin[0];
  s.right_ticks = g_odo.last[1] - g_odo.origin[1];
  s.x_mm = g_odo.x_mm;
  s.y_mm = g_odo.y_mm;
  s.heading_rad = g_odo.heading_rad;
  return s;
}

/* ------------------------------------------------------------------------ */
/* 4. Runs                                                                   */
/* ------------------------------------------------------------------------ */

static olf_ctx_t g_link;

/* A procedure is a sequence of segments, each a straight line or a turn on
 * the spot; generated one at a time (an out-and-back of 100 repeats has 400). */
typedef struct {
  int turn;      /* 0: straight, 1: turn in place */
  double amount; /* mm (straight, signed) or rad (turn, CCW positive) */
} segment_t;

static struct {
  int active;
  volatile int stop_requested;
  olf_run_cmd_t cmd;
  uint32_t segment;     /* index of the segment being driven */
  int seg_running;
  int32_t seg_start[2]; /* counts when the segment started */
  int32_t seg_target[2];/* signed ticks each wheel must travel */
  double rate[2];       /* commanded ticks per second */
  int wheel_done[2];
} g_run;

static int segment_get(const olf_run_cmd_t* cmd, uint32_t i, segment_t* seg) {
  const double turn_sign = cmd->direction == OLF_DIR_CCW ? 1.0 : -1.0;
  switch (cmd->procedure) {
    case OLF_PROC_UMBMARK: /* a square: side, 90 deg turn, four times */
      if (i >= 8u) return 0;
      seg->turn = (int)(i & 1u);
      seg->amount = seg->turn ? turn_sign * 0.5 * PI : cmd->amount_mm;
      return 1;
    case OLF_PROC_STRAIGHT:
      if (i >= 1u) return 0;
      seg->turn = 0;
      seg->amount = cmd->amount_mm;
      return 1;
    case OLF_PROC_SPIN:
      if (i >= 1u) return 0;
      seg->turn = 1;
      seg->amount = turn_sign * 2.0 * PI * (double)cmd->count;
      return 1;
    case OLF_PROC_OUT_AND_BACK: /* out, half turn, back, half turn */
      if (i >= 4u * cmd->count) return 0;
      seg->turn = (int)(i & 1u);
      seg->amount = seg->turn ? turn_sign * PI : cmd->amount_mm;
      return 1;
    default:
      return 0;
  }
}

/* The motor command. A real robot hands these wheel speeds to its speed
 * controllers (PID on the encoder rate, PWM out); the simulated board turns
 * its wheels at exactly this rate. */
static void motor_command(double left_ticks_s, double right_ticks_s) {
  bsp_motor_set((int32_t)left_ticks_s, (int32_t)right_ticks_s);
}

static int32_t round_ticks(double t) { return (int32_t)(t < 0.0 ? t - 0.5 : t + 0.5); }

/* Starts segment `g_run.segment`; 0 when the procedure has no more. Both
 * wheels are timed to arrive together. */
static int segment_begin(void) {
  segment_t seg;
  double wheel_mm[2], seconds;
  int w;
  if (!segment_get(&g_run.cmd, g_run.segment, &seg)) return 0;
  if (seg.turn) {
    const double ddeg_s = g_run.cmd.turn_rate_ddeg_s ? g_run.cmd.turn_rate_ddeg_s
                                                     : DEFAULT_TURN_RATE_DDEG_S;
    wheel_mm[0] = -0.5 * seg.amount * g_geom.track_mm;
    wheel_mm[1] = +0.5 * seg.amount * g_geom.track_mm;
    seconds = fabs(seg.amount) / (ddeg_s * 0.1 * PI / 180.0);
  } else {
    const double mm_s = g_run.cmd.speed_mm_s ? g_run.cmd.speed_mm_s : DEFAULT_SPEED_MM_S;
    wheel_mm[0] = wheel_mm[1] = seg.amount;
    seconds = fabs(seg.amount) / mm_s;
  }
  if (seconds < 0.001) seconds = 0.001;
  encoder_read(g_run.seg_start);
  for (w = 0; w < 2; ++w) {
    g_run.seg_target[w] = round_ticks(wheel_mm[w] / g_geom.mm_per_tick[w]);
    g_run.wheel_done[w] = g_run.seg_target[w] == 0;
  }
  for (w = 0; w < 2; ++w) g_run.rate[w] = g_run.seg_target[w] / seconds;
  motor_command(g_run.rate[0], g_run.rate[1]);
  g_run.seg_running = 1;
  return 1;
}

/* Stops each wheel that reached its target; 1 once both have. */
static int segment_poll(void) {
  int32_t now[2];
  int w;
  encoder_read(now);
  for (w = 0; w < 2; ++w) {
    const int32_t moved = now[w] - g_run.seg_start[w];
    const int32_t target = g_run.seg_target[w];
    if (!g_run.wheel_done[w] && (target > 0 ? moved >= target : moved <= target)) {
      g_run.wheel_done[w] = 1;
    }
  }
  if (g_run.wheel_done[0] && g_run.wheel_done[1]) {
    motor_command(0.0, 0.0);
    return 1;
  }
  /* A wheel that arrived first holds still while the other finishes. */
  if (g_run.wheel_done[0] || g_run.wheel_done[1]) {
    motor_command(g_run.wheel_done[0] ? 0.0 : g_run.rate[0],
                  g_run.wheel_done[1] ? 0.0 : g_run.rate[1]);
  }
  return 0;
}

/* olf validated the command (procedure, ranges); any valid run is accepted.
 * Return 0 here to refuse one (the host then gets OLF_ERR_REJECTED), e.g.
 * with a low battery or a bumper pressed. */
static int on_start_run(void* user, const olf_run_cmd_t* cmd) {
  (void)user;
  memset(&g_run, 0, sizeof g_run);
  g_run.cmd = *cmd;
  g_run.active = 1;
  odometry_reset();
  return 1;
}

/* Host asked for an immediate stop: cut the motors now, end the run on the
 * next main loop pass (olf wants olf_run_complete once the robot stands
 * still). */
static void on_stop(void* user) {
  (void)user;
  motor_command(0.0, 0.0);
  g_run.stop_requested = 1;
}

static void run_finish(uint8_t status) {
  olf_telemetry_t end;
  motor_command(0.0, 0.0);
  odometry_update();
  end = odometry_sample();
  g_run.active = 0;
  olf_run_complete(&g_link, status, &end);
}

/* One main loop pass of the run in progress. */
static void run_poll(void) {
  olf_telemetry_t sample;
  if (!g_run.active) return;
  if (g_run.stop_requested) {
    run_finish(OLF_RUN_STOPPED);
    return;
  }
  odometry_update();
  if (!g_run.seg_running || segment_poll()) {
    if (g_run.seg_running) ++g_run.segment;
    g_run.seg_running = 0;
    if (!segment_begin()) {
      run_finish(OLF_RUN_COMPLETED);
      return;
    }
  }
  sample = odometry_sample();
  (void)olf_emit_telemetry(&g_link, &sample); /* olf applies the host's rate */
}

/* ------------------------------------------------------------------------ */
/* 5. Main loop                                                              */
/* ------------------------------------------------------------------------ */

static void on_write(void* user, const uint8_t* data, size_t len) {
  (void)user;
  bsp_uart_write(data, len);
}

int main(void) {
  olf_config_t config;
  bsp_init();

  memset(&config, 0, sizeof config);
  config.robot_name = "odocal-lm3s6965";
  /* Same defaults as odocal's virtual robot, so the protocol examples in
   * docs/protocol.md hold byte for byte. Used until a set is committed. */
  config.defaults.left_wheel_diameter_mm = 72.0;
  config.defaults.right_wheel_diameter_mm = 72.0;
  config.defaults.track_mm = 270.0;
  config.defaults.ticks_per_rev = 4096u;
  config.storage = bsp_storage();
  config.callbacks.write = on_write;
  config.callbacks.start_run = on_start_run;
  config.callbacks.stop = on_stop;
  config.callbacks.params_applied = on_params_applied;
  config.callbacks.user = NULL;
  olf_init(&g_link, &config); /* loads the persisted set, calls params_applied */

  for (;;) {
    uint8_t byte;
    while (bsp_uart_read(&byte)) olf_feed(&g_link, byte);
    run_poll();
    bsp_idle(); /* WFI: woken by the next byte, or the 1 ms tick */
  }
}
