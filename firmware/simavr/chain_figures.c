/* pirate-chain's figures (chain.h): the bus cycle, from a cycle's first request to its
 * last reply, read off the line's frames; and the 'S' record of figures, the line's
 * counts and what the firmwares keep in their debug blocks. Split out of chain.c. */
#include "chain.h"

#include <stdio.h>

static struct {
    uint64_t cycles_n, cycles_sum, cycles_min, cycles_max;
    uint64_t cycle_start;
    double wall_s;
} fig;

static bool trace;
static uint8_t first_id, last_id; /* the first board polled in a cycle, and the last */

static void on_frame(int sender, const uint8_t *bytes, unsigned n, uint64_t start, uint64_t end) {
    if (trace) {
        fprintf(stderr, "frame %d %llu..%llu n=%u:", sender, (unsigned long long)start,
                (unsigned long long)end, n);
        for (unsigned i = 0; i < n && i < 8; i++) {
            fprintf(stderr, " %02x", bytes[i]);
        }
        fprintf(stderr, "\n");
    }
    if (n < 3) {
        return;
    }
    uint8_t addr = bytes[1]; /* after the COBS code byte; ids are never 0 */
    if (sender == 0 && addr == first_id && bytes[0] >= 3 && bytes[2] == 0x01) {
        fig.cycle_start = start;
    } else if (sender != 0 && addr == last_id && fig.cycle_start) {
        uint64_t d = end - fig.cycle_start;
        if (fig.cycles_n == 0 || d < fig.cycles_min) {
            fig.cycles_min = d;
        }
        if (d > fig.cycles_max) {
            fig.cycles_max = d;
        }
        fig.cycles_n++;
        fig.cycles_sum += d;
        fig.cycle_start = 0;
    }
}

void figures_watch_line(uint8_t first, uint8_t last, bool trace_frames) {
    first_id = first;
    last_id = last;
    trace = trace_frames;
    line_on_frame(on_frame);
}

void figures_add_wall(double seconds) { fig.wall_s += seconds; }

static uint16_t debug16(avr_t *avr, uint32_t at, unsigned offset) {
    return at && avr ? (uint16_t)(avr->data[at + offset] | avr->data[at + offset + 1] << 8) : 0;
}

void figures_send(uint64_t now, avr_t *const *cores, int n_boards, const uint8_t *board_ids,
                  uint32_t bridge_debug_at, uint32_t pico_debug_at) {
    static char text[8192];
    const struct line_stats *l = line_stats();
    double sim_s = (double)now / HZ;
    int k = snprintf(text, sizeof text,
                     "cycles %llu\nsimulated_s %.6f\nwall_s %.3f\nspeed_vs_real_time %.4f\n"
                     "line_bytes %llu\nline_delivered %llu\nline_collisions %llu\n"
                     "line_unheard %llu\nline_driver_off %llu\nline_truncated %llu\nline_echo %llu\n"
                     "bridge_stack_high_water_bytes %u\nbridge_board_own_stops %u\n"
                     "bridge_estop_input_trips %u\nbridge_bus_framing_errors %u\n",
                     (unsigned long long)now, sim_s, fig.wall_s,
                     fig.wall_s > 0 ? sim_s / fig.wall_s : 0.0, (unsigned long long)l->bytes,
                     (unsigned long long)l->delivered, (unsigned long long)l->collisions,
                     (unsigned long long)l->unheard, (unsigned long long)l->driver_off,
                     (unsigned long long)l->truncated, (unsigned long long)l->echo,
                     bridge_debug_at && cores[0] ? 0x21FFu - debug16(cores[0], bridge_debug_at, 6)
                                                 : 0u,
                     debug16(cores[0], bridge_debug_at, 28), debug16(cores[0], bridge_debug_at, 30),
                     debug16(cores[0], bridge_debug_at, 22));
    if (fig.cycles_n) {
        k += snprintf(text + k, sizeof text - (size_t)k,
                      "bus_cycle_us_n %llu\nbus_cycle_us_mean %.1f\nbus_cycle_us_min %.1f\n"
                      "bus_cycle_us_max %.1f\n",
                      (unsigned long long)fig.cycles_n,
                      (double)fig.cycles_sum / (double)fig.cycles_n / (HZ / 1e6),
                      (double)fig.cycles_min / (HZ / 1e6), (double)fig.cycles_max / (HZ / 1e6));
    }
    unsigned worst_stack = 0;
    for (int b = 0; b < n_boards; b++) {
        avr_t *a = cores[b + 1];
        unsigned stack = pico_debug_at ? 0x08FFu - debug16(a, pico_debug_at, 8) : 0u;
        if (stack > worst_stack) {
            worst_stack = stack;
        }
        k += snprintf(text + k, sizeof text - (size_t)k,
                      "pico_%u_exchanges %u\npico_%u_stops %u\npico_%u_bad_frames %u\n"
                      "pico_%u_own_stops %u\npico_%u_own_stop %u\npico_%u_stack_high_water_bytes %u\n",
                      board_ids[b], debug16(a, pico_debug_at, 10), board_ids[b],
                      debug16(a, pico_debug_at, 12), board_ids[b], debug16(a, pico_debug_at, 14),
                      board_ids[b], debug16(a, pico_debug_at, 16), board_ids[b],
                      pico_debug_at ? a->data[pico_debug_at + 22] : 0u, board_ids[b], stack);
        for (int m = 0; m < 2 && pico_debug_at; m++) {
            k += snprintf(text + k, sizeof text - (size_t)k,
                          "pico_%u_motor%d_mode %u\npico_%u_motor%d_raw %d\n", board_ids[b], m,
                          a->data[pico_debug_at + 24 + m], board_ids[b], m,
                          (int16_t)debug16(a, pico_debug_at, 26u + 2u * (unsigned)m));
        }
    }
    k += snprintf(text + k, sizeof text - (size_t)k, "pico_stack_high_water_bytes %u\n",
                  worst_stack);
    channel_send_record('S', (const uint8_t *)text, (uint16_t)k);
}
