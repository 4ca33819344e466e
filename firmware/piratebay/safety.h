/* The bridge's protective state: the motors' setpoint table, the e-stop latch, the
 * host watchdog, and the stop category every stop applies (docs/protocol.md, Stop
 * category): drives to velocity 0, rotation and other motors to pwm 0 (brake),
 * bend joints unchanged so that the clamps keep holding. */
#ifndef PB_SAFETY_H
#define PB_SAFETY_H

#include <stdbool.h>
#include <stdint.h>

#include "robot_layout.h"

/* The setpoints the boards are sent, layout order. */
extern struct pb_setpoint safety_setpoints[PB_N_MOTORS ? PB_N_MOTORS : 1];

/* Boot: latched, the stop category applied, watchdog armed from `now_ms`. */
void safety_init(uint32_t now_ms);

/* Apply the stop category to the setpoints, mark every board MOTORS_OFF and have
 * the board bus send the stop at once. */
void safety_stop(void);

void safety_estop_latch(void);
bool safety_estopped(void);
void safety_estop_release(void);

/* A valid host frame arrived: feed the watchdog and clear its flag. */
void safety_feed(uint32_t now_ms);
/* Trip the watchdog when the host was silent for a whole watchdog period. */
void safety_watchdog_check(uint32_t now_ms);
bool safety_watchdog_tripped(void);
void safety_watchdog_clear(void);
uint32_t safety_watchdog_trips(void);

/* MOTORS_OFF of board `index`: its motors are held by a stop and no setpoint for
 * it was applied since. */
bool safety_motors_off(uint8_t board_index);
/* A setpoint for motor `motor` was applied: store it and clear its board's MOTORS_OFF. */
void safety_apply(uint8_t motor, struct pb_setpoint setpoint);

#endif
