/* A scripted run of build/piratebay.elf in simavr that prints the firmware's figures:
 * CPU cycles to encode a STATE and to decode and apply a BULK_SETPOINTS (from the
 * GPIOR0 markers, docs/firmware.md), the time from an ESTOP frame's last byte to the
 * first STOP on the board bus, the stack high-water mark and the MCU reset count
 * (from pb_debug). Boards on USART1 answer every EXCHANGE at once with fixed
 * readings; the host link is fed at 115200 baud. Not the simavr harness of
 * `pirate-bt sim --firmware` (no pty, no physics): a measuring stick.
 *
 *   make -C firmware/piratebay figures      (needs libsimavr-dev)
 *   build/figures build/piratebay.elf 0x$(avr-nm build/piratebay.elf | awk '/ pb_debug$/{print $1}')
 *
 * With a third argument SECONDS it then soaks the firmware for that long (simulated
 * time) in random bytes and corrupted copies of a SETPOINT frame at full line rate
 * (115200 baud, no gap): every corruption is one CRC-16 is sure to catch (1 to 3
 * flipped bits, or a burst of up to 16 bits), so the SETPOINT's distinctive value
 * must never reach the bus. It reports MCU resets, the longest gap between STATE
 * frames, corrupted frames applied, and whether HELLO is answered afterwards.
 *
 * Prints one `name value` line per figure. */
#include <simavr/avr_extint.h>
#include <simavr/avr_ioport.h>
#include <simavr/avr_uart.h>
#include <simavr/sim_avr.h>
#include <simavr/sim_cycle_timers.h>
#include <simavr/sim_elf.h>
#include <simavr/sim_io.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "../cobs.h"
#include "../crc.h"
#include "../frame.h"
#include "../mcu.h"
#include "../robot_layout.h"

#define HZ 16000000u
#define HOST_BYTE_CYCLES (HZ / (PB_BAUD / 10u))
/* one byte at 1 Mbaud, as simavr times it (11 bit times: it counts a parity bit) */
#define BUS_BYTE_CYCLES (HZ / 100000u * 11u / 10u)
#define GPIOR0_DATA 0x3E

static avr_t *avr;
static avr_irq_t *host_in, *bus_in;
static uint8_t hostq[1 << 16];
static unsigned hostq_head, hostq_tail;
static uint8_t busq[1 << 12];
static unsigned busq_head, busq_tail;
static uint8_t bus_raw[64];
static unsigned bus_raw_n;
static uint64_t mark_at[256];
static uint64_t host_frames[256];
static uint8_t host_raw[300];
static unsigned host_raw_n;

struct stat {
    uint64_t n, sum, max, min;
};
static struct stat state_cycles, bulk_cycles, estop_to_stop_queued, estop_to_stop_on_bus;

static bool estop_armed;     /* measuring one ESTOP */
static uint64_t estop_last_byte; /* cycle its last byte was handed to the USART */
static bool stop_queued_seen, stop_on_bus_seen;

/* the soak */
static bool soaking;
static uint32_t rng_state = 14;
static uint64_t soak_bytes, soak_applied, last_state_cycle, max_state_gap, hello_replies;
static uint8_t poison[FRAME_MAX_WIRE];
static uint16_t poison_len;
static const int16_t POISON_RAW = 777;
static uint8_t poison_board;

static uint32_t rnd(void) {
    rng_state ^= rng_state << 13;
    rng_state ^= rng_state >> 17;
    rng_state ^= rng_state << 5;
    return rng_state;
}

/* One chunk of noise: random bytes, or the poison frame with a corruption CRC-16
 * always detects. */
