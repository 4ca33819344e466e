/* pirate-simavr: USART0, the host side: the MCU's serial port on a pty (see harness.c). */
#include "harness.h"

static int master = -1;

void harness_host_xon(avr_irq_t *irq, uint32_t value, void *param) {
    (void)irq, (void)value, (void)param;
    host_xoff = false;
}

void harness_host_xoff_irq(avr_irq_t *irq, uint32_t value, void *param) {
    (void)irq, (void)value, (void)param;
    host_xoff = true;
}

avr_cycle_count_t harness_feed_host(avr_t *a, avr_cycle_count_t when, void *param) {
    (void)a, (void)param;
    if (host_xoff || avr->cycle < boot_until) {
        return when + HOST_BYTE_CYCLES / 4u;
    }
    if (hostq_tail != hostq_head) {
        uint8_t byte = hostq[hostq_tail++ % RING];
        avr_raise_irq(host_in, byte);
        if (byte == 0) {
            last_host_delimiter = when;
        }
    }
    return when + HOST_BYTE_CYCLES;
}

void harness_host_out(avr_irq_t *irq, uint32_t value, void *param) {
    (void)irq, (void)param;
    if (value == 0) {
        frames_out++;
    }
    if (host_open && host_out_n < sizeof host_out_buf) {
        host_out_buf[host_out_n++] = (uint8_t)value;
    }
}

/* -- the pty ----------------------------------------------------------------------- */

void harness_open_pty(void) {
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
    harness_send_record('P', (const uint8_t *)name, (uint16_t)strlen(name));
}

/* Moves bytes between the pty and the queues; an open is a DTR edge. */
void harness_service_pty(void) {
    struct pollfd p = {.fd = master, .events = POLLIN};
    poll(&p, 1, 0);
    bool open_now = !(p.revents & POLLHUP);
    if (open_now && !host_open) {
        host_open = true;
        harness_reset_mcu();
    } else if (!open_now && host_open) {
        host_open = false;
        host_out_n = 0;
    }
    if (!host_open) {
        return;
    }
    if (p.revents & POLLIN) {
        uint8_t buf[4096];
        ssize_t r = read(master, buf, sizeof buf);
        for (ssize_t i = 0; i < r; i++) {
            if (avr->cycle < boot_until) {
                host_bytes_dropped++; /* the bootloader eats them */
            } else if (hostq_head - hostq_tail < RING) {
                hostq[hostq_head++ % RING] = buf[i];
                host_bytes_in++;
            } else {
                host_bytes_dropped++;
            }
        }
    }
    if (host_out_n) {
        ssize_t w = write(master, host_out_buf, host_out_n);
        if (w > 0) {
            memmove(host_out_buf, host_out_buf + w, host_out_n - (size_t)w);
            host_out_n -= (unsigned)w;
        } else if (w < 0 && errno == EAGAIN) {
            host_out_n = 0; /* a host that does not read loses bytes, as on a real UART */
        }
    }
}
