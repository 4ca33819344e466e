#include "protocol.h"

#include <stdbool.h>
#include <stddef.h>

#include "estop_input.h"
#include "frame.h"
#include "mcu.h"
#include "poller.h"
#include "robot_layout.h"
#include "safety.h"
#include "timer.h"
#include "txq.h"

enum {
    T_HELLO = 0x01,
    T_SETPOINT = 0x02,
    T_BULK = 0x03,
    T_HEARTBEAT = 0x04,
    T_ESTOP = 0x05,
    T_ESTOP_RESET = 0x06,
    T_COUNTERS_REQUEST = 0x07,
    T_HELLO_REPLY = 0x81,
    T_ACK = 0x83,
    T_NACK = 0x84,
    T_COUNTERS = 0x85,
};

enum { ACK_APPLIED = 0, ACK_DUPLICATE = 1, ACK_STALE = 2 };

enum {
    NACK_UNKNOWN_TYPE = 1,
    NACK_BAD_LENGTH = 2,
    NACK_BAD_LAYOUT = 3,
    NACK_BAD_BOARD = 4,
    NACK_BAD_SLOT = 5,
    NACK_BAD_MODE = 6,
    NACK_OUT_OF_RANGE = 7,
    NACK_ESTOP_LATCHED = 8,
    NACK_BUS_ERROR = 9,
    NACK_NOT_READY = 10,
};

#define HELLO_PAYLOAD 5u
#define SETPOINT_PAYLOAD 4u
#define BULK_PAYLOAD (3u * PB_N_MOTORS)
#define NO_ANSWER 0xFFu

static_assert(BULK_PAYLOAD <= FRAME_MAX_PAYLOAD, "BULK_SETPOINTS fits one frame");

static struct frame_rx rx;

static struct {
    bool session;       /* a HELLO was accepted since boot */
    uint8_t minor;      /* the session's protocol minor (its HELLO's); 1 before any */
    uint8_t sessions;   /* saturating at 255 */
    uint16_t last;      /* seq of the last ordered request handled */
    uint8_t last_type;  /* its type (T_ESTOP for an e-stop; 0 after a hello) */
    uint8_t answer;     /* what it got: 0 applied, a NACK code, NO_ANSWER after a hello */
    uint16_t ack_seq;   /* last BULK_SETPOINTS applied in this session */
    uint32_t rx_frames, crc_errors, frame_errors, duplicates;
} br;

/* RFC 1982: a is newer than b. */
static bool seq_newer(uint16_t a, uint16_t b) {
    uint16_t d = (uint16_t)(a - b);
    return d != 0 && d < 0x8000u;
}

void protocol_init(void) {
    frame_rx_init(&rx);
    br.session = false;
    br.minor = PB_PROTOCOL_MINOR_MIN;
    br.sessions = 0;
    br.last = 0;
    br.last_type = 0;
    br.answer = NO_ANSWER;
    br.ack_seq = 0;
    br.rx_frames = br.crc_errors = br.frame_errors = br.duplicates = 0;
}

uint8_t protocol_flags(void) {
    uint8_t f = 0;
    if (safety_estopped()) {
        f |= FLAG_ESTOP;
    }
    if (safety_watchdog_tripped()) {
        f |= FLAG_WATCHDOG;
    }
    if (poller_bus_fault()) {
        f |= FLAG_BUS_FAULT;
    }
    if (!br.session) {
        f |= FLAG_NO_SESSION;
    }
    if (br.minor >= 2u && estop_input_active()) {
        f |= FLAG_ESTOP_INPUT; /* a 1.1 session keeps bits 4-7 at 0 */
    }
    return f;
}

/* ---- answers -------------------------------------------------------------------- */

static void send_ack(uint16_t seq, uint8_t type, uint8_t status) {
    uint8_t *p = txq_answer_begin();
    if (p == NULL) {
        return; /* 4 answers wait: handled, not answered (the host retries) */
    }
    p[0] = type;
    p[1] = status;
    txq_answer_commit(T_ACK, seq, 0, 2);
}

