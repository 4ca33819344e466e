#include "sensors.h"

#include <string.h>

#include "hal.h"

#define RING (VELOCITY_WINDOW_MS / 10u)

/* The build's ENCODER_CPR, in the ELF only: the chain's physics turns wheel travel into
 * encoder counts with the figure this board divides by (pirate_bt.sim.chain). */
const int32_t pico_encoder_cpr PB_IN_ELF = ENCODER_CPR;

static struct {
    int16_t value[PICO_MAX_CHANNELS];
    int16_t speed[PICO_MAX_MOTORS];
    int16_t counts[PICO_MAX_MOTORS][RING]; /* encoder count every 10 ms */
    uint8_t ring_at;
    uint32_t last_10ms;
    uint32_t imu_ok_ms; /* the IMU's last successful read (boot until the first) */
    bool stale;
    struct speed_scale {
        uint64_t num; /* raw = counts x num / den: 25 x circumference / (CPR x step), */
        uint32_t den; /* in lowest terms (0: no velocity feedback) */
        uint32_t half;
        uint8_t shift; /* den == 1 << shift, or DIVIDE */
        bool wide;     /* num >= 2^16: in 64 bits */
    } scale[PICO_MAX_MOTORS];
} s;

#define DIVIDE 0xFFu
#define SPEED_MAX 32767u

static uint32_t gcd32(uint32_t a, uint32_t b) {
    while (b != 0) {
        uint32_t r = a % b;
        a = b;
        b = r;
    }
    return a;
}

/* Motor k's speed scale, worked out once at boot (the divisions here run once). A speed
 * is counts over 40 ms x (1000 / 40) x circumference / (ENCODER_CPR x one velocity raw
 * unit): in 32 bits the numerator overflowed above 65 mm/s with ENCODER_CPR=32768, so
 * the fraction is kept in lowest terms. For the robot descriptions' wheels and steps its
 * numerator is below 65536 (the default robot's 37699 at every ENCODER_CPR), and a
 * reading is a 32-bit multiply and a shift (den a power of two) or one 32-bit division,
 * as before; any other is done in 64 bits, still exact. */
static void speed_scale(uint8_t k) {
    struct speed_scale *sc = &s.scale[k];
    const struct pico_motor_io *io = &board.motor_io[k];
    sc->den = 0;
    if (io->velocity_um_s == 0 || io->circumference_um == 0) {
        return;
    }
    uint64_t num = (uint64_t)(1000u / VELOCITY_WINDOW_MS) * io->circumference_um;
    uint32_t den = (uint32_t)ENCODER_CPR * io->velocity_um_s; /* < 2^31 */
    uint32_t g = gcd32(den, (uint32_t)(num % den));
    sc->num = num / g;
    sc->den = den / g;
    sc->half = sc->den >> 1;
    sc->wide = sc->num > 0xFFFFu;
    sc->shift = DIVIDE;
    for (uint8_t b = 0; b < 32u; b++) {
        if (sc->den == (uint32_t)1 << b) {
            sc->shift = b;
        }
    }
}

void sensors_init(uint32_t now_ms) {
    memset(&s, 0, sizeof s);
    s.imu_ok_ms = now_ms;
    for (uint8_t k = 0; k < PICO_MAX_MOTORS; k++) {
        if (k < board.n_motors) {
            speed_scale(k);
        }
        for (uint8_t i = 0; i < RING; i++) {
            /* the encoder of the motor's slot, as every later sample (speeds()): this read
             * encoder k, slot 0's counter on a board whose one motor is on slot 1 */
            s.counts[k][i] = hal_encoder(board.motor[k].slot);
        }
    }
}

/* x / 1024, rounded towards zero as C divides: the ADC reading's scaling runs for every
 * ADC channel every millisecond, and -Os makes a signed division by 1024 a call of the
 * library's 32-bit division (about 600 cycles). Only non-negative values are shifted. */
static int32_t div1024(int32_t x) {
    return x >= 0 ? x >> 10 : -((-x) >> 10);
}

static int16_t clamp(int32_t v, int16_t lo, int16_t hi) {
    return v < lo ? lo : v > hi ? hi : (int16_t)v;
}

/* `counts` x the scale, rounded half away from zero and held to +-32767: exact for every
 * count of the 16-bit window. The magnitude is unsigned: |counts| <= 32768 and num <
 * 65536 keep the product and its rounding below 2^32. */
static int16_t scaled(int16_t counts, const struct speed_scale *sc) {
    uint16_t m = counts < 0 ? (uint16_t)(0u - (uint16_t)counts) : (uint16_t)counts;
    uint32_t q;
    if (!sc->wide) {
        uint32_t x = (uint32_t)m * (uint16_t)sc->num + sc->half;
        q = sc->shift != DIVIDE ? x >> sc->shift : x / sc->den;
    } else {
        uint64_t x = ((uint64_t)m * sc->num + sc->half) / sc->den; /* < 2^53 */
        q = x > SPEED_MAX ? SPEED_MAX : (uint32_t)x;
    }
    int16_t v = (int16_t)(q > SPEED_MAX ? SPEED_MAX : q);
    return counts < 0 ? (int16_t)-v : v;
}

