/* pirate-simavr: the PIRATEbay firmware in simavr, in real time, behind a pty.
 *
 * The ELF runs on a simulated ATmega2560 at 16 MHz, paced to the wall clock.
 *
 *  - USART0 (the Mega's USB serial) is a pseudo-terminal. Its path is the first
 *    record on stdout. The host opens it like a real Arduino: the open is the DTR
 *    edge, so the MCU is reset then (and held for --boot-ms, the bootloader's
 *    time, during which host bytes are lost as on a real Mega). Host bytes are fed
 *    at 115200 baud, honouring simavr's XON/XOFF so its small FIFO never drops one.
 *  - USART1 (the RS485 board bus) goes to the board simulator on stdin/stdout. Every
 *    frame the bridge sends goes out stamped with the AVR cycle at which its 0x00
 *    left, so the board physics advances in step with the MCU's clock. The answer
 *    to an EXCHANGE is the board's latest reply, which the board simulator updates
 *    once per state period ('U'): the harness sends it at 500 kbaud 20 us after the
 *    request, so the firmware never waits on the host machine's scheduler (real
 *    boards, too, answer with readings sampled before the request). A STOP, a frame
 *    with a bad CRC, or a board without a reply (a silent board) gets none.
 *
 * Channel records, both ways: type u8, length u16 LE, payload.
 *   harness -> boards: 'P' pty path | 'F' cycle u64 LE, frame bytes (COBS, no 0x00;
 *                      a frame repeating the last one to its address is not sent)
 *                      | 'T' cycle u64 LE: the time, once per 10 ms
 *                      | 'S' figures, text "name value\n" lines | 'R' cycle u64: MCU reset
 *   boards -> harness: 'U' addr u8, reply (wire bytes with the 0x00; none = silent)
 *                      | 'Q' ask for figures | 'X' reset the MCU now (a DTR edge)
 *                      | 'H' hold: the MCU's clock stops (the pty is still served);
 *                        answered 'h' cycle u64 once the pty has all the MCU sent
 *                      | 'G' go on from a hold, paced from now
 * stdin closed or SIGTERM: print the figures on stderr and exit 0.
 *
 * Figures come from the firmware's GPIOR0 markers (docs/firmware.md) and its
 * pb_debug record (found by symbol in the ELF): MCU resets, stack high-water mark,
 * cycles to encode a STATE and to decode and apply a BULK_SETPOINTS, and the time
 * from an ESTOP frame's last byte to the first STOP byte on the board bus.
 */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <simavr/avr_uart.h>
#include <simavr/sim_avr.h>
#include <simavr/sim_cycle_timers.h>
#include <simavr/sim_elf.h>
#include <simavr/sim_io.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>

#define HZ 16000000u
#define HOST_BAUD 115200u
#define HOST_BYTE_CYCLES ((HZ * 10u + HOST_BAUD / 2u) / HOST_BAUD)
#define BUS_BAUD 500000u
#define BUS_BYTE_CYCLES (HZ * 10u / BUS_BAUD)
#define BUS_TURNAROUND_CYCLES (HZ / 50000u) /* 20 us */
#define GPIOR0_DATA 0x3Eu
#define RAMEND 0x21FFu
#define MAX_LAG_CYCLES (HZ / 5u) /* behind the wall clock by more: give up catching up */
#define RING 65536u

enum { MARK_STATE_BEGIN = 0x01, MARK_STATE_END = 0x81, MARK_FRAME_END = 0x02,
       MARK_BULK_END = 0x82, MARK_ESTOP = 0x03, MARK_BUS_STOP = 0x04 };

struct tally {
    uint64_t n, sum, min, max;
};

static avr_t *avr;
static avr_irq_t *host_in, *bus_in;
static int master = -1;
static bool host_open, host_xoff, stop_requested;
static bool reset_expected = true; /* the power-on start */
static bool held;                  /* 'H': the MCU's clock stands still until 'G' */
static double wall0;               /* pacing: wall time at cycle0 */
static uint64_t cycle0;
static uint64_t unexpected_resets;
static unsigned boot_ms;
static uint64_t boot_until; /* MCU held in reset (bootloader) until this cycle */
static uint32_t debug_at;   /* pb_debug's SRAM address, 0 when not found */

