/* The PICO board's hardware on an ATmega328p at 16 MHz (pins: docs/board-bus.md, "The
 * reference PICO board").
 *
 *   PD0/PD1   USART0 RXD/TXD to the RS485 transceiver's RO/DI, 1 Mbaud 8N1
 *   PD2       RS485 DE and /RE tied together: high while the board sends (no echo)
 *   PD6, PD5  motor 0 / motor 1 EN (OC0A, OC0B: Timer0 fast PWM, 976 Hz)
 *   PD4, PD7  motor 0 INA, INB       PB0, PB4  motor 1 INA, INB
 *   PC2, PC3  motor 0 encoder A, B   PB1, PB2  motor 1 encoder A, B (pin change)
 *   ADC0/ADC1 sensor connectors 0/1  ADC6/ADC7 motor 0/1 current sense (AVCC ref)
 *   PC4/PC5   TWI SDA/SCL: the IMU (BNO055-style Euler registers, address 0x28)
 *   PD3       H-bridge fault, active low (pull-up)      PB5  LED
 *   Timer1    free-running 2 MHz counter; Timer2: the 1 kHz tick
 * The board id is EEPROM bytes 0 and 1: the id and its complement. */
#include <assert.h>

#include <avr/eeprom.h>
#include <avr/fuse.h>
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/sleep.h>
#include <avr/wdt.h>
#include <util/atomic.h>

#include "hal.h"

static_assert(F_CPU == 16000000UL, "the timer and USART settings assume 16 MHz");

/* Fuses (the Makefile's LFUSE/HFUSE/EFUSE, written by `make fuses`): 16 MHz crystal,
 * no bootloader (boards are flashed by ISP), EEPROM kept through a chip erase (the
 * board id lives there), brown-out at 4.3 V. */
#ifndef PICO_LFUSE
#define PICO_LFUSE 0xFF
#define PICO_HFUSE 0xD1
#define PICO_EFUSE 0xFC
#endif
FUSES = {.low = PICO_LFUSE, .high = PICO_HFUSE, .extended = PICO_EFUSE};

#define BUS_UBRR 1u /* 1 Mbaud with U2X at 16 MHz: exact */
#define RX_RING 64u
#define IMU_ADDR 0x28u
#define IMU_EULER_REG 0x1Au /* heading, roll, pitch: int16 LE each, 1/16 degree */
#define IMU_OPR_MODE_REG 0x3Du /* operation mode: 0 CONFIGMODE (outputs 0) at power-on */
#define IMU_MODE_FUSION 0x08u /* the fusion modes are 8 and up */
#define IMU_MODE_IMU 0x08u    /* accelerometer and gyroscope fusion */
#define STACK_PAINT 0xC5u

static_assert((RX_RING & (RX_RING - 1u)) == 0, "power of two");

static uint8_t mcusr_at_boot __attribute__((section(".noinit")));
extern uint8_t __heap_start;
static uint8_t *stack_scan;

/* Before the C runtime: DE an output at its reset level, low (the driver off). */
void hal_pins_early(void) __attribute__((naked, used, section(".init0")));
void hal_pins_early(void) {
    __asm__ volatile("sbi %0, %1" ::"I"(_SFR_IO_ADDR(DDRD)), "I"(PD2));
}

/* Save and clear MCUSR, stop a running watchdog, paint the free SRAM. */
void hal_early(void) __attribute__((naked, used, section(".init3")));
void hal_early(void) {
    mcusr_at_boot = MCUSR;
    MCUSR = 0;
    wdt_disable();
    uint8_t *p = &__heap_start;
    uint8_t *top = (uint8_t *)SP;
    while (p < top - 2) {
        *p++ = STACK_PAINT;
    }
}

/* ---- time ------------------------------------------------------------------------ */

static volatile uint32_t ms;
static volatile uint8_t imu_due; /* the tick asks the TWI for a read every 10 ms */

static void adc_start_sequence(void);
static void twi_start(void);

ISR(TIMER2_COMPA_vect) {
    ms++;
    adc_start_sequence();
    if (++imu_due >= 10u) {
        imu_due = 0;
        twi_start();
    }
}

uint32_t hal_ms(void) {
    uint32_t now;
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { now = ms; }
    return now;
}

