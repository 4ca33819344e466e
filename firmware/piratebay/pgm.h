/* Flash-resident constants: avr-libc's PROGMEM on the AVR, plain memory on a host
 * build (the unit tests compile the protocol core with the host's compiler). */
#ifndef PB_PGM_H
#define PB_PGM_H

#ifdef __AVR__
#include <avr/pgmspace.h>
#else
#include <string.h>
#define PROGMEM
#define memcpy_P(dst, src, n) memcpy((dst), (src), (n))
#define pgm_read_byte(p) (*(const uint8_t *)(p))
#endif

#endif