/* Motor k's speed in its velocity feedback's raw unit, from the encoder's counts over
 * the last 40 ms: counts/s x circumference / counts per revolution. */
static void speeds(void) {
    uint8_t oldest = (uint8_t)((s.ring_at + 1u) % RING);
    for (uint8_t k = 0; k < board.n_motors && k < PICO_MAX_MOTORS; k++) {
        int16_t now = hal_encoder(board.motor[k].slot);
        int16_t counts = (int16_t)(now - s.counts[k][oldest]);
        s.counts[k][oldest] = now;
        s.speed[k] = s.scale[k].den == 0 ? 0 : scaled(counts, &s.scale[k]);
    }
    s.ring_at = oldest;
}

/* The motor index (in this board's slot order) of slot `slot`. */
static uint8_t motor_of(uint8_t slot) {
    for (uint8_t k = 0; k < board.n_motors; k++) {
        if (board.motor[k].slot == slot) {
            return k;
        }
    }
    return 0;
}

#define HEADING_TURN 5760 /* 360 degrees in the IMU's 1/16 degree */

/* The yaw, in (-180, 180] degrees (1/16 degree) counter-clockwise seen from above, of
 * a heading in 0..360 degrees clockwise (a BNO055's; a value outside is taken modulo a
 * turn): as the simulator's atan2 and docs/simulator.md read yaw. Scaled as it was, a
 * heading past about 188 degrees clamped at the channel's end (a left turn of 90
 * degrees, heading 270, read 188 degrees). */
static int32_t yaw_of_heading(int32_t heading) {
    int32_t yaw = -(heading % HEADING_TURN); /* (-360, 360) degrees */
    if (yaw <= -HEADING_TURN / 2) {
        yaw += HEADING_TURN;
    } else if (yaw > HEADING_TURN / 2) {
        yaw -= HEADING_TURN;
    }
    return yaw;
}

void sensors_tick(uint32_t now_ms) {
    if ((uint32_t)(now_ms - s.last_10ms) >= 10u) {
        s.last_10ms = now_ms;
        speeds();
    }
    int16_t imu[3] = {0, 0, 0};
    bool have_imu = false;
    s.stale = false;
    for (uint8_t c = 0; c < board.n_channels; c++) {
        uint8_t src = board.channel[c].source;
        if (src == PB_SRC_IMU_ROLL || src == PB_SRC_IMU_PITCH || src == PB_SRC_IMU_YAW) {
            have_imu = hal_imu(imu); /* a board without an IMU never starts the TWI */
            if (have_imu) {
                s.imu_ok_ms = now_ms;
            }
            /* an IMU that stops answering: its channels keep their last good values,
             * and the reply says STALE until a read succeeds again */
            s.stale = (uint32_t)(now_ms - s.imu_ok_ms) > SENSOR_STALE_MS;
            break;
        }
    }
    for (uint8_t c = 0; c < board.n_channels; c++) {
        const struct pico_channel *ch = &board.channel[c];
        int32_t v;
        switch (ch->source) {
        case PB_SRC_ADC:
        case PB_SRC_CURRENT: {
            uint8_t input = ch->source == PB_SRC_ADC ? HAL_ADC_SENSOR(ch->slot)
                                                     : HAL_ADC_CURRENT(ch->slot);
            int32_t span = (int32_t)ch->raw_hi - ch->raw_lo + 1;
            v = ch->raw_lo + div1024((int32_t)hal_adc(input) * span);
            break;
        }
        case PB_SRC_IMU_ROLL:
        case PB_SRC_IMU_PITCH:
        case PB_SRC_IMU_YAW: {
            if (!have_imu) {
                continue; /* keep the last value (0 before any) */
            }
            /* the IMU gives heading (yaw), roll, pitch in that register order */
            uint8_t axis = ch->source == PB_SRC_IMU_YAW ? 0u
                           : ch->source == PB_SRC_IMU_ROLL ? 1u
                                                            : 2u;
            int32_t angle = imu[axis];
            if (axis == 0u) {
                angle = yaw_of_heading(angle);
            }
            int64_t q = (int64_t)angle * ch->scale_q16;
            v = ch->zero_raw + (int32_t)((q + (q >= 0 ? 32768 : -32768)) / 65536);
            break;
        }
        case PB_SRC_VELOCITY:
            v = s.speed[motor_of(ch->slot)];
            break;
        default:
            v = 0;
            break;
        }
        s.value[c] = clamp(v, ch->raw_lo, ch->raw_hi);
    }
}

bool sensors_stale(void) { return s.stale; }

int16_t sensors_channel(uint8_t c) { return c < PICO_MAX_CHANNELS ? s.value[c] : 0; }

int16_t sensors_speed(uint8_t k) { return k < PICO_MAX_MOTORS ? s.speed[k] : 0; }