uint16_t hal_ticks(void) {
    uint16_t t;
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { t = TCNT1; }
    return t;
}

/* ---- RS485 on USART0 ------------------------------------------------------------- */

static volatile uint8_t rx_buf[RX_RING];
/* one flag byte per slot, not a bit: a variable shift is a loop on the AVR, and at
 * 1 Mbaud the receive interrupt has 160 cycles a byte */
static volatile uint8_t rx_bad[RX_RING];
static volatile uint8_t rx_head, rx_tail;
static volatile bool rx_lost;
static volatile uint16_t rx_at;
static const uint8_t *volatile tx_ptr;
static volatile uint8_t tx_left;
static volatile bool tx_busy;

ISR(USART_RX_vect) {
    uint8_t status = UCSR0A;
    uint8_t byte = UDR0;
    rx_at = TCNT1;
    bool bad = rx_lost || (status & (_BV(FE0) | _BV(DOR0)));
    uint8_t head = rx_head;
    uint8_t next = (uint8_t)((head + 1u) & (RX_RING - 1u));
    if (next == rx_tail) {
        rx_lost = true;
        return;
    }
    rx_buf[head] = byte;
    rx_bad[head] = bad;
    rx_lost = false;
    rx_head = next;
}

ISR(USART_UDRE_vect) {
    if (tx_left == 0) {
        UCSR0B &= (uint8_t)~_BV(UDRIE0);
        return;
    }
    UDR0 = *tx_ptr;
    tx_ptr = tx_ptr + 1;
    tx_left = (uint8_t)(tx_left - 1u);
}

ISR(USART_TX_vect) {
    /* the last byte has left only when the data register is empty too (as in the
     * bridge's uart.c: a simulator may raise TX-complete for the byte before) */
    if (tx_left == 0 && (UCSR0A & _BV(UDRE0))) {
        PORTD &= (uint8_t)~_BV(PD2); /* release the bus, listen again */
        tx_busy = false;
    }
}

int16_t hal_bus_getc(void) {
    uint8_t tail = rx_tail;
    if (tail == rx_head) {
        return -1;
    }
    int16_t v = rx_buf[tail];
    if (rx_bad[tail]) {
        v |= HAL_RX_ERROR;
    }
    rx_tail = (uint8_t)((tail + 1u) & (RX_RING - 1u));
    return v;
}

uint16_t hal_bus_rx_at(void) {
    uint16_t at;
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { at = rx_at; }
    return at;
}

void hal_bus_send(const uint8_t *p, uint8_t n) {
    if (n == 0) {
        return;
    }
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
        PORTD |= _BV(PD2); /* driver on, receiver off */
        tx_ptr = p;
        tx_left = n;
        tx_busy = true;
        UCSR0A |= _BV(TXC0); /* a stale TX-complete must not drop DE early */
    }
    UCSR0B |= _BV(UDRIE0);
}

bool hal_bus_tx_busy(void) { return tx_busy; }

/* ---- motors ------------------------------------------------------------------------ */

void hal_motor(uint8_t slot, enum hal_drive drive, int16_t duty) {
    uint8_t com = slot == 0 ? _BV(COM0A1) : _BV(COM0B1);
    uint8_t en = slot == 0 ? _BV(PD6) : _BV(PD5);
    uint16_t mag = (uint16_t)(duty < 0 ? -duty : duty);
    bool forward = drive == HAL_RUN && duty > 0;
    bool reverse = drive == HAL_RUN && duty < 0;
    bool pwm = drive == HAL_RUN && mag > 0 && mag < 255u;
    bool high = drive == HAL_BRAKE || (drive == HAL_RUN && mag >= 255u);
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
        if (slot == 0) {
            PORTD = (uint8_t)((PORTD & ~(_BV(PD4) | _BV(PD7))) | (forward ? _BV(PD4) : 0) |
                              (reverse ? _BV(PD7) : 0));
            OCR0A = (uint8_t)mag;
        } else {
            PORTB = (uint8_t)((PORTB & ~(_BV(PB0) | _BV(PB4))) | (forward ? _BV(PB0) : 0) |
                              (reverse ? _BV(PB4) : 0));
            OCR0B = (uint8_t)mag;
        }
        if (pwm) {
            TCCR0A |= com;
        } else {
            TCCR0A &= (uint8_t)~com;
            PORTD = high ? (uint8_t)(PORTD | en) : (uint8_t)(PORTD & ~en);
        }
    }
}

