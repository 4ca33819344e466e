/* pirate-chain: the whole embedded chain in simavr, in virtual time (chain.c has the
 * overview and the records). The interfaces of its files, bottom to top:
 *
 *   chain.c        main: the cores, the lockstep scheduler, the host link, the records
 *     |   chain_figures.c  the bus cycle figure and the 'S' record of figures
 *     |   \
 *     |   chain_board.c  one PICO board's pins: ADC, encoders, IMU (a TWI slave),
 *     |                  the H-bridge outputs sampled
 *   chain_line.c   the RS485 line: who drives it, who hears what, collisions
 *     |
 *   channel.c      records on stdin/stdout (shared with pirate-simavr)
 *
 * A file calls only the ones below it; each keeps its own state. */
#ifndef PIRATE_CHAIN_H
#define PIRATE_CHAIN_H

#include "harness.h"

#include <simavr/avr_adc.h>
#include <simavr/avr_eeprom.h>
#include <simavr/avr_twi.h>

#define CHAIN_MAX_BOARDS 17 /* the wire protocol's most (docs/protocol.md: COUNTERS) */
#define CHAIN_NODES (CHAIN_MAX_BOARDS + 1) /* node 0 is the bridge */
#define QUANTUM_CYCLES 160u                /* 10 us: the cores run in lockstep slices */
#define LINE_BYTE_CYCLES (HZ * 10u / 1000000u) /* one 8N1 byte at 1 Mbaud: 160 */

/* channel.c: a blocking read of one record, to its handler; false at the end. */
bool channel_wait(channel_handler handle);

/* chain_line.c: the RS485 line between the nodes' USARTs */
struct line_stats {
    uint64_t bytes, delivered, collisions, unheard, driver_off, truncated, echo;
};
/* Node `n`'s USART (`uart` '0' or '1') and its driver-enable and receiver-enable pins
 * (port letter, bit; re_active_low: /RE). */
void line_attach(int n, avr_t *avr, char uart, char de_port, int de_bit, char re_port, int re_bit);
/* Stop hearing and driving for node n (a halted core). */
void line_detach(int n);
/* A node detached by line_detach is on the line again. */
void line_reattach(int n);
/* After every core ran to `until`: put the bytes that started before it on the line. */
void line_settle(uint64_t until);
const struct line_stats *line_stats(void);
/* Frames seen on the line (for the cycle-time figure): callback per frame end. */
typedef void (*line_frame_fn)(int sender, const uint8_t *bytes, unsigned n, uint64_t start,
                              uint64_t end);
void line_on_frame(line_frame_fn fn);
/* Every byte that reaches the line (a listener on the line itself: no transceiver). */
typedef void (*line_tap_fn)(int sender, uint8_t value);
void line_on_byte(line_tap_fn fn);

/* chain_board.c: one PICO board */
struct motor_sample {
    int16_t duty;  /* -255..255 while running */
    uint8_t drive; /* 0 off, 1 brake, 2 run */
};
void board_attach(int b, avr_t *avr, uint8_t id);
/* Inputs for the next step: ADC readings 0..1023, each encoder's count to reach by
 * `until` (edges spread over the step), the IMU's heading, roll, pitch (1/16 degree),
 * the H-bridge fault line. */
void board_inputs(int b, const uint16_t adc[4], const int32_t encoder[2], const int16_t imu[3],
                  bool fault, uint64_t from, uint64_t until);
/* The IMU answers its address (true, from boot) or not (false: no ACK). */
void board_imu_answers(int b, bool on);
/* The H-bridge outputs now. */
struct motor_sample board_sample(int b, int slot);
/* The board's power: off, its H-bridges are off (the motors limp) and its IMU forgets
 * its mode; on again, its pins' external levels are put back (after its MCU's reset). */
void board_power(int b, bool on);

/* chain_figures.c: the figures ('S'). Watch the line's frames for the bus cycle (the
 * boards polled first and last; trace_frames: every frame to stderr). */
void figures_watch_line(uint8_t first, uint8_t last, bool trace_frames);
/* Wall time spent stepping, for the speed against real time. */
void figures_add_wall(double seconds);
/* Send the 'S' record: the figures at cycle `now`. */
void figures_send(uint64_t now, avr_t *const *cores, int n_boards, const uint8_t *board_ids,
                  uint32_t bridge_debug_at, uint32_t pico_debug_at);

#endif
