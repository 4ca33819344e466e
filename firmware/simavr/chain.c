/* pirate-chain: the whole embedded chain in simavr, in virtual time.
 *
 * The PIRATEbay bridge ELF on an ATmega2560 and one reference PICO ELF per board on
 * ATmega328ps (each with its board id in EEPROM), all at 16 MHz, on one simulated
 * RS485 line (chain_line.c: drivers, receivers, collisions). The physics is Python's:
 * it sends each step's pin inputs (ADC readings, encoder counts, the IMU's angles)
 * and receives the H-bridges' outputs (chain_board.c). The host link (the bridge's
 * USART0) is carried in the same records, at 115200 baud: no pty, no wall clock.
 * Nothing runs between records, so a run is a pure function of its inputs, and
 * however slow the machine, no deadline is missed: the chain runs in virtual time.
 *
 * The cores run in lockstep slices of 10 us (QUANTUM_CYCLES); a sleeping core is
 * fenced at the slice's end so that it never runs ahead of the others.
 *
 *   pirate-chain BRIDGE.elf PICO.elf ID [ID...]
 *   pirate-chain - PICO.elf ID [ID...]      no bridge: Python is the bus master
 *
 * Without a bridge (for the board bus's vectors) the 'A' record's host bytes are the
 * master's bus bytes instead, sent at 1 Mbaud to every board, and the 'a' record's
 * host bytes are what the boards put on the line.
 *
 * Records, both ways: type u8, length u16 LE, payload.
 *   chain -> Python: 'P' text "boards ID..." once ready
 *                    'a' step done: cycle u64; host bytes out (u16 n, bytes); then per
 *                        board, per motor slot 0 and 1: drive u8 (0 off, 1 brake, 2 run),
 *                        mean duty while running over the step i16; then u16: how many
 *                        of the 'A' record's host bytes were taken (the others did not
 *                        fit the queue to the line: Python sends them again later)
 *                    'w' a watch ended: start cycle u64, then per watched motor the
 *                        cycle u64 its output first read off or brake after the start
 *                    'S' figures, "name value" lines
 *   Python -> chain: 'A' advance: until cycle u64; host bytes (u16 n, bytes); then per
 *                        board: adc[4] u16, encoder[2] i32 (the counts to reach by
 *                        `until`), imu[3] i16 (heading, roll, pitch), fault u8
 *                    'E' u8: the bridge's e-stop contact (D22) opens (1) or closes (0)
 *                    'K' halt the bridge's core (killed: it neither runs nor drives)
 *                    'I' board index u8, answers u8: that board's IMU stops answering
 *                        its address (0: no ACK, as an IMU without power) or answers (1)
 *                    'X' reset the bridge's core (a DTR edge)
 *                    'O' board index u8, powered u8: that board loses its power (0: its
 *                        core stops, off the line, its H-bridges off) or gets it back (1:
 *                        a power-on reset, its SRAM cleared, and it runs from now)
 *                    'W' watch: kind u8 (0: from the end of the next host frame fed to
 *                        the bridge after the frames queued now and `skip` more, 1: from
 *                        now), skip u8, n u8, then n x (board index u8, slot u8)
 *                    'Q' figures
 * stdin closed: exit 0. */
#include "chain.h"

#define MAX_CORES CHAIN_NODES
#define HOST_RING 65536u
/* host bytes out in one 'a' record: its length is a u16, with the motors and `taken` */
#define HOST_OUT_RECORD (65535u - 12u - 6u * CHAIN_MAX_BOARDS)

static avr_t *cores[MAX_CORES];
static bool no_bridge; /* Python is the bus master (the vectors) */
static avr_uart_t *uarts[MAX_CORES][2]; /* each core's USARTs, for the 10-bit fix */
static int n_boards;
static uint8_t board_ids[CHAIN_MAX_BOARDS];
static uint64_t now;
static bool bridge_halted;
static bool board_unpowered[CHAIN_MAX_BOARDS]; /* 'O': its core does not run */
static uint32_t bridge_debug_at, pico_debug_at;