static void noise_chunk(void) {
    uint8_t chunk[FRAME_MAX_WIRE];
    uint16_t n;
    if (rnd() % 2 == 0) {
        n = (uint16_t)(1u + rnd() % 40u);
        for (uint16_t i = 0; i < n; i++) {
            chunk[i] = (uint8_t)rnd();
        }
    } else {
        memcpy(chunk, poison, poison_len);
        n = poison_len;
        uint16_t body_bits = (uint16_t)((n - 1u) * 8u); /* the delimiter stays */
        if (rnd() % 2 == 0) {
            uint32_t flips = 1u + rnd() % 3u; /* 1-3 distinct bits */
            uint16_t done[3];
            for (uint32_t f = 0; f < flips; f++) {
                uint16_t bit;
                bool again;
                do {
                    bit = (uint16_t)(rnd() % body_bits);
                    again = false;
                    for (uint32_t g = 0; g < f; g++) {
                        again = again || done[g] == bit;
                    }
                } while (again);
                done[f] = bit;
                chunk[bit / 8u] ^= (uint8_t)(1u << (bit % 8u));
            }
        } else {
            uint16_t len = (uint16_t)(2u + rnd() % 15u); /* a burst of 2..16 bits */
            uint16_t start = (uint16_t)(rnd() % (body_bits - len + 1u));
            chunk[start / 8u] ^= (uint8_t)(1u << (start % 8u));
            uint16_t end = (uint16_t)(start + len - 1u);
            chunk[end / 8u] ^= (uint8_t)(1u << (end % 8u));
            for (uint16_t bit = (uint16_t)(start + 1u); bit < end; bit++) {
                if (rnd() % 2) {
                    chunk[bit / 8u] ^= (uint8_t)(1u << (bit % 8u));
                }
            }
        }
    }
    for (uint16_t i = 0; i < n; i++) {
        hostq[hostq_head++ & 0xFFFFu] = chunk[i];
    }
    soak_bytes += n;
}

static void add(struct stat *s, uint64_t v) {
    if (s->n == 0 || v < s->min) {
        s->min = v;
    }
    if (v > s->max) {
        s->max = v;
    }
    s->sum += v;
    s->n++;
}

static void send_frame(uint8_t type, uint16_t seq, uint8_t arg, const uint8_t *payload, uint8_t n) {
    uint8_t body[FRAME_MAX_BODY];
    uint8_t wire[FRAME_MAX_WIRE];
    memcpy(body + FRAME_HEADER_BYTES, payload, n);
    uint16_t w = frame_encode(body, type, seq, arg, n, wire);
    for (uint16_t i = 0; i < w; i++) {
        hostq[hostq_head++ & 0xFFFFu] = wire[i];
    }
}

/* simavr's USART has a small input FIFO: feed it only while it says XON, so the
 * line runs at its full rate and no byte is dropped. */
static bool host_xoff;
static void host_xon_irq(avr_irq_t *irq, uint32_t value, void *param) {
    (void)irq;
    (void)value;
    (void)param;
    host_xoff = false;
}
static void host_xoff_irq(avr_irq_t *irq, uint32_t value, void *param) {
    (void)irq;
    (void)value;
    (void)param;
    host_xoff = true;
}

static avr_cycle_count_t feed_host(avr_t *a, avr_cycle_count_t when, void *param) {
    (void)a;
    (void)param;
    if (host_xoff) {
        return when + HOST_BYTE_CYCLES / 4u;
    }
    if (soaking && hostq_head - hostq_tail < 64u) {
        noise_chunk();
    }
    if (hostq_tail != hostq_head) {
        avr_raise_irq(host_in, hostq[hostq_tail++ & 0xFFFFu]);
        if (hostq_tail == hostq_head && estop_armed && estop_last_byte == 0) {
            estop_last_byte = when;
        }
    }
    return when + HOST_BYTE_CYCLES;
}

static uint64_t bus_reply_at; /* a board answers 20 us after the request has left */

static avr_cycle_count_t feed_bus(avr_t *a, avr_cycle_count_t when, void *param) {
    (void)a;
    (void)param;
    if (busq_tail != busq_head && when >= bus_reply_at) {
        avr_raise_irq(bus_in, busq[busq_tail++ & 0xFFFu]);
    }
    return when + BUS_BYTE_CYCLES;
}

