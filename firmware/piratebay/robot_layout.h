/* The robot's wire layout as the bridge sees it: boards, their channel and motor
 * slices, each motor's stop role and accepted raw ranges.
 *
 * The numbers come from build/layout.h, generated from the robot description
 * (`pirate-bt robot header hardware/pirate.yaml -o build/layout.h`, run by the
 * Makefile), so the hardware YAML stays the single source of truth. This file owns
 * the types; robot_layout.c holds the tables. */
#ifndef PB_ROBOT_LAYOUT_H
#define PB_ROBOT_LAYOUT_H

#include <assert.h>
#include <stdbool.h>
#include <stdint.h>

#include "layout.h" /* generated: build/layout.h */

#define PB_MODE_PWM 0u
#define PB_MODE_TORQUE 1u
#define PB_MODE_POSITION 2u
#define PB_MODE_VELOCITY 3u
#define PB_N_MODES 4u
#define PB_MODE_KEEP 0xFFu

struct pb_board {
    uint8_t id;
    uint8_t first_channel;
    uint8_t n_channels;
    uint8_t first_motor;
    uint8_t n_motors;
    uint8_t slot_mask; /* bit i = a motor on slot i */
};

struct pb_range {
    int16_t lo;
    int16_t hi;
};

struct pb_motor {
    uint8_t board_index;
    uint8_t slot;
    uint8_t role;      /* PB_ROLE_* */
    uint8_t mode_mask; /* bit m = mode code m accepted */
    struct pb_range range[PB_N_MODES];
};

/* A constant kept in the ELF only, for a simulator to read by its symbol (the layout
 * digest; the PICO's ENCODER_CPR): a section the chip never gets, not allocated (the ';'
 * ends the flags GCC would add: an AVR assembler comment), so neither the HEX, the sizes
 * nor simavr's image change. */
#ifdef __AVR__
#define PB_IN_ELF \
    __attribute__((section(".pb_layout,\"\",@progbits ;"), used, externally_visible))
#else
#define PB_IN_ELF __attribute__((used))
#endif

/* One motor's setpoint as the bridge holds it and sends it to the board. */
struct pb_setpoint {
    uint8_t mode; /* PB_MODE_*, or PB_MODE_KEEP: not commanded / leave as it is */
    int16_t raw;
};

static_assert(sizeof(struct pb_board) == 6, "board table entry is 6 bytes");
static_assert(sizeof(struct pb_motor) == 20, "motor table entry is 20 bytes");
static_assert(PB_N_BOARDS >= 1 && PB_N_BOARDS <= 17, "COUNTERS fits 17 boards at most");
static_assert(PB_N_MOTORS <= 82, "BULK_SETPOINTS payload fits 247 bytes");
static_assert(PB_MAX_BOARD_MOTORS <= 2 && PB_MAX_BOARD_CHANNELS <= 12, "PICO board size");

/* Entry `index` of the board and motor tables. */
const struct pb_board *layout_board(uint8_t index);
const struct pb_motor *layout_motor(uint8_t index);
/* Index of board `id` in the layout, or -1 when the robot has no such board. */
int8_t layout_board_index(uint8_t id);
/* True when the motor accepts `mode` and `raw` lies in that mode's raw range. */
bool layout_mode_ok(const struct pb_motor *motor, uint8_t mode);
bool layout_raw_ok(const struct pb_motor *motor, uint8_t mode, int16_t raw);

#endif
