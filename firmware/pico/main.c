/* The reference PICO board firmware: see pico.h. */
#include <avr/interrupt.h>

#include "bus.h"
#include "hal.h"
#include "pico.h"

int main(void) {
    pico_init();
    sei();
    for (;;) {
        pico_turn();
        if (!bus_busy()) {
            hal_idle(); /* until the next interrupt: a byte, the tick, an edge */
        }
    }
}
