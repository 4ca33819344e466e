#include "estop_input.h"

#include "mcu.h"
#include "safety.h"

static struct {
    uint32_t last_ms;
    uint8_t run;    /* consecutive samples disagreeing with `pressed` */
    bool pressed;   /* debounced: open */
    bool tripped;   /* latched the e-stop; cleared by ESTOP_RESET */
} in;

void estop_input_init(void) {
    mcu_estop_input_init();
    in.last_ms = 0;
    in.run = 0;
    in.pressed = false;
    in.tripped = false;
}

#if PB_ESTOP_INPUT
static void trip(void) {
    in.pressed = true;
    in.tripped = true;
    safety_estop_latch(); /* the same stop as a host ESTOP, queued for the bus now */
    pb_debug.estop_input_trips++;
    PB_MARK(PB_MARK_ESTOP_INPUT);
}
#endif

void estop_input_poll(uint32_t now_ms) {
#if PB_ESTOP_INPUT
    if (now_ms == in.last_ms) {
        return;
    }
    in.last_ms = now_ms;
    bool open = mcu_estop_input_open();
    if (open == in.pressed) {
        in.run = 0;
    } else if (++in.run >= (open ? ESTOP_TRIP_SAMPLES : ESTOP_RELEASE_SAMPLES)) {
        in.run = 0;
        if (open) {
            trip();
        } else {
            in.pressed = false;
        }
    }
#else
    (void)now_ms;
#endif
    /* the LED shows the latch whatever latched it, with or without a button input (a
     * bridge built ESTOP_INPUT=none never lit it, though it boots latched) */
    mcu_led(safety_estopped());
}

bool estop_input_pressed(void) { return in.pressed; }

bool estop_input_active(void) { return in.pressed || in.tripped; }

void estop_input_reset(void) { in.tripped = false; }