static void send_nack(uint16_t seq, uint8_t type, uint8_t code) {
    uint8_t *p = txq_answer_begin();
    if (p == NULL) {
        return;
    }
    p[0] = type;
    p[1] = code;
    txq_answer_commit(T_NACK, seq, 0, 2);
}

/* The answer to an ordered request: 0 = ACK APPLIED, else the NACK code. */
static void answer(uint16_t seq, uint8_t type, uint8_t code) {
    if (code == 0) {
        send_ack(seq, type, ACK_APPLIED);
    } else {
        send_nack(seq, type, code);
    }
}

static void send_hello_reply(uint16_t seq) {
    uint8_t *p = txq_answer_begin();
    if (p == NULL) {
        return;
    }
    put_u32(p, PB_LAYOUT_DIGEST);
    p[4] = PB_N_CHANNELS;
    p[5] = PB_N_MOTORS;
    put_u16(p + 6, PB_WATCHDOG_MS);
    put_u16(p + 8, PB_FIRMWARE_VERSION);
    p[10] = br.minor;
    put_u16(p + 11, mcu_boot_id());
    p[13] = br.sessions;
    txq_answer_commit(T_HELLO_REPLY, seq, protocol_flags(), HELLO_REPLY_PAYLOAD);
}

static void send_counters(uint16_t seq) {
    uint8_t *p = txq_answer_begin();
    if (p == NULL) {
        return;
    }
    put_u32(p, br.rx_frames);
    put_u32(p + 4, br.crc_errors);
    put_u32(p + 8, br.frame_errors);
    put_u32(p + 12, br.duplicates);
    put_u32(p + 16, safety_watchdog_trips());
    uint8_t *q = p + 20;
    for (uint8_t b = 0; b < PB_N_BOARDS; b++) {
        const struct board_counters *c = poller_counters(b);
        q[0] = layout_board(b)->id;
        put_u32(q + 1, c->timeouts);
        put_u32(q + 5, c->crc_errors);
        put_u32(q + 9, c->retries);
        q += 13;
    }
    txq_answer_commit(T_COUNTERS, seq, 0, COUNTERS_PAYLOAD);
}

/* ---- requests ------------------------------------------------------------------- */

static bool board_unreachable(uint8_t board_index) {
    return poller_bus_fault() || (poller_board_status(board_index) & BOARD_TIMEOUT) != 0;
}

static void hello(uint16_t seq, const uint8_t *payload) {
    uint8_t minor = payload[4];
    if (get_u32(payload) != PB_LAYOUT_DIGEST || minor < PB_PROTOCOL_MINOR_MIN ||
        minor > PB_PROTOCOL_MINOR) {
        send_nack(seq, T_HELLO, NACK_BAD_LAYOUT);
        return;
    }
    /* a retried HELLO (its reply was lost: the same seq, no ordered request handled
     * since) is the same session; any other starts a new one */
    bool retry = br.session && seq == br.last && br.answer == NO_ANSWER;
    if (!retry && br.sessions < 255u) {
        br.sessions++;
    }
    br.last = seq;
    br.last_type = 0;
    br.answer = NO_ANSWER;
    br.ack_seq = 0;
    br.session = true;
    br.minor = minor; /* the session speaks what its host asked for */
    safety_watchdog_clear();
    safety_stop(); /* a session starts from the stopped state; the latch stays */
    send_hello_reply(seq);
}

static uint8_t setpoint(uint8_t board_id, const uint8_t *payload) {
    int8_t b = layout_board_index(board_id);
    if (b < 0) {
        return NACK_BAD_BOARD;
    }
    const struct pb_board *board = layout_board((uint8_t)b);
    uint8_t slot = payload[0];
    uint8_t mode = payload[1];
    int16_t raw = (int16_t)get_u16(payload + 2);
    /* no mutate flip, off-by-one: slots are 0 or 1: slot 7 or 8 fails the mask as well */
    if (slot > 7u || !(board->slot_mask & (1u << slot))) {
        return NACK_BAD_SLOT;
    }
    uint8_t index = board->first_motor;
    while (layout_motor(index)->slot != slot) {
        index++;
    }
    const struct pb_motor *m = layout_motor(index);
    if (!layout_mode_ok(m, mode)) {
        return NACK_BAD_MODE;
    }
    if (!layout_raw_ok(m, mode, raw)) {
        return NACK_OUT_OF_RANGE;
    }
    if (safety_estopped()) {
        return NACK_ESTOP_LATCHED;
    }
    if (board_unreachable((uint8_t)b)) {
        return NACK_BUS_ERROR;
    }
    safety_apply(index, (struct pb_setpoint){mode, raw});
    return 0;
}

