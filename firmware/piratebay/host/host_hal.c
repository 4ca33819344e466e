/* Host build of the bridge for unit tests (no simavr, no AVR): the hardware files
 * (uart.c, timer.c, mcu.c, main.c) are replaced by this one, which keeps time
 * virtually, transmits at the line's byte rate, and puts simple PICO boards on the
 * bus that answer EXCHANGE with readings the test sets. Everything else is the
 * firmware's own code. Built as a shared library and driven through ctypes
 * (tests/test_firmware_core.py):
 *
 *   fw_boot()                        reset (as DTR does): a new boot
 *   fw_write(bytes, n)               host -> bridge bytes
 *   fw_write_damaged(byte)           one host byte the USART flags (framing error)
 *   fw_run_us(us)                    let virtual time pass, running main-loop turns
 *   fw_read(buf, cap)                bridge -> host bytes sent so far
 *   fw_board(index, online, status)  a board answers (1), does not (0), or answers
 *                                    with a broken CRC (2), with a status byte
 *   fw_reading(channel, raw)         the value the boards report for a channel
 *   fw_bus_log(buf, cap)             every frame the bridge sent on the bus, decoded
 *   fw_bus_times(out, cap)           the virtual time (us) each of those frames ended
 *   fw_board_reply(index, bytes, n)  a board answers every EXCHANGE with these wire
 *                                    bytes (n = 0: as fw_board and fw_reading say)
 *   fw_bus_inject(bytes, n)          bytes arrive on the bus now, whoever sent them (a
 *                                    late, doubled or foreign reply, noise); past a
 *                                    full receive ring they are lost and the next is
 *                                    flagged, as uart.c does
 *   fw_bus_inject_damaged(byte)      one bus byte the USART flags (framing error)
 *   fw_debug(out)                    the pb_debug record
 *   fw_estop_input(open)             the e-stop contact opens (1) or closes (0)
 *   fw_led()                         the LED (lit while the e-stop is latched)
 *   fw_timer_read_cost(ticks)        each read of the timer within a turn moves it on
 *                                    by `ticks` (default 0: time stands still within a
 *                                    turn), so the firmware's cycle figures measure
 *                                    something
 */
#include <stdbool.h>
#include <stdint.h>
#include <string.h>

#include "../board_bus.h"
#include "../bridge.h"
#include "../cobs.h"
#include "../crc.h"
#include "../frame.h"
#include "../mcu.h"
#include "../timer.h"
#include "../uart.h"

#define TURN_US 20u
#define IDLE_TURN_US 200u
#define BYTE_US_HOST (10000000.0 / PB_BAUD)

static uint64_t now_us;
static uint16_t boot_count;
static uint16_t read_cost;  /* ticks each timer read within a turn adds */
static uint16_t turn_ticks; /* what the reads of this turn added so far */

/* ---- time ---- */
void timer_init(void) {}
uint32_t timer_ms(void) { return (uint32_t)(now_us / 1000u); }
uint16_t timer_ticks(void) {
    uint16_t t = (uint16_t)(now_us * TIMER_TICKS_PER_US + turn_ticks);
    turn_ticks = (uint16_t)(turn_ticks + read_cost);
    return t;
}
void timer_wake_at(uint16_t ticks) { (void)ticks; }

/* ---- mcu ---- */
struct pb_debug pb_debug;
void mcu_init(void) {
    memset(&pb_debug, 0, sizeof pb_debug);
    pb_debug.magic = PB_DEBUG_MAGIC;
}
void mcu_feed(void) {}
uint16_t mcu_boot_id(void) { return boot_count; }
static bool estop_open;
void mcu_estop_input_init(void) {}
bool mcu_estop_input_open(void) { return estop_open; }
static bool led;
void mcu_led(bool on) { led = on; }
void mcu_stack_check(void) {}
void mcu_record_cycles(uint16_t *last, uint16_t *max, uint16_t ticks) {
    *last = ticks;
    if (ticks > *max) {
        *max = ticks;
    }
}

/* ---- USART0: host link ---- */
static uint16_t rx0[1 << 16];
static uint32_t rx0_head, rx0_tail;
static uint8_t tx0[1 << 16];
static uint32_t tx0_n;
static uint64_t tx0_busy_until;

