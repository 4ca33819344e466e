/* The board bus port: how the bridge talks to one PICO board.
 *
 * This is the seam for another board protocol. The rest of the firmware (which
 * board to poll when, retries, timeouts counted, what the readings mean) only
 * calls the functions below; board_bus.c implements them for the bus of
 * docs/board-bus.md (COBS frames with CRC-16 over RS485 on USART1). A team whose
 * PICO boards speak something else rewrites board_bus.c, and nothing else.
 *
 * Exactly one exchange is in progress at a time: board_bus_exchange() starts it,
 * board_bus_poll() is called from the main loop until it stops answering
 * BUS_BUSY. After a timeout or a bad reply the bus stays busy (board_bus_idle() is
 * false) until the line has been quiet for the longest legal reply, so a late reply
 * never collides with the next request; but no longer than the reply timeout and one
 * longest frame after the failure, so noise or a babbling board cannot silence the
 * bridge. Nothing here may block: the host link is served in the same loop. */
#ifndef PB_BOARD_BUS_H
#define PB_BOARD_BUS_H

#include <stdbool.h>
#include <stdint.h>

#include "robot_layout.h"

#ifndef BUS_BAUD
#define BUS_BAUD 1000000UL
#endif
/* Give up on a reply this long after the request's last byte left the line. */
#ifndef BUS_REPLY_TIMEOUT_US
#define BUS_REPLY_TIMEOUT_US 1500u
#endif

/* Board status bits of a reply (the board's own view; docs/board-bus.md). */
#define BUS_STATUS_FAULT 0x01u
#define BUS_STATUS_MOTORS_OFF 0x02u
#define BUS_STATUS_OWN_STOP 0x04u /* the board stopped itself: the master fell silent */
/* a sensor of the board has not been read in its time: the reply carries its last good
 * values, and the board's sensor channels (not its motors' feedback) are not fresh */
#define BUS_STATUS_STALE 0x08u

enum bus_result {
    BUS_BUSY = 0,  /* still sending or waiting */
    BUS_OK,        /* the board answered; the reply is filled in */
    BUS_TIMEOUT,   /* no reply in time */
    BUS_BAD_REPLY, /* a reply arrived but failed its checks (CRC, address, length, line) */
};

struct bus_reply {
    uint8_t status; /* BUS_STATUS_* */
    int16_t readings[PB_MAX_BOARD_CHANNELS + 1]; /* this board's channels, layout order */
};

void board_bus_init(void);
/* Send `board` its setpoints (one per motor, slot order) and start waiting for its
 * readings. Call only when board_bus_idle(). */
void board_bus_exchange(const struct pb_board *board, const struct pb_setpoint *setpoints);
/* Progress of the current exchange. */
enum bus_result board_bus_poll(struct bus_reply *reply);
/* Send `board` setpoints to apply at once, expecting no reply (the stop category);
 * several may be queued back to back. Call only when board_bus_idle(). False when the
 * transmit buffer has no room for it: nothing was sent, try again later. */
bool board_bus_stop(const struct pb_board *board, const struct pb_setpoint *setpoints);
/* True when no exchange is in progress and the line is clear for the next request. */
bool board_bus_idle(void);
/* Worst-case duration of one exchange, in microseconds (for scheduling). */
uint16_t board_bus_exchange_us(const struct pb_board *board);
/* The quiet time after a failed exchange, before the line is clear again. */
uint16_t board_bus_guard_us(void);

#endif