static uint8_t bulk(uint16_t seq, const uint8_t *payload) {
    const uint8_t *e = payload;
    for (uint8_t i = 0; i < PB_N_MOTORS; i++, e += 3) {
        if (e[0] == PB_MODE_KEEP) {
            continue;
        }
        const struct pb_motor *m = layout_motor(i);
        if (!layout_mode_ok(m, e[0])) {
            return NACK_BAD_MODE;
        }
        if (!layout_raw_ok(m, e[0], (int16_t)get_u16(e + 1))) {
            return NACK_OUT_OF_RANGE;
        }
    }
    if (safety_estopped()) {
        return NACK_ESTOP_LATCHED;
    }
    e = payload;
    for (uint8_t i = 0; i < PB_N_MOTORS; i++, e += 3) {
        if (e[0] == PB_MODE_KEEP) {
            continue;
        }
        if (board_unreachable(layout_motor(i)->board_index)) {
            return NACK_BUS_ERROR;
        }
    }
    e = payload;
    for (uint8_t i = 0; i < PB_N_MOTORS; i++, e += 3) {
        if (e[0] != PB_MODE_KEEP) {
            safety_apply(i, (struct pb_setpoint){e[0], (int16_t)get_u16(e + 1)});
        }
    }
    br.ack_seq = seq;
    PB_MARK(PB_MARK_BULK_END);
    return 0;
}

static uint8_t estop_reset(void) {
    if (!safety_estopped()) {
        return 0;
    }
    if (poller_bus_fault() || estop_input_pressed()) {
        return NACK_NOT_READY; /* the button is still pressed: the latch stays */
    }
    for (uint8_t b = 0; b < PB_N_BOARDS; b++) {
        if (poller_board_status(b) & (BOARD_FAULT | BOARD_TIMEOUT)) {
            return NACK_NOT_READY;
        }
    }
    safety_estop_release(); /* the motors stay in their stop setpoints */
    estop_input_reset();
    return 0;
}

/* SETPOINT, BULK_SETPOINTS, ESTOP_RESET: session, filter, then the request. */
static void ordered(uint8_t type, uint16_t seq, uint8_t arg, const uint8_t *payload) {
    if (!br.session) {
        send_nack(seq, type, NACK_NOT_READY);
        return;
    }
    if (!seq_newer(seq, br.last)) {
        /* not applied again: the same seq and type get the first copy's answer; an
         * older seq, the same seq with another type, or a hello's seq: STALE */
        br.duplicates++;
        if (seq != br.last || type != br.last_type || br.answer == NO_ANSWER) {
            send_ack(seq, type, ACK_STALE);
        } else if (br.answer != 0) {
            send_nack(seq, type, br.answer);
        } else {
            send_ack(seq, type, ACK_DUPLICATE);
        }
        return;
    }
    br.last = seq;
    br.last_type = type;
    uint8_t code;
    if (type == T_SETPOINT) {
        code = setpoint(arg, payload);
    } else if (type == T_BULK) {
        code = bulk(seq, payload);
    } else {
        code = estop_reset();
    }
    br.answer = code;
    if (type != T_BULK || code != 0) {
        answer(seq, type, code); /* an applied bulk is acknowledged by STATE.ack_seq */
    }
}

static uint8_t payload_length(uint8_t type) {
    switch (type) {
    case T_HELLO:
        return HELLO_PAYLOAD;
    case T_SETPOINT:
        return SETPOINT_PAYLOAD;
    case T_BULK:
        return BULK_PAYLOAD;
    default:
        return 0;
    }
}