static void host_out(avr_irq_t *irq, uint32_t value, void *param) {
    (void)irq;
    (void)param;
    if (value != 0) {
        if (host_raw_n < sizeof host_raw) {
            host_raw[host_raw_n++] = (uint8_t)value;
        }
        return;
    }
    uint8_t body[FRAME_MAX_BODY];
    int16_t n = cobs_decode(host_raw, (uint16_t)host_raw_n, body, sizeof body);
    host_raw_n = 0;
    if (n >= (int16_t)FRAME_MIN_BODY) {
        host_frames[body[1]]++;
        if (body[1] == 0x82u) {
            if (soaking && last_state_cycle && avr->cycle - last_state_cycle > max_state_gap) {
                max_state_gap = avr->cycle - last_state_cycle;
            }
            last_state_cycle = avr->cycle;
        }
        if (body[1] == 0x81u && n == (int16_t)(FRAME_MIN_BODY + 14u) &&
            get_u32(body + FRAME_HEADER_BYTES) == PB_LAYOUT_DIGEST) {
            hello_replies++;
        }
    }
}

/* The boards: answer EXCHANGE with fixed readings, take STOP silently. */
static void bus_out(avr_irq_t *irq, uint32_t value, void *param) {
    (void)irq;
    (void)param;
    if (value != 0) {
        if (bus_raw_n < sizeof bus_raw) {
            bus_raw[bus_raw_n++] = (uint8_t)value;
        }
        if (bus_raw_n == 1 && estop_armed && stop_queued_seen && !stop_on_bus_seen) {
            stop_on_bus_seen = true; /* the first byte after the STOP marker */
            add(&estop_to_stop_on_bus, avr->cycle - estop_last_byte);
        }
        return;
    }
    uint8_t body[40];
    int16_t n = cobs_decode(bus_raw, (uint16_t)bus_raw_n, body, sizeof body);
    bus_raw_n = 0;
    if (n < 4 || body[1] != 0x01u) {
        return;
    }
    if (body[0] == poison_board) {
        for (int16_t k = 2; k + 3 <= n - 2; k += 3) {
            if (body[k] == PB_MODE_VELOCITY && (int16_t)get_u16(body + k + 1) == POISON_RAW) {
                soak_applied++;
            }
        }
    }
    int8_t b = layout_board_index(body[0]);
    if (b < 0) {
        return;
    }
    bus_reply_at = avr->cycle + BUS_BYTE_CYCLES + HZ / 50000u;
    struct pb_board board = *layout_board((uint8_t)b);
    uint8_t reply[40];
    uint8_t k = 0;
    reply[k++] = board.id;
    reply[k++] = 0x81u;
    reply[k++] = 0;
    for (uint8_t c = 0; c < board.n_channels; c++) {
        put_u16(reply + k, (uint16_t)(100 * c));
        k = (uint8_t)(k + 2u);
    }
    put_u16(reply + k, crc16_xmodem(reply, k));
    k = (uint8_t)(k + 2u);
    uint8_t wire[48];
    uint16_t w = cobs_encode(reply, k, wire);
    wire[w++] = 0;
    for (uint16_t i = 0; i < w; i++) {
        busq[busq_head++ & 0xFFFu] = wire[i];
    }
}

static void marker(avr_t *a, avr_io_addr_t addr, uint8_t value, void *param) {
    (void)param;
    a->data[addr] = value;
    mark_at[value] = a->cycle;
    if (value == 0x81u) {
        add(&state_cycles, a->cycle - mark_at[0x01u]);
    } else if (value == 0x82u) {
        add(&bulk_cycles, a->cycle - mark_at[0x02u]);
    } else if (value == 0x04u && estop_armed && estop_last_byte && !stop_queued_seen) {
        stop_queued_seen = true;
        add(&estop_to_stop_queued, a->cycle - estop_last_byte);
    }
}

static void run_ms(double ms) {
    uint64_t end = avr->cycle + (uint64_t)(ms * (HZ / 1000u));
    while (avr->cycle < end) {
        int s = avr_run(avr);
        if (s == cpu_Done || s == cpu_Crashed) {
            fprintf(stderr, "figures: the AVR stopped (state %d)\n", s);
            exit(1);
        }
    }
}

static void print(const char *name, const struct stat *s, double scale) {
    if (s->n == 0) {
        printf("%s_n 0\n", name);
        return;
    }
    printf("%s_n %llu\n%s_mean %.1f\n%s_min %.1f\n%s_max %.1f\n", name,
           (unsigned long long)s->n, name, (double)s->sum / (double)s->n / scale, name,
           (double)s->min / scale, name, (double)s->max / scale);
}

