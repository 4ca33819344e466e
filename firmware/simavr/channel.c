/* pirate-simavr: the channel to the board simulator on stdin/stdout (see harness.c).
 * The bottom file: it calls no other; what a record means is its caller's business. */
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

void channel_send_record(char type, const uint8_t *payload, uint16_t n) {
    uint8_t head[3] = {(uint8_t)type, (uint8_t)(n & 0xFFu), (uint8_t)(n >> 8)};
    write_all(STDOUT_FILENO, head, 3);
    if (n) {
        write_all(STDOUT_FILENO, payload, n);
    }
}

void channel_put_u64(uint8_t *p, uint64_t v) {
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

/* Records from the boards, whenever they arrive, each to `handle`. False at the end
 * of the channel (stdin closed or unreadable). */
bool channel_service(channel_handler handle) {
    struct pollfd p = {.fd = STDIN_FILENO, .events = POLLIN};
    while (poll(&p, 1, 0) > 0) {
        if (p.revents & (POLLHUP | POLLERR) && !(p.revents & POLLIN)) {
            return false;
        }
        static uint8_t in[65536];
        char type;
        uint16_t n;
        if (!read_record(&type, in, &n)) {
            return false;
        }
        handle(type, in, n);
    }
    return true;
}

/* One record from the boards, waiting for it, to `handle`. False at the end of the
 * channel. (pirate-chain runs in lockstep with Python: it waits for every step.) */
bool channel_wait(channel_handler handle) {
    static uint8_t in[65536];
    char type;
    uint16_t n;
    if (!read_record(&type, in, &n)) {
        return false;
    }
    handle(type, in, n);
    return true;
}
