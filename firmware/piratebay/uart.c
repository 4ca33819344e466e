/* USART0 (host link) and USART1 (RS485 board bus) drivers for the ATmega2560.
 *
 * Receive: each byte lands in a ring from the RX-complete interrupt; the main loop
 * takes it with uartN_getc(). Transmit on USART0 is zero-copy: the data-register-
 * empty interrupt walks the caller's frame buffer, so a 256-byte frame needs no
 * second copy. USART1 copies into a small ring (several STOP frames go out back to
 * back) and drives the RS485 transceiver's driver-enable pin (PD4) high while it
 * sends; the TX-complete interrupt drops it and stamps the time, from which the
 * board bus counts its reply timeout. */
#include "uart.h"

#include <assert.h>

#include <avr/interrupt.h>
#include <avr/io.h>
#include <util/atomic.h>

#include "timer.h"

#define RS485_DE_DDR DDRD
#define RS485_DE_PORT PORTD
#define RS485_DE_BIT PD4

static_assert(UART0_RX_RING == 256, "uint8_t indices wrap at 256");
static_assert((UART1_RX_RING & (UART1_RX_RING - 1)) == 0, "power of two");
static_assert((UART1_TX_RING & (UART1_TX_RING - 1)) == 0, "power of two");

/* UBRR for double speed (U2X): F_CPU / (8 * baud) - 1, rounded. */
static uint16_t ubrr_u2x(uint32_t baud) {
    return (uint16_t)((F_CPU + 4u * baud) / (8u * baud) - 1u);
}

/* ---- USART0: host link ---------------------------------------------------------- */

static volatile uint8_t rx0_buf[UART0_RX_RING];
static volatile uint8_t rx0_head;
static volatile uint8_t rx0_tail;
static volatile uint16_t rx0_overruns;
static const uint8_t *volatile tx0_ptr;
static volatile uint16_t tx0_left;

void uart0_init(uint32_t baud) {
    UCSR0A = _BV(U2X0); /* before UBRR0: simavr computes the baud rate when UBRR is written */
    UBRR0 = ubrr_u2x(baud);
    UCSR0C = _BV(UCSZ01) | _BV(UCSZ00); /* 8N1 */
    UCSR0B = _BV(RXEN0) | _BV(TXEN0) | _BV(RXCIE0);
}

ISR(USART0_RX_vect) {
    uint8_t status = UCSR0A; /* before UDR0: its error flags belong to this byte */
    uint8_t byte = UDR0;
    if (status & _BV(DOR0)) {
        rx0_overruns++; /* the hardware lost a byte before this one */
    }
    uint8_t next = (uint8_t)(rx0_head + 1u);
    if (next == rx0_tail) {
        rx0_overruns++;
        return;
    }
    rx0_buf[rx0_head] = byte;
    rx0_head = next;
}

ISR(USART0_UDRE_vect) {
    if (tx0_left == 0) {
        UCSR0B &= (uint8_t)~_BV(UDRIE0);
        return;
    }
    UDR0 = *tx0_ptr;
    tx0_ptr = tx0_ptr + 1;
    tx0_left = tx0_left - 1u;
}

int16_t uart0_getc(void) {
    uint8_t tail = rx0_tail;
    if (tail == rx0_head) {
        return -1;
    }
    uint8_t byte = rx0_buf[tail];
    rx0_tail = (uint8_t)(tail + 1u);
    return byte;
}

bool uart0_tx_busy(void) {
    bool busy;
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { busy = tx0_left != 0; }
    return busy;
}

void uart0_send(const uint8_t *p, uint16_t n) {
    if (n == 0) {
        return;
    }
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
        tx0_ptr = p;
        tx0_left = n;
    }
    UCSR0B |= _BV(UDRIE0);
}

uint16_t uart0_rx_overruns(void) {
    uint16_t n;
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { n = rx0_overruns; }
    return n;
}

/* ---- USART1: RS485 board bus ---------------------------------------------------- */

static volatile uint8_t rx1_buf[UART1_RX_RING];
static volatile uint8_t rx1_head;
static volatile uint8_t rx1_tail;
static volatile uint8_t tx1_buf[UART1_TX_RING];
static volatile uint8_t tx1_head;
static volatile uint8_t tx1_tail;
static volatile bool tx1_done = true;
static volatile uint16_t tx1_done_at;

void uart1_init(uint32_t baud) {
    RS485_DE_DDR |= _BV(RS485_DE_BIT);
    RS485_DE_PORT &= (uint8_t)~_BV(RS485_DE_BIT);
    UCSR1A = _BV(U2X1);
    UBRR1 = ubrr_u2x(baud);
    UCSR1C = _BV(UCSZ11) | _BV(UCSZ10);
    UCSR1B = _BV(RXEN1) | _BV(TXEN1) | _BV(RXCIE1) | _BV(TXCIE1);
}

ISR(USART1_RX_vect) {
    uint8_t byte = UDR1;
    uint8_t next = (uint8_t)((rx1_head + 1u) & (UART1_RX_RING - 1u));
    if (next == rx1_tail) {
        return; /* a reply longer than any board sends: the frame check drops it */
    }
    rx1_buf[rx1_head] = byte;
    rx1_head = next;
}

ISR(USART1_UDRE_vect) {
    uint8_t tail = tx1_tail;
    if (tail == tx1_head) {
        UCSR1B &= (uint8_t)~_BV(UDRIE1);
        return;
    }
    UDR1 = tx1_buf[tail];
    tx1_tail = (uint8_t)((tail + 1u) & (UART1_TX_RING - 1u));
}

ISR(USART1_TX_vect) {
    if (tx1_tail == tx1_head) {
        RS485_DE_PORT &= (uint8_t)~_BV(RS485_DE_BIT); /* release the bus */
        tx1_done_at = timer_ticks();
        tx1_done = true;
    }
}

int16_t uart1_getc(void) {
    uint8_t tail = rx1_tail;
    if (tail == rx1_head) {
        return -1;
    }
    uint8_t byte = rx1_buf[tail];
    rx1_tail = (uint8_t)((tail + 1u) & (UART1_RX_RING - 1u));
    return byte;
}

void uart1_rx_flush(void) {
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { rx1_tail = rx1_head; }
}

uint16_t uart1_tx_free(void) {
    uint8_t used;
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
        used = (uint8_t)((tx1_head - tx1_tail) & (UART1_TX_RING - 1u));
    }
    return (uint16_t)(UART1_TX_RING - 1u - used);
}

void uart1_write(const uint8_t *p, uint8_t n) {
    if (n == 0) {
        return;
    }
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
        RS485_DE_PORT |= _BV(RS485_DE_BIT);
        tx1_done = false;
        for (uint8_t i = 0; i < n; i++) {
            uint8_t next = (uint8_t)((tx1_head + 1u) & (UART1_TX_RING - 1u));
            if (next == tx1_tail) {
                break;
            }
            tx1_buf[tx1_head] = p[i];
            tx1_head = next;
        }
    }
    UCSR1B |= _BV(UDRIE1);
}

bool uart1_tx_done(uint16_t *at) {
    bool done;
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
        done = tx1_done;
        *at = tx1_done_at;
    }
    return done;
}