/* the host link: bytes in (fed at the line's rate), bytes out */
static avr_irq_t *host_in;
static uint8_t host_q[HOST_RING];
static unsigned host_q_head, host_q_tail;
static bool host_xoff;
static uint8_t host_out[HOST_RING];
static unsigned host_out_n;
static uint64_t last_delimiter_in;

/* the motors: duty sums over the step */
static int64_t duty_sum[CHAIN_MAX_BOARDS][2];
static uint64_t run_samples[CHAIN_MAX_BOARDS][2], samples;

/* a watch: every watched motor's first off/brake after `watch_start` */
static struct {
    bool on, waiting_delimiter;
    unsigned skip; /* host delimiters to let pass before the one that starts the clock */
    uint64_t start, armed_at;
    int n;
    uint8_t board[2 * CHAIN_MAX_BOARDS], slot[2 * CHAIN_MAX_BOARDS];
    uint64_t stopped[2 * CHAIN_MAX_BOARDS];
} watch;

static void nosleep(avr_t *avr, avr_cycle_count_t how_long) { (void)avr, (void)how_long; }

static double wall_now(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

/* -- the cores ---------------------------------------------------------------------- */

/* A timer at every slice boundary: a sleeping core wakes there and goes no further. */
static avr_cycle_count_t fence(avr_t *avr, avr_cycle_count_t when, void *param) {
    (void)avr, (void)param;
    return when + QUANTUM_CYCLES;
}

static void arm_fence(avr_t *avr) {
    avr_cycle_timer_cancel(avr, fence, NULL);
    avr_cycle_timer_register(avr, QUANTUM_CYCLES - avr->cycle % QUANTUM_CYCLES, fence, NULL);
}

/* simavr 1.6 counts a parity bit in every USART frame, parity or not: 11 bit times for
 * 8N1. Back to 10 (the real line's byte time) once the firmware has set its rate. */
static void find_uarts(int c) {
    int k = 0;
    for (avr_io_t *io = cores[c]->io_port; io && k < 2; io = io->next) {
        if (io->kind && strcmp(io->kind, "uart") == 0) {
            uarts[c][k++] = (avr_uart_t *)io;
        }
    }
}

static void ten_bit_bytes(int c) {
    for (int k = 0; k < 2; k++) {
        avr_uart_t *u = uarts[c][k];
        if (u && u->cycles_per_byte && u->cycles_per_byte % 11u == 0) {
            u->cycles_per_byte = u->cycles_per_byte / 11u * 10u;
        }
    }
}

static void set_estop_input(bool open);
static bool estop_open;

static void run_core(avr_t *avr, uint64_t until) {
    while (avr->cycle < until) {
        if (avr->pc == 0 && avr == cores[0] && !no_bridge) {
            /* a reset (X, the watchdog) cleared PINA: the e-stop contact outlives it */
            set_estop_input(estop_open);
        }
        int state = avr_run(avr);
        if (state == cpu_Done || state == cpu_Crashed) {
            fprintf(stderr, "pirate-chain: %s %s at cycle %llu (pc 0x%05x)\n",
                    avr == cores[0] ? "the bridge" : "a PICO board",
                    state == cpu_Crashed ? "crashed" : "stopped", (unsigned long long)avr->cycle,
                    (unsigned)avr->pc);
            exit(4);
        }
    }
}

static avr_t *make_core(const char *mcu, elf_firmware_t *fw) {
    avr_t *avr = avr_make_mcu_by_name(mcu);
    if (!avr) {
        fprintf(stderr, "pirate-chain: this simavr has no %s\n", mcu);
        exit(2);
    }
    avr_init(avr);
    avr->frequency = HZ;
    avr->log = 0;
    avr->sleep = nosleep; /* virtual time: a sleeping core skips ahead, never waits */
    avr_load_firmware(avr, fw);
    no_level_polling(avr);
    return avr;
}

static uint32_t find_symbol(const elf_firmware_t *fw, const char *name) {
    for (uint32_t i = 0; i < fw->symbolcount; i++) {
        if (strcmp(fw->symbol[i]->symbol, name) == 0) {
            return fw->symbol[i]->addr & 0xFFFFu;
        }
    }
    return 0;
}

/* -- the host link ------------------------------------------------------------------ */

static avr_cycle_count_t feed_host(avr_t *avr, avr_cycle_count_t when, void *param) {
    (void)avr, (void)param;
    if (host_xoff) {
        return when + HOST_BYTE_CYCLES / 4u;
    }
    if (host_q_tail != host_q_head) {
        uint8_t byte = host_q[host_q_tail++ % HOST_RING];
        avr_raise_irq(host_in, byte);
        if (byte == 0) {
            last_delimiter_in = when;
            if (watch.on && watch.waiting_delimiter && watch.skip > 0) {
                watch.skip--;
            } else if (watch.on && watch.waiting_delimiter) {
                watch.waiting_delimiter = false;
                watch.start = when; /* the frame's last byte entered the bridge */
            }
        }
    }
    return when + HOST_BYTE_CYCLES;
}

static void host_byte_out(avr_irq_t *irq, uint32_t value, void *param) {
    (void)irq, (void)param;
    if (host_out_n < sizeof host_out) {
        host_out[host_out_n++] = (uint8_t)value;
    }
}

static void host_xon(avr_irq_t *irq, uint32_t value, void *param) {
    (void)irq, (void)value, (void)param;
    host_xoff = false;
}

static void host_xoff_irq(avr_irq_t *irq, uint32_t value, void *param) {
    (void)irq, (void)value, (void)param;
    host_xoff = true;
}

static void attach_host(avr_t *avr) {
    uint32_t flags = 0;
    avr_ioctl(avr, AVR_IOCTL_UART_SET_FLAGS('0'), &flags);
    host_in = avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_INPUT);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUTPUT),
                            host_byte_out, NULL);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XON),
                            host_xon, NULL);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XOFF),
                            host_xoff_irq, NULL);
    avr_cycle_timer_register(avr, HOST_BYTE_CYCLES, feed_host, NULL);
}

