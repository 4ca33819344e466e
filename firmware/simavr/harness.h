/* pirate-simavr: the interfaces of its files, bottom to top (harness.c has the
 * overview, the channel's records and the file graph). A file calls only the
 * sections above its own; no state is shared between files: each file keeps its
 * own and lends it out through the functions below, and where a lower file must
 * tell a higher one something it calls a function the higher one registered. */
#ifndef PIRATE_SIMAVR_HARNESS_H
#define PIRATE_SIMAVR_HARNESS_H

#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <simavr/avr_extint.h>
#include <simavr/avr_ioport.h>
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
#define BUS_BAUD 1000000u
#define BUS_BYTE_CYCLES (HZ * 10u / BUS_BAUD)
#define BUS_TURNAROUND_CYCLES (HZ / 50000u) /* 20 us */
#define GPIOR0_DATA 0x3Eu
#define RAMEND 0x21FFu
#define MAX_LAG_CYCLES (HZ / 5u) /* behind the wall clock by more: give up catching up */
#define RING 65536u

enum { MARK_STATE_BEGIN = 0x01, MARK_STATE_END = 0x81, MARK_FRAME_END = 0x02,
       MARK_BULK_END = 0x82, MARK_ESTOP = 0x03, MARK_BUS_STOP = 0x04 };

/* simavr polls a level-triggered external interrupt pin every cycle while it is low
 * (a new poll at every write to its port, whether or not the interrupt is enabled):
 * the bridge's RS485 DE and /RE (INT4, INT5) and the PICO's DE (INT0) are low most of
 * the time. The firmwares use no external interrupt; turn the polling off after every
 * reset (a reset turns it on again). */
static inline void no_level_polling(avr_t *avr) {
    for (uint8_t i = 0; i < 8; i++) {
        avr_extint_set_strict_lvl_trig(avr, i, 0);
    }
}

/* Whether `path` is an AVR ELF built for the architecture `mach` (the e_flags'
 * EF_AVR_MACH: 6 = avr6, the bridge's ATmega2560; 5 = avr5, a PICO's ATmega328p). If not,
 * one line on stderr names the file and what it is. simavr's loader takes anything: a
 * HEX, a text file or the other chip's ELF loaded as an empty or wrong flash that
 * crashed at once or reset forever, with a pty that never answered. */
static inline bool elf_built_for(const char *prog, const char *path, unsigned mach,
                                 const char *chip) {
    unsigned char h[52];
    FILE *f = fopen(path, "rb");
    if (!f) {
        fprintf(stderr, "%s: cannot read %s: %s\n", prog, path, strerror(errno));
        return false;
    }
    size_t n = fread(h, 1, sizeof h, f);
    fclose(f);
    if (n < sizeof h || memcmp(h, "\177ELF", 4) != 0) {
        fprintf(stderr, "%s: %s is %s\n", prog, path,
                n > 0 && h[0] == ':' ? "Intel HEX, not an ELF file: give the .elf built beside it"
                                     : "not an ELF file");
        return false;
    }
    unsigned machine = (unsigned)(h[18] | h[19] << 8);
    if (h[4] != 1 || h[5] != 1 || machine != 83u) { /* ELFCLASS32, LSB, EM_AVR */
        fprintf(stderr, "%s: %s is an ELF file, but not for an AVR (machine %u)\n", prog,
                path, machine);
        return false;
    }
    unsigned built = h[36] & 0x7Fu; /* EF_AVR_MACH */
    if (built != mach) {
        fprintf(stderr, "%s: %s is built for avr%u%s, not for the %s (avr%u)\n", prog, path,
                built,
                built == 5u   ? " (an ATmega328p: a PICO board's firmware?)"
                : built == 6u ? " (an ATmega2560: the bridge's firmware?)"
                              : "",
                chip, mach);
        return false;
    }
    return true;
}

/* channel.c (calls no other file): the records to and from the board simulator */
typedef void (*channel_handler)(char type, const uint8_t *payload, uint16_t n);
void channel_send_record(char type, const uint8_t *payload, uint16_t n);
void channel_put_u64(uint8_t *p, uint64_t v);
/* Hands every record that has arrived to `handle`; false once stdin is closed. */
bool channel_service(channel_handler handle);

/* host.c (calls channel.c): USART0 on the pty */
struct host_stats {
    uint64_t bytes_in, bytes_dropped, frames_out;
    uint64_t bytes_out_dropped; /* MCU bytes lost to a host that did not read */
    uint64_t last_delimiter; /* cycle at which the last host 0x00 entered the MCU */
};
/* Wires USART0; `on_open` is called when a host opens the pty (the DTR edge). */
void host_init(avr_t *avr, void (*on_open)(void));
/* After an MCU reset: queues emptied, feeding restarted, bytes before `boot_until` lost. */
void host_reset(uint64_t boot_until);
void host_open_pty(void);
void host_service_pty(void);
const struct host_stats *host_stats(void);
unsigned host_queue_bytes(void);

/* bus.c (calls channel.c): USART1, the board bus */
struct bus_stats {
    uint64_t frames, replies, unanswered, repeats, stops;
};
void bus_init(avr_t *avr);
void bus_reset(void);
/* The board `addr`'s reply to an EXCHANGE (n == 0: silent; longer than 64: ignored). */
void bus_set_reply(uint8_t addr, const uint8_t *reply, uint16_t n);
/* Answers and forwards the frame the bridge finished, if any (between instructions). */
void bus_service(void);
const struct bus_stats *bus_stats(void);

/* figures.c (calls host.c and bus.c): markers, tallies, the figures text */
struct mcu_stats {
    uint64_t dtr_resets, unexpected_resets, lag_events;
};
void figures_init(avr_t *avr, uint32_t debug_at);
void figures_reset(void);
int figures_text(char *out, size_t size, const struct mcu_stats *mcu);

/* harness.c (calls all of the above): the MCU, its reset and pacing, main */

#endif
