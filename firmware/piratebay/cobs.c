#include "cobs.h"

uint16_t cobs_encode(const uint8_t *in, uint16_t n, uint8_t *out) {
    uint16_t code_at = 0;
    uint16_t w = 1;
    uint8_t code = 1;
    for (uint16_t i = 0; i < n; i++) {
        if (in[i] == 0) {
            out[code_at] = code;
            code_at = w++;
            code = 1;
            continue;
        }
        out[w++] = in[i];
        if (++code == 0xFF) {
            out[code_at] = code;
            if (i + 1 == n) {
                return w; /* a full block ends the data: no trailing 0x01 block */
            }
            code_at = w++;
            code = 1;
        }
    }
    out[code_at] = code;
    return w;
}

int16_t cobs_decode(const uint8_t *in, uint16_t n, uint8_t *out, uint16_t cap) {
    uint16_t r = 0;
    uint16_t w = 0;
    if (n == 0) {
        return -1;
    }
    while (r < n) {
        uint8_t code = in[r];
        if (code == 0 || (uint16_t)(r + code) > n) {
            return -1;
        }
        r++;
        for (uint8_t k = 1; k < code; k++) {
            uint8_t b = in[r++];
            if (b == 0 || w >= cap) {
                return -1;
            }
            out[w++] = b;
        }
        if (code != 0xFF && r < n) {
            if (w >= cap) {
                return -1;
            }
            out[w++] = 0;
        }
    }
    return (int16_t)w;
}
