/* The generated layout tables. They live in SRAM (avr-gcc copies them from flash
 * at start-up: 6 bytes per board, 20 per motor, 374 for the default robot): the
 * checks of every SETPOINT and BULK_SETPOINTS read them, and reading them in place
 * is several times faster than copying each entry out of flash with memcpy_P. */
#include "robot_layout.h"

/* The layout digest of the description this ELF was built for, under a symbol of its
 * own, in the ELF only: a simulator reads it there and refuses to put the firmware
 * behind boards of another description (pirate-bt sim --firmware, the chain), as a
 * host's HELLO refuses it at connect time. Nothing reads it here. */
const uint32_t pb_layout_digest PB_IN_ELF = PB_LAYOUT_DIGEST;

static const struct pb_board boards[PB_N_BOARDS] = PB_BOARD_TABLE;
#if PB_N_MOTORS > 0
static const struct pb_motor motors[PB_N_MOTORS] = PB_MOTOR_TABLE;
#else
static const struct pb_motor motors[1];
#endif

/* The host build for the tests (HOST_SANITIZE in the Makefile) traps on an index past
 * a table here: its bounds check sees the arrays' own accesses, not the accesses
 * through the pointers these return (and one past the end is a valid address). */
#ifdef PB_TRAP_PAST_TABLES
#define IN_TABLE(index, n) ((index) < (n) ? (void)0 : __builtin_trap())
#else
#define IN_TABLE(index, n) ((void)0)
#endif

const struct pb_board *layout_board(uint8_t index) {
    IN_TABLE(index, PB_N_BOARDS);
    return &boards[index];
}

const struct pb_motor *layout_motor(uint8_t index) {
    IN_TABLE(index, PB_N_MOTORS);
    return &motors[index];
}

int8_t layout_board_index(uint8_t id) {
    for (uint8_t i = 0; i < PB_N_BOARDS; i++) {
        if (boards[i].id == id) {
            return (int8_t)i;
        }
    }
    return -1;
}

bool layout_mode_ok(const struct pb_motor *motor, uint8_t mode) {
    return mode < PB_N_MODES && (motor->mode_mask & (1u << mode)) != 0;
}

bool layout_raw_ok(const struct pb_motor *motor, uint8_t mode, int16_t raw) {
    return raw >= motor->range[mode].lo && raw <= motor->range[mode].hi;
}
