/* The stub motion backend: two simulated wheels with quadrature encoders.
 *
 * bsp_motor_set() is where a real board would set PWM duty cycles (through a
 * speed controller); here each wheel simply turns at the commanded rate. The
 * SysTick interrupt advances each wheel once a millisecond and produces the
 * quadrature edges the encoder would, calling bsp_encoder_edge() the way a
 * GPIO edge interrupt would on hardware. The application cannot tell the
 * difference, which is the point: its decoding, odometry and run logic are
 * the real thing. */
#include "bsp.h"
#include "lm3s6965.h"

/* More than any sane wheel needs; bounds the work per tick. */
#define MAX_TICKS_PER_S 50000

typedef struct {
  volatile int32_t rate;  /* commanded ticks per second */
  int32_t fraction;       /* accumulated thousandths of a tick */
  unsigned phase;         /* position in the Gray sequence 00 01 11 10 */
} sim_wheel_t;

static sim_wheel_t g_wheels[2];

static int32_t clamp_rate(int32_t r) {
  if (r > MAX_TICKS_PER_S) return MAX_TICKS_PER_S;
  if (r < -MAX_TICKS_PER_S) return -MAX_TICKS_PER_S;
  return r;
}

void bsp_motor_set(int32_t left_ticks_per_s, int32_t right_ticks_per_s) {
  g_wheels[BSP_WHEEL_LEFT].rate = clamp_rate(left_ticks_per_s);
  g_wheels[BSP_WHEEL_RIGHT].rate = clamp_rate(right_ticks_per_s);
}

/* Channel levels (A = bit 1, B = bit 0) for each quarter cycle; turning
 * forward steps through 00 01 11 10 (B leads A by a quarter cycle). */
static const uint8_t kGray[4] = {0u, 1u, 3u, 2u};

void bsp_motor_sim_tick(void) {
  int w;
  for (w = 0; w < 2; ++w) {
    sim_wheel_t* s = &g_wheels[w];
    s->fraction += s->rate;
    while (s->fraction >= 1000) {
      s->fraction -= 1000;
      s->phase = (s->phase + 1u) & 3u;
      bsp_encoder_edge(w, kGray[s->phase]);
    }
    while (s->fraction <= -1000) {
      s->fraction += 1000;
      s->phase = (s->phase + 3u) & 3u;
      bsp_encoder_edge(w, kGray[s->phase]);
    }
    if (s->rate == 0) s->fraction = 0; /* stopped: no creeping */
  }
}
