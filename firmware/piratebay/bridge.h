/* The bridge's main loop, one turn at a time (main.c on the AVR; the host-side
 * unit tests drive the same turns in virtual time). */
#ifndef PB_BRIDGE_H
#define PB_BRIDGE_H

/* Boot: everything initialised, latched, watchdog armed, interrupts not yet on. */
void bridge_init(void);
/* One turn of the main loop: host bytes, board bus, watchdog, the state period,
 * the transmitter. Never blocks. */
void bridge_turn(void);

#endif
