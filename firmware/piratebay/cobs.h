/* Consistent Overhead Byte Stuffing (docs/protocol.md, Framing), both links. */
#ifndef PB_COBS_H
#define PB_COBS_H

#include <stdint.h>

/* Bytes COBS needs for a body of n bytes (n <= 254): n + 1. */
#define COBS_MAX_ENCODED(n) ((n) + 1u + (n) / 254u)

/* Encode `n` bytes into `out` (no delimiter); returns the encoded length. */
uint16_t cobs_encode(const uint8_t *in, uint16_t n, uint8_t *out);

/* Decode `n` encoded bytes (delimiter removed) into `out`, which holds `cap` bytes.
 * Returns the decoded length, or -1 when a code byte points past the end, a zero
 * byte appears, or the result would not fit. */
int16_t cobs_decode(const uint8_t *in, uint16_t n, uint8_t *out, uint16_t cap);

#endif
