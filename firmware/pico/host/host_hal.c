/* Host build of the PICO board for the shared bus vectors (no AVR, no simavr): the
 * hardware file (hal_avr.c) is replaced by this one, which keeps time virtually and
 * lets a test set the inputs and read the outputs. Everything else is the firmware's
 * own code. Driven through ctypes (tests/test_board_bus.py):
 *
 *   pk_boot(id, warm)             a reset with `id` in EEPROM (warm: not a power-on)
 *   pk_run_us(us)                 let virtual time pass, running main-loop turns
 *   pk_write(bytes, n)            bus bytes to the board (delivered at once)
 *   pk_write_damaged(byte)        one bus byte the USART flags (framing error)
 *   pk_read(buf, cap)             what the board sent on the bus
 *   pk_adc(input, value)          an ADC input's reading (0..1023)
 *   pk_encoder(slot, count)       an encoder's count
 *   pk_imu(h, r, p)               the IMU's Euler angles (1/16 degree)
 *   pk_imu_silent(on)             the IMU stops answering (1) or answers again (0)
 *   pk_motor(slot, out3)          the H-bridge output: {drive, duty}
 *   pk_state(k, out2)             motor k's mode and raw setpoint
 *   pk_debug(out)                 the pico_debug record
 *   pk_channel(c)                 this board's state channel c (raw), as the reply says
 *   pk_speed(k)                   motor k's measured speed (velocity raw), as its loop sees
 */
#include <string.h>

#include "../hal.h"
#include "../motors.h"
#include "../pico.h"
#include "../sensors.h"

static uint64_t now_us;
static uint8_t eeprom_id;
static bool warm;
static uint16_t rx[4096]; /* byte | HAL_RX_ERROR */
static uint16_t rx_head, rx_tail;
static uint8_t tx[4096];
static uint16_t tx_n;
static uint16_t adc[4];
static int16_t enc[2];
static int16_t imu[3];
static bool imu_set, imu_silent;
static int16_t out_drive[2], out_duty[2];
static uint16_t rx_at;

void hal_init(void) {}
uint8_t hal_board_id(void) { return eeprom_id; }
uint32_t hal_ms(void) { return (uint32_t)(now_us / 1000u); }
uint16_t hal_ticks(void) { return (uint16_t)(now_us * HAL_TICKS_PER_US); }
int16_t hal_bus_getc(void) {
    if (rx_tail == rx_head) {
        return -1;
    }
    return (int16_t)rx[rx_tail++ % (sizeof rx / sizeof rx[0])];
}
uint16_t hal_bus_rx_at(void) { return rx_at; }
void hal_bus_send(const uint8_t *p, uint8_t n) {
    for (uint8_t i = 0; i < n && tx_n < sizeof tx; i++) {
        tx[tx_n++] = p[i];
    }
}
bool hal_bus_tx_busy(void) { return false; }
void hal_motor(uint8_t slot, enum hal_drive drive, int16_t duty) {
    out_drive[slot & 1u] = (int16_t)drive;
    out_duty[slot & 1u] = duty;
}
uint16_t hal_adc(uint8_t input) { return input < 4 ? adc[input] : 0; }
int16_t hal_encoder(uint8_t slot) { return enc[slot & 1u]; }
bool hal_imu(int16_t out[3]) {
    if (!imu_set || imu_silent) {
        return false; /* no read succeeded: `out` keeps the last good values */
    }
    memcpy(out, imu, sizeof imu);
    return true;
}
bool hal_fault(void) { return false; }
void hal_feed(void) {}
void hal_idle(void) {}
void hal_led(bool on) { (void)on; }
uint16_t hal_stack_low(void) { return 0; }
uint8_t hal_reset_cause(void) { return warm ? 0x08u : 0x01u; }
bool hal_warm_boot(void) { return warm; }

/* ---- the API for ctypes ---- */
void pk_boot(uint8_t id, uint8_t warm_boot) {
    eeprom_id = id;
    warm = warm_boot != 0;
    rx_head = rx_tail = 0;
    tx_n = 0;
    pico_init();
}

void pk_write(const uint8_t *p, uint32_t n) {
    for (uint32_t i = 0; i < n; i++) {
        rx[rx_head++ % (sizeof rx / sizeof rx[0])] = p[i];
    }
    rx_at = hal_ticks();
}

void pk_write_damaged(uint8_t byte) {
    rx[rx_head++ % (sizeof rx / sizeof rx[0])] = (uint16_t)(byte | HAL_RX_ERROR);
    rx_at = hal_ticks();
}

/* Turns every 10 us of virtual time. */
void pk_run_us(uint32_t us) {
    uint64_t end = now_us + us;
    while (now_us < end) {
        pico_turn();
        now_us += 10u;
    }
}

uint32_t pk_read(uint8_t *out, uint32_t cap) {
    uint32_t n = tx_n < cap ? tx_n : cap;
    memcpy(out, tx, n);
    memmove(tx, tx + n, tx_n - n);
    tx_n = (uint16_t)(tx_n - n);
    return n;
}

void pk_adc(uint8_t input, uint16_t value) {
    if (input < 4) {
        adc[input] = value;
    }
}

void pk_encoder(uint8_t slot, int16_t count) { enc[slot & 1u] = count; }

void pk_imu(int16_t h, int16_t r, int16_t p) {
    imu[0] = h;
    imu[1] = r;
    imu[2] = p;
    imu_set = true;
}

void pk_imu_silent(uint8_t on) { imu_silent = on != 0; }

void pk_motor(uint8_t slot, int16_t out[2]) {
    out[0] = out_drive[slot & 1u];
    out[1] = out_duty[slot & 1u];
}

void pk_state(uint8_t k, int16_t out[2]) {
    const struct motor_state *s = motors_state(k);
    out[0] = s->mode;
    out[1] = s->raw;
}

void pk_debug(struct pico_debug *out) { *out = pico_debug; }

int16_t pk_channel(uint8_t c) { return sensors_channel(c); }

int16_t pk_speed(uint8_t k) { return sensors_speed(k); }

uint64_t pk_now_us(void) { return now_us; }
