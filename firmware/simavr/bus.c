/* pirate-simavr: USART1, the board bus: frames out, the boards' replies in (see harness.c).
 * Calls channel.c only. */
#include "harness.h"

static avr_t *mcu;
static avr_irq_t *bus_in;
static uint8_t busq[4096];
static unsigned busq_head, busq_tail;
static uint8_t replies[256][64]; /* per address: the board's latest reply ('U') */
static uint8_t reply_len[256];
static uint8_t bus_frame[256];
static unsigned bus_frame_n;
static bool bus_frame_ready;
static uint8_t last_frame[256][64]; /* per address: the last frame told to the boards */
static uint8_t last_frame_len[256];
static uint64_t bus_frame_cycle;
static uint64_t line_free_at; /* the cycle the last byte written leaves the shift register */
static struct bus_stats stats;

static avr_cycle_count_t feed_bus(avr_t *a, avr_cycle_count_t when, void *param) {
    (void)a, (void)param;
    if (busq_tail != busq_head) {
        avr_raise_irq(bus_in, busq[busq_tail++ % sizeof busq]);
        return when + BUS_BYTE_CYCLES;
    }
    return 0; /* idle until the next answer */
}

static void bus_out(avr_irq_t *irq, uint32_t value, void *param) {
    (void)irq, (void)param;
    /* simavr reports a byte when it is written to UDR1; on the line it starts once the
     * byte before it has left the shift register */
    uint64_t start = line_free_at > mcu->cycle ? line_free_at : mcu->cycle;
    line_free_at = start + BUS_BYTE_CYCLES;
    if (value != 0) {
        if (bus_frame_n < sizeof bus_frame) {
            bus_frame[bus_frame_n++] = (uint8_t)value;
        }
        return;
    }
    bus_frame_ready = true; /* reported between two instructions: bus_service */
    bus_frame_cycle = line_free_at; /* its last stop bit */
    stats.frames++;
}

void bus_init(avr_t *avr) {
    mcu = avr;
    uint32_t flags = 0; /* no stdio echo, no pacing by simavr itself */
    avr_ioctl(avr, AVR_IOCTL_UART_SET_FLAGS('1'), &flags);
    bus_in = avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('1'), UART_IRQ_INPUT);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('1'), UART_IRQ_OUTPUT),
                            bus_out, NULL);
}

void bus_reset(void) {
    avr_cycle_timer_cancel(mcu, feed_bus, NULL);
    busq_tail = busq_head;
    bus_frame_n = 0;
    line_free_at = 0;
    memset(last_frame_len, 0, sizeof last_frame_len);
}

void bus_set_reply(uint8_t addr, const uint8_t *reply, uint16_t n) {
    if (n <= sizeof replies[0]) {
        memcpy(replies[addr], reply, n);
        reply_len[addr] = (uint8_t)n;
    }
}

const struct bus_stats *bus_stats(void) {
    return &stats;
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
 * reply gets it, 20 us after the request's 0x00 has left the line. */
static void answer(const uint8_t *frame, unsigned n) {
    uint8_t body[64];
    int k = cobs_decode(frame, n, body, sizeof body);
    if (k < 4 || crc16_xmodem(body, (unsigned)k - 2u) !=
                     (uint16_t)(body[k - 2] | body[k - 1] << 8)) {
        return;
    }
    if (body[1] != 0x01u) {
        if (body[1] == 0x02u) {
            stats.stops++; /* STOP: applied silently */
        }
        return;
    }
    uint8_t addr = body[0];
    if (!reply_len[addr]) {
        stats.unanswered++;
        return;
    }
    stats.replies++;
    for (unsigned i = 0; i < reply_len[addr]; i++) {
        busq[busq_head++ % sizeof busq] = replies[addr][i];
    }
    avr_cycle_timer_cancel(mcu, feed_bus, NULL);
    /* the board's turnaround counts from the end of the request's last stop bit */
    avr_cycle_timer_register(mcu, line_free_at - mcu->cycle + BUS_TURNAROUND_CYCLES, feed_bus,
                             NULL);
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
            stats.repeats++;
            bus_frame_n = 0;
            return;
        }
        memcpy(last_frame[addr], bus_frame, bus_frame_n);
        last_frame_len[addr] = (uint8_t)bus_frame_n;
    }
    uint8_t payload[8 + sizeof bus_frame];
    channel_put_u64(payload, bus_frame_cycle);
    memcpy(payload + 8, bus_frame, bus_frame_n);
    channel_send_record('F', payload, (uint16_t)(8 + bus_frame_n));
    bus_frame_n = 0;
}

void bus_service(void) {
    if (bus_frame_ready) {
        exchange();
    }
}
