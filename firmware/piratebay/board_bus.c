/* The board bus of docs/board-bus.md (version 2), bridge (master) side. Rewrite this
 * file, and only this file, for another board protocol; keep board_bus.h.
 *
 * A frame is COBS(addr, cmd, payload, CRC-16/XMODEM little-endian) 0x00, at
 * 1 Mbaud 8N1 on RS485. EXCHANGE (0x01) carries the board's setpoints and is
 * answered by EXCHANGE_REPLY (0x81): status, then the board's state channels as
 * int16. STOP (0x02) carries setpoints too and is not answered. A reply with a byte
 * the USART flagged (framing error, overrun) is a bad reply. After a timeout or a bad
 * reply the line must be quiet for GUARD_US (the longest legal frame) before the next
 * request: a board answering late finishes before anyone else speaks. A line that is
 * not quiet GUARD_MAX_US after the failure is not a late reply but noise or a babbling
 * board: the bridge speaks anyway, or it would send nothing (no STOP, no poll, no
 * board status) for as long as the noise lasts. */
#include "board_bus.h"

#include "cobs.h"
#include "crc.h"
#include "frame.h"
#include "mcu.h"
#include "timer.h"
#include "uart.h"

#define CMD_EXCHANGE 0x01u
#define CMD_STOP 0x02u
#define CMD_REPLY 0x81u
#define BODY_MAX 32u
#define WIRE_MAX (COBS_MAX_ENCODED(BODY_MAX) + 1u)
#define BYTE_US (10000000UL / BUS_BAUD) /* one 8N1 byte on the line */
#define GUARD_US (WIRE_MAX * BYTE_US)     /* the longest legal frame: 340 us */
/* The quiet time ends this long after the failure at the latest: a board that started
 * its reply late, even at the reply timeout, has finished by then. */
#define GUARD_MAX_US (BUS_REPLY_TIMEOUT_US + GUARD_US)

/* The bus rate is exact at 16 MHz (U2X: F_CPU / 8 / (UBRR + 1)), on the bridge and on
 * every PICO board: 1 Mbaud is UBRR 1. */
static_assert(F_CPU % (8UL * BUS_BAUD) == 0 && F_CPU / (8UL * BUS_BAUD) >= 1,
              "the board bus rate must be exact at 16 MHz");
static_assert(4u + 3u * PB_MAX_BOARD_MOTORS <= BODY_MAX, "a request fits 32 bytes");
static_assert(5u + 2u * PB_MAX_BOARD_CHANNELS <= BODY_MAX, "a reply fits 32 bytes");
static_assert(BUS_REPLY_TIMEOUT_US >= 100u && BUS_REPLY_TIMEOUT_US <= 30000u,
              "the reply timeout is counted on the 16-bit 2 MHz timer");
static_assert(GUARD_MAX_US * TIMER_TICKS_PER_US < 65536UL,
              "the longest quiet time is counted on the 16-bit 2 MHz timer");
static_assert((PB_N_BOARDS + 1u) * (6u + 3u * PB_MAX_BOARD_MOTORS) < UART1_TX_RING,
              "a STOP to every board and the next request fit the transmit ring");

static struct {
    bool waiting;
    bool guard;         /* after a failed exchange: wait for a quiet line */
    uint16_t guard_from; /* timer_ticks() the quiet time counts from */
    uint8_t addr;
    uint8_t n_channels;
    uint8_t rx_n;
    bool rx_overflow;
    uint8_t rx_raw[WIRE_MAX];
    uint8_t body[BODY_MAX];
    uint8_t wire[WIRE_MAX];
} bus;

void board_bus_init(void) {
    uart1_init(BUS_BAUD);
    bus.waiting = false;
    bus.guard = false;
}

bool board_bus_idle(void) {
    if (bus.waiting) {
        return false;
    }
    if (bus.guard) {
        /* quiet since the failure and since the last byte heard, whichever is later;
         * but no longer than GUARD_MAX_US after the failure */
        uint16_t now = timer_ticks();
        uint16_t since_rx = (uint16_t)(now - uart1_last_rx());
        uint16_t since_fail = (uint16_t)(now - bus.guard_from);
        uint16_t quiet = since_rx < since_fail ? since_rx : since_fail;
        uint16_t guard = (uint16_t)(GUARD_US * TIMER_TICKS_PER_US);
        uint16_t most = (uint16_t)(GUARD_MAX_US * TIMER_TICKS_PER_US);
        if (quiet < guard && since_fail < most) {
            uint16_t wait = (uint16_t)(guard - quiet);
            uint16_t left = (uint16_t)(most - since_fail);
            timer_wake_at((uint16_t)(now + (wait < left ? wait : left)));
            return false;
        }
        bus.guard = false;
    }
    return true;
}

