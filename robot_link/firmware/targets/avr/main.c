/* odolink on an ATmega328P: the library fed from UART0, parameters in the
 * EEPROM, a stub in place of the motion code. */
#include <avr/interrupt.h>
#include <avr/sleep.h>
#include <stddef.h>
#include <stdint.h>

#include "motion_stub.h"
#include "odolink/olf.h"
#include "storage_eeprom.h"
#include "tick.h"
#include "uart.h"

/* About 1 KiB: half the part's RAM. Static, never on the stack. */
static olf_ctx_t link;

static void link_write(void* user, const uint8_t* data, size_t len) {
  (void)user;
  uart_write(data, len);
}

/* Sleeps until the next interrupt (a received byte, the 1 ms tick) unless a
 * byte is already waiting. The check and the sleep are atomic: `sei` enables
 * interrupts only after the next instruction, so an interrupt arriving after
 * the check wakes the `sleep` instead of being missed by it. */
static void idle(void) {
  cli();
  if (!uart_rx_pending()) {
    sleep_enable();
    sei();
    sleep_cpu();
    sleep_disable();
  }
  sei();
}

int main(void) {
  olf_config_t config;
  uint8_t byte;

  uart_init();
  tick_init();
  set_sleep_mode(SLEEP_MODE_IDLE); /* the timers and the UART keep running */

  config.robot_name = "odocal-avr";
  /* The odocal virtual robot's defaults, so the documented byte examples
   * (HELLO's set checksum and the rest) hold on this board too. */
  config.defaults.left_wheel_diameter_mm = olf_f64_from_float(72.0f); /* exact */
  config.defaults.right_wheel_diameter_mm = olf_f64_from_float(72.0f);
  config.defaults.track_mm = olf_f64_from_float(270.0f);
  config.defaults.ticks_per_rev = 4096u;
  config.storage = storage_eeprom();
  config.callbacks.write = link_write;
  config.callbacks.start_run = motion_start_run;
  config.callbacks.stop = motion_stop;
  config.callbacks.params_applied = motion_params_applied;
  config.callbacks.user = NULL;
  olf_init(&link, &config);
  sei();

  for (;;) {
    while (uart_read(&byte)) olf_feed(&link, byte);
    motion_poll(&link, bsp_millis());
    idle();
  }
}