/* A reset clears simavr's PINA (its ioport keeps no external level through avr_reset):
 * run_core puts the contact back at the bridge's reset vector, or a button held down
 * through a reset read released, and the bridge released its latch with it pressed. */
static void set_estop_input(bool open) {
    estop_open = open;
    avr_ioport_external_t ext = {.name = 'A', .mask = 0x01, .value = open ? 0x01 : 0x00};
    avr_ioctl(cores[0], AVR_IOCTL_IOPORT_SET_EXTERNAL('A'), &ext);
    avr_irq_t *pin = avr_io_getirq(cores[0], AVR_IOCTL_IOPORT_GETIRQ('A'), 0);
    avr_raise_irq(pin, open ? 0 : 1); /* the irq drops a raise of the level it holds, */
    avr_raise_irq(pin, open ? 1 : 0); /* which a reset's cleared PINA no longer has */
}

/* -- the bus cycle figure: from the first request of a cycle to the last reply ------ */


/* Without a bridge: the master's bytes straight into every board's USART, one per byte
 * time; what the boards put on the line back to Python. */
static avr_cycle_count_t feed_master(avr_t *avr, avr_cycle_count_t when, void *param) {
    (void)avr, (void)param;
    if (host_q_tail != host_q_head) {
        uint8_t byte = host_q[host_q_tail++ % HOST_RING];
        for (int b = 0; b < n_boards; b++) {
            avr_raise_irq(avr_io_getirq(cores[b + 1], AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_INPUT),
                          byte);
        }
    }
    return when + LINE_BYTE_CYCLES;
}

static void master_hears(int sender, uint8_t value) {
    if (sender != 0 && host_out_n < sizeof host_out) {
        host_out[host_out_n++] = value;
    }
}

/* -- stepping ----------------------------------------------------------------------- */

