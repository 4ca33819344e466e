/* The board's motors: the setpoint each one executes, in the board's own modes, and
 * the loops that turn it into the H-bridge's duty every millisecond.
 *
 *   pwm       duty = raw scaled to the pwm range; 0 = brake (both low-side switches)
 *   torque    duty = raw / the torque range's top (the motor's stall torque at full
 *             duty: a joint pressed against the wall is stalled); 0 = brake
 *   position  proportional loop on the angle sensor of the same slot, its duty
 *             limited to the position hold torque; within the dead band: brake
 *   velocity  feed-forward (full duty = the top of the velocity range) plus a PI loop
 *             on the encoder's speed; **0 = brake**, never a loop holding zero speed
 *   off       never commanded since boot: the H-bridge off, the motor coasts
 *
 * A stop (the bridge's STOP, or the board's own when the master falls silent) uses
 * these modes only: pwm 0 (brake) for drives, rotate and other motors, and keep for
 * bend joints, which go on closing their loop (a clamp keeps its torque). */
#ifndef PICO_MOTORS_H
#define PICO_MOTORS_H

#include <stdbool.h>
#include <stdint.h>

#include "board.h"

#define MOTOR_OFF 0xFEu /* mode of a motor never commanded since boot */

struct motor_state {
    uint8_t mode; /* PB_MODE_*, or MOTOR_OFF */
    int16_t raw;
};

void motors_init(bool warm);
/* Apply one setpoint (PB_MODE_KEEP: leave it). False when the motor does not accept
 * that mode or value (then nothing changes). */
bool motors_set(uint8_t k, uint8_t mode, int16_t raw);
/* The stop category in the board's own modes (above). */
void motors_stop(void);
/* Some motor was never commanded (the reply's MOTORS_OFF). */
bool motors_off(void);
/* The millisecond control step: the loops, then the H-bridge outputs. */
void motors_tick(void);
const struct motor_state *motors_state(uint8_t k);
/* The duty last given to motor k (-255..255) and whether it brakes or is off. */
int16_t motors_duty(uint8_t k);

#endif
