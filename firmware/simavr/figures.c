/* pirate-simavr: the figures, from the GPIOR0 markers and pb_debug (see harness.c).
 * Calls host.c and bus.c only, for their counts. */
#include "harness.h"

static avr_t *mcu;
static uint32_t debug_at; /* pb_debug's SRAM address, 0 when not found */
static uint64_t mark_at[256], estop_byte_at;
static bool estop_waiting;

struct tally {
    uint64_t n, sum, min, max;
};

static struct tally state_cycles, bulk_cycles, estop_us;

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

static uint16_t debug_u16(unsigned offset) {
    if (!debug_at) {
        return 0;
    }
    return (uint16_t)(mcu->data[debug_at + offset] | mcu->data[debug_at + offset + 1] << 8);
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
        estop_byte_at = host_stats()->last_delimiter;
    } else if (value == MARK_BUS_STOP && estop_waiting) {
        estop_waiting = false;
        add(&estop_us, a->cycle - estop_byte_at);
    }
}

void figures_init(avr_t *avr, uint32_t debug_address) {
    mcu = avr;
    debug_at = debug_address;
    avr_register_io_write(avr, GPIOR0_DATA, marker, NULL);
}

void figures_reset(void) {
    estop_waiting = false;
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

int figures_text(char *out, size_t size, const struct mcu_stats *m) {
    const struct host_stats *host = host_stats();
    const struct bus_stats *bus = bus_stats();
    int k = snprintf(out, size,
                     "cycles %llu\nsimulated_s %.3f\ndtr_resets %llu\n"
                     "unexpected_resets %llu\nfirmware_reset_count %u\nstack_high_water_bytes %u\nstack_room_bytes %u\n"
                     "debug_magic 0x%04x\nlag_events %llu\nbus_frames %llu\n"
                     "host_bytes_in %llu\nhost_bytes_dropped %llu\nhost_frames_out %llu\n"
                     "rx_overruns %u\nbus_replies %llu\nbus_unanswered %llu\nbus_repeats %llu\n"
                     "bus_stops %llu\nhost_queue_bytes %u\n"
                     "host_framing_errors %u\nbus_framing_errors %u\nbus_bytes_lost %u\n"
                     "bus_echo_bytes %u\nboard_own_stops %u\nestop_input_trips %u\nhost_bytes_out_dropped %llu\n",
                     (unsigned long long)mcu->cycle, (double)mcu->cycle / HZ,
                     (unsigned long long)m->dtr_resets,
                     (unsigned long long)m->unexpected_resets, debug_u16(2),
                     debug_at ? RAMEND - debug_u16(6) : 0u, debug_at ? RAMEND - debug_u16(8) : 0u,
                     debug_u16(0), (unsigned long long)m->lag_events,
                     (unsigned long long)bus->frames, (unsigned long long)host->bytes_in,
                     (unsigned long long)host->bytes_dropped, (unsigned long long)host->frames_out,
                     debug_u16(18), (unsigned long long)bus->replies,
                     (unsigned long long)bus->unanswered, (unsigned long long)bus->repeats,
                     (unsigned long long)bus->stops, host_queue_bytes(), debug_u16(20),
                     debug_u16(22), debug_u16(24), debug_u16(26), debug_u16(28), debug_u16(30),
                     (unsigned long long)host->bytes_out_dropped);
    k += put_stat(out + k, size - (size_t)k, "state_encode_cycles", &state_cycles, 1.0);
    k += put_stat(out + k, size - (size_t)k, "bulk_decode_apply_cycles", &bulk_cycles, 1.0);
    k += put_stat(out + k, size - (size_t)k, "estop_to_bus_stop_us", &estop_us, HZ / 1e6);
    return k;
}
