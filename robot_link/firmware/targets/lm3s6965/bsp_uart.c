/* UART0 (PL011) at 115200 8N1: receive by interrupt into a ring buffer,
 * transmit polled. Pins PA0 (RX) and PA1 (TX). */
#include "bsp.h"
#include "lm3s6965.h"

#define RX_RING_SIZE 256u /* a power of two; holds one full odolink frame */

/* Single producer (the ISR writes head), single consumer (the main loop
 * writes tail): no lock needed, each index is one aligned word. */
static volatile uint8_t g_rx_ring[RX_RING_SIZE];
static volatile uint32_t g_rx_head;
static volatile uint32_t g_rx_tail;
static volatile uint32_t g_rx_dropped;

void bsp_uart_init(void);
void bsp_uart_init(void) {
  /* Baud divisor = 50 MHz / (16 * 115200) = 27.127: integer 27, fraction
   * round(0.127 * 64) = 8. */
  const uint32_t div64 = (BSP_SYSCLK_HZ * 4u + 115200u / 2u) / 115200u; /* 64 * divisor */
  SYSCTL_RCGC1 |= SYSCTL_RCGC1_UART0;
  SYSCTL_RCGC2 |= SYSCTL_RCGC2_GPIOA;
  GPIOA_AFSEL |= 0x3u;
  GPIOA_DEN |= 0x3u;
  UART0_CTL = 0;
  UART0_IBRD = div64 / 64u;
  UART0_FBRD = div64 % 64u;
  UART0_LCRH = UART_LCRH_WLEN_8 | UART_LCRH_FEN; /* 8 bits, no parity, 1 stop, FIFOs on */
  UART0_IFLS = 0; /* RX interrupt at 1/8 full; the receive timeout covers the rest */
  UART0_ICR = 0x7FFu;
  UART0_IM = UART_INT_RX | UART_INT_RT | UART_INT_OE;
  UART0_CTL = UART_CTL_UARTEN | UART_CTL_TXE | UART_CTL_RXE;
  NVIC_ISER(UART0_IRQ / 32u) = 1u << (UART0_IRQ % 32u);
}

void UART0_IRQHandler(void);
void UART0_IRQHandler(void) {
  UART0_ICR = UART_INT_RX | UART_INT_RT | UART_INT_OE;
  while (!(UART0_FR & UART_FR_RXFE)) {
    const uint32_t dr = UART0_DR;
    const uint32_t head = g_rx_head;
    if (dr & 0xF00u) ++g_rx_dropped; /* overrun, break, parity or framing error */
    if (head - g_rx_tail >= RX_RING_SIZE) {
      ++g_rx_dropped;
      continue;
    }
    g_rx_ring[head % RX_RING_SIZE] = (uint8_t)dr;
    g_rx_head = head + 1u;
  }
}

int bsp_uart_read(uint8_t* byte) {
  const uint32_t tail = g_rx_tail;
  if (tail == g_rx_head) return 0;
  *byte = g_rx_ring[tail % RX_RING_SIZE];
  g_rx_tail = tail + 1u;
  return 1;
}

uint32_t bsp_uart_dropped(void) { return g_rx_dropped; }

void bsp_uart_write(const uint8_t* data, size_t len) {
  size_t i;
  for (i = 0; i < len; ++i) {
    while (UART0_FR & UART_FR_TXFF) {
    }
    UART0_DR = data[i];
  }
}

void bsp_idle(void) {
  lm3s_irq_disable();
  if (g_rx_tail == g_rx_head) lm3s_wfi();
  lm3s_irq_enable();
}
