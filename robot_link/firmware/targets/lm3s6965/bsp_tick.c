/* System clock (PLL, 50 MHz) and the SysTick millisecond tick. */
#include "bsp.h"
#include "lm3s6965.h"

static volatile uint32_t g_millis;

/* RCC sequence from the datasheet (section "Initialization and
 * Configuration"): bypass the PLL, pick the 8 MHz crystal of the EK board and
 * power the PLL, set the divider, wait for lock, then switch to the PLL.
 * 200 MHz / (3 + 1) = 50 MHz. QEMU models this register and derives the
 * SysTick rate from it, so the tick is right there too. */
static void clock_init(void) {
  uint32_t rcc = SYSCTL_RCC;
  uint32_t spins;
  rcc |= SYSCTL_RCC_BYPASS;
  rcc &= ~SYSCTL_RCC_USESYSDIV;
  SYSCTL_RCC = rcc;
  rcc &= ~(SYSCTL_RCC_XTAL_MASK | SYSCTL_RCC_OSCSRC_MASK | SYSCTL_RCC_PWRDN | SYSCTL_RCC_MOSCDIS);
  rcc |= SYSCTL_RCC_XTAL_8MHZ; /* OSCSRC 0: main oscillator */
  SYSCTL_RCC = rcc;
  rcc &= ~SYSCTL_RCC_SYSDIV_MASK;
  rcc |= SYSCTL_RCC_SYSDIV(3) | SYSCTL_RCC_USESYSDIV;
  SYSCTL_RCC = rcc;
  for (spins = 0; spins < 100000u && !(SYSCTL_RIS & SYSCTL_RIS_PLLLRIS); ++spins) {
  }
  rcc &= ~SYSCTL_RCC_BYPASS;
  SYSCTL_RCC = rcc;
  /* Flash timing for program/erase: system clock in MHz, minus one. */
  SYSCTL_USECRL = BSP_SYSCLK_HZ / 1000000u - 1u;
}

static void systick_init(void) {
  SYST_RVR = BSP_SYSCLK_HZ / 1000u - 1u;
  SYST_CVR = 0;
  SYST_CSR = SYST_CSR_CLKSOURCE | SYST_CSR_TICKINT | SYST_CSR_ENABLE;
}

void SysTick_Handler(void);
void SysTick_Handler(void) {
  ++g_millis;
  bsp_motor_sim_tick();
}

uint32_t bsp_millis(void) { return g_millis; /* one aligned word: atomic read */ }

void bsp_uart_init(void);
int bsp_flash_backend_init(void);

void bsp_init(void) {
  lm3s_irq_disable();
  clock_init();
  systick_init();
  bsp_uart_init();
  (void)bsp_flash_backend_init();
  lm3s_irq_enable();
}
