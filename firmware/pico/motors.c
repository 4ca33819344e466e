#include "motors.h"

#include <string.h>

#include "hal.h"
#include "sensors.h"

#define POSITION_DEADBAND 6 /* angle raw units (0.5 degree): brake inside it */
#define POSITION_KP 4       /* duty per angle raw unit of error */
#define VELOCITY_KP_Q16 13107L /* 0.2 duty per velocity raw unit */
#define VELOCITY_KI_Q16 70L    /* per millisecond: a 0.2 s time constant at 4.7 raw/duty */
#define DUTY_Q16 (255L << 16)
#define SAVED_MAGIC 0x5043u /* "PC" */

static struct motor_state state[PICO_MAX_MOTORS];
static int32_t integral_q16[PICO_MAX_MOTORS];
static int16_t duty_now[PICO_MAX_MOTORS];
/* Worked out once per setpoint, not every millisecond (a 32-bit division costs the AVR
 * some 600 cycles): pwm and torque's duty, position's target in angle raw units,
 * velocity's feed-forward duty. */
static int32_t derived[PICO_MAX_MOTORS];

static void derive(uint8_t k);

/* What a watchdog or brown-out reset must not lose: the joints' setpoints. */
static struct {
    uint16_t magic;
    struct motor_state state[PICO_MAX_MOTORS];
    uint16_t check;
} saved __attribute__((section(".noinit")));

static uint16_t checksum(void) {
    const uint8_t *p = (const uint8_t *)saved.state;
    uint16_t sum = SAVED_MAGIC;
    for (uint8_t i = 0; i < sizeof saved.state; i++) {
        sum = (uint16_t)((sum << 1 | sum >> 15) ^ p[i]);
    }
    return sum;
}

static void save(void) {
    memcpy(saved.state, state, sizeof saved.state);
    saved.magic = SAVED_MAGIC;
    saved.check = checksum();
}

void motors_init(bool warm) {
    bool kept = warm && saved.magic == SAVED_MAGIC && saved.check == checksum();
    for (uint8_t k = 0; k < PICO_MAX_MOTORS; k++) {
        state[k].mode = MOTOR_OFF;
        state[k].raw = 0;
        integral_q16[k] = 0;
        duty_now[k] = 0;
        if (k >= board.n_motors) {
            continue;
        }
        if (kept && board.motor[k].role == PB_ROLE_BEND) {
            state[k] = saved.state[k]; /* a clamp goes on holding through a reset */
        } else if (kept) {
            state[k].mode = PB_MODE_PWM; /* the others brake */
        }
        derive(k);
    }
    save();
}

/* The top of a mode's raw range, max(|lo|, hi), unsigned: a range from -32768 has 32768
 * (in int16, -(-32768) is -32768 again, and the top came out as hi: torque -1023 of
 * [-32768, 1023] ran at full duty). */
static uint16_t range_top(const struct pb_motor *m, uint8_t mode) {
    int16_t lo = m->range[mode].lo;
    int16_t hi = m->range[mode].hi;
    uint16_t a = lo < 0 ? (uint16_t)-(int32_t)lo : (uint16_t)lo;
    uint16_t h = hi < 0 ? 0u : (uint16_t)hi;
    return h > a ? h : a;
}

static int16_t limit(int32_t v, int16_t top);
static uint16_t range_top(const struct pb_motor *m, uint8_t mode);

static void derive(uint8_t k) {
    const struct pb_motor *m = &board.motor[k];
    int16_t raw = state[k].raw;
    switch (state[k].mode) {
    case PB_MODE_PWM:
    case PB_MODE_TORQUE:
    case PB_MODE_VELOCITY: {
        uint16_t top = range_top(m, state[k].mode);
        derived[k] = top > 0 ? limit((int32_t)raw * 255 / (int32_t)top, 255) : 0;
        break;
    }
    case PB_MODE_POSITION: {
        /* In 64 bits, once per setpoint: raw x position_q16 overflowed 32 bits for a
         * position unit 16 times the angle sensor's, and the joint drove the other way.
         * A target beyond what the sensor reads is held at its end. */
        int8_t c = board.angle_channel[k];
        if (c < 0) {
            derived[k] = 0;
            break;
        }
        const struct pico_channel *ch = &board.channel[c];
        int64_t target =
            ch->zero_raw + ((int64_t)raw * board.motor_io[k].position_q16) / 65536;
        derived[k] = target < ch->raw_lo   ? ch->raw_lo
                     : target > ch->raw_hi ? ch->raw_hi
                                           : (int32_t)target;
        break;
    }
    default:
        derived[k] = 0;
        break;
    }
}

