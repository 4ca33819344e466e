/* What the bridge sends the host, and in which order (docs/protocol.md, Transmit
 * order): frames never interleave; answers go first, in the order of their
 * requests (at most 4 wait; a request arriving while 4 wait is handled but not
 * answered); then the STATE, of which only the newest waits (a waiting STATE is
 * replaced by the next one and its seq is not consumed); a BRIDGE_HEARTBEAT when
 * nothing was sent for 50 ms. */
#ifndef PB_TXQ_H
#define PB_TXQ_H

#include <stdbool.h>
#include <stdint.h>

#include "frame.h"
#include "robot_layout.h"

#define TXQ_ANSWERS 4u
#define COUNTERS_PAYLOAD (20u + 13u * PB_N_BOARDS)
#define HELLO_REPLY_PAYLOAD 14u
#define ANSWER_MAX_PAYLOAD (COUNTERS_PAYLOAD > HELLO_REPLY_PAYLOAD ? COUNTERS_PAYLOAD : HELLO_REPLY_PAYLOAD)
#define STATE_PAYLOAD \
    (2u + (PB_N_CHANNELS + 7u) / 8u + (PB_N_BOARDS + 1u) / 2u + 2u * PB_N_CHANNELS)
#define BRIDGE_HEARTBEAT_MS 50u

static_assert(ANSWER_MAX_PAYLOAD <= FRAME_MAX_PAYLOAD, "COUNTERS fits one frame");
static_assert(STATE_PAYLOAD <= FRAME_MAX_PAYLOAD, "STATE fits one frame");

void txq_init(void);
/* The payload area to write an answer into, or NULL when 4 answers wait already. */
uint8_t *txq_answer_begin(void);
/* Encode and queue the answer whose payload (n bytes) was written. */
void txq_answer_commit(uint8_t type, uint16_t seq, uint8_t arg, uint8_t n);
/* The payload area of the next STATE. */
uint8_t *txq_state_begin(void);
/* Encode and queue it (replacing a STATE that is still waiting). */
void txq_state_commit(uint8_t flags);
/* Hand the next frame to the UART when it is free; BRIDGE_HEARTBEAT when due. */
void txq_pump(uint32_t now_ms, uint8_t flags);

#endif