/* ---- ADC ------------------------------------------------------------------------- */

static const uint8_t adc_mux[4] = {0, 1, 6, 7}; /* HAL_ADC_SENSOR(0..1), HAL_ADC_CURRENT(0..1) */
static volatile uint16_t adc_value[4];
static volatile uint8_t adc_at = 4;

static void adc_start_sequence(void) {
    if (adc_at < 4u) {
        return; /* the last sequence is still running */
    }
    adc_at = 0;
    ADMUX = (uint8_t)(_BV(REFS0) | adc_mux[0]);
    ADCSRA |= _BV(ADSC);
}

ISR(ADC_vect) {
    adc_value[adc_at] = ADC;
    if (++adc_at < 4u) {
        ADMUX = (uint8_t)(_BV(REFS0) | adc_mux[adc_at]);
        ADCSRA |= _BV(ADSC);
    }
}

uint16_t hal_adc(uint8_t input) {
    uint16_t v;
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { v = input < 4u ? adc_value[input] : 0u; }
    return v;
}

/* ---- encoders: quadrature on pin changes ----------------------------------------- */

static const int8_t quad[16] = {0, -1, 1, 0, 1, 0, 0, -1, -1, 0, 0, 1, 0, 1, -1, 0};
static volatile int16_t enc_count[2];
static volatile uint8_t enc_last[2];

static inline uint8_t enc_pins(uint8_t slot) {
    return slot == 0 ? (uint8_t)((PINC >> PC2) & 3u) : (uint8_t)((PINB >> PB1) & 3u);
}

static inline void enc_step(uint8_t slot) {
    uint8_t now = enc_pins(slot);
    enc_count[slot] = (int16_t)(enc_count[slot] + quad[(enc_last[slot] << 2) | now]);
    enc_last[slot] = now;
}

ISR(PCINT1_vect) { enc_step(0); }
ISR(PCINT0_vect) { enc_step(1); }

int16_t hal_encoder(uint8_t slot) {
    int16_t v;
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { v = enc_count[slot & 1u]; }
    return v;
}

/* ---- the IMU on TWI, interrupt-driven, one transfer every 10 ms once someone asked --
 * A BNO055 powers up (and resets) in CONFIGMODE, where its output registers read 0: a
 * board that only read the Euler registers took 0, 0, 0 for good, fresh, and the host a
 * level robot in a riser. So each 10 ms slot does one of: read OPR_MODE (after boot and
 * after any transfer that failed: the IMU may have reset), write OPR_MODE = IMU (a fusion
 * mode without the magnetometer, which a steel pipe would bend: heading is relative to
 * the IMU's start) when it reads CONFIGMODE, or read heading, roll, pitch. An IMU in a
 * fusion mode is never written to again (that could restart its fusion).
 * A read: START, address+W, register, repeated START, address+R, n bytes, STOP. A write:
 * START, address+W, register, value, STOP. */

enum imu_action { IMU_READ_MODE, IMU_WRITE_MODE, IMU_READ_EULER };

static volatile uint8_t twi_step; /* 0: idle */
static volatile uint8_t twi_n;
static volatile uint8_t twi_want; /* bytes to read */
static volatile uint8_t imu_action;
static volatile uint8_t imu_raw[6];
static volatile int16_t imu_euler[3];
static volatile bool imu_new, imu_wanted; /* imu_new: a read succeeded since hal_imu() */

static void twi_start(void) {
    if (!imu_wanted) {
        return;
    }
    if (twi_step != 0) {
        /* the last transfer has not finished in 10 ms (a slave holding SCL low, a lost
         * interrupt): reset the TWI, which lets go of both lines, and start afresh */
        TWCR = 0;
        twi_step = 0;
        imu_action = IMU_READ_MODE;
    }
    twi_step = 1;
    TWCR = _BV(TWINT) | _BV(TWSTA) | _BV(TWEN) | _BV(TWIE);
}

static void twi_stop(void) {
    TWCR = _BV(TWINT) | _BV(TWSTO) | _BV(TWEN);
    twi_step = 0;
}

