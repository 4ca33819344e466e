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
 *    once per state period ('U'): the harness sends it at 1 Mbaud 20 us after the
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
 *                      | 'E' u8: the hardware e-stop contact on D22 (PA0) opens (1,
 *                        pressed) or closes (0; the default: a closed contact to GND)
 * stdin closed or SIGTERM: print the figures on stderr and exit 0.
 *
 * Figures come from the firmware's GPIOR0 markers (docs/firmware.md) and its
 * pb_debug record (found by symbol in the ELF): MCU resets, stack high-water mark,
 * cycles to encode a STATE and to decode and apply a BULK_SETPOINTS, and the time
 * from an ESTOP frame's last byte to the first STOP byte on the board bus.
 *
 * The files and who calls whom, a DAG (harness.h declares each file's functions in
 * this order, bottom first):
 *
 *   harness.c  main, the MCU (reset, run_until, pacing), the boards' records
 *      |  \      -> figures.c, host.c, bus.c, channel.c
 *      |  figures.c  markers, tallies, the figures text  -> host.c, bus.c
 *      |   /    \
 *    host.c    bus.c  USART0 on the pty | USART1, the board bus  -> channel.c
 *         \    /
 *       channel.c  records on stdin/stdout  -> nothing
 *
 * No file reads or writes another's variables: each keeps its own state and lends
 * counts out through functions (host_stats, bus_stats; harness.c hands figures_text
 * its own). Where a lower file has news for a higher one it calls a function the
 * higher one handed down: host.c calls the `on_open` that harness.c gave host_init()
 * at the pty's DTR edge (harness.c resets the MCU, and with it host.c, bus.c and
 * figures.c), and channel_service() gives each record from the boards to harness.c's
 * handler. bus.c answers a finished frame when harness.c calls bus_service() between
 * two instructions.
 */
#include "harness.h"

static avr_t *avr;
static bool stop_requested;
static bool reset_expected = true; /* the power-on start */
static bool held;                  /* 'H': the MCU's clock stands still until 'G' */
static double wall0;               /* pacing: wall time at cycle0 */
static uint64_t cycle0;
static unsigned boot_ms;
static uint64_t boot_until; /* MCU held in reset (bootloader) until this cycle */
static uint64_t last_tick;
static struct mcu_stats mcu_stats;

static double now_s(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

/* -- the MCU ---------------------------------------------------------------------- */

static void reset_mcu(void) {
    avr_reset(avr); /* also clears simavr's cycle timers: ours start again */
    no_level_polling(avr);
    mcu_stats.dtr_resets++;
    reset_expected = true;
    boot_until = avr->cycle + (uint64_t)boot_ms * (HZ / 1000u);
    host_reset(boot_until); /* its feeding restarts; what arrives meanwhile is eaten */
    bus_reset();
    figures_reset();
    uint8_t p[8];
    channel_put_u64(p, avr->cycle);
    channel_send_record('R', p, 8);
}

/* The e-stop contact between PA0 (Mega D22) and GND: closed holds the pin low against
 * the firmware's pull-up, open lets the pull-up win. A reset clears simavr's PINA (its
 * ioport keeps no external level through avr_reset), so the contact is put back at the
 * reset vector: a button held down through a reset (DTR, watchdog) stays pressed, as on
 * a real Mega, where the bridge released its latch with the button still pressed. */
static bool estop_open;

static void set_estop_input(bool open) {
    estop_open = open;
    avr_ioport_external_t ext = {.name = 'A', .mask = 0x01, .value = open ? 0x01 : 0x00};
    avr_ioctl(avr, AVR_IOCTL_IOPORT_SET_EXTERNAL('A'), &ext);
    avr_irq_t *pin = avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ('A'), 0);
    avr_raise_irq(pin, open ? 0 : 1); /* the irq drops a raise of the level it holds, */
    avr_raise_irq(pin, open ? 1 : 0); /* which a reset's cleared PINA no longer has */
}

