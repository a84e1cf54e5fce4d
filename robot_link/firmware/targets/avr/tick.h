/* A millisecond clock from Timer0 in CTC mode. */
#ifndef ODOLINK_AVR_TICK_H_
#define ODOLINK_AVR_TICK_H_

#include <stdint.h>

void tick_init(void);
/* Milliseconds since tick_init(); wraps after 49.7 days. Safe to call with
 * interrupts enabled or disabled. */
uint32_t bsp_millis(void);

#endif /* ODOLINK_AVR_TICK_H_ */
