/* imu-probe: the PICO's AVR build in simavr, in virtual time, with a BNO055 on its TWI
 * that behaves as the datasheet says (section 3.3.1): it powers up in CONFIGMODE
 * (OPR_MODE 0x3D = 0), where every output register reads 0, and gives its Euler angles
 * (0x1A..0x1F: heading, roll, pitch, int16 LE, 1/16 degree) only in a fusion mode
 * (OPR_MODE 8 and up), 7 ms after it was switched there. Then one request from the
 * master on the board's USART, and what the board answers.
 *
 *   imu-probe PICO.elf ID HEADING ROLL PITCH REQUEST_HEX [MS]
 *
 * runs the board MS milliseconds (default 200), sends REQUEST_HEX (a whole frame, its
 * 0x00 included), runs 3 ms more and prints `reply HEX` (the bytes the board sent, or
 * `reply -`) and `opr_mode N` (the IMU's operation mode at the end). Exit 2 on bad
 * arguments, 4 if the core stops. Built by `make -C firmware/pico imu-probe` (Debian's
 * libsimavr-dev); tests/test_probe20_firmware.py runs it. */
#include <simavr/avr_eeprom.h>
#include <simavr/avr_twi.h>
#include <simavr/avr_uart.h>
#include <simavr/sim_avr.h>
#include <simavr/sim_elf.h>
#include <simavr/sim_io.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define HZ 16000000u
#define IMU_ADDR 0x28u
#define OPR_MODE 0x3Du
#define SWITCH_CYCLES (HZ / 1000u * 7u) /* CONFIGMODE to a fusion mode: 7 ms */

static struct {
    avr_t *avr;
    uint8_t reg[0x40];
    int16_t euler[3];
    uint8_t at;
    bool selected, addr_written;
    uint64_t switched_at;
} imu;

static uint8_t out[256];
static unsigned out_n;
static bool capture;

static uint8_t imu_read(uint8_t r) {
    bool fusion = (imu.reg[OPR_MODE] & 0x0Fu) >= 8u &&
                  imu.avr->cycle >= imu.switched_at + SWITCH_CYCLES;
    if (r >= 0x1Au && r < 0x20u) {
        if (!fusion) {
            return 0; /* CONFIGMODE: all output data is reset to zero */
        }
        uint16_t v = (uint16_t)imu.euler[(r - 0x1Au) / 2u];
        return (uint8_t)((r - 0x1Au) % 2u ? v >> 8 : v);
    }
    return imu.reg[r & 0x3Fu];
}

static void imu_write(uint8_t r, uint8_t value) {
    if (r == OPR_MODE && (value & 0x0Fu) != (imu.reg[OPR_MODE] & 0x0Fu)) {
        imu.switched_at = imu.avr->cycle;
    }
    imu.reg[r & 0x3Fu] = value;
}

static void twi_out(avr_irq_t *irq, uint32_t value, void *param) {
    (void)irq, (void)param;
    avr_twi_msg_irq_t v;
    v.u.v = value;
    avr_irq_t *in = avr_io_getirq(imu.avr, AVR_IOCTL_TWI_GETIRQ(0), TWI_IRQ_INPUT);
    if (v.u.twi.msg & TWI_COND_STOP) {
        imu.selected = false;
    }
    if (v.u.twi.msg & TWI_COND_START) {
        imu.selected = (v.u.twi.addr >> 1) == IMU_ADDR;
        if (imu.selected) {
            if (!(v.u.twi.addr & 1u)) {
                imu.addr_written = false; /* a write: the register address comes next */
            }
            avr_raise_irq(in, avr_twi_irq_msg(TWI_COND_ACK, v.u.twi.addr, 1));
        }
    }
    if (!imu.selected) {
        return;
    }
    if (v.u.twi.msg & TWI_COND_WRITE) {
        avr_raise_irq(in, avr_twi_irq_msg(TWI_COND_ACK, v.u.twi.addr, 1));
        if (!imu.addr_written) {
            imu.at = v.u.twi.data & 0x3Fu;
            imu.addr_written = true;
        } else {
            imu_write(imu.at, v.u.twi.data);
            imu.at = (uint8_t)((imu.at + 1u) & 0x3Fu);
        }
    }
    if (v.u.twi.msg & TWI_COND_READ) {
        uint8_t data = imu_read(imu.at);
        imu.at = (uint8_t)((imu.at + 1u) & 0x3Fu);
        avr_raise_irq(in, avr_twi_irq_msg(TWI_COND_READ, v.u.twi.addr, data));
    }
}