bool motors_set(uint8_t k, uint8_t mode, int16_t raw) {
    if (k >= board.n_motors) {
        return false;
    }
    if (mode == PB_MODE_KEEP) {
        return true;
    }
    const struct pb_motor *m = &board.motor[k];
    if (!layout_mode_ok(m, mode) || !layout_raw_ok(m, mode, raw)) {
        return false;
    }
    if (state[k].mode != mode) {
        integral_q16[k] = 0;
    }
    if (state[k].mode == mode && state[k].raw == raw) {
        return true; /* the same setpoint again (every poll): nothing to work out */
    }
    state[k].mode = mode;
    state[k].raw = raw;
    derive(k);
    save();
    return true;
}

void motors_stop(void) {
    for (uint8_t k = 0; k < board.n_motors; k++) {
        const struct pb_motor *m = &board.motor[k];
        if (m->role == PB_ROLE_BEND) {
            continue; /* the clamp keeps its torque */
        }
        if (layout_mode_ok(m, PB_MODE_PWM)) {
            state[k].mode = PB_MODE_PWM; /* brake */
            state[k].raw = 0;
        } else if (m->role == PB_ROLE_DRIVE) {
            state[k].mode = PB_MODE_VELOCITY; /* 0 is a brake too */
            state[k].raw = 0;
        }
        derive(k);
    }
    save();
}

bool motors_off(void) {
    for (uint8_t k = 0; k < board.n_motors; k++) {
        if (state[k].mode == MOTOR_OFF) {
            return true;
        }
    }
    return false;
}

const struct motor_state *motors_state(uint8_t k) { return &state[k]; }

int16_t motors_duty(uint8_t k) { return duty_now[k]; }

static int16_t limit(int32_t v, int16_t top) {
    return v > top ? top : v < -top ? (int16_t)-top : (int16_t)v;
}

/* The duty of motor k this millisecond; 0 means brake (unless it is off). */
static int16_t control(uint8_t k) {
    int16_t raw = state[k].raw;
    switch (state[k].mode) {
    case PB_MODE_PWM:
    case PB_MODE_TORQUE:
        return (int16_t)derived[k];
    case PB_MODE_POSITION: {
        int8_t c = board.angle_channel[k];
        if (c < 0) {
            return 0;
        }
        int32_t error = derived[k] - sensors_channel((uint8_t)c);
        if (error >= -POSITION_DEADBAND && error <= POSITION_DEADBAND) {
            return 0;
        }
        return limit(error * POSITION_KP, board.motor_io[k].hold_duty);
    }
    case PB_MODE_VELOCITY: {
        if (raw == 0) {
            integral_q16[k] = 0;
            return 0; /* velocity 0 is a brake, not a loop */
        }
        int32_t error = (int32_t)raw - sensors_speed(k);
        int32_t i = integral_q16[k] + error * VELOCITY_KI_Q16;
        i = i > DUTY_Q16 ? DUTY_Q16 : i < -DUTY_Q16 ? -DUTY_Q16 : i;
        integral_q16[k] = i;
        /* >> 16 of a signed value: rounds toward minus infinity, a bias below one duty */
        return limit(derived[k] + ((error * VELOCITY_KP_Q16 + i) >> 16), 255);
    }
    default:
        return 0;
    }
}

void motors_tick(void) {
    for (uint8_t k = 0; k < board.n_motors; k++) {
        uint8_t slot = board.motor[k].slot;
        if (state[k].mode == MOTOR_OFF) {
            duty_now[k] = 0;
            hal_motor(slot, HAL_OFF, 0);
            continue;
        }
        int16_t duty = control(k);
        duty_now[k] = duty;
        hal_motor(slot, duty == 0 ? HAL_BRAKE : HAL_RUN, duty);
    }
}
