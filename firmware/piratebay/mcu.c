#include "mcu.h"

#include <avr/eeprom.h>
#include <avr/fuse.h>
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/sleep.h>
#include <avr/wdt.h>

#include "pins.h"
#include "uart.h"

#define STACK_PAINT 0xC5u
/* One byte: a count of power-ons, the high byte of the boot id (docs/firmware.md). */
#define POWER_COUNT_EEPROM ((uint8_t *)0)

/* The fuses this firmware is built for, in the ELF's .fuse section (`make fuses` writes
 * the same values with an ISP programmer; the Makefile is their one source): the
 * 16 MHz crystal, the 8 KB bootloader section and its reset vector as on a stock Mega,
 * and brown-out detection at 4.3 V instead of the stock 2.7 V: 16 MHz is specified
 * for 4.5-5.5 V, so the chip is held in reset before it runs out of its spec. */
#ifndef PB_LFUSE
#define PB_LFUSE 0xFF
#define PB_HFUSE 0xD8
#define PB_EFUSE 0xFC
#endif
FUSES = {.low = PB_LFUSE, .high = PB_HFUSE, .extended = PB_EFUSE};

/* .noinit survives a reset that is not a power-on: the reset count lives there. */
struct pb_debug pb_debug __attribute__((section(".noinit")));

static uint8_t mcusr_at_boot __attribute__((section(".noinit")));
static uint16_t boot_id_kept __attribute__((section(".noinit")));
static uint16_t boot_id;
static uint8_t *stack_scan;

extern uint8_t __heap_start; /* end of .bss and .noinit (linker symbol) */

/* The very first instructions after the reset vector, before the C runtime: the RS485
 * driver-enable pin becomes an output at the reset value of its PORT bit, 0 (the
 * driver off). Until here (a few cycles) and through the bootloader the board's
 * pull-down on DE holds it low. */
void mcu_pins_early(void) __attribute__((naked, used, section(".init0")));
void mcu_pins_early(void) {
    __asm__ volatile("sbi %0, %1" ::"I"(_SFR_IO_ADDR(RS485_DE_DDR)), "I"(RS485_DE_BIT));
}

/* Before anything else runs in C: save and clear MCUSR and stop a watchdog that may
 * still run after a watchdog reset (avr-libc FAQ), then paint the free SRAM between
 * the end of the data and the stack pointer. */
void mcu_early(void) __attribute__((naked, used, section(".init3")));
void mcu_early(void) {
    mcusr_at_boot = MCUSR;
    MCUSR = 0;
    wdt_disable();
    uint8_t *p = &__heap_start;
    uint8_t *top = (uint8_t *)SP;
    while (p < top - 2) { /* leave the bytes under SP alone */
        *p++ = STACK_PAINT;
    }
}

void mcu_init(void) {
    uint8_t cause = mcusr_at_boot;
    bool power_on = (cause & _BV(PORF)) || pb_debug.magic != PB_DEBUG_MAGIC;
    if (power_on) {
        /* power-on (or a first boot): .noinit holds garbage */
        pb_debug.magic = PB_DEBUG_MAGIC;
        pb_debug.mcu_resets = 0;
    } else {
        pb_debug.mcu_resets++;
    }
    pb_debug.last_mcusr = cause;
    pb_debug.reserved = 0;
    pb_debug.stack_bottom = (uint16_t)(uintptr_t)&__heap_start;
    pb_debug.stack_low = (uint16_t)SP;
    pb_debug.state_cycles_last = pb_debug.state_cycles_max = 0;
    pb_debug.bulk_cycles_last = pb_debug.bulk_cycles_max = 0;
    pb_debug.rx_overruns = 0;
    pb_debug.host_framing = pb_debug.bus_framing = pb_debug.bus_overrun = 0;
    pb_debug.bus_echo = pb_debug.board_own_stops = pb_debug.estop_input_trips = 0;
    stack_scan = (uint8_t *)SP;

    /* The boot id differs from the previous boot's without wearing the EEPROM: its
     * high byte counts power-ons (one EEPROM byte written per power-on: 100 000
     * cycles last 27 years at ten a day), its low byte the resets since (DTR, the
     * watchdog, brown-out), kept in .noinit. A host connects with a DTR reset, so
     * the old scheme (a word written at every boot) wore the EEPROM per connection. */
    if (power_on) {
        uint8_t powers = (uint8_t)(eeprom_read_byte(POWER_COUNT_EEPROM) + 1u);
        eeprom_update_byte(POWER_COUNT_EEPROM, powers);
        boot_id = (uint16_t)powers << 8;
    } else {
        boot_id = (uint16_t)((boot_id_kept & 0xFF00u) | ((boot_id_kept + 1u) & 0x00FFu));
    }
    boot_id_kept = boot_id;

    set_sleep_mode(SLEEP_MODE_IDLE);
    wdt_enable(WDTO_120MS);
}

void mcu_feed(void) { wdt_reset(); }

void mcu_idle(void) {
    cli();
    if (!uart_rx_pending()) {
        sleep_enable();
        sei();
        sleep_cpu(); /* the instruction after sei runs first: no wake-up is lost */
        sleep_disable();
    }
    sei();
}

void mcu_estop_input_init(void) {
    ESTOP_DDR &= (uint8_t)~_BV(ESTOP_BIT);
    ESTOP_PORT |= _BV(ESTOP_BIT); /* pull-up: an open contact reads high */
    LED_PORT &= (uint8_t)~_BV(LED_BIT);
    LED_DDR |= _BV(LED_BIT);
}

bool mcu_estop_input_open(void) { return (ESTOP_PIN & _BV(ESTOP_BIT)) != 0; }

void mcu_led(bool on) {
    if (on) {
        LED_PORT |= _BV(LED_BIT);
    } else {
        LED_PORT &= (uint8_t)~_BV(LED_BIT);
    }
}

uint16_t mcu_boot_id(void) { return boot_id; }

void mcu_stack_check(void) {
    /* The stack grows down into painted SRAM. Walk down while any of the next 16
     * bytes was touched, so a stacked byte that happens to equal the paint does not
     * stop the walk early. */
    uint8_t *bottom = &__heap_start;
    for (;;) {
        uint8_t *p = stack_scan;
        uint8_t k = 0;
        while (k < 16 && p - k - 1 >= bottom && p[-(int)k - 1] == STACK_PAINT) {
            k++;
        }
        if (k == 16 || p - k - 1 < bottom) {
            break;
        }
        stack_scan = p - k - 1;
    }
    pb_debug.stack_low = (uint16_t)(uintptr_t)stack_scan;
}

void mcu_record_cycles(uint16_t *last, uint16_t *max, uint16_t ticks) {
    uint16_t cycles = ticks > 8191u ? 0xFFFFu : (uint16_t)(ticks * 8u);
    *last = cycles;
    if (cycles > *max) {
        *max = cycles;
    }
}
