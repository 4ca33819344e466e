#include "board.h"

#include <string.h>

#ifdef __AVR__
#include <avr/pgmspace.h>
#else
#define PROGMEM
#define memcpy_P memcpy
#endif

static const struct pb_board boards[PB_N_BOARDS] PROGMEM = PB_BOARD_TABLE;
#if PB_N_MOTORS > 0
static const struct pb_motor motors[PB_N_MOTORS] PROGMEM = PB_MOTOR_TABLE;
static const struct pico_motor_io motor_io[PB_N_MOTORS] PROGMEM = PB_MOTOR_IO_TABLE;
#endif
#if PB_N_CHANNELS > 0
static const struct pico_channel channels[PB_N_CHANNELS] PROGMEM = PB_CHANNEL_IO_TABLE;
#endif

struct pico_board board;

void board_load(uint8_t id) {
    memset(&board, 0, sizeof board);
    board.id = id;
    for (uint8_t b = 0; b < PB_N_BOARDS; b++) {
        struct pb_board entry;
        memcpy_P(&entry, &boards[b], sizeof entry);
        if (entry.id != id) {
            continue;
        }
        board.known = true;
        board.index = b;
        board.n_motors = entry.n_motors;
        board.n_channels = entry.n_channels;
#if PB_N_MOTORS > 0
        for (uint8_t k = 0; k < entry.n_motors; k++) {
            uint8_t i = (uint8_t)(entry.first_motor + k);
            memcpy_P(&board.motor[k], &motors[i], sizeof board.motor[k]);
            memcpy_P(&board.motor_io[k], &motor_io[i], sizeof board.motor_io[k]);
            int16_t angle = board.motor_io[k].angle_channel;
            board.angle_channel[k] =
                angle < 0 ? -1 : (int8_t)(angle - (int16_t)entry.first_channel);
        }
#endif
#if PB_N_CHANNELS > 0
        for (uint8_t c = 0; c < entry.n_channels; c++) {
            memcpy_P(&board.channel[c], &channels[entry.first_channel + c],
                     sizeof board.channel[c]);
        }
#endif
        return;
    }
}