int main(int argc, char **argv) {
    if (argc != 3 && argc != 4) {
        fprintf(stderr, "usage: figures PIRATEBAY.elf PB_DEBUG_ADDRESS [SOAK_SECONDS]\n");
        return 2;
    }
    elf_firmware_t fw;
    memset(&fw, 0, sizeof fw);
    if (elf_read_firmware(argv[1], &fw) != 0) {
        fprintf(stderr, "figures: cannot read %s\n", argv[1]);
        return 2;
    }
    unsigned long debug_at = strtoul(argv[2], NULL, 16) & 0xFFFFu;
    avr = avr_make_mcu_by_name("atmega2560");
    avr_init(avr);
    avr->frequency = HZ;
    avr->log = 0;
    avr_load_firmware(avr, &fw);
    /* the hardware e-stop input (D22, PA0): a closed contact holds it low against the
     * firmware's pull-up: not pressed */
    avr_ioport_external_t closed = {.name = 'A', .mask = 0x01, .value = 0x00};
    avr_ioctl(avr, AVR_IOCTL_IOPORT_SET_EXTERNAL('A'), &closed);
    /* simavr polls a low level-triggered interrupt pin every cycle (DE and /RE are
     * INT4 and INT5, low most of the time); the firmware uses no external interrupt */
    for (uint8_t i = 0; i < 8; i++) {
        avr_extint_set_strict_lvl_trig(avr, i, 0);
    }
    uint32_t flags = 0;
    avr_ioctl(avr, AVR_IOCTL_UART_SET_FLAGS('0'), &flags);
    avr_ioctl(avr, AVR_IOCTL_UART_SET_FLAGS('1'), &flags);
    host_in = avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_INPUT);
    bus_in = avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('1'), UART_IRQ_INPUT);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUTPUT),
                            host_out, NULL);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('1'), UART_IRQ_OUTPUT),
                            bus_out, NULL);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XON),
                            host_xon_irq, NULL);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XOFF),
                            host_xoff_irq, NULL);
    avr_register_io_write(avr, GPIOR0_DATA, marker, NULL);
    avr_cycle_timer_register(avr, HOST_BYTE_CYCLES, feed_host, NULL);
    avr_cycle_timer_register(avr, BUS_BYTE_CYCLES, feed_bus, NULL);

    uint16_t seq = 1;
    run_ms(30);
    uint8_t hello[5];
    put_u32(hello, PB_LAYOUT_DIGEST);
    hello[4] = PB_PROTOCOL_MINOR;
    send_frame(0x01, seq++, 0, hello, 5);
    run_ms(20);
    send_frame(0x06, seq++, 0, NULL, 0);
    run_ms(20);
    /* 200 bulk setpoints, one per period: every motor at the low end of its first mode */
    uint8_t bulk[3 * PB_N_MOTORS + 1];
    for (uint8_t i = 0; i < PB_N_MOTORS; i++) {
        struct pb_motor m = *layout_motor(i);
        uint8_t mode = 0;
        while (!(m.mode_mask & (1u << mode))) {
            mode++;
        }
        bulk[3 * i] = mode;
        put_u16(bulk + 3 * i + 1, (uint16_t)m.range[mode].lo);
    }
    for (int i = 0; i < 200; i++) {
        send_frame(0x03, seq++, 0, bulk, 3 * PB_N_MOTORS);
        run_ms(10);
    }
    /* the other requests, so the stack's high-water mark covers every path: a
     * setpoint per motor, a refused one, counters, a mid-session hello, bad frames */
    for (uint8_t i = 0; i < PB_N_MOTORS; i++) {
        const struct pb_motor *m = layout_motor(i);
        uint8_t sp[4] = {m->slot, bulk[3 * i], bulk[3 * i + 1], bulk[3 * i + 2]};
        send_frame(0x02, seq++, layout_board(m->board_index)->id, sp, 4);
        run_ms(2);
    }
    uint8_t refused[4] = {7, 0, 0, 0};
    send_frame(0x02, seq++, 0xEE, refused, 4);
    send_frame(0x07, 1, 0, NULL, 0);
    run_ms(20);
    send_frame(0x01, seq++, 0, hello, 5);
    send_frame(0x42, 2, 0, NULL, 0);
    hostq[hostq_head++ & 0xFFFFu] = 0x05; /* a COBS code past the end */
    hostq[hostq_head++ & 0xFFFFu] = 0x00;
    run_ms(20);
    send_frame(0x06, seq++, 0, NULL, 0);
    run_ms(20);
    /* 40 e-stops at spread phases of the state period and the bus cycle */
    srand(14);
    for (int i = 0; i < 40; i++) {
        send_frame(0x06, seq++, 0, NULL, 0);
        run_ms(15.0 + (double)(rand() % 1000) / 100.0);
        estop_armed = true;
        estop_last_byte = 0;
        stop_queued_seen = stop_on_bus_seen = false;
        send_frame(0x05, seq++, 0, NULL, 0);
        run_ms(15);
        estop_armed = false;
    }
    /* a minute-long soak would go here; 1 s of heartbeats is enough for the stack */
    for (int i = 0; i < 40; i++) {
        send_frame(0x04, seq++, 0, NULL, 0);
        run_ms(25);
    }

    double soak_s = argc == 4 ? atof(argv[3]) : 0.0;
    if (soak_s > 0) {
        /* the poison: a valid SETPOINT of the first drive motor at a distinctive speed,
         * sent only corrupted */
        uint8_t drive = 0;
        while (drive < PB_N_MOTORS && layout_motor(drive)->role != PB_ROLE_DRIVE) {
            drive++;
        }
        if (drive == PB_N_MOTORS) {
            fprintf(stderr, "figures: the robot has no drive motor to soak with\n");
            return 2;
        }
        const struct pb_motor *m = layout_motor(drive);
        poison_board = layout_board(m->board_index)->id;
        uint8_t body[FRAME_MAX_BODY];
        body[FRAME_HEADER_BYTES] = m->slot;
        body[FRAME_HEADER_BYTES + 1] = PB_MODE_VELOCITY;
        put_u16(body + FRAME_HEADER_BYTES + 2, (uint16_t)POISON_RAW);
        poison_len = frame_encode(body, 0x02, (uint16_t)(seq + 1000u), poison_board, 4, poison);
        send_frame(0x06, seq++, 0, NULL, 0); /* released: a poison would be accepted */
        run_ms(20);
        last_state_cycle = 0;
        soaking = true;
        run_ms(soak_s * 1000.0);
        soaking = false;
        hostq_tail = hostq_head;
        hello_replies = 0;
        uint8_t flush = 0;
        hostq[hostq_head++ & 0xFFFFu] = flush;
        send_frame(0x01, seq++, 0, hello, 5);
        run_ms(30);
        printf("soak_seconds %.1f\nsoak_bytes %llu\nsoak_max_state_gap_ms %.2f\n"
               "soak_corrupted_applied %llu\nsoak_hello_answered %llu\n",
               soak_s, (unsigned long long)soak_bytes, (double)max_state_gap / (HZ / 1000.0),
               (unsigned long long)soak_applied, (unsigned long long)hello_replies);
    }

    const uint8_t *d = avr->data + debug_at;
    unsigned magic = d[0] | d[1] << 8;
    unsigned resets = d[2] | d[3] << 8;
    unsigned stack_low = d[6] | d[7] << 8;
    unsigned stack_bottom = d[8] | d[9] << 8;
    print("state_encode_cycles", &state_cycles, 1.0);
    print("bulk_decode_apply_cycles", &bulk_cycles, 1.0);
    print("estop_to_stop_queued_us", &estop_to_stop_queued, HZ / 1e6);
    print("estop_to_stop_on_bus_us", &estop_to_stop_on_bus, HZ / 1e6);
    printf("state_frames %llu\nacks %llu\nnacks %llu\n", (unsigned long long)host_frames[0x82],
           (unsigned long long)host_frames[0x83], (unsigned long long)host_frames[0x84]);
    printf("debug_magic 0x%04x\nmcu_resets %u\nstack_high_water_bytes %u\nstack_room_bytes %u\n",
           magic, resets, 0x21FFu - stack_low, 0x21FFu - stack_bottom);
    bool ok = magic == PB_DEBUG_MAGIC && resets == 0 && soak_applied == 0 &&
              (soak_s <= 0 || hello_replies == 1);
    return ok ? 0 : 1;
}
