/* PIRATEbay bridge firmware: the host link (USART0, wire protocol v1.1) in front of
 * the PICO boards' RS485 bus (USART1), on an ATmega2560 at 16 MHz.
 *
 * The AVR's own watchdog (mcu.c) resets the chip if a turn of the loop ever takes
 * longer than 120 ms; the bridge then boots latched, and pb_debug.mcu_resets counts
 * it. */
#include <avr/interrupt.h>

#include "bridge.h"

int main(void) {
    bridge_init();
    sei();
    for (;;) {
        bridge_turn();
    }
}
