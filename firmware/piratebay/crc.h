/* CRC-16/XMODEM (poly 0x1021, init 0, no reflection), both links. On the AVR it
 * is avr-libc's _crc_xmodem_update; a host build gets the same bitwise loop. */
#ifndef PB_CRC_H
#define PB_CRC_H

#include <stdint.h>

#ifdef __AVR__
#include <util/crc16.h>
#else
static inline uint16_t _crc_xmodem_update(uint16_t crc, uint8_t data) {
    crc ^= (uint16_t)data << 8;
    for (uint8_t i = 0; i < 8; i++) {
        crc = (crc & 0x8000u) ? (uint16_t)((crc << 1) ^ 0x1021u) : (uint16_t)(crc << 1);
    }
    return crc;
}
#endif

static inline uint16_t crc16_xmodem(const uint8_t *p, uint16_t n) {
    uint16_t crc = 0;
    while (n--) {
        crc = _crc_xmodem_update(crc, *p++);
    }
    return crc;
}

#endif
