/* Host-link frames (docs/protocol.md, Framing and Body): the receiver that cuts
 * the byte stream at each 0x00 and checks COBS, length, CRC and version, and the
 * encoder that turns a body into COBS(body) 0x00. */
#ifndef PB_FRAME_H
#define PB_FRAME_H

#include <assert.h>
#include <stdbool.h>
#include <stdint.h>

#define PB_PROTOCOL_VERSION 1u
#define PB_PROTOCOL_MINOR 2u     /* the highest minor spoken; a HELLO may ask for 1 or 2 */
#define PB_PROTOCOL_MINOR_MIN 1u
#define FRAME_HEADER_BYTES 5u
#define FRAME_CRC_BYTES 2u
#define FRAME_MIN_BODY (FRAME_HEADER_BYTES + FRAME_CRC_BYTES)
#define FRAME_MAX_BODY 254u
#define FRAME_MAX_PAYLOAD (FRAME_MAX_BODY - FRAME_MIN_BODY)
#define FRAME_MAX_RAW 255u  /* bytes before a delimiter */
#define FRAME_MAX_WIRE 256u /* COBS(254) + 0x00 */
/* Wire bytes of a frame with an n-byte payload (n <= 247). */
#define FRAME_WIRE(n) ((n) + FRAME_MIN_BODY + 2u)

static_assert(FRAME_MAX_PAYLOAD == 247, "docs/protocol.md: 247 payload bytes at most");

enum frame_result {
    FRAME_MORE = 0,   /* no complete frame yet (or an empty frame, ignored) */
    FRAME_OK,         /* a frame passed COBS, length, CRC and version */
    FRAME_BAD_CRC,    /* dropped: CRC mismatch */
    FRAME_BAD_FRAME,  /* dropped: oversize, cobs, short, version, or damaged on the line */
};

struct frame_rx {
    uint8_t raw[FRAME_MAX_RAW];
    uint16_t n;
    bool oversize;
    bool damaged; /* a byte of it arrived damaged or was lost on the line */
    uint8_t body[FRAME_MAX_BODY];
    uint8_t body_len; /* valid after FRAME_OK: header + payload + CRC */
};

void frame_rx_init(struct frame_rx *rx);
/* Feed one received byte; `damaged`: the line flagged it (framing error, overrun,
 * lost before it), so the frame it belongs to is dropped as a bad frame. */
enum frame_result frame_rx_byte(struct frame_rx *rx, uint8_t byte, bool damaged);

/* Header field access on a received body. */
static inline uint8_t frame_type(const uint8_t *body) { return body[1]; }
static inline uint16_t frame_seq(const uint8_t *body) {
    return (uint16_t)(body[2] | ((uint16_t)body[3] << 8));
}
static inline uint8_t frame_arg(const uint8_t *body) { return body[4]; }

/* Fill the header and CRC of `body` (payload already at body + 5, `n` bytes) and
 * write COBS(body) 0x00 to `out` (FRAME_WIRE(n) bytes). Returns the wire length. */
uint16_t frame_encode(uint8_t *body, uint8_t type, uint16_t seq, uint8_t arg, uint8_t n,
                      uint8_t *out);

static inline void put_u16(uint8_t *p, uint16_t v) {
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
}
static inline void put_u32(uint8_t *p, uint32_t v) {
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
    p[2] = (uint8_t)(v >> 16);
    p[3] = (uint8_t)(v >> 24);
}
static inline uint16_t get_u16(const uint8_t *p) { return (uint16_t)(p[0] | ((uint16_t)p[1] << 8)); }
static inline uint32_t get_u32(const uint8_t *p) {
    return (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) | ((uint32_t)p[3] << 24);
}

#endif
