/* Scheduling of the board bus: every state period each board is polled once,
 * ascending id (its setpoints out, its readings back), with one retry if time is
 * left; readings, freshness, board status and the RS485 counters kept here for the
 * STATE and COUNTERS frames. Stops go out ahead of the next poll. The bus protocol
 * itself is behind board_bus.h. */
#ifndef PB_POLLER_H
#define PB_POLLER_H

#include <stdbool.h>
#include <stdint.h>

#include "robot_layout.h"

/* Board status nibble bits (docs/protocol.md, STATE). */
#define BOARD_ONLINE 0x1u
#define BOARD_FAULT 0x2u
#define BOARD_TIMEOUT 0x4u
#define BOARD_MOTORS_OFF 0x8u

#define FRESH_BYTES ((PB_N_CHANNELS + 7) / 8)

struct board_counters {
    uint32_t timeouts;
    uint32_t crc_errors;
    uint32_t retries;
};

void poller_init(void);
/* A state period begins: the freshness of the period just ended is kept for the
 * STATE frame, and a new poll cycle starts (or the late one goes on). */
void poller_period(uint32_t now_ms);
/* Advance the bus (main loop). */
void poller_run(void);
/* Send the stop to every board as soon as the bus is free. */
void poller_request_stop(void);

/* For STATE: channels read fresh in the period that just ended. */
const uint8_t *poller_fresh(void);
/* Last value read of every channel (0 before any). */
const int16_t *poller_readings(void);
/* ONLINE, FAULT, TIMEOUT of board `index` (MOTORS_OFF as the board reports it). */
uint8_t poller_board_status(uint8_t index);
bool poller_bus_fault(void);
const struct board_counters *poller_counters(uint8_t index);

#endif
