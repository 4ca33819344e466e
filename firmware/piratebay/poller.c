#include "poller.h"

#include <string.h>

#include "board_bus.h"
#include "mcu.h"
#include "safety.h"
#include "timer.h"
#include "uart.h"

#define MARGIN_US 300u /* keep clear of the next period's start */
/* A board not heard for this long has stopped itself (its silence time, docs/board-bus.md)
 * or lost its power: the rest of the robot stops too, as on its OWN_STOP. */
#define BOARD_AWAY_MS 100u

#ifdef __AVR__
#include <avr/pgmspace.h>
#else
#define PROGMEM
#define pgm_read_byte(p) (*(const uint8_t *)(p))
#endif

/* The generated table of what produces each channel (the PICO's, layout.h): here only
 * to tell a board's sensors from its motors' feedback (velocity, current), whose
 * channels a reply's STALE leaves fresh. In flash; read once, into sensor_bits. */
struct channel_io {
    uint8_t board_index;
    uint8_t source;
    uint8_t slot;
    int16_t raw_lo, raw_hi, zero_raw;
    int32_t scale_q16;
};
#if PB_N_CHANNELS > 0
static const struct channel_io channel_io[PB_N_CHANNELS] PROGMEM = PB_CHANNEL_IO_TABLE;
#endif

static struct {
    int16_t readings[PB_N_CHANNELS ? PB_N_CHANNELS : 1];
    uint8_t fresh_now[FRESH_BYTES ? FRESH_BYTES : 1];
    uint8_t fresh_done[FRESH_BYTES ? FRESH_BYTES : 1];
    uint8_t sensor_bits[FRESH_BYTES ? FRESH_BYTES : 1]; /* channels a STALE concerns */
    uint8_t status[PB_N_BOARDS];
    struct board_counters counters[PB_N_BOARDS];
    uint16_t heard_ms[PB_N_BOARDS]; /* each board's last good reply (boot: boot time),
                                     * in ms mod 65536: 100 ms is all it measures */
    bool away[PB_N_BOARDS]; /* not heard for BOARD_AWAY_MS: the robot stopped for it */
    bool bus_fault;
    bool stop_pending;
    uint8_t stop_next;   /* board whose STOP goes out next */
    /* the cycle */
    uint8_t next;        /* board to poll next */
    uint8_t polled;      /* boards polled this cycle */
    bool any_ok;         /* a board answered this cycle */
    bool cycle_done;
    bool busy;           /* an exchange is in progress */
    bool retry;          /* retry `current` once the bus is clear */
    bool retried;
    uint8_t current;
    uint32_t period_ms;  /* start of the current period */
    uint16_t period_ticks;
} poll;

void poller_init(void) {
    memset(&poll, 0, sizeof poll);
    poll.cycle_done = true;
    uint16_t now = (uint16_t)timer_ms();
    for (uint8_t b = 0; b < PB_N_BOARDS; b++) {
        poll.heard_ms[b] = now;
    }
#if PB_N_CHANNELS > 0
    for (uint8_t ch = 0; ch < PB_N_CHANNELS; ch++) {
        uint8_t src = pgm_read_byte(&channel_io[ch].source);
        if (src != PB_SRC_VELOCITY && src != PB_SRC_CURRENT) {
            poll.sensor_bits[ch >> 3] |= (uint8_t)(1u << (ch & 7u));
        }
    }
#endif
    board_bus_init();
}

void poller_request_stop(void) {
    poll.stop_pending = true;
    poll.stop_next = 0;
}

const uint8_t *poller_fresh(void) { return poll.fresh_done; }

const int16_t *poller_readings(void) { return poll.readings; }

uint8_t poller_board_status(uint8_t index) { return poll.status[index]; }

bool poller_bus_fault(void) { return poll.bus_fault; }

const struct board_counters *poller_counters(uint8_t index) { return &poll.counters[index]; }

void poller_period(uint32_t now_ms) {
    memcpy(poll.fresh_done, poll.fresh_now, sizeof poll.fresh_done);
    memset(poll.fresh_now, 0, sizeof poll.fresh_now);
    poll.period_ms = now_ms;
    poll.period_ticks = timer_ticks();
    if (poll.cycle_done) {
        poll.cycle_done = false;
        poll.next = 0;
        poll.polled = 0;
        poll.any_ok = false;
    }
    /* else: the last cycle is late (boards timing out); it goes on from where it
     * is, so every board gets its turn. */
}

/* Microseconds since the period began (saturating past 30 ms). */
static uint32_t period_elapsed_us(void) {
    uint32_t ms = timer_ms() - poll.period_ms;
    if (ms >= 30u) {
        return ms * 1000u;
    }
    return (uint16_t)(timer_ticks() - poll.period_ticks) / TIMER_TICKS_PER_US;
}

/* Time left in this period for a whole exchange with `board`, after `wait_us`. */
static bool time_left_for(const struct pb_board *board, uint16_t wait_us) {
    uint32_t need = period_elapsed_us() + wait_us + board_bus_exchange_us(board) + MARGIN_US;
    return need <= (uint32_t)PB_STATE_PERIOD_MS * 1000u;
}

/* The STOP to every board (board bus 2), in the board's own modes: a drive brakes
 * (pwm 0) rather than being handed a velocity loop, rotate and other motors get their
 * stop setpoint (pwm 0 = brake, or the setpoint they keep), bend joints keep theirs.
 * Every board gets one, even an all-keep one: a STOP also ends a board's own stop.
 * Resumable: a STOP that does not fit the transmit buffer goes out on a later turn. */