/* A transfer that went wrong: the IMU may have reset; ask its mode again next slot. */
static void twi_fail(void) {
    imu_action = IMU_READ_MODE;
    twi_stop();
}

/* A transfer done: what the next slot does. */
static void twi_done(void) {
    if (imu_action == IMU_READ_MODE) {
        /* low nibble 0: CONFIGMODE, its outputs 0; a fusion mode (8 and up) is read */
        imu_action = (imu_raw[0] & 0x0Fu) >= IMU_MODE_FUSION ? IMU_READ_EULER : IMU_WRITE_MODE;
    } else if (imu_action == IMU_WRITE_MODE) {
        imu_action = IMU_READ_EULER; /* 10 ms later: it switches in 7 ms */
    } else {
        for (uint8_t i = 0; i < 3u; i++) {
            imu_euler[i] = (int16_t)(imu_raw[2u * i] | (uint16_t)imu_raw[2u * i + 1u] << 8);
        }
        imu_new = true;
    }
    twi_stop();
}

ISR(TWI_vect) {
    uint8_t status = TWSR & 0xF8u;
    switch (twi_step) {
    case 1: /* START sent */
        if (status != 0x08u) {
            twi_fail();
            return;
        }
        TWDR = (uint8_t)(IMU_ADDR << 1);
        twi_step = 2;
        break;
    case 2: /* SLA+W sent: 0x18 (simavr 1.6 says 0x28 when TWDR was written first) */
        if (status != 0x18u && status != 0x28u) {
            twi_fail();
            return;
        }
        TWDR = imu_action == IMU_READ_EULER ? IMU_EULER_REG : IMU_OPR_MODE_REG;
        twi_step = 3;
        break;
    case 3: /* register sent: the value (a write), or a repeated START (a read) */
        if (status != 0x28u) {
            twi_fail();
            return;
        }
        if (imu_action == IMU_WRITE_MODE) {
            TWDR = IMU_MODE_IMU;
            twi_step = 7;
            break;
        }
        twi_step = 4;
        TWCR = _BV(TWINT) | _BV(TWSTA) | _BV(TWEN) | _BV(TWIE);
        return;
    case 4: /* repeated START sent */
        if (status != 0x10u) {
            twi_fail();
            return;
        }
        TWDR = (uint8_t)(IMU_ADDR << 1 | 1u);
        twi_step = 5;
        twi_n = 0;
        twi_want = imu_action == IMU_READ_EULER ? 6u : 1u;
        break;
    case 5: /* SLA+R sent, then data: ACK all but the last byte */
        if (status == 0x40u) {
            TWCR = (uint8_t)(_BV(TWINT) | _BV(TWEN) | _BV(TWIE) | (twi_want > 1u ? _BV(TWEA) : 0));
            twi_step = 6;
            return;
        }
        twi_fail();
        return;
    case 6:
        if (status == 0x50u || status == 0x58u) {
            imu_raw[twi_n++] = TWDR;
            if (twi_n >= twi_want) {
                twi_done();
                return;
            }
            if (status == 0x58u) {
                twi_fail(); /* the last byte came early */
                return;
            }
            TWCR = (uint8_t)(_BV(TWINT) | _BV(TWEN) | _BV(TWIE) |
                             (twi_n + 1u < twi_want ? _BV(TWEA) : 0));
            return;
        }
        twi_fail();
        return;
    case 7: /* the mode written */
        if (status != 0x28u) {
            twi_fail();
            return;
        }
        twi_done();
        return;
    default:
        twi_fail();
        return;
    }
    TWCR = _BV(TWINT) | _BV(TWEN) | _BV(TWIE);
}

bool hal_imu(int16_t out[3]) {
    if (!imu_wanted) {
        imu_wanted = true;
        imu_due = 9; /* the first read at the next tick, then every 10 ms */
    }
    bool fresh;
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
        fresh = imu_new;
        imu_new = false;
        for (uint8_t i = 0; i < 3u; i++) {
            out[i] = imu_euler[i];
        }
    }
    return fresh;
}

/* ---- the rest ---------------------------------------------------------------------- */

bool hal_fault(void) { return (PIND & _BV(PD3)) == 0; }

void hal_led(bool on) {
    if (on) {
        PORTB |= _BV(PB5);
    } else {
        PORTB &= (uint8_t)~_BV(PB5);
    }
}

