/* PIRATEbay bridge firmware: the host link (USART0, wire protocol v1.2) in front of
 * the PICO boards' RS485 bus (USART1), on an ATmega2560 at 16 MHz.
 *
 * Between turns of the loop the CPU sleeps (idle mode: the USARTs and timers run on)
 * until the next interrupt: a byte in either direction, a frame sent, the 1 ms tick,
 * or Timer1's compare at a bus timeout. Everything the loop waits for is one of them.
 *
 * The AVR's own watchdog (mcu.c) resets the chip if a turn of the loop ever takes
 * longer than 120 ms; the bridge then boots latched, and pb_debug.mcu_resets counts
 * it. */
#include <avr/interrupt.h>

#include "bridge.h"
#include "mcu.h"

int main(void) {
    bridge_init();
    sei();
    for (;;) {
        bridge_turn();
        mcu_idle();
    }
}
