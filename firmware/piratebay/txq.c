#include "txq.h"

#include <stddef.h>

#include "timer.h"
#include "uart.h"

#define TYPE_STATE 0x82u
#define TYPE_BRIDGE_HEARTBEAT 0x86u
#define SLOTS (TXQ_ANSWERS + 1u) /* the waiting answers and the one on the line */

static uint8_t body[FRAME_MAX_BODY]; /* encoding scratch */

static struct {
    uint8_t wire[SLOTS][FRAME_WIRE(ANSWER_MAX_PAYLOAD)];
    uint16_t len[SLOTS];
    uint8_t head;    /* next to send */
    uint8_t waiting; /* encoded, not yet on the line */
    int8_t on_line;  /* slot being sent, or -1 */
} answers;

static struct {
    uint8_t wire[2][FRAME_WIRE(STATE_PAYLOAD)];
    uint16_t len[2];
    int8_t waiting; /* buffer index, or -1 */
    int8_t on_line;
    uint16_t seq;   /* seq of the last STATE or BRIDGE_HEARTBEAT started */
    uint8_t beat[FRAME_WIRE(0)];
} state;

static uint32_t last_sent_ms;

void txq_init(void) {
    answers.head = 0;
    answers.waiting = 0;
    answers.on_line = -1;
    state.waiting = -1;
    state.on_line = -1;
    state.seq = 0;
    /* boot time, not 0: on the AVR the two are the same, but a bridge whose clock
     * does not restart at boot (the host build's fw_boot) sent a BRIDGE_HEARTBEAT
     * first instead of STATE seq 1 (docs/protocol.md: with a 10 ms period, never) */
    last_sent_ms = timer_ms();
}

uint8_t *txq_answer_begin(void) {
    if (answers.waiting >= TXQ_ANSWERS) {
        return NULL;
    }
    return body + FRAME_HEADER_BYTES;
}

void txq_answer_commit(uint8_t type, uint16_t seq, uint8_t arg, uint8_t n) {
    uint8_t slot = (uint8_t)((answers.head + answers.waiting) % SLOTS);
    answers.len[slot] = frame_encode(body, type, seq, arg, n, answers.wire[slot]);
    answers.waiting++;
}

uint8_t *txq_state_begin(void) { return body + FRAME_HEADER_BYTES; }

void txq_state_commit(uint8_t flags) {
    int8_t buf = state.waiting >= 0 ? state.waiting : (state.on_line == 0 ? 1 : 0);
    /* a waiting STATE is replaced and its seq reused: the seq is the one the frame
     * will carry when it starts, last + 1 */
    uint16_t seq = (uint16_t)(state.seq + 1u);
    state.len[buf] = frame_encode(body, TYPE_STATE, seq, flags, STATE_PAYLOAD, state.wire[buf]);
    state.waiting = buf;
}

void txq_pump(uint32_t now_ms, uint8_t flags) {
    if (uart0_tx_busy()) {
        return;
    }
    if (answers.on_line >= 0) {
        answers.on_line = -1; /* its slot is free again */
    }
    state.on_line = -1;
    if (answers.waiting > 0) {
        uint8_t slot = answers.head;
        answers.on_line = (int8_t)slot;
        answers.head = (uint8_t)((slot + 1u) % SLOTS);
        answers.waiting--;
        uart0_send(answers.wire[slot], answers.len[slot]);
        last_sent_ms = now_ms;
        return;
    }
    if (state.waiting >= 0) {
        int8_t buf = state.waiting;
        state.waiting = -1;
        state.on_line = buf;
        state.seq++;
        uart0_send(state.wire[buf], state.len[buf]);
        last_sent_ms = now_ms;
        return;
    }
    if ((uint32_t)(now_ms - last_sent_ms) >= BRIDGE_HEARTBEAT_MS) {
        state.seq++;
        frame_encode(body, TYPE_BRIDGE_HEARTBEAT, state.seq, flags, 0, state.beat);
        uart0_send(state.beat, FRAME_WIRE(0));
        last_sent_ms = now_ms;
    }
}
