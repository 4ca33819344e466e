/* USART0 (host link) and USART1 (RS485 board bus) drivers for the ATmega2560.
 *
 * Receive: each byte lands in a ring from the RX-complete interrupt, with its status
 * read first (UCSRnA belongs to the byte in UDRn): a framing error, a data overrun
 * before it, or a byte lost to a full ring marks it (a bit per ring entry), and the
 * main loop drops the frame it belongs to. Transmit on USART0 is zero-copy: the
 * data-register-empty interrupt walks the caller's frame buffer, so a 256-byte frame
 * needs no second copy. USART1 copies into a ring (several STOP frames go out back to
 * back; a frame that does not fit is refused whole) and drives the RS485 module: DE
 * high and /RE high while it sends (no echo), both low once the last stop bit has
 * left (the TX-complete interrupt, which stamps the time the board bus counts its
 * reply timeout from). A byte heard while DE is high (a module whose /RE is tied low)
 * is our own echo: counted and discarded. */
#include "uart.h"

#include <assert.h>

#include <avr/interrupt.h>
#include <avr/io.h>
#include <util/atomic.h>

#include "layout.h" /* generated: PB_BAUD, the host line rate */
#include "pins.h"
#include "timer.h"

static_assert(UART0_RX_RING == 256, "uint8_t indices wrap at 256");
static_assert((UART1_RX_RING & (UART1_RX_RING - 1)) == 0, "power of two");
static_assert((UART1_TX_RING & (UART1_TX_RING - 1)) == 0, "power of two");

/* UBRR for double speed (U2X): F_CPU / (8 * baud) - 1, rounded; the rate it gives. */
#define UBRR_U2X(baud) ((F_CPU + 4UL * (baud)) / (8UL * (baud)) - 1UL)
#define ACTUAL_BAUD(baud) (F_CPU / (8UL * (UBRR_U2X(baud) + 1UL)))
/* The AVR's deviation from the nominal rate, in units of 0.01 %. */
#define BAUD_ERROR_BP(baud) \
    ((long)((ACTUAL_BAUD(baud) * 10000ULL + (baud) / 2u) / (baud)) - 10000L)

static_assert(UBRR_U2X(PB_BAUD) <= 4095u, "the host baud rate is too low for UBRR");
#if PB_HOST_LINK_ADAPTER
/* An adapter makes the nominal rate; ours must be within 1 % of it (115200 gives
 * +2.1 %: choose 250000, 500000 or 1000000 for 0 %, or 76800 for +0.16 %). */
static_assert(BAUD_ERROR_BP(PB_BAUD) >= -100 && BAUD_ERROR_BP(PB_BAUD) <= 100,
              "host baud rate more than 1 % off at 16 MHz: see docs/firmware.md, Baud rates");
#endif

static uint16_t ubrr_u2x(uint32_t baud) { return (uint16_t)UBRR_U2X(baud); }

static volatile struct uart_line_stats stats;

static inline void mark(volatile uint8_t *bits, uint8_t index, bool bad) {
    uint8_t m = (uint8_t)(1u << (index & 7u));
    if (bad) {
        bits[index >> 3] |= m;
    } else {
        bits[index >> 3] &= (uint8_t)~m;
    }
}

static inline bool marked(const volatile uint8_t *bits, uint8_t index) {
    return (bits[index >> 3] >> (index & 7u)) & 1u;
}

/* ---- USART0: host link ---------------------------------------------------------- */

static volatile uint8_t rx0_buf[UART0_RX_RING];
static volatile uint8_t rx0_bad[UART0_RX_RING / 8];
static volatile uint8_t rx0_head;
static volatile uint8_t rx0_tail;
static volatile bool rx0_lost; /* a byte was lost: the next one stored carries the mark */
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
    bool bad = rx0_lost;
    if (status & _BV(FE0)) {
        stats.host_framing++;
        bad = true;
    }
    if (status & _BV(DOR0)) {
        stats.host_overrun++; /* the hardware lost a byte before this one */
        bad = true;
    }
    uint8_t head = rx0_head;
    uint8_t next = (uint8_t)(head + 1u);
    if (next == rx0_tail) {
        stats.host_ring_full++;
        rx0_lost = true;
        return;
    }
    rx0_buf[head] = byte;
    mark(rx0_bad, head, bad);
    rx0_lost = false;
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
    int16_t value = rx0_buf[tail];
    if (marked(rx0_bad, tail)) {
        value |= UART_RX_ERROR;
    }
    rx0_tail = (uint8_t)(tail + 1u);
    return value;
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

/* ---- USART1: RS485 board bus ---------------------------------------------------- */

static volatile uint8_t rx1_buf[UART1_RX_RING];
/* One flag byte per slot, not a bit: at 1 Mbaud a byte lasts 160 cycles, and the
 * receive interrupt must take fewer (a variable shift is a loop on the AVR). */
static volatile uint8_t rx1_bad[UART1_RX_RING];
static volatile uint8_t rx1_head;
static volatile uint8_t rx1_tail;
static volatile bool rx1_lost;
static volatile uint16_t rx1_at;
static volatile uint8_t tx1_buf[UART1_TX_RING];
static volatile uint8_t tx1_head;
static volatile uint8_t tx1_tail;
static volatile bool tx1_done = true;
static volatile uint16_t tx1_done_at;