static void handle(const uint8_t *body, uint8_t len, uint32_t now_ms) {
    uint8_t type = frame_type(body);
    uint16_t seq = frame_seq(body);
    uint8_t n = (uint8_t)(len - FRAME_MIN_BODY);
    const uint8_t *payload = body + FRAME_HEADER_BYTES;
    /* 3. accept: count, feed the watchdog */
    br.rx_frames++;
    safety_feed(now_ms);
    /* 4. type */
    if (type < T_HELLO || type > T_COUNTERS_REQUEST) {
        send_nack(seq, type, NACK_UNKNOWN_TYPE);
        return;
    }
    /* 5. length */
    if (n != payload_length(type)) {
        send_nack(seq, type, NACK_BAD_LENGTH);
        return;
    }
    /* 6. by type */
    switch (type) {
    case T_HELLO:
        hello(seq, payload);
        break;
    case T_HEARTBEAT:
        send_ack(seq, T_HEARTBEAT, ACK_APPLIED);
        break;
    case T_COUNTERS_REQUEST:
        send_counters(seq);
        break;
    case T_ESTOP:
        safety_estop_latch();
        PB_MARK(PB_MARK_ESTOP);
        if (br.session && seq_newer(seq, br.last)) {
            br.last = seq;
            br.last_type = T_ESTOP;
            br.answer = 0;
        }
        send_ack(seq, T_ESTOP, ACK_APPLIED);
        break;
    default:
        ordered(type, seq, frame_arg(body), payload);
        break;
    }
}

void protocol_rx_byte(uint8_t byte, bool damaged, uint32_t now_ms) {
    uint16_t t0 = 0;
    if (byte == 0) {
        PB_MARK(PB_MARK_FRAME_END); /* decoding starts: a BULK's cycles count from here */
        t0 = timer_ticks();
    }
    switch (frame_rx_byte(&rx, byte, damaged)) {
    case FRAME_MORE:
        return;
    case FRAME_BAD_CRC:
        br.crc_errors++;
        return;
    case FRAME_BAD_FRAME:
        br.frame_errors++;
        return;
    case FRAME_OK:
        break;
    }
    handle(rx.body, rx.body_len, now_ms);
    if (frame_type(rx.body) == T_BULK) {
        mcu_record_cycles(&pb_debug.bulk_cycles_last, &pb_debug.bulk_cycles_max,
                          (uint16_t)(timer_ticks() - t0));
    }
}

void protocol_send_state(void) {
    PB_MARK(PB_MARK_STATE_BEGIN);
    uint16_t t0 = timer_ticks();
    uint8_t *p = txq_state_begin();
    put_u16(p, br.ack_seq);
    p += 2;
    const uint8_t *fresh = poller_fresh();
    for (uint8_t i = 0; i < (PB_N_CHANNELS + 7) / 8; i++) {
        *p++ = fresh[i];
    }
    for (uint8_t b = 0; b < PB_N_BOARDS; b += 2) {
        uint8_t lo = poller_board_status(b);
        if (safety_motors_off(b)) {
            lo |= BOARD_MOTORS_OFF;
        }
        uint8_t hi = 0;
        if (b + 1u < PB_N_BOARDS) {
            hi = poller_board_status((uint8_t)(b + 1u));
            if (safety_motors_off((uint8_t)(b + 1u))) {
                hi |= BOARD_MOTORS_OFF;
            }
        }
        *p++ = (uint8_t)((lo & 0x0Fu) | (uint8_t)(hi << 4));
    }
    const int16_t *r = poller_readings();
    /* no mutate flip, off-by-one: the extra channel lands where the CRC is written next */
    for (uint8_t i = 0; i < PB_N_CHANNELS; i++) {
        put_u16(p, (uint16_t)r[i]);
        p += 2;
    }
    txq_state_commit(protocol_flags());
    mcu_record_cycles(&pb_debug.state_cycles_last, &pb_debug.state_cycles_max,
                      (uint16_t)(timer_ticks() - t0));
    PB_MARK(PB_MARK_STATE_END);
}