static uint8_t hostq[RING], busq[4096], host_out_buf[RING];
static unsigned hostq_head, hostq_tail, busq_head, busq_tail, host_out_n;
static uint8_t bus_frame[256];
static uint8_t replies[256][64];
static uint8_t last_frame[256][64]; /* per address: the last frame told to the boards */
static uint8_t last_frame_len[256];
static uint64_t bus_repeats, last_tick;
static uint8_t reply_len[256];
static uint64_t bus_replies, bus_unanswered; /* EXCHANGEs: answered, not (silent board) */
static uint64_t bus_stops;                    /* STOPs with a good CRC */
static unsigned bus_frame_n;
static bool bus_frame_ready;
static uint64_t bus_frame_cycle;

static uint64_t mark_at[256], last_host_delimiter, estop_byte_at;
static bool estop_waiting;
static struct tally state_cycles, bulk_cycles, estop_us;
static uint64_t dtr_resets, lag_events, bus_frames, host_bytes_in, host_bytes_dropped, frames_out;

static void add(struct tally *s, uint64_t v) {
    if (s->n == 0 || v < s->min) {
        s->min = v;
    }
    if (v > s->max) {
        s->max = v;
    }
    s->n++;
    s->sum += v;
}

static double now_s(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

/* -- the channel to the boards ---------------------------------------------------- */

static void write_all(int fd, const uint8_t *p, size_t n) {
    while (n > 0) {
        ssize_t w = write(fd, p, n);
        if (w < 0) {
            if (errno == EINTR) {
                continue;
            }
            exit(0); /* the board simulator is gone: so are we */
        }
        p += w;
        n -= (size_t)w;
    }
}

static void send_record(char type, const uint8_t *payload, uint16_t n) {
    uint8_t head[3] = {(uint8_t)type, (uint8_t)(n & 0xFFu), (uint8_t)(n >> 8)};
    write_all(STDOUT_FILENO, head, 3);
    if (n) {
        write_all(STDOUT_FILENO, payload, n);
    }
}

static void put_u64(uint8_t *p, uint64_t v) {
    for (int i = 0; i < 8; i++) {
        p[i] = (uint8_t)(v >> (8 * i));
    }
}

/* Reads one record from stdin (blocking). False at end of input. */
static bool read_record(char *type, uint8_t *payload, uint16_t *n) {
    uint8_t head[3];
    size_t got = 0;
    while (got < 3) {
        ssize_t r = read(STDIN_FILENO, head + got, 3 - got);
        if (r <= 0) {
            if (r < 0 && errno == EINTR) {
                continue;
            }
            return false;
        }
        got += (size_t)r;
    }
    *type = (char)head[0];
    *n = (uint16_t)(head[1] | head[2] << 8);
    got = 0;
    while (got < *n) {
        ssize_t r = read(STDIN_FILENO, payload + got, *n - got);
        if (r <= 0) {
            if (r < 0 && errno == EINTR) {
                continue;
            }
            return false;
        }
        got += (size_t)r;
    }
    return true;
}

static int figures_text(char *out, size_t size);

static void reset_mcu(void);

/* Handles one record from the boards. */
static void handle_record(char type, const uint8_t *payload, uint16_t n) {
    if (type == 'U' && n >= 1 && n - 1u <= sizeof replies[0]) {
        memcpy(replies[payload[0]], payload + 1, n - 1u);
        reply_len[payload[0]] = (uint8_t)(n - 1u);
    } else if (type == 'Q') {
        char text[2048];
        int len = figures_text(text, sizeof text);
        send_record('S', (const uint8_t *)text, (uint16_t)len);
    } else if (type == 'X') {
        reset_mcu();
    } else if (type == 'H') {
        held = true; /* what the MCU sent is on the pty already (service_pty ran) */
        uint8_t p[8];
        put_u64(p, avr->cycle);
        send_record('h', p, 8);
    } else if (type == 'G' && held) {
        held = false;
        wall0 = now_s();
        cycle0 = avr->cycle;
    }
}

/* -- the MCU ---------------------------------------------------------------------- */

static uint16_t debug_u16(unsigned offset) {
    if (!debug_at) {
        return 0;
    }
    return (uint16_t)(avr->data[debug_at + offset] | avr->data[debug_at + offset + 1] << 8);
}

static avr_cycle_count_t feed_host(avr_t *a, avr_cycle_count_t when, void *param);
static avr_cycle_count_t feed_bus(avr_t *a, avr_cycle_count_t when, void *param);

static void reset_mcu(void) {
    avr_reset(avr); /* also clears simavr's cycle timers: ours start again */
    avr_cycle_timer_cancel(avr, feed_host, NULL);
    avr_cycle_timer_cancel(avr, feed_bus, NULL);
    avr_cycle_timer_register(avr, HOST_BYTE_CYCLES, feed_host, NULL);
    dtr_resets++;
    reset_expected = true;
    host_xoff = false;
    busq_tail = busq_head;
    bus_frame_n = 0;
    host_out_n = 0; /* bytes of the old boot not yet on the pty: lost with the reset */
    memset(last_frame_len, 0, sizeof last_frame_len);
    hostq_tail = hostq_head; /* the bootloader eats what arrives meanwhile */
    boot_until = avr->cycle + (uint64_t)boot_ms * (HZ / 1000u);
    estop_waiting = false;
    uint8_t p[8];
    put_u64(p, avr->cycle);
    send_record('R', p, 8);
}

static void host_xon(avr_irq_t *irq, uint32_t value, void *param) {
    (void)irq, (void)value, (void)param;
    host_xoff = false;
}

static void host_xoff_irq(avr_irq_t *irq, uint32_t value, void *param) {
    (void)irq, (void)value, (void)param;
    host_xoff = true;
}

static avr_cycle_count_t feed_host(avr_t *a, avr_cycle_count_t when, void *param) {
    (void)a, (void)param;
    if (host_xoff || avr->cycle < boot_until) {
        return when + HOST_BYTE_CYCLES / 4u;
    }
    if (hostq_tail != hostq_head) {
        uint8_t byte = hostq[hostq_tail++ % RING];
        avr_raise_irq(host_in, byte);
        if (byte == 0) {
            last_host_delimiter = when;
        }
    }
    return when + HOST_BYTE_CYCLES;
}

static avr_cycle_count_t feed_bus(avr_t *a, avr_cycle_count_t when, void *param) {
    (void)a, (void)param;
    if (busq_tail != busq_head) {
        avr_raise_irq(bus_in, busq[busq_tail++ % sizeof busq]);
        return when + BUS_BYTE_CYCLES;
    }
    return 0; /* idle until the next answer */
}

static void host_out(avr_irq_t *irq, uint32_t value, void *param) {
    (void)irq, (void)param;
    if (value == 0) {
        frames_out++;
    }
    if (host_open && host_out_n < sizeof host_out_buf) {
        host_out_buf[host_out_n++] = (uint8_t)value;
    }
}

static void bus_out(avr_irq_t *irq, uint32_t value, void *param) {
    (void)irq, (void)param;
    if (value != 0) {
        if (bus_frame_n < sizeof bus_frame) {
            bus_frame[bus_frame_n++] = (uint8_t)value;
        }
        return;
    }
    bus_frame_ready = true; /* reported between two instructions, see run_until */
    bus_frame_cycle = avr->cycle;
    bus_frames++;
}

static uint16_t crc16_xmodem(const uint8_t *p, unsigned n) {
    uint16_t crc = 0;
    while (n--) {
        crc ^= (uint16_t)(*p++ << 8);
        for (int i = 0; i < 8; i++) {
            crc = (uint16_t)(crc & 0x8000u ? ((unsigned)crc << 1) ^ 0x1021u : (unsigned)crc << 1);
        }
    }
    return crc;
}

/* COBS-decodes a bus frame; returns its length, or -1 if malformed. */
static int cobs_decode(const uint8_t *in, unsigned n, uint8_t *out, unsigned size) {
    unsigned i = 0, k = 0;
    while (i < n) {
        unsigned code = in[i++];
        if (code == 0 || i + code - 1u > n) {
            return -1;
        }
        for (unsigned j = 1; j < code; j++) {
            if (k >= size) {
                return -1;
            }
            out[k++] = in[i++];
        }
        if (code < 0xFFu && i < n) {
            if (k >= size) {
                return -1;
            }
            out[k++] = 0;
        }
    }
    return (int)k;
}

/* The boards' side of a request: an EXCHANGE with a good CRC to a board that has a
 * reply gets it, 20 us after the request's 0x00. */
static void answer(const uint8_t *frame, unsigned n) {
    uint8_t body[64];
    int k = cobs_decode(frame, n, body, sizeof body);
    if (k < 4 || crc16_xmodem(body, (unsigned)k - 2u) !=
                     (uint16_t)(body[k - 2] | body[k - 1] << 8)) {
        return;
    }
    if (body[1] != 0x01u) {
        if (body[1] == 0x02u) {
            bus_stops++; /* STOP: applied silently */
        }
        return;
    }
    uint8_t addr = body[0];
    if (!reply_len[addr]) {
        bus_unanswered++;
        return;
    }
    bus_replies++;
    for (unsigned i = 0; i < reply_len[addr]; i++) {
        busq[busq_head++ % sizeof busq] = replies[addr][i];
    }
    avr_cycle_timer_cancel(avr, feed_bus, NULL);
    avr_cycle_timer_register(avr, BUS_TURNAROUND_CYCLES, feed_bus, NULL);
}

static void marker(avr_t *a, avr_io_addr_t addr, uint8_t value, void *param) {
    (void)param;
    a->data[addr] = value;
    mark_at[value] = a->cycle;
    if (value == MARK_STATE_END) {
        add(&state_cycles, a->cycle - mark_at[MARK_STATE_BEGIN]);
    } else if (value == MARK_BULK_END) {
        add(&bulk_cycles, a->cycle - mark_at[MARK_FRAME_END]);
    } else if (value == MARK_ESTOP) {
        estop_waiting = true;
        estop_byte_at = last_host_delimiter;
    } else if (value == MARK_BUS_STOP && estop_waiting) {
        estop_waiting = false;
        add(&estop_us, a->cycle - estop_byte_at);
    }
}

/* The bridge finished a bus frame: answer it, and tell the boards unless it repeats
 * the last frame to that address byte for byte (the same setpoints: nothing to
 * apply; the 'T' ticks carry the time). */
static void exchange(void) {
    bus_frame_ready = false;
    answer(bus_frame, bus_frame_n);
    uint8_t addr = bus_frame_n >= 2 ? bus_frame[1] : 0; /* COBS code, then addr (or 0) */
    if (bus_frame_n <= sizeof last_frame[0]) {
        if (last_frame_len[addr] == bus_frame_n &&
            memcmp(last_frame[addr], bus_frame, bus_frame_n) == 0) {
            bus_repeats++;
            bus_frame_n = 0;
            return;
        }
        memcpy(last_frame[addr], bus_frame, bus_frame_n);
        last_frame_len[addr] = (uint8_t)bus_frame_n;
    }
    uint8_t payload[8 + sizeof bus_frame];
    put_u64(payload, bus_frame_cycle);
    memcpy(payload + 8, bus_frame, bus_frame_n);
    send_record('F', payload, (uint16_t)(8 + bus_frame_n));
    bus_frame_n = 0;
}

/* Runs the core until `target` cycles, stopping for every bus frame. */
static void run_until(uint64_t target) {
    while (avr->cycle < target && !stop_requested) {
        if (avr->cycle < boot_until) {
            /* the bootloader: the application does not run, time passes */
            avr->cycle = boot_until < target ? boot_until : target;
            avr_cycle_timer_process(avr);
            continue;
        }
        if (avr->pc == 0 && !reset_expected) {
            unexpected_resets++; /* the reset vector, not by us: watchdog, crash, jump */
        }
        int state = avr_run(avr);
        reset_expected = false;
        if (state == cpu_Done || state == cpu_Crashed) {
            fprintf(stderr, "pirate-simavr: the AVR %s at cycle %llu (pc 0x%05x)\n",
                    state == cpu_Crashed ? "crashed" : "stopped",
                    (unsigned long long)avr->cycle, (unsigned)avr->pc);
            exit(4);
        }
        if (bus_frame_ready) {
            exchange();
        }
    }
}

/* -- the pty ----------------------------------------------------------------------- */

static void open_pty(void) {
    master = posix_openpt(O_RDWR | O_NOCTTY | O_NONBLOCK);
    if (master < 0 || grantpt(master) != 0 || unlockpt(master) != 0) {
        perror("pirate-simavr: cannot create a pty");
        exit(3);
    }
    const char *name = ptsname(master);
    int slave = open(name, O_RDWR | O_NOCTTY);
    if (slave < 0) {
        perror("pirate-simavr: cannot open the pty");
        exit(3);
    }
    struct termios t;
    tcgetattr(slave, &t);
    cfmakeraw(&t);
    cfsetspeed(&t, B115200);
    tcsetattr(slave, TCSANOW, &t);
    close(slave); /* from now on POLLHUP on the master means: no host has it open */
    send_record('P', (const uint8_t *)name, (uint16_t)strlen(name));
}

/* Moves bytes between the pty and the queues; an open is a DTR edge. */
static void service_pty(void) {
    struct pollfd p = {.fd = master, .events = POLLIN};
    poll(&p, 1, 0);
    bool open_now = !(p.revents & POLLHUP);
    if (open_now && !host_open) {
        host_open = true;
        reset_mcu();
    } else if (!open_now && host_open) {
        host_open = false;
        host_out_n = 0;
    }
    if (!host_open) {
        return;
    }
    if (p.revents & POLLIN) {
        uint8_t buf[4096];
        ssize_t r = read(master, buf, sizeof buf);
        for (ssize_t i = 0; i < r; i++) {
            if (avr->cycle < boot_until) {
                host_bytes_dropped++; /* the bootloader eats them */
            } else if (hostq_head - hostq_tail < RING) {
                hostq[hostq_head++ % RING] = buf[i];
                host_bytes_in++;
            } else {
                host_bytes_dropped++;
            }
        }
    }
    if (host_out_n) {
        ssize_t w = write(master, host_out_buf, host_out_n);
        if (w > 0) {
            memmove(host_out_buf, host_out_buf + w, host_out_n - (size_t)w);
            host_out_n -= (unsigned)w;
        } else if (w < 0 && errno == EAGAIN) {
            host_out_n = 0; /* a host that does not read loses bytes, as on a real UART */
        }
    }
}

/* Records from the boards ('U', 'Q', 'X'), whenever they arrive. */
static void service_channel(void) {
    struct pollfd p = {.fd = STDIN_FILENO, .events = POLLIN};
    while (poll(&p, 1, 0) > 0) {
        if (p.revents & (POLLHUP | POLLERR) && !(p.revents & POLLIN)) {
            stop_requested = true;
            return;
        }
        static uint8_t in[65536];
        char type;
        uint16_t n;
        if (!read_record(&type, in, &n)) {
            stop_requested = true;
            return;
        }
        handle_record(type, in, n);
    }
}

/* -- figures ----------------------------------------------------------------------- */

static int put_stat(char *out, size_t size, const char *name, const struct tally *s, double scale) {
    if (s->n == 0) {
        return snprintf(out, size, "%s_n 0\n", name);
    }
    return snprintf(out, size, "%s_n %llu\n%s_mean %.1f\n%s_min %.1f\n%s_max %.1f\n", name,
                    (unsigned long long)s->n, name, (double)s->sum / (double)s->n / scale, name,
                    (double)s->min / scale, name, (double)s->max / scale);
}

static int figures_text(char *out, size_t size) {
    int k = snprintf(out, size,
                     "cycles %llu\nsimulated_s %.3f\ndtr_resets %llu\n"
                     "unexpected_resets %llu\nfirmware_reset_count %u\nstack_high_water_bytes %u\nstack_room_bytes %u\n"
                     "debug_magic 0x%04x\nlag_events %llu\nbus_frames %llu\n"
                     "host_bytes_in %llu\nhost_bytes_dropped %llu\nhost_frames_out %llu\n"
                     "rx_overruns %u\nbus_replies %llu\nbus_unanswered %llu\nbus_repeats %llu\n"
                     "bus_stops %llu\nhost_queue_bytes %u\n",
                     (unsigned long long)avr->cycle, (double)avr->cycle / HZ,
                     (unsigned long long)dtr_resets,
                     (unsigned long long)unexpected_resets, debug_u16(2),
                     debug_at ? RAMEND - debug_u16(6) : 0u, debug_at ? RAMEND - debug_u16(8) : 0u,
                     debug_u16(0), (unsigned long long)lag_events,
                     (unsigned long long)bus_frames, (unsigned long long)host_bytes_in,
                     (unsigned long long)host_bytes_dropped, (unsigned long long)frames_out,
                     debug_u16(18), (unsigned long long)bus_replies,
                     (unsigned long long)bus_unanswered, (unsigned long long)bus_repeats,
                     (unsigned long long)bus_stops, hostq_head - hostq_tail);
    k += put_stat(out + k, size - (size_t)k, "state_encode_cycles", &state_cycles, 1.0);
    k += put_stat(out + k, size - (size_t)k, "bulk_decode_apply_cycles", &bulk_cycles, 1.0);
    k += put_stat(out + k, size - (size_t)k, "estop_to_bus_stop_us", &estop_us, HZ / 1e6);
    return k;
}

static void on_signal(int sig) {
    (void)sig;
    stop_requested = true;
}

static uint32_t find_symbol(const elf_firmware_t *fw, const char *name) {
    for (uint32_t i = 0; i < fw->symbolcount; i++) {
        if (strcmp(fw->symbol[i]->symbol, name) == 0) {
            return fw->symbol[i]->addr & 0xFFFFu; /* data addresses carry 0x800000 */
        }
    }
    return 0;
}

int main(int argc, char **argv) {
    const char *elf = NULL;
    double speed = 1.0;
    for (int i = 1; i < argc; i++) {
        if (strcmp(argv[i], "--boot-ms") == 0 && i + 1 < argc) {
            boot_ms = (unsigned)atoi(argv[++i]);
        } else if (strcmp(argv[i], "--speed") == 0 && i + 1 < argc) {
            speed = atof(argv[++i]);
        } else if (argv[i][0] != '-' && !elf) {
            elf = argv[i];
        } else {
            elf = NULL;
            break;
        }
    }
    if (!elf || speed <= 0) {
        fprintf(stderr, "usage: pirate-simavr [--boot-ms MS] [--speed X] PIRATEBAY.elf\n");
        return 2;
    }
    elf_firmware_t fw;
    memset(&fw, 0, sizeof fw);
    if (access(elf, R_OK) != 0 || elf_read_firmware(elf, &fw) != 0) {
        fprintf(stderr, "pirate-simavr: cannot read the ELF %s\n", elf);
        return 2;
    }
    avr = avr_make_mcu_by_name("atmega2560");
    if (!avr) {
        fprintf(stderr, "pirate-simavr: this simavr has no atmega2560\n");
        return 2;
    }
    avr_init(avr);
    avr->frequency = HZ;
    avr->log = 0;
    avr_load_firmware(avr, &fw);
    debug_at = find_symbol(&fw, "pb_debug");
    if (!debug_at) {
        fprintf(stderr, "pirate-simavr: no pb_debug in %s: resets and stack not measured\n",
                elf);
    }
    uint32_t flags = 0; /* no stdio echo, no pacing by simavr itself */
    avr_ioctl(avr, AVR_IOCTL_UART_SET_FLAGS('0'), &flags);
    avr_ioctl(avr, AVR_IOCTL_UART_SET_FLAGS('1'), &flags);
    host_in = avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_INPUT);
    bus_in = avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('1'), UART_IRQ_INPUT);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUTPUT),
                            host_out, NULL);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('1'), UART_IRQ_OUTPUT),
                            bus_out, NULL);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XON),
                            host_xon, NULL);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XOFF),
                            host_xoff_irq, NULL);
    avr_register_io_write(avr, GPIOR0_DATA, marker, NULL);
    avr_cycle_timer_register(avr, HOST_BYTE_CYCLES, feed_host, NULL);

    signal(SIGTERM, on_signal);
    signal(SIGINT, on_signal);
    signal(SIGPIPE, SIG_IGN);
    open_pty();

    /* Paced to the wall clock in 1 ms slices; when the host machine falls behind by
     * more than MAX_LAG_CYCLES the reference moves (a lag event), never a burst. */
    wall0 = now_s();
    cycle0 = avr->cycle;
    while (!stop_requested) {
        service_pty();
        if (avr->cycle - last_tick >= HZ / 100u) {
            /* after the pty got what the MCU sent up to now: a reader that waits for
             * this time has the bytes too */
            last_tick = avr->cycle;
            uint8_t p[8];
            put_u64(p, avr->cycle);
            send_record('T', p, 8);
        }
        service_channel();
        if (held) {
            struct timespec nap = {0, 500000};
            nanosleep(&nap, NULL);
            continue;
        }
        uint64_t target = cycle0 + (uint64_t)((now_s() - wall0) * speed * HZ);
        if (target > avr->cycle + MAX_LAG_CYCLES) {
            lag_events++;
            cycle0 = avr->cycle;
            wall0 = now_s();
            continue;
        }
        if (avr->cycle >= target) {
            struct timespec nap = {0, 500000}; /* ahead of the clock: 0.5 ms */
            nanosleep(&nap, NULL);
            continue;
        }
        uint64_t slice = avr->cycle + HZ / 1000u;
        run_until(target < slice ? target : slice);
    }
    char text[2048];
    figures_text(text, sizeof text);
    fputs(text, stderr);
    return 0;
}
