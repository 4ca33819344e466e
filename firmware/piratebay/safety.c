#include "safety.h"

#include "poller.h"

struct pb_setpoint safety_setpoints[PB_N_MOTORS ? PB_N_MOTORS : 1];

static struct {
    bool estop;
    bool watchdog;
    uint32_t watchdog_trips;
    uint32_t last_rx_ms;
    uint8_t motors_off[(PB_N_BOARDS + 7) / 8];
} safe;

void safety_init(uint32_t now_ms) {
    for (uint8_t i = 0; i < PB_N_MOTORS; i++) {
        safety_setpoints[i].mode = PB_MODE_KEEP; /* never commanded */
        safety_setpoints[i].raw = 0;
    }
    safe.estop = true; /* the bridge boots latched */
    safe.watchdog = false;
    safe.watchdog_trips = 0;
    safe.last_rx_ms = now_ms;
    safety_stop();
}

void safety_stop(void) {
    for (uint8_t i = 0; i < PB_N_MOTORS; i++) {
        const struct pb_motor *m = layout_motor(i);
        if (m->role == PB_ROLE_BEND) {
            continue; /* the clamps keep holding */
        }
        uint8_t mode = m->role == PB_ROLE_DRIVE ? PB_MODE_VELOCITY : PB_MODE_PWM;
        if (!layout_mode_ok(m, mode)) {
            continue; /* a rotate or other motor that lists no pwm keeps its setpoint */
        }
        safety_setpoints[i].mode = mode;
        safety_setpoints[i].raw = 0;
    }
    for (uint8_t i = 0; i < sizeof safe.motors_off; i++) {
        safe.motors_off[i] = 0xFF;
    }
    poller_request_stop();
}

void safety_estop_latch(void) {
    safe.estop = true;
    safety_stop();
}

bool safety_estopped(void) { return safe.estop; }

void safety_estop_release(void) { safe.estop = false; }

void safety_feed(uint32_t now_ms) {
    safe.last_rx_ms = now_ms;
    safe.watchdog = false;
}

void safety_watchdog_check(uint32_t now_ms) {
    if (safe.watchdog || (uint32_t)(now_ms - safe.last_rx_ms) <= PB_WATCHDOG_MS) {
        return;
    }
    safe.watchdog = true;
    safe.watchdog_trips++;
    safety_stop();
}

bool safety_watchdog_tripped(void) { return safe.watchdog; }

void safety_watchdog_clear(void) { safe.watchdog = false; }

uint32_t safety_watchdog_trips(void) { return safe.watchdog_trips; }

bool safety_motors_off(uint8_t board_index) {
    return (safe.motors_off[board_index >> 3] >> (board_index & 7u)) & 1u;
}

void safety_apply(uint8_t motor, struct pb_setpoint setpoint) {
    uint8_t b = layout_motor(motor)->board_index;
    safety_setpoints[motor] = setpoint;
    safe.motors_off[b >> 3] &= (uint8_t)~(1u << (b & 7u));
}
