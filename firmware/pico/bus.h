/* The board side of the board bus (docs/board-bus.md, version 2): frames addressed to
 * this board, EXCHANGE answered with its status and channels, STOP applied silently,
 * and the board-side timeout: no frame from the master for BOARD_SILENCE_MS, and the
 * board applies the stop itself (drives braked, joints holding) and holds it, reporting
 * OWN_STOP in every reply, until the master sends a STOP. */
#ifndef PICO_BUS_H
#define PICO_BUS_H

#include <stdbool.h>
#include <stdint.h>

#define BOARD_SILENCE_MS 100u
/* A reply starts no sooner than this after the request's last byte (the master must
 * have released the line), and well within the 300 us the bus allows. */
#define REPLY_TURNAROUND_US 20u

#define STATUS_FAULT 0x01u
#define STATUS_MOTORS_OFF 0x02u
#define STATUS_OWN_STOP 0x04u
#define STATUS_STALE 0x08u /* a sensor has not been read for SENSOR_STALE_MS */

struct bus_counts {
    uint16_t exchanges;  /* EXCHANGE frames to this board, answered */
    uint16_t stops;      /* STOP frames to this board */
    uint16_t bad;        /* frames dropped: damaged, COBS, CRC, length */
    uint16_t others;     /* good frames to other boards */
    uint16_t own_stops;  /* times the master fell silent */
    uint16_t refused;    /* setpoint entries the motor does not accept */
};

void bus_init(uint32_t now_ms);
/* Take the received bytes; answer when due. */
void bus_poll(void);
/* Once per millisecond: the silence check. */
void bus_tick(uint32_t now_ms);
bool bus_own_stop(void);
/* A reply is waiting for its turnaround: do not sleep. */
bool bus_busy(void);
const struct bus_counts *bus_counts(void);

#endif