void uart0_init(uint32_t baud) { (void)baud; }
int16_t uart0_getc(void) {
    if (rx0_tail == rx0_head) {
        return -1;
    }
    return rx0[rx0_tail++ & 0xFFFFu];
}
bool uart0_tx_busy(void) { return now_us < tx0_busy_until; }
void uart0_send(const uint8_t *p, uint16_t n) {
    for (uint16_t i = 0; i < n && tx0_n < sizeof tx0; i++) {
        tx0[tx0_n++] = p[i];
    }
    tx0_busy_until = now_us + (uint64_t)(n * BYTE_US_HOST + 0.5);
}
static struct uart_line_stats line;
void uart_line_stats(struct uart_line_stats *out) { *out = line; }

/* ---- USART1: the bus, with boards on it ---- */
static uint8_t board_online[PB_N_BOARDS];
static uint8_t board_status_byte[PB_N_BOARDS];
static int16_t board_readings[PB_N_CHANNELS ? PB_N_CHANNELS : 1];
static uint16_t rx1[256]; /* byte | UART_RX_ERROR */
static uint16_t rx1_head, rx1_tail;
static bool rx1_lost;      /* a byte was lost to the full ring: flag the next one */
static uint16_t rx1_at;    /* timer ticks of the last byte received */
static uint8_t fixed_reply[PB_N_BOARDS][64];
static uint8_t fixed_len[PB_N_BOARDS];
static uint8_t bus_raw[64];
static uint8_t bus_raw_n;
static uint8_t bus_log[1 << 16];
static uint32_t bus_log_n;
static uint64_t bus_times[1 << 12];
static uint32_t bus_times_n;

void uart1_init(uint32_t baud) { (void)baud; }
int16_t uart1_getc(void) {
    if (rx1_tail == rx1_head) {
        return -1;
    }
    return rx1[rx1_tail++ & 0xFFu];
}
void uart1_rx_flush(void) {
    rx1_tail = rx1_head;
    rx1_lost = false;
}
uint16_t uart1_tx_free(void) { return 255u; }
static uint16_t tx1_done_at;
bool uart1_tx_done(uint16_t *at) {
    *at = tx1_done_at;
    return true;
}
uint16_t uart1_last_rx(void) { return rx1_at; }

/* A byte arrives on the bus (uart.c's receive interrupt: a full ring loses it and
 * flags the next one). */
static void rx1_put(uint16_t value) {
    if ((uint16_t)(rx1_head - rx1_tail) >= sizeof rx1 / sizeof rx1[0] - 1u) {
        rx1_lost = true;
        return;
    }
    if (rx1_lost) {
        value |= UART_RX_ERROR;
        rx1_lost = false;
    }
    rx1[rx1_head++ & 0xFFu] = value;
}

static void board_frame(void) {
    uint8_t body[64];
    int16_t n = cobs_decode(bus_raw, bus_raw_n, body, sizeof body);
    if (n < 4 || crc16_xmodem(body, (uint16_t)(n - 2)) != get_u16(body + n - 2)) {
        return;
    }
    /* log: length, then the body */
    if (bus_log_n + 1u + (uint32_t)n <= sizeof bus_log) {
        bus_log[bus_log_n++] = (uint8_t)n;
        memcpy(bus_log + bus_log_n, body, (size_t)n);
        bus_log_n += (uint32_t)n;
        if (bus_times_n < sizeof bus_times / sizeof bus_times[0]) {
            bus_times[bus_times_n++] = now_us;
        }
    }
    int8_t b = layout_board_index(body[0]);
    if (b < 0 || body[1] != 0x01u || !board_online[b]) {
        return; /* STOP, or nobody home */
    }
    if (fixed_len[b]) {
        for (uint8_t i = 0; i < fixed_len[b]; i++) {
            rx1_put(fixed_reply[b][i]);
        }
        rx1_at = tx1_done_at;
        return;
    }
    bool garble = board_online[b] == 2; /* answers, but with a broken CRC */
    struct pb_board board = *layout_board((uint8_t)b);
    uint8_t reply[40];
    uint8_t k = 0;
    reply[k++] = board.id;
    reply[k++] = 0x81u;
    reply[k++] = board_status_byte[b];
    for (uint8_t c = 0; c < board.n_channels; c++) {
        put_u16(reply + k, (uint16_t)board_readings[board.first_channel + c]);
        k = (uint8_t)(k + 2u);
    }
    put_u16(reply + k, (uint16_t)(crc16_xmodem(reply, k) ^ (garble ? 0x0100u : 0u)));
    k = (uint8_t)(k + 2u);
    uint8_t wire[48];
    uint16_t w = cobs_encode(reply, k, wire);
    wire[w++] = 0;
    for (uint16_t i = 0; i < w; i++) {
        rx1_put(wire[i]);
    }
    rx1_at = tx1_done_at;
}

