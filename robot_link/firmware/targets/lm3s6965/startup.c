/* Cortex-M3 startup for the LM3S6965: the vector table and the reset handler
 * (copy .data from flash, zero .bss, call main). Plain C, no assembly file:
 * the core loads the initial stack pointer and the reset vector from the
 * first two words, so C is enough from the first instruction on. */
#include <stdint.h>

#include "lm3s6965.h"

/* Symbols from lm3s6965.ld. */
extern uint32_t __data_start, __data_end, __data_load, __bss_start, __bss_end, __stack_top;

int main(void);

void Reset_Handler(void);
void Default_Handler(void);
void HardFault_Handler(void);

/* Handlers the board files define; a weak alias keeps the table complete
 * when one is not linked in. */
void NMI_Handler(void) __attribute__((weak, alias("Default_Handler")));
void MemManage_Handler(void) __attribute__((weak, alias("Default_Handler")));
void BusFault_Handler(void) __attribute__((weak, alias("Default_Handler")));
void UsageFault_Handler(void) __attribute__((weak, alias("Default_Handler")));
void SVC_Handler(void) __attribute__((weak, alias("Default_Handler")));
void DebugMon_Handler(void) __attribute__((weak, alias("Default_Handler")));
void PendSV_Handler(void) __attribute__((weak, alias("Default_Handler")));
void SysTick_Handler(void) __attribute__((weak, alias("Default_Handler")));
void UART0_IRQHandler(void) __attribute__((weak, alias("Default_Handler")));

typedef void (*vector_t)(void);

/* 16 core exceptions, then the LM3S6965's interrupts 0..42. Entry 0 is the
 * initial stack pointer, stored as a function pointer value. */
#define LM3S_IRQ_COUNT 43
__attribute__((section(".isr_vector"), used))
const vector_t lm3s_vectors[16 + LM3S_IRQ_COUNT] = {
    (vector_t)(uintptr_t)&__stack_top,
    Reset_Handler,
    NMI_Handler,
    HardFault_Handler,
    MemManage_Handler,
    BusFault_Handler,
    UsageFault_Handler,
    0, 0, 0, 0, /* reserved */
    SVC_Handler,
    DebugMon_Handler,
    0, /* reserved */
    PendSV_Handler,
    SysTick_Handler,
    /* IRQ 0..4: GPIO ports A..E */
    Default_Handler, Default_Handler, Default_Handler, Default_Handler, Default_Handler,
    UART0_IRQHandler, /* IRQ 5 */
    /* IRQ 6..42: everything else this board does not use. */
    Default_Handler, Default_Handler, Default_Handler, Default_Handler, Default_Handler,
    Default_Handler, Default_Handler, Default_Handler, Default_Handler, Default_Handler,
    Default_Handler, Default_Handler, Default_Handler, Default_Handler, Default_Handler,
    Default_Handler, Default_Handler, Default_Handler, Default_Handler, Default_Handler,
    Default_Handler, Default_Handler, Default_Handler, Default_Handler, Default_Handler,
    Default_Handler, Default_Handler, Default_Handler, Default_Handler, Default_Handler,
    Default_Handler, Default_Handler, Default_Handler, Default_Handler, Default_Handler,
    Default_Handler, Default_Handler,
};

void Reset_Handler(void) {
  const uint32_t* src = &__data_load;
  uint32_t* dst = &__data_start;
  while (dst < &__data_end) *dst++ = *src++;
  for (dst = &__bss_start; dst < &__bss_end;) *dst++ = 0;
  (void)main();
  for (;;) lm3s_wfi();
}

/* An unexpected interrupt or a fault: stop here, where a debugger finds it. */
void Default_Handler(void) {
  for (;;) {
  }
}
void HardFault_Handler(void) {
  for (;;) {
  }
}
