/* pirate-simavr: what its files share (harness.c has the overview and the channel's
 * records; host.c the pty, bus.c the board bus, channel.c the board simulator's
 * channel, figures.c the figures). */
#ifndef PIRATE_SIMAVR_HARNESS_H
#define PIRATE_SIMAVR_HARNESS_H

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

/* harness.c: the state, the MCU and its pacing */
extern avr_t *avr;
extern avr_irq_t *host_in, *bus_in;
extern bool host_open, host_xoff, stop_requested;
extern bool held;
extern double wall0;
extern uint64_t cycle0;
extern uint64_t unexpected_resets;
extern uint64_t boot_until;
extern uint32_t debug_at;
extern uint8_t hostq[RING], busq[4096], host_out_buf[RING];
extern unsigned hostq_head, hostq_tail, busq_head, busq_tail, host_out_n;
extern uint8_t replies[256][64];
extern uint8_t last_frame_len[256];
extern uint64_t bus_repeats, last_tick;
extern uint8_t reply_len[256];
extern uint64_t bus_replies, bus_unanswered;
extern uint64_t bus_stops;
extern unsigned bus_frame_n;
extern bool bus_frame_ready;
extern uint64_t mark_at[256], last_host_delimiter, estop_byte_at;
extern bool estop_waiting;
extern uint64_t dtr_resets, lag_events, bus_frames, host_bytes_in, host_bytes_dropped, frames_out;

double harness_now_s(void);
void harness_reset_mcu(void);

/* host.c: USART0 on the pty */
void harness_host_xon(avr_irq_t *irq, uint32_t value, void *param);
void harness_host_xoff_irq(avr_irq_t *irq, uint32_t value, void *param);
avr_cycle_count_t harness_feed_host(avr_t *a, avr_cycle_count_t when, void *param);
void harness_host_out(avr_irq_t *irq, uint32_t value, void *param);
void harness_open_pty(void);
void harness_service_pty(void);

/* bus.c: USART1, the board bus */
avr_cycle_count_t harness_feed_bus(avr_t *a, avr_cycle_count_t when, void *param);
void harness_bus_out(avr_irq_t *irq, uint32_t value, void *param);
void harness_exchange(void);

/* channel.c: the records to and from the board simulator */
void harness_send_record(char type, const uint8_t *payload, uint16_t n);
void harness_put_u64(uint8_t *p, uint64_t v);
void harness_service_channel(void);

/* figures.c */
void harness_marker(avr_t *a, avr_io_addr_t addr, uint8_t value, void *param);
int harness_figures_text(char *out, size_t size);

#endif
