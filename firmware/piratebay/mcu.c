#include "mcu.h"

#include <avr/eeprom.h>
#include <avr/io.h>
#include <avr/wdt.h>

#define STACK_PAINT 0xC5u
#define BOOT_ID_EEPROM ((uint16_t *)0)

/* .noinit survives a reset that is not a power-on: the reset count lives there. */
struct pb_debug pb_debug __attribute__((section(".noinit")));

static uint8_t mcusr_at_boot __attribute__((section(".noinit")));
static uint16_t boot_id;
static uint8_t *stack_scan;

extern uint8_t __heap_start; /* end of .bss and .noinit (linker symbol) */

/* Before anything else runs: save and clear MCUSR and stop a watchdog that may
 * still run after a watchdog reset (avr-libc FAQ), then paint the free SRAM
 * between the end of the data and the stack pointer. */
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
    if ((cause & _BV(PORF)) || pb_debug.magic != PB_DEBUG_MAGIC) {
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
    stack_scan = (uint8_t *)SP;

    boot_id = (uint16_t)(eeprom_read_word(BOOT_ID_EEPROM) + 1u);
    eeprom_update_word(BOOT_ID_EEPROM, boot_id);

    wdt_enable(WDTO_120MS);
}

void mcu_feed(void) { wdt_reset(); }

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