static void sample_motors(void) {
    samples++;
    for (int b = 0; b < n_boards; b++) {
        for (int slot = 0; slot < 2; slot++) {
            struct motor_sample s = board_sample(b, slot);
            if (s.drive == 2) {
                duty_sum[b][slot] += s.duty;
                run_samples[b][slot]++;
            }
            if (watch.on && !watch.waiting_delimiter) {
                for (int k = 0; k < watch.n; k++) {
                    if (watch.board[k] == b && watch.slot[k] == slot && !watch.stopped[k] &&
                        s.drive != 2 && now >= watch.start) {
                        watch.stopped[k] = now;
                    }
                }
            }
        }
    }
}

static void check_watch(void) {
    if (!watch.on || watch.waiting_delimiter) {
        return;
    }
    for (int k = 0; k < watch.n; k++) {
        if (!watch.stopped[k]) {
            return;
        }
    }
    uint8_t out[8 + 8 * 2 * CHAIN_MAX_BOARDS];
    channel_put_u64(out, watch.start);
    for (int k = 0; k < watch.n; k++) {
        channel_put_u64(out + 8 + 8 * k, watch.stopped[k]);
    }
    channel_send_record('w', out, (uint16_t)(8 + 8 * watch.n));
    watch.on = false;
}

static void advance(uint64_t until) {
    memset(duty_sum, 0, sizeof duty_sum);
    memset(run_samples, 0, sizeof run_samples);
    samples = 0;
    while (now < until) {
        uint64_t q1 = now + QUANTUM_CYCLES < until ? now + QUANTUM_CYCLES : until;
        for (int c = 0; c <= n_boards; c++) {
            if ((c == 0 && (bridge_halted || no_bridge)) || (c > 0 && board_unpowered[c - 1])) {
                continue;
            }
            run_core(cores[c], q1);
            ten_bit_bytes(c);
        }
        if (bridge_halted) {
            cores[0]->cycle = q1; /* its clock goes on; it does nothing */
        }
        line_settle(q1);
        now = q1;
        sample_motors();
        check_watch();
    }
}

static uint16_t get_u16(const uint8_t *p) { return (uint16_t)(p[0] | p[1] << 8); }

static uint64_t get_u64(const uint8_t *p) {
    uint64_t v = 0;
    for (int i = 7; i >= 0; i--) {
        v = v << 8 | p[i];
    }
    return v;
}

static void step(const uint8_t *p, uint16_t n) {
    if (n < 10) {
        return;
    }
    uint64_t until = get_u64(p);
    uint16_t host_n = get_u16(p + 8);
    const uint8_t *q = p + 10;
    /* a serial line loses no byte to a host that writes faster than its rate: what does
     * not fit the queue stays with the host (Python) and comes again in a later step;
     * the queue used to wrap over bytes not yet fed, splicing later frames into earlier */
    unsigned taken = 0;
    while (taken < host_n && host_q_head - host_q_tail < HOST_RING) {
        host_q[host_q_head++ % HOST_RING] = q[taken++];
    }
    q += host_n;
    for (int b = 0; b < n_boards; b++) {
        uint16_t adc[4];
        int32_t enc[2];
        int16_t imu[3];
        for (int k = 0; k < 4; k++) {
            adc[k] = get_u16(q + 2 * k);
        }
        for (int k = 0; k < 2; k++) {
            enc[k] = (int32_t)(q[8 + 4 * k] | q[9 + 4 * k] << 8 | q[10 + 4 * k] << 16 |
                               (uint32_t)q[11 + 4 * k] << 24);
        }
        for (int k = 0; k < 3; k++) {
            imu[k] = (int16_t)get_u16(q + 16 + 2 * k);
        }
        board_inputs(b, adc, enc, imu, q[22] != 0, now, until);
        q += 23;
    }
    advance(until);
    /* the answer */
    static uint8_t out[HOST_OUT_RECORD + 12 + 6 * CHAIN_MAX_BOARDS];
    channel_put_u64(out, now);
    unsigned k = 8;
    /* a record carries at most 65535 bytes: what the bridge sent beyond that in one step
     * (a step of seconds) goes in the next record */
    unsigned sent = host_out_n < HOST_OUT_RECORD ? host_out_n : HOST_OUT_RECORD;
    out[k++] = (uint8_t)sent;
    out[k++] = (uint8_t)(sent >> 8);
    memcpy(out + k, host_out, sent);
    k += sent;
    memmove(host_out, host_out + sent, host_out_n - sent);
    host_out_n -= sent;
    for (int b = 0; b < n_boards; b++) {
        for (int slot = 0; slot < 2; slot++) {
            struct motor_sample s = board_sample(b, slot);
            int16_t mean = run_samples[b][slot]
                               ? (int16_t)(duty_sum[b][slot] / (int64_t)run_samples[b][slot])
                               : 0;
            if (s.drive == 2 && mean == 0) {
                mean = s.duty;
            }
            out[k++] = s.drive;
            out[k++] = (uint8_t)mean;
            out[k++] = (uint8_t)((uint16_t)mean >> 8);
        }
    }
    out[k++] = (uint8_t)taken;
    out[k++] = (uint8_t)(taken >> 8);
    channel_send_record('a', out, (uint16_t)k);
}

