/* This board's part of the robot's layout: which board it is (its id from EEPROM),
 * its motors with their stop roles, modes and raw ranges, and what produces each of
 * its state channels. The whole robot's tables (the generated layout.h, the same
 * header the bridge is built from) stay in flash; only this board's entries are
 * copied to SRAM. */
#ifndef PICO_BOARD_H
#define PICO_BOARD_H

#include <stdbool.h>
#include <stdint.h>

#include "robot_layout.h" /* firmware/piratebay: the layout types, and layout.h */

#define PICO_MAX_MOTORS 2u
#define PICO_MAX_CHANNELS 8u

static_assert(PB_MAX_BOARD_MOTORS <= PICO_MAX_MOTORS, "a PICO board drives two motors");
static_assert(PB_MAX_BOARD_CHANNELS <= PICO_MAX_CHANNELS, "channels of one board");

/* One PB_CHANNEL_IO_TABLE entry. */
struct pico_channel {
    uint8_t board_index;
    uint8_t source; /* PB_SRC_* */
    uint8_t slot;   /* sensor connector, or motor slot for velocity and current */
    int16_t raw_lo;
    int16_t raw_hi;
    int16_t zero_raw;
    int32_t scale_q16; /* IMU: raw per 1/16 degree */
};

/* One PB_MOTOR_IO_TABLE entry. */
struct pico_motor_io {
    int16_t angle_channel; /* layout index of the position loop's angle channel, -1 */
    int32_t position_q16;  /* angle raw per position raw */
    uint8_t hold_duty;     /* largest duty of the position loop */
    uint32_t circumference_um;
    uint16_t velocity_um_s; /* one raw unit of velocity feedback */
};

struct pico_board {
    bool known;    /* the id is one of the layout's boards */
    uint8_t id;
    uint8_t index; /* in the layout's board table */
    uint8_t n_motors;
    uint8_t n_channels;
    struct pb_motor motor[PICO_MAX_MOTORS];        /* in slot order */
    struct pico_motor_io motor_io[PICO_MAX_MOTORS];
    int8_t angle_channel[PICO_MAX_MOTORS];         /* in this board's channels, or -1 */
    struct pico_channel channel[PICO_MAX_CHANNELS]; /* in layout order */
};

extern struct pico_board board;

/* Look up board `id` in the layout; board.known says whether it is there. */
void board_load(uint8_t id);

#endif
