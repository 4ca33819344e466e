/* Interrupt-driven, ring-buffered USARTs: USART0 is the host link (the Mega's USB
 * serial), USART1 the RS485 board bus (driver enable on PD4, high while sending). */
#ifndef PB_UART_H
#define PB_UART_H

#include <stdbool.h>
#include <stdint.h>

#define UART0_RX_RING 256u /* 22 ms of line at 115200 baud */
#define UART1_RX_RING 64u
#define UART1_TX_RING 256u /* a STOP to every board back to back, then a request */

void uart0_init(uint32_t baud);
/* Next received byte, or -1. */
int16_t uart0_getc(void);
/* True while a frame handed to uart0_send() is still being sent. */
bool uart0_tx_busy(void);
/* Send n bytes straight from `p` (no copy): the buffer must stay untouched until
 * uart0_tx_busy() is false. Call only when not busy. */
void uart0_send(const uint8_t *p, uint16_t n);
/* Bytes lost: the receive ring was full, or the USART overran. */
uint16_t uart0_rx_overruns(void);

void uart1_init(uint32_t baud);
int16_t uart1_getc(void);
void uart1_rx_flush(void);
uint16_t uart1_tx_free(void);
void uart1_write(const uint8_t *p, uint8_t n);
/* True when the last queued byte has left the shift register (the bus is ours to
 * listen on again); *at gets the timer_ticks() of that moment. */
bool uart1_tx_done(uint16_t *at);

#endif
