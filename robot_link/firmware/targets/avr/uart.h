/* UART0 of the ATmega328P: 115200 8N1 (double speed), receive by interrupt
 * into a ring buffer, transmit blocking. */
#ifndef ODOLINK_AVR_UART_H_
#define ODOLINK_AVR_UART_H_

#include <stddef.h>
#include <stdint.h>

/* Ring size; a power of two, at most 256 (8-bit indices). At 115200 baud a
 * byte arrives every 87 us, so 128 bytes cover 11 ms of main loop latency
 * (writing a 70-byte storage record to real EEPROM takes 3.3 ms per byte, but
 * nothing arrives meanwhile: the host waits for the reply). */
#define UART_RX_RING_SIZE 128u

void uart_init(void);
/* 1 and the oldest received byte in *byte, or 0 if the ring is empty. */
int uart_read(uint8_t* byte);
/* 1 if uart_read would return a byte (for the idle check). */
int uart_rx_pending(void);
/* Blocks until every byte is in the transmitter. */
void uart_write(const uint8_t* data, size_t len);
/* Bytes lost because the ring was full, and bytes the hardware flagged as
 * data overrun or frame error, since boot. */
uint16_t uart_rx_overflows(void);
uint16_t uart_rx_errors(void);

#endif /* ODOLINK_AVR_UART_H_ */
