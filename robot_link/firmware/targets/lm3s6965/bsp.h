/* Board support for the TI Stellaris LM3S6965 (EK-LM3S6965, QEMU
 * lm3s6965evb): what the application in examples/cortex_m/main.c uses.
 *
 *   clock + tick   bsp_tick.c       50 MHz from the PLL, SysTick at 1 kHz
 *   UART0          bsp_uart.c       115200 8N1, RX interrupt into a ring
 *   storage        bsp_storage.c    olf_storage_t on a flash page pair,
 *                  flash_hw_*.c     over one of two flash backends
 *   motors         bsp_motor_sim.c  simulated motors and encoders (stub)
 */
#ifndef ODOLINK_LM3S6965_BSP_H_
#define ODOLINK_LM3S6965_BSP_H_

#include <stddef.h>
#include <stdint.h>

#include "odolink/olf.h"

#define BSP_SYSCLK_HZ 50000000u

/* Clock, SysTick, UART, storage backend, in that order. Interrupts are on
 * when it returns. */
void bsp_init(void);

/* ---- Time ---- */
/* Milliseconds since bsp_init (wraps after 49.7 days; compare differences). */
uint32_t bsp_millis(void);

/* ---- UART0 ---- */
/* Blocking, polled transmit of `len` bytes. */
void bsp_uart_write(const uint8_t* data, size_t len);
/* Takes one received byte out of the ring; 0 if the ring is empty. */
int bsp_uart_read(uint8_t* byte);
/* Bytes lost because the ring was full or the UART overran. */
uint32_t bsp_uart_dropped(void);

/* Sleeps (WFI) until the next interrupt unless a received byte is waiting.
 * Free of the check-then-sleep race: interrupts are masked around the check
 * and WFI still wakes on a pending one. */
void bsp_idle(void);

/* ---- Parameter storage ---- */
/* The storage callbacks for olf_config_t: slot A in one 1 KB flash page,
 * slot B in the next. If the flash backend failed to start, reads fail (the
 * robot runs on its defaults) and commits fail with OLF_ERR_STORAGE. */
olf_storage_t bsp_storage(void);

/* ---- Motors and encoders ----
 * On a real robot: PWM outputs and two quadrature encoders on GPIO pins with
 * edge interrupts. Here a simulated drive (bsp_motor_sim.c) turns each motor
 * command into encoder edges at the commanded rate, from the SysTick
 * interrupt, and calls bsp_encoder_edge() as the GPIO interrupt would. */
enum { BSP_WHEEL_LEFT = 0, BSP_WHEEL_RIGHT = 1 };
/* Wheel speeds in encoder ticks per second, signed (forward positive). */
void bsp_motor_set(int32_t left_ticks_per_s, int32_t right_ticks_per_s);
/* Defined by the application: an edge on a wheel's encoder, `ab` = the new
 * levels of channel A (bit 1) and channel B (bit 0). Called in interrupt
 * context. */
void bsp_encoder_edge(int wheel, unsigned ab);

/* Called from the SysTick handler every millisecond (internal). */
void bsp_motor_sim_tick(void);

#endif /* ODOLINK_LM3S6965_BSP_H_ */