/* Handles one record from the boards. */
static void handle_record(char type, const uint8_t *payload, uint16_t n) {
    if (type == 'U') {
        if (n >= 1) {
            bus_set_reply(payload[0], payload + 1, (uint16_t)(n - 1u));
        }
    } else if (type == 'Q') {
        char text[2048];
        int len = figures_text(text, sizeof text, &mcu_stats);
        channel_send_record('S', (const uint8_t *)text, (uint16_t)len);
    } else if (type == 'X') {
        reset_mcu();
    } else if (type == 'H') {
        held = true; /* what the MCU sent is on the pty already (host_service_pty ran) */
        uint8_t p[8];
        channel_put_u64(p, avr->cycle);
        channel_send_record('h', p, 8);
    } else if (type == 'E' && n >= 1) {
        set_estop_input(payload[0] != 0);
    } else if (type == 'G' && held) {
        held = false;
        wall0 = now_s();
        cycle0 = avr->cycle;
    }
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
        if (avr->pc == 0) {
            if (!reset_expected) {
                /* the reset vector, not by us: watchdog, crash, jump */
                mcu_stats.unexpected_resets++;
            }
            set_estop_input(estop_open); /* the contact outlives the reset */
        }
        int state = avr_run(avr);
        reset_expected = false;
        if (state == cpu_Done || state == cpu_Crashed) {
            fprintf(stderr, "pirate-simavr: the AVR %s at cycle %llu (pc 0x%05x)\n",
                    state == cpu_Crashed ? "crashed" : "stopped",
                    (unsigned long long)avr->cycle, (unsigned)avr->pc);
            exit(4);
        }
        bus_service();
    }
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
    bool bad = false;
    for (int i = 1; i < argc && !bad; i++) {
        char *end = NULL;
        if (strcmp(argv[i], "--boot-ms") == 0 && i + 1 < argc) {
            /* whole milliseconds, at most a minute: atoi took "-5" as 4294967291 ms, a
             * bootloader that ate every host byte for ever, and "abc" as 0 */
            errno = 0;
            long ms = strtol(argv[++i], &end, 10);
            bad = errno || end == argv[i] || *end || ms < 0 || ms > 60000;
            boot_ms = (unsigned)ms;
        } else if (strcmp(argv[i], "--speed") == 0 && i + 1 < argc) {
            /* a finite rate: "nan" passed `speed <= 0` and paced the MCU to NaN cycles */
            speed = strtod(argv[++i], &end);
            bad = end == argv[i] || *end || !(speed > 0 && speed <= 100);
        } else if (argv[i][0] != '-' && !elf) {
            elf = argv[i];
        } else {
            bad = true;
        }
    }
    if (!elf || bad) {
        fprintf(stderr, "usage: pirate-simavr [--boot-ms MS] [--speed X] PIRATEBAY.elf (MS a"
                        " whole number 0..60000, X more than 0 and at most 100)\n");
        return 2;
    }
    elf_firmware_t fw;
    memset(&fw, 0, sizeof fw);
    if (!elf_built_for("pirate-simavr", elf, 6u, "bridge's ATmega2560")) {
        return 2;
    }
    if (elf_read_firmware(elf, &fw) != 0) {
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
    no_level_polling(avr);
    uint32_t debug_at = find_symbol(&fw, "pb_debug"); /* its SRAM address, 0: none */
    if (!debug_at) {
        fprintf(stderr, "pirate-simavr: no pb_debug in %s: resets and stack not measured\n",
                elf);
    }
    set_estop_input(false); /* a closed contact: the e-stop is not pressed */
    host_init(avr, reset_mcu);
    bus_init(avr);
    figures_init(avr, debug_at);

    signal(SIGTERM, on_signal);
    signal(SIGINT, on_signal);
    signal(SIGPIPE, SIG_IGN);
    host_open_pty();

    /* Paced to the wall clock in 1 ms slices; when the host machine falls behind by
     * more than MAX_LAG_CYCLES the reference moves (a lag event), never a burst. */
    wall0 = now_s();
    cycle0 = avr->cycle;
    while (!stop_requested) {
        host_service_pty();
        if (avr->cycle - last_tick >= HZ / 100u) {
            /* after the pty got what the MCU sent up to now: a reader that waits for
             * this time has the bytes too */
            last_tick = avr->cycle;
            uint8_t p[8];
            channel_put_u64(p, avr->cycle);
            channel_send_record('T', p, 8);
        }
        if (!channel_service(handle_record)) {
            stop_requested = true;
        }
        if (held) {
            struct timespec nap = {0, 500000};
            nanosleep(&nap, NULL);
            continue;
        }
        uint64_t target = cycle0 + (uint64_t)((now_s() - wall0) * speed * HZ);
        if (target > avr->cycle + MAX_LAG_CYCLES) {
            mcu_stats.lag_events++;
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
    figures_text(text, sizeof text, &mcu_stats);
    fputs(text, stderr);
    return 0;
}