static void send_stops(void) {
    struct pb_setpoint sp[PB_MAX_BOARD_MOTORS ? PB_MAX_BOARD_MOTORS : 1];
    for (uint8_t b = poll.stop_next; b < PB_N_BOARDS; b++) {
        const struct pb_board *board = layout_board(b);
        for (uint8_t k = 0; k < board->n_motors; k++) {
            uint8_t i = (uint8_t)(board->first_motor + k);
            const struct pb_motor *m = layout_motor(i);
            if (m->role == PB_ROLE_BEND) {
                sp[k].mode = PB_MODE_KEEP;
                sp[k].raw = 0;
            } else if (m->role == PB_ROLE_DRIVE && layout_mode_ok(m, PB_MODE_PWM)) {
                sp[k].mode = PB_MODE_PWM;
                sp[k].raw = 0;
            } else {
                sp[k] = safety_setpoints[i];
            }
        }
        if (!board_bus_stop(board, sp)) {
            poll.stop_next = b;
            return;
        }
    }
    poll.stop_pending = false;
    poll.stop_next = 0;
}

static void start(uint8_t index) {
    const struct pb_board *board = layout_board(index);
    poll.current = index;
    poll.busy = true;
    board_bus_exchange(board, &safety_setpoints[board->first_motor]);
}

static void finish_cycle(void) {
    poll.cycle_done = true;
    poll.bus_fault = poll.polled > 0 && !poll.any_ok;
}

static void done(enum bus_result result, const struct bus_reply *reply) {
    uint8_t b = poll.current;
    const struct pb_board *board = layout_board(b);
    if (result == BUS_OK) {
        memcpy(&poll.readings[board->first_channel], reply->readings,
               (size_t)board->n_channels * sizeof(int16_t));
        /* STALE: the board's sensors were not read in time (the values are the last
         * good ones); they stay not fresh, so the host's freshness check sees it */
        uint8_t keep = reply->status & BUS_STATUS_STALE ? 0xFFu : 0u;
        for (uint8_t k = 0; k < board->n_channels; k++) {
            uint8_t ch = (uint8_t)(board->first_channel + k);
            uint8_t bit = (uint8_t)(1u << (ch & 7u));
            if (!(poll.sensor_bits[ch >> 3] & bit & keep)) {
                poll.fresh_now[ch >> 3] |= bit;
            }
        }
        uint8_t s = BOARD_ONLINE;
        if (reply->status & BUS_STATUS_FAULT) {
            s |= BOARD_FAULT;
        }
        if (reply->status & BUS_STATUS_MOTORS_OFF) {
            s |= BOARD_MOTORS_OFF;
        }
        poll.status[b] = s;
        poll.any_ok = true;
        poll.heard_ms[b] = (uint16_t)timer_ms();
        poll.away[b] = false;
        if (reply->status & BUS_STATUS_OWN_STOP) {
            /* the board stopped itself (it heard no master for its silence time):
             * the whole robot stops, and the STOP to every board ends its own stop */
            pb_debug.board_own_stops++;
            safety_stop();
        }
    } else {
        if (result == BUS_BAD_REPLY) {
            poll.counters[b].crc_errors++;
        } else {
            poll.counters[b].timeouts++;
        }
        if (!poll.retried && !poll.stop_pending && time_left_for(board, board_bus_guard_us())) {
            poll.retried = true;
            poll.counters[b].retries++;
            poll.retry = true; /* once the line has been quiet for a whole reply */
            poll.busy = false;
            return;
        }
        poll.status[b] = BOARD_TIMEOUT;
        uint16_t unheard = (uint16_t)((uint16_t)timer_ms() - poll.heard_ms[b]);
        if (!poll.away[b] && unheard > BOARD_AWAY_MS) {
            /* once an absence: it has stopped on its own (or has no power), and when it
             * answers again it gets the stop setpoints, not the ones it had (a drive that
             * came back restarted alone, the host having stopped the others) */
            poll.away[b] = true;
            safety_stop();
        }
    }
    poll.busy = false;
    poll.polled++;
    poll.next = (uint8_t)(b + 1u);
    if (poll.next >= PB_N_BOARDS) {
        poll.next = 0;
        finish_cycle();
    }
}

void poller_run(void) {
    if (!poll.busy) {
        uart1_rx_flush(); /* bytes between exchanges answer nothing (and would keep the
                           * main loop from sleeping) */
    }
    if (poll.busy) {
        struct bus_reply reply;
        enum bus_result r = board_bus_poll(&reply);
        if (r == BUS_BUSY) {
            return;
        }
        done(r, &reply);
    }
    if (!board_bus_idle()) {
        return; /* quiet time after a failed exchange */
    }
    if (poll.stop_pending) {
        send_stops();
        if (poll.stop_pending) {
            return;
        }
    }
    if (poll.retry) {
        poll.retry = false;
        start(poll.current);
        return;
    }
    if (poll.cycle_done || poll.busy) {
        return;
    }
    if (!time_left_for(layout_board(poll.next), 0) && poll.polled > 0) {
        return; /* the rest of the cycle goes on in the next period */
    }
    poll.retried = false;
    start(poll.next);
}
