/* Interrupt-driven, ring-buffered USARTs: USART0 is the host link (the Mega's USB
 * serial), USART1 the RS485 board bus (driver enable and receiver enable on the pins
 * of pins.h).
 *
 * No byte is lost silently. A received byte that arrives damaged (framing error),
 * after a byte the hardware lost (data overrun), or after one that found the ring
 * full, is handed on with UART_RX_ERROR set, so the frame it belongs to is dropped
 * and counted; every such event is also counted here (uart_line_stats). A transmit
 * that does not fit is refused whole, never cut short. */
#ifndef PB_UART_H
#define PB_UART_H

#include <stdbool.h>
#include <stdint.h>

#define UART0_RX_RING 256u /* 22 ms of line at 115200 baud */
#define UART1_RX_RING 64u
#define UART1_TX_RING 256u /* a STOP to every board back to back, then a request */

/* Set in a received value when the byte, or one lost just before it, was damaged. */
#define UART_RX_ERROR 0x100

/* How the host line's rate is checked at build time (docs/firmware.md, "Baud rates"):
 * 0 = through the Mega's own ATmega16U2, which derives its rate from 16 MHz with the
 * same divisor (both ends agree exactly); 1 = an external USB-serial adapter that
 * makes the nominal rate exactly, so the AVR's own error must be within 1 %. */
#ifndef PB_HOST_LINK_ADAPTER
#define PB_HOST_LINK_ADAPTER 0
#endif

/* Line events since boot, both USARTs. */
struct uart_line_stats {
    uint16_t host_framing;  /* USART0 framing errors */
    uint16_t host_overrun;  /* USART0 data overruns (a byte lost in the hardware) */
    uint16_t host_ring_full; /* USART0 bytes lost to a full receive ring */
    uint16_t bus_framing;
    uint16_t bus_overrun;
    uint16_t bus_ring_full;
    uint16_t bus_echo;      /* bytes heard while the bridge itself drove the bus */
};

void uart0_init(uint32_t baud);
/* Next received byte (0..255, with UART_RX_ERROR when damaged), or -1. */
int16_t uart0_getc(void);
/* True while a frame handed to uart0_send() is still being sent. */
bool uart0_tx_busy(void);
/* Send n bytes straight from `p` (no copy): the buffer must stay untouched until
 * uart0_tx_busy() is false. Call only when not busy. */
void uart0_send(const uint8_t *p, uint16_t n);

void uart1_init(uint32_t baud);
/* Next received byte (0..255, with UART_RX_ERROR when damaged), or -1. */
int16_t uart1_getc(void);
void uart1_rx_flush(void);
uint16_t uart1_tx_free(void);
/* Queue n bytes for the bus (driver enabled, receiver off, while they go out). False
 * when they do not all fit: then nothing is queued. */
bool uart1_write(const uint8_t *p, uint8_t n);
/* True when the last queued byte has left the shift register (the bus is ours to
 * listen on again); *at gets the timer_ticks() of that moment. */
bool uart1_tx_done(uint16_t *at);
/* timer_ticks() of the last byte received on the bus (echo included). */
uint16_t uart1_last_rx(void);

/* A copy of the line counters. */
void uart_line_stats(struct uart_line_stats *out);
/* Received bytes wait in either ring (call with interrupts off, before sleeping). */
bool uart_rx_pending(void);

#endif
