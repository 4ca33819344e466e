/* The bridge's host-link code as a program, for differential and hostile-input tests
 * (tests/test_codec_differential13.py): `make link-probe` builds it with
 * -fsanitize=address,undefined (PROBE_SANITIZE) from host/host_hal.c and the
 * firmware's own files, so every byte goes through the code as flashed.
 *
 * It reads records from stdin and writes one text line per answer to stdout:
 *
 *   'F' u16 n, n bytes   to a receiver of its own (frame.c: frame_rx_byte), byte by
 *                        byte; a partial frame carries over to the next record. One
 *                        line per frame it completes: "K <body hex>" (FRAME_OK),
 *                        "C" (FRAME_BAD_CRC), "B" (FRAME_BAD_FRAME); then "."
 *   'W' u16 n, n bytes, u32 us
 *                        to the whole bridge (protocol.c through host_hal.c's host
 *                        line: fw_write), then `us` of virtual time (fw_run_us); one
 *                        line "W <hex>": every byte the bridge sent meanwhile
 *   'E' type u8, seq u16, arg u8, n u8, n payload bytes
 *                        frame.c's frame_encode of that frame: "E <wire hex>"
 *   'R' u8 channel, i16 raw   the boards report `raw` for `channel` (fw_reading)
 *   'O' u8 index, u8 online   board `index` answers its polls (1) or not (0)
 *   'I' u8 open          the hardware e-stop contact opens (1) or closes (0)
 *   'T'                  a reset (fw_boot) with every board answering
 *   'Q'                  "Q <flags> <boards> <motors> <channels>": protocol_flags()
 *                        and the layout's sizes
 *
 * Integers little-endian. Ends at end of input; a malformed record exits 2. */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

#include "../frame.h"
#include "../protocol.h"
#include "../robot_layout.h"

void fw_boot(void);
void fw_write(const uint8_t *p, uint32_t n);
void fw_run_us(uint32_t us);
uint32_t fw_read(uint8_t *out, uint32_t cap);
void fw_board(uint8_t index, uint8_t online, uint8_t status);
void fw_reading(uint8_t channel, int16_t raw);
void fw_estop_input(uint8_t open);

static uint8_t in[1 << 16];
static uint8_t out[1 << 17];

static void take(void *p, size_t n) {
    if (n && fread(p, 1, n, stdin) != n) {
        fputs("link_probe: truncated record\n", stderr);
        exit(2);
    }
}

static uint16_t take_u16(void) {
    uint8_t b[2];
    take(b, 2);
    return get_u16(b);
}

static void hex_line(char tag, const uint8_t *p, uint32_t n) {
    static const char digits[] = "0123456789abcdef";
    putchar(tag);
    putchar(' ');
    for (uint32_t i = 0; i < n; i++) {
        putchar(digits[p[i] >> 4]);
        putchar(digits[p[i] & 15]);
    }
    putchar('\n');
}

int main(void) {
    static struct frame_rx rx;
    frame_rx_init(&rx);
    for (uint8_t b = 0; b < PB_N_BOARDS; b++) {
        fw_board(b, 1, 0);
    }
    fw_boot();
    int op;
    while ((op = getchar()) != EOF) {
        switch (op) {
        case 'F': {
            uint16_t n = take_u16();
            take(in, n);
            for (uint16_t i = 0; i < n; i++) {
                switch (frame_rx_byte(&rx, in[i], false)) {
                case FRAME_MORE:
                    break;
                case FRAME_OK:
                    hex_line('K', rx.body, rx.body_len);
                    break;
                case FRAME_BAD_CRC:
                    puts("C");
                    break;
                case FRAME_BAD_FRAME:
                    puts("B");
                    break;
                }
            }
            puts(".");
            break;
        }
        case 'W': {
            uint16_t n = take_u16();
            take(in, n);
            uint8_t us[4];
            take(us, 4);
            fw_write(in, n);
            fw_run_us(get_u32(us));
            hex_line('W', out, fw_read(out, sizeof out));
            break;
        }
        case 'E': {
            uint8_t head[5];
            take(head, 5);
            uint8_t n = head[4];
            if (n > FRAME_MAX_PAYLOAD) {
                fputs("link_probe: payload over 247 bytes\n", stderr);
                return 2;
            }
            uint8_t body[FRAME_MAX_BODY];
            take(body + FRAME_HEADER_BYTES, n);
            uint8_t wire[FRAME_MAX_WIRE];
            hex_line('E', wire, frame_encode(body, head[0], get_u16(head + 1), head[3], n, wire));
            break;
        }
        case 'R': {
            uint8_t r[3];
            take(r, 3);
            fw_reading(r[0], (int16_t)get_u16(r + 1));
            break;
        }
        case 'O': {
            uint8_t r[2];
            take(r, 2);
            fw_board(r[0], r[1], 0);
            break;
        }
        case 'I': {
            uint8_t open;
            take(&open, 1);
            fw_estop_input(open);
            break;
        }
        case 'T':
            for (uint8_t b = 0; b < PB_N_BOARDS; b++) {
                fw_board(b, 1, 0);
            }
            fw_boot();
            break;
        case 'Q':
            printf("Q %u %u %u %u\n", protocol_flags(), (unsigned)PB_N_BOARDS,
                   (unsigned)PB_N_MOTORS, (unsigned)PB_N_CHANNELS);
            break;
        default:
            fprintf(stderr, "link_probe: unknown record 0x%02x\n", op);
            return 2;
        }
    }
    return fflush(stdout) == 0 ? 0 : 1;
}
