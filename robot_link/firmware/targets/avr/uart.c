#include "uart.h"

#include <avr/interrupt.h>
#include <avr/io.h>
#include <util/atomic.h>

#define UART_BAUD 115200UL
/* Double speed (U2X0): divisor 8. At 16 MHz, 16 gives 117647 baud (+2.1 %),
 * well inside the receiver's tolerance; without U2X the error is -3.5 %. */
#define UART_UBRR ((F_CPU + 4UL * UART_BAUD) / (8UL * UART_BAUD) - 1UL)

typedef char uart_ring_size_is_power_of_two[(UART_RX_RING_SIZE & (UART_RX_RING_SIZE - 1u)) == 0u &&
                                                    UART_RX_RING_SIZE <= 256u
                                                ? 1
                                                : -1];

/* Single producer (the ISR writes head), single consumer (the main loop writes
 * tail); 8-bit indices are read and written atomically on AVR. */
static volatile uint8_t rx_ring[UART_RX_RING_SIZE];
static volatile uint8_t rx_head;
static volatile uint8_t rx_tail;
static volatile uint16_t rx_overflows;
static volatile uint16_t rx_errors;

void uart_init(void) {
  UBRR0H = (uint8_t)(UART_UBRR >> 8);
  UBRR0L = (uint8_t)UART_UBRR;
  UCSR0A = (uint8_t)(1u << U2X0);
  UCSR0C = (uint8_t)((1u << UCSZ01) | (1u << UCSZ00)); /* 8 data bits, no parity, 1 stop */
  UCSR0B = (uint8_t)((1u << RXEN0) | (1u << TXEN0) | (1u << RXCIE0));
}

ISR(USART_RX_vect) {
  /* The status belongs to the byte in UDR0: read it first. */
  const uint8_t status = UCSR0A;
  const uint8_t byte = UDR0;
  const uint8_t next = (uint8_t)((rx_head + 1u) & (UART_RX_RING_SIZE - 1u));
  if (status & ((1u << FE0) | (1u << DOR0))) ++rx_errors;
  if (next == rx_tail) {
    ++rx_overflows; /* the frame it belonged to fails its CRC; the host retries */
    return;
  }
  rx_ring[rx_head] = byte;
  rx_head = next;
}

int uart_read(uint8_t* byte) {
  const uint8_t tail = rx_tail;
  if (tail == rx_head) return 0;
  *byte = rx_ring[tail];
  rx_tail = (uint8_t)((tail + 1u) & (UART_RX_RING_SIZE - 1u));
  return 1;
}

int uart_rx_pending(void) { return rx_tail != rx_head; }

void uart_write(const uint8_t* data, size_t len) {
  size_t i;
  for (i = 0; i < len; ++i) {
    while (!(UCSR0A & (1u << UDRE0))) {
    }
    UDR0 = data[i];
  }
}

uint16_t uart_rx_overflows(void) {
  uint16_t n;
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { n = rx_overflows; }
  return n;
}

uint16_t uart_rx_errors(void) {
  uint16_t n;
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { n = rx_errors; }
  return n;
}