static void uart_out(avr_irq_t *irq, uint32_t value, void *param) {
    (void)irq, (void)param;
    if (capture && out_n < sizeof out) {
        out[out_n++] = (uint8_t)value;
    }
}

static void nosleep(avr_t *avr, avr_cycle_count_t how_long) { (void)avr, (void)how_long; }

static void run_until(avr_t *avr, uint64_t until) {
    while (avr->cycle < until) {
        int state = avr_run(avr);
        if (state == cpu_Done || state == cpu_Crashed) {
            fprintf(stderr, "imu-probe: the PICO %s at cycle %llu\n",
                    state == cpu_Crashed ? "crashed" : "stopped", (unsigned long long)avr->cycle);
            exit(4);
        }
    }
}

static bool number(const char *s, long lo, long hi, long *v) {
    char *end;
    *v = strtol(s, &end, 10);
    return *s != '\0' && *end == '\0' && *v >= lo && *v <= hi;
}

int main(int argc, char **argv) {
    long id, euler[3], ms = 200;
    uint8_t request[64];
    size_t request_n = argc > 6 ? strlen(argv[6]) / 2u : 0u;
    bool ok = (argc == 7 || argc == 8) && number(argv[2], 0, 255, &id) &&
              number(argv[3], -32768, 32767, &euler[0]) &&
              number(argv[4], -32768, 32767, &euler[1]) &&
              number(argv[5], -32768, 32767, &euler[2]) && strlen(argv[6]) % 2u == 0 &&
              request_n > 0 && request_n <= sizeof request &&
              (argc == 7 || number(argv[7], 1, 10000, &ms));
    for (size_t i = 0; ok && i < request_n; i++) {
        unsigned byte;
        ok = sscanf(argv[6] + 2u * i, "%2x", &byte) == 1;
        request[i] = (uint8_t)byte;
    }
    if (!ok) {
        fprintf(stderr, "usage: imu-probe PICO.elf ID HEADING ROLL PITCH REQUEST_HEX [MS]\n");
        return 2;
    }
    elf_firmware_t fw;
    memset(&fw, 0, sizeof fw);
    if (elf_read_firmware(argv[1], &fw) != 0) {
        fprintf(stderr, "imu-probe: cannot read %s\n", argv[1]);
        return 2;
    }
    avr_t *avr = avr_make_mcu_by_name("atmega328p");
    if (!avr) {
        fprintf(stderr, "imu-probe: this simavr has no atmega328p\n");
        return 2;
    }
    avr_init(avr);
    avr->frequency = HZ;
    avr->log = 0;
    avr->sleep = nosleep; /* virtual time: a sleeping core skips ahead */
    avr_load_firmware(avr, &fw);
    uint8_t ee[2] = {(uint8_t)id, (uint8_t)~id};
    avr_eeprom_desc_t desc = {.ee = ee, .offset = 0, .size = 2};
    avr_ioctl(avr, AVR_IOCTL_EEPROM_SET, &desc);
    uint32_t flags = 0;
    avr_ioctl(avr, AVR_IOCTL_UART_SET_FLAGS('0'), &flags);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUTPUT),
                            uart_out, NULL);
    imu.avr = avr;
    imu.reg[0] = 0xA0; /* chip id */
    for (int k = 0; k < 3; k++) {
        imu.euler[k] = (int16_t)euler[k];
    }
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_TWI_GETIRQ(0), TWI_IRQ_OUTPUT), twi_out,
                            NULL);
    uint64_t at = (uint64_t)ms * (HZ / 1000u);
    run_until(avr, at);
    capture = true;
    avr_irq_t *in = avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_INPUT);
    for (size_t i = 0; i < request_n; i++) {
        avr_raise_irq(in, request[i]); /* simavr's USART takes them one byte time apart */
    }
    run_until(avr, at + 3u * (HZ / 1000u));
    printf("reply ");
    for (unsigned i = 0; i < out_n; i++) {
        printf("%02x", out[i]);
    }
    printf("%s\nopr_mode %u\n", out_n ? "" : "-", imu.reg[OPR_MODE]);
    return 0;
}
