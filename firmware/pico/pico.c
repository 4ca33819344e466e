#include "pico.h"

#include "board.h"
#include "bus.h"
#include "hal.h"
#include "motors.h"
#include "sensors.h"

/* used, externally visible: a harness reads it by symbol; link-time optimisation must
 * neither drop it nor its stores */
struct pico_debug pico_debug __attribute__((used, externally_visible));

static uint32_t last_ms;

void pico_init(void) {
    hal_init();
    board_load(hal_board_id());
    bool warm = hal_warm_boot();
    last_ms = hal_ms();
    sensors_init(last_ms);
    motors_init(warm);
    bus_init(last_ms);
    pico_debug.magic = PICO_DEBUG_MAGIC;
    pico_debug.last_mcusr = hal_reset_cause();
    pico_debug.resets = 0;
    pico_debug.board_id = board.id;
    pico_debug.known = board.known;
    pico_debug.warm = warm;
}

void pico_turn(void) {
    bus_poll();
    for (uint8_t k = 0; k < 2u; k++) { /* what each motor executes, at once */
        const struct motor_state *m = motors_state(k);
        pico_debug.motor_mode[k] = k < board.n_motors ? m->mode : MOTOR_OFF;
        pico_debug.motor_raw[k] = k < board.n_motors ? m->raw : 0;
    }
    uint32_t now = hal_ms();
    if (now == last_ms) {
        return;
    }
    last_ms = now;
    hal_feed(); /* once a millisecond: plenty against the 60 ms watchdog */
    sensors_tick(now);
    bus_poll(); /* between the steps of the tick: a request is answered in time */
    bus_tick(now);
    motors_tick();
    bus_poll();
    const struct bus_counts *c = bus_counts();
    pico_debug.exchanges = c->exchanges;
    pico_debug.stops = c->stops;
    pico_debug.bad_frames = c->bad;
    pico_debug.own_stops = c->own_stops;
    pico_debug.refused = c->refused;
    pico_debug.others = c->others;
    pico_debug.own_stop = bus_own_stop();
    pico_debug.stack_low = hal_stack_low();
    /* the LED: on while stopped by itself, blinking when the id is not the layout's */
    hal_led(board.known ? bus_own_stop() : (now & 256u) != 0);
}
