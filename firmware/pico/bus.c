#include "bus.h"

#include "board.h"
#include "cobs.h"
#include "crc.h"
#include "hal.h"
#include "motors.h"
#include "sensors.h"

#define CMD_EXCHANGE 0x01u
#define CMD_STOP 0x02u
#define CMD_REPLY 0x81u
#define BODY_MAX 32u
#define WIRE_MAX (COBS_MAX_ENCODED(BODY_MAX) + 1u)

static struct {
    uint8_t raw[WIRE_MAX];
    uint8_t n;
    bool damaged;
    uint8_t body[BODY_MAX];
    uint8_t reply[WIRE_MAX];
    uint8_t reply_n;      /* a reply waiting for its turnaround, 0: none */
    uint16_t request_end; /* hal_ticks() of the request's last byte */
    uint32_t heard_ms;    /* the master's last frame to this board */
    uint32_t now_ms;
    bool own_stop;
    struct bus_counts counts;
} bus;

void bus_init(uint32_t now_ms) {
    bus.n = 0;
    bus.damaged = false;
    bus.reply_n = 0;
    bus.heard_ms = now_ms;
    bus.now_ms = now_ms;
    bus.own_stop = false;
}

bool bus_own_stop(void) { return bus.own_stop; }

bool bus_busy(void) { return bus.reply_n != 0; }

const struct bus_counts *bus_counts(void) { return &bus.counts; }

static inline void put16(uint8_t *p, uint16_t v) {
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
}

static void build_reply(void) {
    uint8_t n = 0;
    bus.body[n++] = board.id;
    bus.body[n++] = CMD_REPLY;
    uint8_t status = 0;
    if (hal_fault()) {
        status |= STATUS_FAULT;
    }
    if (motors_off()) {
        status |= STATUS_MOTORS_OFF;
    }
    if (bus.own_stop) {
        status |= STATUS_OWN_STOP;
    }
    if (sensors_stale()) {
        status |= STATUS_STALE;
    }
    bus.body[n++] = status;
    for (uint8_t c = 0; c < board.n_channels; c++) {
        put16(bus.body + n, (uint16_t)sensors_channel(c));
        n = (uint8_t)(n + 2u);
    }
    put16(bus.body + n, crc16_xmodem(bus.body, n));
    n = (uint8_t)(n + 2u);
    uint8_t w = (uint8_t)cobs_encode(bus.body, n, bus.reply);
    bus.reply[w++] = 0;
    bus.reply_n = w;
}

static void apply(const uint8_t *payload) {
    for (uint8_t k = 0; k < board.n_motors; k++) {
        const uint8_t *e = payload + 3u * k;
        int16_t raw = (int16_t)(e[1] | (uint16_t)e[2] << 8);
        if (!motors_set(k, e[0], raw)) {
            bus.counts.refused++;
        }
    }
}

/* A whole frame (delimiter removed) has arrived. */
static void frame(void) {
    int16_t len = cobs_decode(bus.raw, bus.n, bus.body, BODY_MAX);
    if (len < 4) {
        bus.counts.bad++;
        return;
    }
    uint8_t n = (uint8_t)len;
    if (crc16_xmodem(bus.body, (uint16_t)(n - 2u)) !=
        (uint16_t)(bus.body[n - 2u] | (uint16_t)bus.body[n - 1u] << 8)) {
        bus.counts.bad++;
        return;
    }
    if (bus.body[0] != board.id) {
        bus.counts.others++; /* another board's, or another board's reply */
        return;
    }
    uint8_t cmd = bus.body[1];
    if ((cmd != CMD_EXCHANGE && cmd != CMD_STOP) || n != 4u + 3u * board.n_motors) {
        bus.counts.bad++;
        return;
    }
    bus.heard_ms = bus.now_ms;
    if (cmd == CMD_STOP) {
        bus.counts.stops++;
        bus.own_stop = false; /* the master took over the stop */
        apply(bus.body + 2);
        motors_tick(); /* a stop reaches the H-bridge now, not at the next tick */
        return;
    }
    bus.counts.exchanges++;
    if (!bus.own_stop) {
        apply(bus.body + 2);
    }
    build_reply();
    bus.request_end = hal_bus_rx_at();
}

void bus_poll(void) {
    int16_t c;
    while ((c = hal_bus_getc()) >= 0) {
        uint8_t byte = (uint8_t)c;
        if (c & HAL_RX_ERROR) {
            if (byte == 0 && bus.n == 0 && !bus.damaged) {
                continue; /* a break with nothing before it: no frame, not a bad one */
            }
            bus.damaged = true;
        }
        if (byte != 0) {
            if (bus.n < WIRE_MAX) {
                bus.raw[bus.n++] = byte;
            } else {
                bus.damaged = true; /* longer than any request */
            }
            continue;
        }
        if (bus.damaged) {
            bus.counts.bad++;
        } else if (bus.n > 1 && board.known && bus.raw[0] > 1u && bus.raw[1] != board.id) {
            /* another board's frame (its address is the first byte after the COBS code,
             * never 0): not even decoded, so a busy bus costs little */
            bus.counts.others++;
        } else if (bus.n > 0 && board.known) {
            frame();
        }
        bus.n = 0;
        bus.damaged = false;
    }
    if (bus.reply_n && !hal_bus_tx_busy() &&
        (uint16_t)(hal_ticks() - bus.request_end) >= REPLY_TURNAROUND_US * HAL_TICKS_PER_US) {
        hal_bus_send(bus.reply, bus.reply_n);
        bus.reply_n = 0;
    }
}

void bus_tick(uint32_t now_ms) {
    bus.now_ms = now_ms;
    if (!bus.own_stop && (uint32_t)(now_ms - bus.heard_ms) > BOARD_SILENCE_MS) {
        bus.own_stop = true; /* the master is silent: stop, hold the joints */
        bus.counts.own_stops++;
        motors_stop();
    }
}
