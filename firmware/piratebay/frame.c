#include "frame.h"

#include "cobs.h"
#include "crc.h"

void frame_rx_init(struct frame_rx *rx) {
    rx->n = 0;
    rx->oversize = false;
    rx->damaged = false;
    rx->body_len = 0;
}

static enum frame_result finish(struct frame_rx *rx) {
    uint16_t n = rx->n;
    bool oversize = rx->oversize || rx->damaged;
    rx->n = 0;
    rx->oversize = false;
    rx->damaged = false;
    if (oversize) {
        return FRAME_BAD_FRAME;
    }
    if (n == 0) {
        return FRAME_MORE; /* two delimiters in a row: ignored */
    }
    int16_t len = cobs_decode(rx->raw, n, rx->body, FRAME_MAX_BODY);
    /* no mutate flip, off-by-one: a 0-byte body is refused below as too short */
    if (len < 0) {
        /* a body over 254 bytes also lands here (cobs_decode refuses to overflow) */
        return FRAME_BAD_FRAME;
    }
    if ((uint16_t)len < FRAME_MIN_BODY) {
        return FRAME_BAD_FRAME;
    }
    uint16_t data = (uint16_t)len - FRAME_CRC_BYTES;
    if (crc16_xmodem(rx->body, data) != get_u16(rx->body + data)) {
        return FRAME_BAD_CRC;
    }
    if (rx->body[0] != PB_PROTOCOL_VERSION) {
        return FRAME_BAD_FRAME;
    }
    rx->body_len = (uint8_t)len;
    return FRAME_OK;
}

enum frame_result frame_rx_byte(struct frame_rx *rx, uint8_t byte, bool damaged) {
    if (damaged) {
        rx->damaged = true; /* a damaged 0x00 still ends the frame it damaged */
    }
    if (byte == 0) {
        return finish(rx);
    }
    if (rx->n >= FRAME_MAX_RAW) {
        rx->oversize = true; /* drop everything up to the next delimiter */
        return FRAME_MORE;
    }
    rx->raw[rx->n++] = byte;
    return FRAME_MORE;
}

uint16_t frame_encode(uint8_t *body, uint8_t type, uint16_t seq, uint8_t arg, uint8_t n,
                      uint8_t *out) {
    body[0] = PB_PROTOCOL_VERSION;
    body[1] = type;
    put_u16(body + 2, seq);
    body[4] = arg;
    uint16_t data = (uint16_t)(FRAME_HEADER_BYTES + n);
    put_u16(body + data, crc16_xmodem(body, data));
    uint16_t w = cobs_encode(body, (uint16_t)(data + FRAME_CRC_BYTES), out);
    out[w++] = 0;
    return w;
}
