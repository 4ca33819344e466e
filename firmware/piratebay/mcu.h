/* The microcontroller itself: the RS485 driver held off from the first instructions
 * after reset, the fuses (brown-out detection), the AVR's hardware watchdog (last
 * resort against a hung main loop), reset causes (MCUSR) and a count of MCU resets,
 * the boot id (one EEPROM write per power-on, none per DTR reset), the painted stack
 * and its high-water mark, and the debug record and GPIOR0 markers a simulator
 * harness reads (docs/firmware.md). */
#ifndef PB_MCU_H
#define PB_MCU_H

#include <assert.h>
#include <stdbool.h>
#include <stdint.h>

#define PB_DEBUG_MAGIC 0x5042u /* "PB" */

/* Read by the simavr harness by symbol (`pb_debug`); layout fixed. */
struct pb_debug {
    uint16_t magic;
    uint16_t mcu_resets;  /* resets other than power-on since power-on */
    uint8_t last_mcusr;   /* MCUSR at the last boot (bit 0 PORF, 1 EXTRF, 2 BORF, 3 WDRF) */
    uint8_t reserved;
    uint16_t stack_low;   /* lowest SRAM address the stack ever reached */
    uint16_t stack_bottom; /* end of .bss/.noinit: the stack may not go below it */
    uint16_t state_cycles_last; /* encoding one STATE frame, in CPU cycles (+-8) */
    uint16_t state_cycles_max;
    uint16_t bulk_cycles_last;  /* decoding and applying one BULK_SETPOINTS frame */
    uint16_t bulk_cycles_max;
    uint16_t rx_overruns;       /* host-link bytes lost (hardware overrun or a full ring) */
    uint16_t host_framing;      /* host-link framing errors */
    uint16_t bus_framing;       /* board-bus framing errors */
    uint16_t bus_overrun;       /* board-bus bytes lost (hardware overrun or a full ring) */
    uint16_t bus_echo;          /* board-bus bytes heard while the bridge drove the bus */
    uint16_t board_own_stops;   /* replies of a board holding its own stop (master silent) */
    uint16_t estop_input_trips; /* the hardware e-stop input tripped the latch */
};

static_assert(sizeof(struct pb_debug) == 32, "pb_debug layout is read by the harness");

extern struct pb_debug pb_debug;

/* GPIOR0 markers (docs/firmware.md): a harness hooks writes to GPIOR0 and reads
 * the cycle counter at each. */
#define PB_MARK_STATE_BEGIN 0x01u
#define PB_MARK_STATE_END 0x81u
#define PB_MARK_FRAME_END 0x02u /* a host frame's 0x00 taken from the ring */
#define PB_MARK_BULK_END 0x82u
#define PB_MARK_ESTOP 0x03u
#define PB_MARK_BUS_STOP 0x04u
#define PB_MARK_ESTOP_INPUT 0x05u /* the hardware e-stop input tripped the latch */

#ifdef __AVR__
#include <avr/io.h>
#define PB_MARK(x) (GPIOR0 = (x))
#else
#define PB_MARK(x) ((void)0)
#endif

/* Count the reset (MCUSR), start the hardware watchdog, read and advance the boot id. */
void mcu_init(void);
/* Feed the hardware watchdog (once per main-loop turn). */
void mcu_feed(void);
/* Idle sleep until the next interrupt, unless received bytes wait (then at once). */
void mcu_idle(void);
/* This boot's id (differs from the previous boot's). */
uint16_t mcu_boot_id(void);
/* Update pb_debug.stack_low from the painted stack (cheap; call every period). */
void mcu_stack_check(void);
/* The hardware e-stop input's pin (pull-up on) and the LED (off). */
void mcu_estop_input_init(void);
/* The e-stop input reads open (high): pressed, or its wire is broken. */
bool mcu_estop_input_open(void);
/* The LED on (the e-stop is latched) or off. */
void mcu_led(bool on);
/* Cycle figures: elapsed timer ticks (0.5 us = 8 cycles) into pb_debug. */
void mcu_record_cycles(uint16_t *last, uint16_t *max, uint16_t ticks);

#endif