/* A PICO board loses its power, or gets it back: a power-on reset from now, with its
 * SRAM cleared (what .noinit kept is gone: a cold boot), its EEPROM (its id) kept. */
static void power_board(int b, bool on) {
    avr_t *avr = cores[b + 1];
    if (!on) {
        if (!board_unpowered[b]) {
            board_unpowered[b] = true;
            line_detach(b + 1);
            board_power(b, false);
        }
        return;
    }
    if (!board_unpowered[b]) {
        return;
    }
    avr->cycle = now; /* it was not running: it starts now, not where it stopped (and
                       * the pin changes of its reset are stamped now on the line) */
    avr_reset(avr); /* also clears its cycle timers: ours start again */
    avr->cycle = now;
    memset(avr->data + 0x100, 0, (size_t)avr->ramend + 1u - 0x100u);
    avr_regbit_set(avr, avr->reset_flags.porf);
    no_level_polling(avr);
    arm_fence(avr);
    board_power(b, true);
    line_reattach(b + 1);
    board_unpowered[b] = false;
}

static void handle(char type, const uint8_t *payload, uint16_t n) {
    double t0 = wall_now();
    if (type == 'A') {
        step(payload, n);
    } else if (type == 'I' && n >= 2) {
        if (payload[0] < n_boards) {
            board_imu_answers(payload[0], payload[1] != 0);
        }
    } else if (no_bridge && type != 'Q') {
        return; /* nothing else applies without a bridge */
    } else if (type == 'E' && n >= 1) {
        set_estop_input(payload[0] != 0);
    } else if (type == 'K') {
        bridge_halted = true;
        line_detach(0);
    } else if (type == 'X') {
        avr_reset(cores[0]); /* also clears its cycle timers: ours start again */
        no_level_polling(cores[0]);
        avr_cycle_timer_register(cores[0], HOST_BYTE_CYCLES, feed_host, NULL);
        arm_fence(cores[0]);
        host_q_tail = host_q_head;
    } else if (type == 'O' && n >= 2 && payload[0] < n_boards) {
        power_board(payload[0], payload[1] != 0);
    } else if (type == 'W' && n >= 3) {
        memset(&watch, 0, sizeof watch);
        watch.on = true;
        watch.waiting_delimiter = payload[0] == 0;
        watch.skip = payload[1];
        for (unsigned i = host_q_tail; i != host_q_head; i++) {
            watch.skip += host_q[i % HOST_RING] == 0; /* frames already queued */
        }
        watch.start = now;
        watch.n = payload[2] <= 2 * CHAIN_MAX_BOARDS ? payload[2] : 2 * CHAIN_MAX_BOARDS;
        for (int k = 0; k < watch.n && 3 + 2 * k + 1 < n; k++) {
            watch.board[k] = payload[3 + 2 * k];
            watch.slot[k] = payload[4 + 2 * k];
        }
    } else if (type == 'Q') {
        figures_send(now, cores, n_boards, board_ids, bridge_debug_at, pico_debug_at);
    }
    figures_add_wall(wall_now() - t0);
}

