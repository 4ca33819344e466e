/* The reference PICO board firmware (docs/board-bus.md, "The reference PICO board"):
 * an ATmega328p at 16 MHz with two H-bridge motor outputs, two sensor inputs, an IMU
 * on TWI where the robot description gives the board one, and an RS485 transceiver,
 * as the slave side of the board bus.
 *
 * One cooperative loop, nothing blocks: bus bytes as they arrive (an EXCHANGE is
 * answered within its turnaround), and every millisecond the sensors, the silence
 * check and the motors' loops. Between interrupts the CPU sleeps (idle mode: timers,
 * USART, ADC, TWI and pin changes run on). */
#ifndef PICO_PICO_H
#define PICO_PICO_H

#include <assert.h>
#include <stdint.h>

#define PICO_DEBUG_MAGIC 0x5043u /* "PC" */

/* Read by a harness by symbol (`pico_debug`), like the bridge's pb_debug; layout fixed. */
struct pico_debug {
    uint16_t magic;
    uint8_t board_id;   /* from EEPROM; 0: none */
    uint8_t known;      /* the id is one of the layout's boards */
    uint16_t resets;    /* resets other than power-on since power-on */
    uint8_t last_mcusr;
    uint8_t warm;       /* the joints' setpoints survived the last reset */
    uint16_t stack_low; /* lowest SRAM address the stack reached (painted stack) */
    uint16_t exchanges;
    uint16_t stops;
    uint16_t bad_frames;
    uint16_t own_stops;
    uint16_t refused;
    uint16_t others;    /* good frames to other boards */
    uint8_t own_stop;   /* holding its own stop now */
    uint8_t reserved;
    uint8_t motor_mode[2]; /* the setpoint each motor (slot order) executes: mode code, */
    int16_t motor_raw[2];  /* 0xFE while never commanded, and raw value */
    uint16_t reserved2;
};

static_assert(sizeof(struct pico_debug) == 32, "pico_debug layout is read by the harness");

extern struct pico_debug pico_debug;

void pico_init(void);
void pico_turn(void);

#endif
