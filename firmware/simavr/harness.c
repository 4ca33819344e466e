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
#include "harness.h"

avr_t *avr;
avr_irq_t *host_in, *bus_in;
bool host_open, host_xoff, stop_requested;
static bool reset_expected = true; /* the power-on start */
bool held;                  /* 'H': the MCU's clock stands still until 'G' */
double wall0;               /* pacing: wall time at cycle0 */
uint64_t cycle0;
uint64_t unexpected_resets;
static unsigned boot_ms;
uint64_t boot_until; /* MCU held in reset (bootloader) until this cycle */
uint32_t debug_at;   /* pb_debug's SRAM address, 0 when not found */

uint8_t hostq[RING], busq[4096], host_out_buf[RING];
unsigned hostq_head, hostq_tail, busq_head, busq_tail, host_out_n;
uint8_t replies[256][64];
uint8_t last_frame_len[256];
uint64_t bus_repeats, last_tick;
uint8_t reply_len[256];
uint64_t bus_replies, bus_unanswered; /* EXCHANGEs: answered, not (silent board) */
uint64_t bus_stops;                    /* STOPs with a good CRC */
unsigned bus_frame_n;
bool bus_frame_ready;

uint64_t mark_at[256], last_host_delimiter, estop_byte_at;
bool estop_waiting;
uint64_t dtr_resets, lag_events, bus_frames, host_bytes_in, host_bytes_dropped, frames_out;

double harness_now_s(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

/* -- the MCU ---------------------------------------------------------------------- */

void harness_reset_mcu(void) {
    avr_reset(avr); /* also clears simavr's cycle timers: ours start again */
    avr_cycle_timer_cancel(avr, harness_feed_host, NULL);
    avr_cycle_timer_cancel(avr, harness_feed_bus, NULL);
    avr_cycle_timer_register(avr, HOST_BYTE_CYCLES, harness_feed_host, NULL);
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
    harness_put_u64(p, avr->cycle);
    harness_send_record('R', p, 8);
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
            harness_exchange();
        }
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
                            harness_host_out, NULL);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('1'), UART_IRQ_OUTPUT),
                            harness_bus_out, NULL);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XON),
                            harness_host_xon, NULL);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XOFF),
                            harness_host_xoff_irq, NULL);
    avr_register_io_write(avr, GPIOR0_DATA, harness_marker, NULL);
    avr_cycle_timer_register(avr, HOST_BYTE_CYCLES, harness_feed_host, NULL);

    signal(SIGTERM, on_signal);
    signal(SIGINT, on_signal);
    signal(SIGPIPE, SIG_IGN);
    harness_open_pty();

    /* Paced to the wall clock in 1 ms slices; when the host machine falls behind by
     * more than MAX_LAG_CYCLES the reference moves (a lag event), never a burst. */
    wall0 = harness_now_s();
    cycle0 = avr->cycle;
    while (!stop_requested) {
        harness_service_pty();
        if (avr->cycle - last_tick >= HZ / 100u) {
            /* after the pty got what the MCU sent up to now: a reader that waits for
             * this time has the bytes too */
            last_tick = avr->cycle;
            uint8_t p[8];
            harness_put_u64(p, avr->cycle);
            harness_send_record('T', p, 8);
        }
        harness_service_channel();
        if (held) {
            struct timespec nap = {0, 500000};
            nanosleep(&nap, NULL);
            continue;
        }
        uint64_t target = cycle0 + (uint64_t)((harness_now_s() - wall0) * speed * HZ);
        if (target > avr->cycle + MAX_LAG_CYCLES) {
            lag_events++;
            cycle0 = avr->cycle;
            wall0 = harness_now_s();
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
    harness_figures_text(text, sizeof text);
    fputs(text, stderr);
    return 0;
}
