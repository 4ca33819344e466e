/* The board's state channels, in layout order, in the robot description's raw units:
 * an analog sensor (angle, spring) and a motor's current sense span the channel's raw
 * range over the ADC's 0..1023; an IMU axis is the IMU's 1/16 degree scaled to the
 * channel's unit; a drive's velocity comes from its quadrature encoder, counted over
 * the last 40 ms. Updated every millisecond (velocity every 10 ms). */
#ifndef PICO_SENSORS_H
#define PICO_SENSORS_H

#include <stdbool.h>
#include <stdint.h>

#include "board.h"

/* Encoder counts per wheel revolution (4 x the encoder's lines x the gear ratio): a
 * property of the drive motors, a build option (ENCODER_CPR) with this assumed value. */
#ifndef ENCODER_CPR
#define ENCODER_CPR 3072L
#endif
static_assert(ENCODER_CPR >= 1 && ENCODER_CPR <= 32768L,
              "ENCODER_CPR: counts per wheel revolution, 1 to 32768 (40 ms of counts in int16)");
#define VELOCITY_WINDOW_MS 40u
/* A sensor read over a bus that can fail (the IMU on TWI, read every 10 ms) with no
 * successful read for longer than this makes the reply's STALE (docs/board-bus.md). */
#define SENSOR_STALE_MS 50u

void sensors_init(uint32_t now_ms);
void sensors_tick(uint32_t now_ms);
/* Channel c of this board (raw units), and motor k's measured speed (velocity raw). */
int16_t sensors_channel(uint8_t c);
int16_t sensors_speed(uint8_t k);
/* A sensor of this board has not been read successfully for SENSOR_STALE_MS. */
bool sensors_stale(void);

#endif
