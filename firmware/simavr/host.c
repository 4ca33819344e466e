/* pirate-simavr: USART0, the host side: the MCU's serial port on a pty (see harness.c).
 * Calls channel.c only; tells harness.c of a DTR edge through the `on_open` it gave. */
#include "harness.h"

static avr_t *mcu;
static avr_irq_t *host_in;
static void (*opened)(void);
static int master = -1;
static bool host_open, host_xoff;
static uint64_t boot_until; /* bytes from the host before this cycle: the bootloader's */
static uint8_t hostq[RING], host_out_buf[RING];
static unsigned hostq_head, hostq_tail, host_out_n;
static struct host_stats stats;

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
    if (host_xoff || mcu->cycle < boot_until) {
        return when + HOST_BYTE_CYCLES / 4u;
    }
    if (hostq_tail != hostq_head) {
        uint8_t byte = hostq[hostq_tail++ % RING];
        avr_raise_irq(host_in, byte);
        if (byte == 0) {
            stats.last_delimiter = when;
        }
    }
    return when + HOST_BYTE_CYCLES;
}

static void host_out(avr_irq_t *irq, uint32_t value, void *param) {
    (void)irq, (void)param;
    if (value == 0) {
        stats.frames_out++;
    }
    if (!host_open) {
        return;
    }
    if (host_out_n < sizeof host_out_buf) {
        host_out_buf[host_out_n++] = (uint8_t)value;
    } else {
        stats.bytes_out_dropped++; /* a host that has not read for seconds loses bytes */
    }
}

void host_init(avr_t *avr, void (*on_open)(void)) {
    mcu = avr;
    opened = on_open;
    uint32_t flags = 0; /* no stdio echo, no pacing by simavr itself */
    avr_ioctl(avr, AVR_IOCTL_UART_SET_FLAGS('0'), &flags);
    host_in = avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_INPUT);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUTPUT),
                            host_out, NULL);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XON),
                            host_xon, NULL);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XOFF),
                            host_xoff_irq, NULL);
    avr_cycle_timer_register(avr, HOST_BYTE_CYCLES, feed_host, NULL);
}

void host_reset(uint64_t until) {
    avr_cycle_timer_cancel(mcu, feed_host, NULL);
    avr_cycle_timer_register(mcu, HOST_BYTE_CYCLES, feed_host, NULL);
    host_xoff = false;
    host_out_n = 0; /* bytes of the old boot not yet on the pty: lost with the reset */
    hostq_tail = hostq_head; /* the bootloader eats what arrives meanwhile */
    boot_until = until;
}

const struct host_stats *host_stats(void) {
    return &stats;
}

unsigned host_queue_bytes(void) {
    return hostq_head - hostq_tail;
}

/* -- the pty ----------------------------------------------------------------------- */

void host_open_pty(void) {
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
    channel_send_record('P', (const uint8_t *)name, (uint16_t)strlen(name));
}

/* Moves bytes between the pty and the queues; an open is a DTR edge. */
void host_service_pty(void) {
    struct pollfd p = {.fd = master, .events = POLLIN};
    poll(&p, 1, 0);
    bool open_now = !(p.revents & POLLHUP);
    if (open_now && !host_open) {
        host_open = true;
        opened(); /* the MCU resets: host_reset() runs before the bytes below are read */
    } else if (!open_now && host_open) {
        host_open = false;
        host_out_n = 0;
        /* what the host wrote that the queue had no room for goes with it (the next open
         * resets the MCU, whose bootloader would eat it): it must not reach the next boot */
        uint8_t junk[4096];
        ssize_t r;
        while ((r = read(master, junk, sizeof junk)) > 0) {
            stats.bytes_dropped += (uint64_t)r;
        }
    }
    if (!host_open) {
        return;
    }
    if (p.revents & POLLIN) {
        /* Only what the queue to the MCU has room for: the rest stays in the pty, whose
         * buffer fills and then holds the host's writes, as a serial port's driver does
         * (a host faster than the line waits, and loses nothing). The queue used to take
         * every byte and drop what did not fit (host_bytes_dropped). */
        uint8_t buf[4096];
        size_t room = sizeof buf;
        bool booting = mcu->cycle < boot_until;
        if (!booting && RING - (hostq_head - hostq_tail) < room) {
            room = RING - (hostq_head - hostq_tail);
        }
        ssize_t r = room ? read(master, buf, room) : 0;
        for (ssize_t i = 0; i < r; i++) {
            if (booting) {
                stats.bytes_dropped++; /* the bootloader eats them */
            } else {
                hostq[hostq_head++ % RING] = buf[i];
                stats.bytes_in++;
            }
        }
    }
    if (host_out_n) {
        ssize_t w = write(master, host_out_buf, host_out_n);
        if (w > 0) {
            memmove(host_out_buf, host_out_buf + w, host_out_n - (size_t)w);
            host_out_n -= (unsigned)w;
        }
        /* EAGAIN: the pty is full (the host is slow to read, as a loaded machine may
         * make it for a while): the bytes wait here, as in a USB serial adapter's and
         * the host driver's buffers, and only what overflows this buffer is lost. */
    }
}
