#include "tick.h"

#include <avr/interrupt.h>
#include <avr/io.h>
#include <util/atomic.h>

/* F_CPU / 64 / 1000 counts per millisecond: 250 at 16 MHz, exact. */
#define TICK_PRESCALER 64UL
#define TICK_COUNTS (F_CPU / TICK_PRESCALER / 1000UL)
typedef char tick_counts_fit_8_bits[(TICK_COUNTS >= 1UL && TICK_COUNTS <= 256UL) ? 1 : -1];

static volatile uint32_t millis_count;

void tick_init(void) {
  TCCR0A = (uint8_t)(1u << WGM01);              /* CTC, TOP = OCR0A */
  OCR0A = (uint8_t)(TICK_COUNTS - 1UL);
  TCNT0 = 0;
  TIFR0 = (uint8_t)(1u << OCF0A);               /* a stale flag would tick at once */
  TIMSK0 = (uint8_t)(1u << OCIE0A);
  TCCR0B = (uint8_t)((1u << CS01) | (1u << CS00)); /* clk/64: starts the timer */
}

ISR(TIMER0_COMPA_vect) { ++millis_count; }

uint32_t bsp_millis(void) {
  uint32_t ms;
  /* Four byte loads: the ISR must not run between them. */
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { ms = millis_count; }
  return ms;
}
