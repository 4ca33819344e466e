/* pirate-simavr: the channel to the board simulator on stdin/stdout (see harness.c). */
#include "harness.h"

/* -- the channel to the boards ---------------------------------------------------- */

static void write_all(int fd, const uint8_t *p, size_t n) {
    while (n > 0) {
        ssize_t w = write(fd, p, n);
        if (w < 0) {
            if (errno == EINTR) {
                continue;
            }
            exit(0); /* the board simulator is gone: so are we */
        }
        p += w;
        n -= (size_t)w;
    }
}

void harness_send_record(char type, const uint8_t *payload, uint16_t n) {
    uint8_t head[3] = {(uint8_t)type, (uint8_t)(n & 0xFFu), (uint8_t)(n >> 8)};
    write_all(STDOUT_FILENO, head, 3);
    if (n) {
        write_all(STDOUT_FILENO, payload, n);
    }
}

void harness_put_u64(uint8_t *p, uint64_t v) {
    for (int i = 0; i < 8; i++) {
        p[i] = (uint8_t)(v >> (8 * i));
    }
}

/* Reads one record from stdin (blocking). False at end of input. */
static bool read_record(char *type, uint8_t *payload, uint16_t *n) {
    uint8_t head[3];
    size_t got = 0;
    while (got < 3) {
        ssize_t r = read(STDIN_FILENO, head + got, 3 - got);
        if (r <= 0) {
            if (r < 0 && errno == EINTR) {
                continue;
            }
            return false;
        }
        got += (size_t)r;
    }
    *type = (char)head[0];
    *n = (uint16_t)(head[1] | head[2] << 8);
    got = 0;
    while (got < *n) {
        ssize_t r = read(STDIN_FILENO, payload + got, *n - got);
        if (r <= 0) {
            if (r < 0 && errno == EINTR) {
                continue;
            }
            return false;
        }
        got += (size_t)r;
    }
    return true;
}

/* Handles one record from the boards. */
static void handle_record(char type, const uint8_t *payload, uint16_t n) {
    if (type == 'U' && n >= 1 && n - 1u <= sizeof replies[0]) {
        memcpy(replies[payload[0]], payload + 1, n - 1u);
        reply_len[payload[0]] = (uint8_t)(n - 1u);
    } else if (type == 'Q') {
        char text[2048];
        int len = harness_figures_text(text, sizeof text);
        harness_send_record('S', (const uint8_t *)text, (uint16_t)len);
    } else if (type == 'X') {
        harness_reset_mcu();
    } else if (type == 'H') {
        held = true; /* what the MCU sent is on the pty already (harness_service_pty ran) */
        uint8_t p[8];
        harness_put_u64(p, avr->cycle);
        harness_send_record('h', p, 8);
    } else if (type == 'G' && held) {
        held = false;
        wall0 = harness_now_s();
        cycle0 = avr->cycle;
    }
}

/* Records from the boards ('U', 'Q', 'X'), whenever they arrive. */
void harness_service_channel(void) {
    struct pollfd p = {.fd = STDIN_FILENO, .events = POLLIN};
    while (poll(&p, 1, 0) > 0) {
        if (p.revents & (POLLHUP | POLLERR) && !(p.revents & POLLIN)) {
            stop_requested = true;
            return;
        }
        static uint8_t in[65536];
        char type;
        uint16_t n;
        if (!read_record(&type, in, &n)) {
            stop_requested = true;
            return;
        }
        handle_record(type, in, n);
    }
}