bool uart1_write(const uint8_t *p, uint8_t n) {
    tx1_done_at = timer_ticks();
    for (uint8_t i = 0; i < n; i++) {
        if (p[i] == 0) {
            board_frame();
            bus_raw_n = 0;
        } else if (bus_raw_n < sizeof bus_raw) {
            bus_raw[bus_raw_n++] = p[i];
        }
    }
    return true;
}

/* ---- the API for ctypes ---- */
void fw_boot(void) {
    boot_count++;
    rx0_head = rx0_tail = 0;
    tx0_busy_until = now_us;
    rx1_head = rx1_tail = 0;
    rx1_lost = false;
    bus_raw_n = 0;
    bridge_init();
}

void fw_write(const uint8_t *p, uint32_t n) {
    for (uint32_t i = 0; i < n; i++) {
        rx0[rx0_head++ & 0xFFFFu] = p[i];
    }
}

void fw_write_damaged(uint8_t byte) {
    line.host_framing++;
    rx0[rx0_head++ & 0xFFFFu] = (uint16_t)(byte | UART_RX_ERROR);
}

/* Turns every 20 us while bytes are moving; every 200 us when the line is idle
 * (an hour of virtual time then takes seconds). */
void fw_run_us(uint32_t us) {
    uint64_t end = now_us + us;
    while (now_us < end) {
        turn_ticks = 0;
        bridge_turn();
        bool idle = rx0_tail == rx0_head && !uart0_tx_busy();
        uint64_t step = idle ? IDLE_TURN_US : TURN_US;
        now_us = now_us + step < end ? now_us + step : end;
    }
}

uint32_t fw_read(uint8_t *out, uint32_t cap) {
    uint32_t n = tx0_n < cap ? tx0_n : cap;
    memcpy(out, tx0, n);
    memmove(tx0, tx0 + n, tx0_n - n);
    tx0_n -= n;
    return n;
}

void fw_bus_inject(const uint8_t *p, uint32_t n) {
    for (uint32_t i = 0; i < n; i++) {
        rx1_put(p[i]);
    }
    rx1_at = (uint16_t)(now_us * TIMER_TICKS_PER_US);
}

void fw_bus_inject_damaged(uint8_t byte) {
    rx1_put((uint16_t)(byte | UART_RX_ERROR));
    rx1_at = (uint16_t)(now_us * TIMER_TICKS_PER_US);
}

void fw_board(uint8_t index, uint8_t online, uint8_t status) {
    if (index < PB_N_BOARDS) {
        board_online[index] = online;
        board_status_byte[index] = status;
    }
}

void fw_board_reply(uint8_t index, const uint8_t *p, uint8_t n) {
    if (index < PB_N_BOARDS && n <= sizeof fixed_reply[0]) {
        memcpy(fixed_reply[index], p, n);
        fixed_len[index] = n;
    }
}

void fw_reading(uint8_t channel, int16_t raw) {
    if (channel < PB_N_CHANNELS) {
        board_readings[channel] = raw;
    }
}

uint32_t fw_bus_log(uint8_t *out, uint32_t cap) {
    uint32_t n = bus_log_n < cap ? bus_log_n : cap;
    memcpy(out, bus_log, n);
    bus_log_n = 0;
    return n;
}

uint32_t fw_bus_times(uint64_t *out, uint32_t cap) {
    uint32_t n = bus_times_n < cap ? bus_times_n : cap;
    memcpy(out, bus_times, n * sizeof *out);
    bus_times_n = 0;
    return n;
}

void fw_debug(struct pb_debug *out) { *out = pb_debug; }

void fw_estop_input(uint8_t open) { estop_open = open != 0; }

uint8_t fw_led(void) { return led; }

uint64_t fw_now_us(void) { return now_us; }

void fw_timer_read_cost(uint16_t ticks) { read_cost = ticks; }