uint16_t board_bus_exchange_us(const struct pb_board *board) {
    uint16_t request = (uint16_t)(4u + 3u * board->n_motors + 2u);
    uint16_t reply = (uint16_t)(5u + 2u * board->n_channels + 2u);
    return (uint16_t)((request + reply) * BYTE_US + BUS_REPLY_TIMEOUT_US);
}

uint16_t board_bus_guard_us(void) { return GUARD_US; }

static bool send(uint8_t addr, uint8_t cmd, uint8_t n_motors,
                 const struct pb_setpoint *setpoints) {
    uint8_t n = 0;
    bus.body[n++] = addr;
    bus.body[n++] = cmd;
    for (uint8_t i = 0; i < n_motors; i++) {
        bus.body[n++] = setpoints[i].mode;
        put_u16(bus.body + n, (uint16_t)setpoints[i].raw);
        n = (uint8_t)(n + 2u);
    }
    put_u16(bus.body + n, crc16_xmodem(bus.body, n));
    n = (uint8_t)(n + 2u);
    uint8_t w = (uint8_t)cobs_encode(bus.body, n, bus.wire);
    bus.wire[w++] = 0;
    return uart1_write(bus.wire, w);
}

void board_bus_exchange(const struct pb_board *board, const struct pb_setpoint *setpoints) {
    uart1_rx_flush();
    bus.addr = board->id;
    bus.n_channels = board->n_channels;
    bus.rx_n = 0;
    bus.rx_overflow = false;
    bus.waiting = true;
    if (!send(board->id, CMD_EXCHANGE, board->n_motors, setpoints)) {
        /* no room (the transmit ring holds far more than a STOP to every board and a
         * request, static_assert above): the exchange fails as a timeout, counted */
        bus.waiting = false;
        bus.guard = true;
        bus.guard_from = timer_ticks();
    }
}

bool board_bus_stop(const struct pb_board *board, const struct pb_setpoint *setpoints) {
    PB_MARK(PB_MARK_BUS_STOP);
    return send(board->id, CMD_STOP, board->n_motors, setpoints);
}

/* Check a complete reply frame (delimiter removed) and fill `reply`. */
static bool take_reply(struct bus_reply *reply) {
    int16_t len = cobs_decode(bus.rx_raw, bus.rx_n, bus.body, BODY_MAX);
    uint8_t want = (uint8_t)(5u + 2u * bus.n_channels);
    if (len != (int16_t)want) {
        return false;
    }
    if (crc16_xmodem(bus.body, (uint16_t)(want - 2u)) != get_u16(bus.body + want - 2u)) {
        return false;
    }
    if (bus.body[0] != bus.addr || bus.body[1] != CMD_REPLY) {
        return false;
    }
    reply->status = bus.body[2];
    for (uint8_t i = 0; i < bus.n_channels; i++) {
        reply->readings[i] = (int16_t)get_u16(bus.body + 3u + 2u * i);
    }
    return true;
}

static enum bus_result failed(enum bus_result result) {
    bus.waiting = false;
    bus.guard = true;
    bus.guard_from = timer_ticks();
    return result;
}

enum bus_result board_bus_poll(struct bus_reply *reply) {
    if (!bus.waiting) {
        return BUS_TIMEOUT;
    }
    uint16_t sent_at;
    if (!uart1_tx_done(&sent_at)) {
        return BUS_BUSY;
    }
    int16_t c;
    while ((c = uart1_getc()) >= 0) {
        uint8_t byte = (uint8_t)c;
        if (c & UART_RX_ERROR) {
            if (byte == 0 && bus.rx_n == 0 && !bus.rx_overflow) {
                continue; /* a break with nothing before it (a driver turning on): no
                           * frame, as a clean lone delimiter is none */
            }
            bus.rx_overflow = true; /* a damaged byte: the reply is dropped */
        }
        if (byte != 0) {
            if (bus.rx_n < WIRE_MAX) {
                bus.rx_raw[bus.rx_n++] = byte;
            } else {
                bus.rx_overflow = true;
            }
            continue;
        }
        if (bus.rx_n == 0 && !bus.rx_overflow) {
            continue; /* a lone delimiter */
        }
        if (!bus.rx_overflow && take_reply(reply)) {
            bus.waiting = false;
            return BUS_OK;
        }
        return failed(BUS_BAD_REPLY);
    }
    uint16_t waited = (uint16_t)(timer_ticks() - sent_at);
    uint16_t timeout = (uint16_t)(BUS_REPLY_TIMEOUT_US * TIMER_TICKS_PER_US);
    if (waited > timeout) {
        return failed(BUS_TIMEOUT);
    }
    timer_wake_at((uint16_t)(sent_at + timeout + 1u)); /* a reply byte wakes us sooner */
    return BUS_BUSY;
}
