/* The generated layout tables, kept in flash (PROGMEM) and read on demand. */
#include "robot_layout.h"

#include "pgm.h"

static const struct pb_board boards[PB_N_BOARDS] PROGMEM = PB_BOARD_TABLE;
#if PB_N_MOTORS > 0
static const struct pb_motor motors[PB_N_MOTORS] PROGMEM = PB_MOTOR_TABLE;
#endif

void layout_board(uint8_t index, struct pb_board *out) {
    memcpy_P(out, &boards[index], sizeof *out);
}

void layout_motor(uint8_t index, struct pb_motor *out) {
#if PB_N_MOTORS > 0
    memcpy_P(out, &motors[index], sizeof *out);
#else
    (void)index;
    (void)out;
#endif
}

int8_t layout_board_index(uint8_t id) {
    for (uint8_t i = 0; i < PB_N_BOARDS; i++) {
        if (pgm_read_byte(&boards[i].id) == id) {
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