static inline bool driving(void) { return (RS485_DE_PORT & _BV(RS485_DE_BIT)) != 0; }

void uart1_init(uint32_t baud) {
    /* DE is an output driven low from the first instructions (mcu.c, .init0); /RE low:
     * listen. The pull-up on RXD1 keeps the line idle-high whenever the module's
     * receiver output is off (while we send, or before the module is powered). */
    RS485_DE_PORT &= (uint8_t)~_BV(RS485_DE_BIT);
    RS485_DE_DDR |= _BV(RS485_DE_BIT);
    RS485_RE_PORT &= (uint8_t)~_BV(RS485_RE_BIT);
    RS485_RE_DDR |= _BV(RS485_RE_BIT);
    RS485_RX_PORT |= _BV(RS485_RX_BIT);
    UCSR1A = _BV(U2X1);
    UBRR1 = ubrr_u2x(baud);
    UCSR1C = _BV(UCSZ11) | _BV(UCSZ10);
    UCSR1B = _BV(RXEN1) | _BV(TXEN1) | _BV(RXCIE1) | _BV(TXCIE1);
}

ISR(USART1_RX_vect) {
    uint8_t status = UCSR1A;
    uint8_t byte = UDR1;
    /* timer_ticks() without the call: interrupts are off in here, so the 16-bit read
     * is atomic, and a call would make the compiler save every call-clobbered register */
    rx1_at = TCNT1;
    if (driving()) {
        stats.bus_echo++; /* our own transmission, heard through the module */
        return;
    }
    bool bad = rx1_lost;
    if (status & _BV(FE1)) {
        stats.bus_framing++;
        bad = true;
    }
    if (status & _BV(DOR1)) {
        stats.bus_overrun++;
        bad = true;
    }
    uint8_t head = rx1_head;
    uint8_t next = (uint8_t)((head + 1u) & (UART1_RX_RING - 1u));
    if (next == rx1_tail) {
        stats.bus_ring_full++; /* longer than any reply: the frame is dropped */
        rx1_lost = true;
        return;
    }
    rx1_buf[head] = byte;
    rx1_bad[head] = bad;
    rx1_lost = false;
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
    /* The last byte has left only when the data register is empty too: on a real USART
     * it always is when TX-complete fires; a simulator (simavr) may raise TX-complete
     * for the byte before while the last one is already loaded. */
    if (tx1_tail == tx1_head && (UCSR1A & _BV(UDRE1))) {
        RS485_DE_PORT &= (uint8_t)~_BV(RS485_DE_BIT); /* release the bus */
        RS485_RE_PORT &= (uint8_t)~_BV(RS485_RE_BIT); /* and listen */
        tx1_done_at = timer_ticks();
        tx1_done = true;
    }
}

int16_t uart1_getc(void) {
    uint8_t tail = rx1_tail;
    if (tail == rx1_head) {
        return -1;
    }
    int16_t value = rx1_buf[tail];
    if (rx1_bad[tail]) {
        value |= UART_RX_ERROR;
    }
    rx1_tail = (uint8_t)((tail + 1u) & (UART1_RX_RING - 1u));
    return value;
}

void uart1_rx_flush(void) {
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
        rx1_tail = rx1_head;
        rx1_lost = false;
    }
}

uint16_t uart1_tx_free(void) {
    uint8_t used;
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
        used = (uint8_t)((tx1_head - tx1_tail) & (UART1_TX_RING - 1u));
    }
    return (uint16_t)(UART1_TX_RING - 1u - used);
}

bool uart1_write(const uint8_t *p, uint8_t n) {
    if (n == 0) {
        return true;
    }
    bool fits;
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
        uint8_t used = (uint8_t)((tx1_head - tx1_tail) & (UART1_TX_RING - 1u));
        fits = n <= UART1_TX_RING - 1u - used;
        if (fits) {
            RS485_RE_PORT |= _BV(RS485_RE_BIT); /* receiver off: no echo */
            RS485_DE_PORT |= _BV(RS485_DE_BIT);
            tx1_done = false;
            for (uint8_t i = 0; i < n; i++) {
                tx1_buf[tx1_head] = p[i];
                tx1_head = (uint8_t)((tx1_head + 1u) & (UART1_TX_RING - 1u));
            }
        }
    }
    if (fits) {
        UCSR1B |= _BV(UDRIE1);
    }
    return fits;
}

bool uart1_tx_done(uint16_t *at) {
    bool done;
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
        done = tx1_done;
        *at = tx1_done_at;
    }
    return done;
}

uint16_t uart1_last_rx(void) {
    uint16_t at;
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { at = rx1_at; }
    return at;
}

bool uart_rx_pending(void) { return rx0_tail != rx0_head || rx1_tail != rx1_head; }

void uart_line_stats(struct uart_line_stats *out) {
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
        out->host_framing = stats.host_framing;
        out->host_overrun = stats.host_overrun;
        out->host_ring_full = stats.host_ring_full;
        out->bus_framing = stats.bus_framing;
        out->bus_overrun = stats.bus_overrun;
        out->bus_ring_full = stats.bus_ring_full;
        out->bus_echo = stats.bus_echo;
    }
}
