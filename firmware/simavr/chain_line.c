/* pirate-chain: the RS485 line (see chain.c). Calls channel.c only (nothing, in fact).
 *
 * Every node's USART reports a byte when the firmware writes it to UDR; on the line it
 * starts once the node's shift register is free and lasts one byte time (320 cycles
 * at 1 Mbaud). After every core has run to the end of a slice, the bytes that
 * started in it are settled: a byte reaches the line only if its sender's driver was
 * enabled (DE high) when it started; every node whose receiver is enabled (/RE low)
 * then hears it, the sender too if its own receiver is on (an echo); if another node
 * drives the line during the byte, it is a collision and everyone hears a framing
 * error; a driver switched off while its USART still sends is counted (truncated). The byte is raised into each receiver's USART at its start (simavr then
 * completes it one byte time later), at most one slice (10 us) late. Biased idle
 * line: when nobody drives, nobody hears anything. */
#include "chain.h"

#define PENDING 512u
#define HISTORY 16u

struct edge {
    uint64_t at;
    bool level;
};

static struct node {
    bool used, detached;
    avr_t *avr;
    avr_uart_t *uart;
    avr_irq_t *uart_in;
    uint64_t line_free;
    struct edge de[HISTORY]; /* DE changes, newest at de_n - 1 (ring) */
    unsigned de_n;
    struct edge re[HISTORY]; /* /RE changes */
    unsigned re_n;
    uint8_t frame[64];
    unsigned frame_n;
    uint64_t frame_start;
} nodes[CHAIN_NODES];

static struct pending {
    int sender;
    uint8_t value;
    uint64_t start;
} pending[PENDING];
static unsigned n_pending;
static struct line_stats stats;
static line_frame_fn frame_fn;
static line_tap_fn tap_fn;

static void record(struct edge *ring, unsigned *n, uint64_t at, bool level) {
    if (*n > 0 && ring[(*n - 1u) % HISTORY].level == level) {
        return; /* a PORT write that changed nothing */
    }
    ring[*n % HISTORY] = (struct edge){at, level};
    (*n)++;
}

/* The level of a pin (from its change history) at cycle t; `initial` before any. */
static bool level_at(const struct edge *ring, unsigned n, uint64_t t, bool initial) {
    for (unsigned k = 0; k < n && k < HISTORY; k++) {
        const struct edge *e = &ring[(n - 1u - k) % HISTORY];
        if (e->at <= t) {
            return e->level;
        }
    }
    return initial;
}

/* A rising DE of node m within (from, to]. */
static bool rose_within(const struct node *m, uint64_t from, uint64_t to) {
    for (unsigned k = 0; k < m->de_n && k < HISTORY; k++) {
        const struct edge *e = &m->de[(m->de_n - 1u - k) % HISTORY];
        if (e->at <= from) {
            break;
        }
        if (e->at <= to && e->level) {
            return true;
        }
    }
    return false;
}

static void de_changed(avr_irq_t *irq, uint32_t value, void *param) {
    (void)irq;
    struct node *n = param;
    bool before = n->de_n > 0 && n->de[(n->de_n - 1u) % HISTORY].level;
    if (before && !value && n->uart && n->uart->tx_cnt > 0) {
        stats.truncated++; /* the driver went off while the USART still had a byte */
    }
    record(n->de, &n->de_n, n->avr->cycle, value != 0);
}

static void re_changed(avr_irq_t *irq, uint32_t value, void *param) {
    (void)irq;
    struct node *n = param;
    record(n->re, &n->re_n, n->avr->cycle, value != 0);
}

static void uart_out(avr_irq_t *irq, uint32_t value, void *param) {
    (void)irq;
    struct node *n = param;
    if (n->detached) {
        return;
    }
    uint64_t start = n->line_free > n->avr->cycle ? n->line_free : n->avr->cycle;
    n->line_free = start + LINE_BYTE_CYCLES;
    if (n_pending < PENDING) {
        pending[n_pending++] = (struct pending){(int)(n - nodes), (uint8_t)value, start};
    }
}

void line_attach(int i, avr_t *avr, char uart, char de_port, int de_bit, char re_port,
                 int re_bit) {
    struct node *n = &nodes[i];
    memset(n, 0, sizeof *n);
    n->used = true;
    n->avr = avr;
    uint32_t flags = 0;
    avr_ioctl(avr, AVR_IOCTL_UART_SET_FLAGS(uart), &flags);
    n->uart_in = avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ(uart), UART_IRQ_INPUT);
    for (avr_io_t *io = avr->io_port; io; io = io->next) {
        if (io->kind && strcmp(io->kind, "uart") == 0 && ((avr_uart_t *)io)->name == uart) {
            n->uart = (avr_uart_t *)io;
        }
    }
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ(uart), UART_IRQ_OUTPUT),
                            uart_out, n);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ(de_port), de_bit),
                            de_changed, n);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ(re_port), re_bit),
                            re_changed, n);
}

void line_detach(int i) { nodes[i].detached = true; }

void line_reattach(int i) { nodes[i].detached = false; }

void line_on_frame(line_frame_fn fn) { frame_fn = fn; }

void line_on_byte(line_tap_fn fn) { tap_fn = fn; }

const struct line_stats *line_stats(void) { return &stats; }

static int by_start(const void *a, const void *b) {
    const struct pending *x = a, *y = b;
    return x->start < y->start ? -1 : x->start > y->start;
}

static void settle_one(const struct pending *p, uint64_t until) {
    struct node *s = &nodes[p->sender];
    stats.bytes++;
    if (s->detached) {
        return;
    }
    if (!level_at(s->de, s->de_n, p->start, false)) {
        stats.driver_off++; /* written with the driver off: never on the line */
        return;
    }
    uint64_t end = p->start + LINE_BYTE_CYCLES;
    if (tap_fn) {
        tap_fn(p->sender, p->value);
    }
    bool collision = false;
    for (int m = 0; m < CHAIN_NODES; m++) {
        const struct node *o = &nodes[m];
        if (m == p->sender || !o->used || o->detached) {
            continue;
        }
        if (level_at(o->de, o->de_n, p->start, false) ||
            rose_within(o, p->start, end < until ? end : until)) {
            collision = true;
        }
    }
    if (collision) {
        stats.collisions++;
    }
    bool heard = false;
    for (int r = 0; r < CHAIN_NODES; r++) {
        struct node *n = &nodes[r];
        if (!n->used || n->detached || level_at(n->re, n->re_n, p->start, false)) {
            continue; /* its receiver is off (/RE high) */
        }
        if (r == p->sender) {
            stats.echo++;
        }
        avr_raise_irq(n->uart_in, p->value | (collision ? UART_INPUT_FE : 0u));
        stats.delivered++;
        heard = true;
    }
    if (!heard) {
        stats.unheard++;
    }
    /* frames, for the figures */
    if (s->frame_n == 0) {
        s->frame_start = p->start;
    }
    if (p->value != 0) {
        if (s->frame_n < sizeof s->frame) {
            s->frame[s->frame_n++] = p->value;
        }
    } else {
        if (frame_fn && s->frame_n) {
            frame_fn(p->sender, s->frame, s->frame_n, s->frame_start, end);
        }
        s->frame_n = 0;
    }
}

void line_settle(uint64_t until) {
    if (n_pending == 0) {
        return;
    }
    qsort(pending, n_pending, sizeof pending[0], by_start);
    unsigned done = 0;
    while (done < n_pending && pending[done].start < until) {
        settle_one(&pending[done], until);
        done++;
    }
    memmove(pending, pending + done, (n_pending - done) * sizeof pending[0]);
    n_pending -= done;
}