int main(int argc, char **argv) {
    if (argc < 4) {
        fprintf(stderr, "usage: pirate-chain BRIDGE.elf PICO.elf ID [ID...]\n");
        return 2;
    }
    /* every id as given, or none: a truncated list (a 17th board) or an id read as
     * another (atoi: "300" was board 44, "22x" 22, "abc" 0) left a board of the robot
     * without its PICO, and the bridge could never release its boot latch */
    n_boards = argc - 3;
    if (n_boards > CHAIN_MAX_BOARDS) {
        fprintf(stderr, "pirate-chain: %d board ids given, at most %d\n", n_boards,
                CHAIN_MAX_BOARDS);
        return 2;
    }
    for (int b = 0; b < n_boards; b++) {
        char *end;
        errno = 0;
        long id = strtol(argv[3 + b], &end, 10);
        if (errno || end == argv[3 + b] || *end || id < 0 || id > 255) {
            fprintf(stderr, "pirate-chain: board id '%s' is not a number from 0 to 255\n",
                    argv[3 + b]);
            return 2;
        }
        for (int a = 0; a < b; a++) {
            if (board_ids[a] == id) {
                fprintf(stderr, "pirate-chain: board id %ld given twice\n", id);
                return 2;
            }
        }
        board_ids[b] = (uint8_t)id;
    }
    static elf_firmware_t bridge_fw, pico_fw;
    no_bridge = strcmp(argv[1], "-") == 0;
    if ((!no_bridge && !elf_built_for("pirate-chain", argv[1], 6u, "bridge's ATmega2560")) ||
        !elf_built_for("pirate-chain", argv[2], 5u, "PICO board's ATmega328p")) {
        return 2;
    }
    if ((!no_bridge && elf_read_firmware(argv[1], &bridge_fw) != 0) ||
        elf_read_firmware(argv[2], &pico_fw) != 0) {
        fprintf(stderr, "pirate-chain: cannot read the ELFs %s, %s\n", argv[1], argv[2]);
        return 2;
    }
    pico_debug_at = find_symbol(&pico_fw, "pico_debug");
    if (!no_bridge) {
        cores[0] = make_core("atmega2560", &bridge_fw);
        bridge_debug_at = find_symbol(&bridge_fw, "pb_debug");
        attach_host(cores[0]);
        line_attach(0, cores[0], '1', 'E', 4, 'E', 5);
        set_estop_input(false);
    }
    char hello[512];
    int k = snprintf(hello, sizeof hello, "boards");
    for (int b = 0; b < n_boards; b++) {
        cores[b + 1] = make_core("atmega328p", &pico_fw);
        board_attach(b, cores[b + 1], board_ids[b]);
        line_attach(b + 1, cores[b + 1], '0', 'D', 2, 'D', 2);
        k += snprintf(hello + k, sizeof hello - (size_t)k, " %u", board_ids[b]);
    }
    for (int c = no_bridge ? 1 : 0; c <= n_boards; c++) {
        find_uarts(c);
        arm_fence(cores[c]);
    }
    if (no_bridge) {
        avr_cycle_timer_register(cores[1], LINE_BYTE_CYCLES, feed_master, NULL);
        line_on_byte(master_hears);
    }
    figures_watch_line(board_ids[0], board_ids[n_boards - 1],
                       getenv("PIRATE_CHAIN_TRACE") != NULL); /* every frame, to stderr */
    signal(SIGPIPE, SIG_IGN);
    channel_send_record('P', (const uint8_t *)hello, (uint16_t)k);
    while (channel_wait(handle)) {
    }
    return 0;
}