uint8_t hal_board_id(void) {
    uint8_t id = eeprom_read_byte((const uint8_t *)0);
    uint8_t check = eeprom_read_byte((const uint8_t *)1);
    return (uint8_t)(id ^ check) == 0xFFu ? id : 0u;
}

bool hal_warm_boot(void) { return (mcusr_at_boot & _BV(PORF)) == 0; }

uint8_t hal_reset_cause(void) { return mcusr_at_boot; }

void hal_feed(void) { wdt_reset(); }

void hal_idle(void) {
    cli();
    if (rx_tail == rx_head) {
        sleep_enable();
        sei();
        sleep_cpu(); /* the instruction after sei runs first: no wake-up is lost */
        sleep_disable();
    }
    sei();
}

uint16_t hal_stack_low(void) {
    uint8_t *bottom = &__heap_start;
    for (;;) {
        uint8_t *p = stack_scan;
        uint8_t k = 0;
        while (k < 16 && p - k - 1 >= bottom && p[-(int)k - 1] == STACK_PAINT) {
            k++;
        }
        if (k == 16 || p - k - 1 < bottom) {
            break;
        }
        stack_scan = p - k - 1;
    }
    return (uint16_t)(uintptr_t)stack_scan;
}

void hal_init(void) {
    stack_scan = (uint8_t *)SP;
    /* motors: EN, INA, INB outputs, low (off: the board's pull-downs held them so
     * through reset); LED out; fault input with pull-up; DE output low */
    DDRD |= _BV(PD2) | _BV(PD4) | _BV(PD5) | _BV(PD6) | _BV(PD7);
    PORTD &= (uint8_t)~(_BV(PD2) | _BV(PD4) | _BV(PD5) | _BV(PD6) | _BV(PD7));
    PORTD |= _BV(PD3);
    /* RXD with its pull-up: the transceiver's RO floats while this board sends (its
     * /RE is DE, high), as the bridge's RXD1 has one */
    PORTD |= _BV(PD0);
    DDRB |= _BV(PB0) | _BV(PB4) | _BV(PB5);
    PORTB &= (uint8_t)~(_BV(PB0) | _BV(PB4) | _BV(PB5));
    /* encoder inputs with pull-ups; pin-change interrupts */
    PORTC |= _BV(PC2) | _BV(PC3);
    PORTB |= _BV(PB1) | _BV(PB2);
    PCMSK1 = _BV(PCINT10) | _BV(PCINT11);
    PCMSK0 = _BV(PCINT1) | _BV(PCINT2);
    PCICR = _BV(PCIE1) | _BV(PCIE0);
    enc_last[0] = enc_pins(0);
    enc_last[1] = enc_pins(1);
    /* Timer0: fast PWM, clk/64 (976 Hz), outputs connected per motor by hal_motor */
    TCCR0A = _BV(WGM01) | _BV(WGM00);
    TCCR0B = _BV(CS01) | _BV(CS00);
    /* Timer1: free running at clk/8 */
    TCCR1A = 0;
    TCCR1B = _BV(CS11);
    /* Timer2: CTC at 1 kHz (16 MHz / 64 / 250) */
    TCCR2A = _BV(WGM21);
    OCR2A = 249;
    TCCR2B = _BV(CS22);
    TIMSK2 = _BV(OCIE2A);
    /* ADC: AVCC reference, clk/128, interrupt */
    ADMUX = _BV(REFS0);
    ADCSRA = _BV(ADEN) | _BV(ADIE) | _BV(ADPS2) | _BV(ADPS1) | _BV(ADPS0);
    DIDR0 = _BV(ADC0D) | _BV(ADC1D);
    /* TWI at 400 kHz */
    TWSR = 0;
    TWBR = 12;
    /* USART0: 1 Mbaud 8N1 */
    UCSR0A = _BV(U2X0);
    UBRR0 = BUS_UBRR;
    UCSR0C = _BV(UCSZ01) | _BV(UCSZ00);
    UCSR0B = _BV(RXEN0) | _BV(TXEN0) | _BV(RXCIE0) | _BV(TXCIE0);
    set_sleep_mode(SLEEP_MODE_IDLE);
    wdt_enable(WDTO_60MS);
}
