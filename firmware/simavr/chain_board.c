/* pirate-chain: one PICO board's pins (see chain.c and docs/board-bus.md, "The
 * reference PICO board"). Calls nothing of the chain's own.
 *
 *  - ADC: the harness sets the core's AVCC to 1023 "millivolts", so the value raised
 *    on an ADC input is the reading the firmware gets (0..1023).
 *  - Encoders: each step the physics says which count each encoder must reach by the
 *    step's end; the edges (quadrature, A leading B forward) are spread evenly over
 *    the step, on cycle timers of the board's own core. The pins are driven as the
 *    port's external level, so the firmware's pull-ups do not override them.
 *  - IMU: a TWI slave at 0x28 with BNO055-style registers (0x00 chip id 0xA0, 0x1A..
 *    0x1F heading, roll, pitch, int16 LE, 1/16 degree).
 *  - H-bridge: sampled from the registers (Timer0's compare outputs and OCR0A/B, the
 *    EN, INA and INB bits of PORTD and PORTB). */
#include "chain.h"

#define R_PORTB 0x25u
#define R_PORTD 0x2Bu
#define R_TCCR0A 0x44u
#define R_OCR0A 0x47u
#define R_OCR0B 0x48u
#define IMU_ADDR 0x28u

static struct board {
    avr_t *avr;
    uint8_t id;
    /* encoders: slot 0 on PC2/PC3, slot 1 on PB1/PB2 */
    int32_t count[2], target[2];
    uint64_t edge_every[2];
    uint8_t ext_b, ext_c, ext_d; /* external levels of ports B, C, D */
    /* the IMU */
    uint8_t imu_reg[0x40];
    uint8_t imu_at;
    bool imu_selected, imu_addr_written;
    bool imu_gone; /* it answers nothing (no ACK) */
    bool unpowered; /* the board has no power: its outputs are off */
} boards[CHAIN_MAX_BOARDS];

static void set_external(struct board *b, char port, uint8_t mask, uint8_t value) {
    avr_ioport_external_t ext = {.name = (unsigned)port, .mask = mask, .value = value};
    avr_ioctl(b->avr, AVR_IOCTL_IOPORT_SET_EXTERNAL(port), &ext);
}

/* The quadrature state of a count: 00, 01, 11, 10 (A = bit 0, B = bit 1) for +1 steps,
 * matching the firmware's table (quad[] in hal_avr.c). */
static uint8_t quad_state(int32_t count) {
    static const uint8_t seq[4] = {0, 2, 3, 1}; /* B A: 00 -> 10 -> 11 -> 01: one way */
    return seq[((count % 4) + 4) % 4];
}

static void drive_encoder(struct board *b, int slot, bool all) {
    uint8_t st = quad_state(b->count[slot]);
    char port = slot == 0 ? 'C' : 'B';
    int bit_a = slot == 0 ? 2 : 1;
    uint8_t *ext = slot == 0 ? &b->ext_c : &b->ext_b;
    uint8_t mask = (uint8_t)(3u << bit_a);
    uint8_t before = (uint8_t)((*ext & mask) >> bit_a);
    *ext = (uint8_t)((*ext & ~mask) | (st << bit_a));
    set_external(b, port, mask, (uint8_t)(st << bit_a));
    for (int k = 0; k < 2; k++) { /* only the pin that changed: one pin-change interrupt */
        if (all || ((before ^ st) >> k & 1u)) {
            avr_raise_irq(avr_io_getirq(b->avr, AVR_IOCTL_IOPORT_GETIRQ(port), bit_a + k),
                          (st >> k) & 1u);
        }
    }
}

static avr_cycle_count_t encoder_edge(avr_t *avr, avr_cycle_count_t when, void *param) {
    (void)avr;
    uintptr_t v = (uintptr_t)param;
    struct board *b = &boards[v >> 1];
    int slot = (int)(v & 1u);
    if (b->count[slot] == b->target[slot]) {
        return 0;
    }
    b->count[slot] += b->target[slot] > b->count[slot] ? 1 : -1;
    drive_encoder(b, slot, false);
    return b->count[slot] == b->target[slot] ? 0 : when + b->edge_every[slot];
}

static void twi_out(avr_irq_t *irq, uint32_t value, void *param) {
    (void)irq;
    struct board *b = param;
    avr_twi_msg_irq_t v;
    v.u.v = value;
    if (getenv("PIRATE_CHAIN_TRACE")) {
        fprintf(stderr, "twi %llu msg %02x addr %02x data %02x\n",
                (unsigned long long)b->avr->cycle, v.u.twi.msg, v.u.twi.addr, v.u.twi.data);
    }
    avr_irq_t *in = avr_io_getirq(b->avr, AVR_IOCTL_TWI_GETIRQ(0), TWI_IRQ_INPUT);
    if (v.u.twi.msg & TWI_COND_STOP) {
        b->imu_selected = false;
    }
    if (v.u.twi.msg & TWI_COND_START) {
        b->imu_selected = (v.u.twi.addr >> 1) == IMU_ADDR && !b->imu_gone;
        if (b->imu_selected) {
            if (!(v.u.twi.addr & 1u)) {
                b->imu_addr_written = false; /* a write: the register address comes next */
            }
            avr_raise_irq(in, avr_twi_irq_msg(TWI_COND_ACK, v.u.twi.addr, 1));
        }
    }
    if (!b->imu_selected) {
        return;
    }
    if (v.u.twi.msg & TWI_COND_WRITE) {
        avr_raise_irq(in, avr_twi_irq_msg(TWI_COND_ACK, v.u.twi.addr, 1));
        if (!b->imu_addr_written) {
            b->imu_at = v.u.twi.data & 0x3Fu;
            b->imu_addr_written = true;
        } else { /* a register written (OPR_MODE): kept, as a BNO055 keeps it */
            b->imu_reg[b->imu_at & 0x3Fu] = v.u.twi.data;
            b->imu_at = (uint8_t)((b->imu_at + 1u) & 0x3Fu);
        }
    }
    if (v.u.twi.msg & TWI_COND_READ) {
        uint8_t at = b->imu_at & 0x3Fu;
        /* a BNO055 in CONFIGMODE (OPR_MODE 0x3D low nibble below 8, as at power-on)
         * reads 0 on its output registers (0x08-0x35): only a fusion mode fills them */
        bool config = (b->imu_reg[0x3D] & 0x0Fu) < 0x08u;
        uint8_t data = config && at >= 0x08u && at <= 0x35u ? 0u : b->imu_reg[at];
        b->imu_at = (uint8_t)((b->imu_at + 1u) & 0x3Fu);
        avr_raise_irq(in, avr_twi_irq_msg(TWI_COND_READ, v.u.twi.addr, data));
    }
}

void board_attach(int i, avr_t *avr, uint8_t id) {
    struct board *b = &boards[i];
    memset(b, 0, sizeof *b);
    b->avr = avr;
    b->id = id;
    avr->avcc = avr->aref = avr->vcc = 1023; /* the raised "millivolts" are the reading */
    uint8_t ee[2] = {id, (uint8_t)~id};
    avr_eeprom_desc_t desc = {.ee = ee, .offset = 0, .size = 2};
    avr_ioctl(avr, AVR_IOCTL_EEPROM_SET, &desc);
    b->ext_d = 0x08; /* PD3: the H-bridge's fault line, high = no fault */
    set_external(b, 'D', 0x08, b->ext_d);
    drive_encoder(b, 0, true);
    drive_encoder(b, 1, true);
    b->imu_reg[0] = 0xA0; /* BNO055 chip id */
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_TWI_GETIRQ(0), TWI_IRQ_OUTPUT), twi_out,
                            b);
}

void board_imu_answers(int i, bool on) {
    boards[i].imu_gone = !on;
    boards[i].imu_selected = false;
}

void board_inputs(int i, const uint16_t adc[4], const int32_t encoder[2], const int16_t imu[3],
                  bool fault, uint64_t from, uint64_t until) {
    struct board *b = &boards[i];
    static const int mux[4] = {ADC_IRQ_ADC0, ADC_IRQ_ADC1, ADC_IRQ_ADC6, ADC_IRQ_ADC7};
    for (int k = 0; k < 4; k++) {
        avr_raise_irq(avr_io_getirq(b->avr, AVR_IOCTL_ADC_GETIRQ, mux[k]), adc[k]);
    }
    for (int k = 0; k < 3; k++) {
        b->imu_reg[0x1A + 2 * k] = (uint8_t)imu[k];
        b->imu_reg[0x1B + 2 * k] = (uint8_t)((uint16_t)imu[k] >> 8);
    }
    uint8_t level = fault ? 0x00 : 0x08;
    if (level != b->ext_d) {
        b->ext_d = level;
        set_external(b, 'D', 0x08, level);
        avr_raise_irq(avr_io_getirq(b->avr, AVR_IOCTL_IOPORT_GETIRQ('D'), 3), level ? 1 : 0);
    }
    for (int slot = 0; slot < 2; slot++) {
        avr_cycle_timer_cancel(b->avr, encoder_edge, (void *)(uintptr_t)(i << 1 | slot));
        b->target[slot] = encoder[slot];
        int64_t edges = b->target[slot] - b->count[slot];
        if (edges < 0) {
            edges = -edges;
        }
        if (edges == 0) {
            continue;
        }
        uint64_t span = until > from ? until - from : 1u;
        b->edge_every[slot] = span / (uint64_t)edges ? span / (uint64_t)edges : 1u;
        uint64_t first = from + b->edge_every[slot] / 2u;
        uint64_t in = first > b->avr->cycle ? first - b->avr->cycle : 1u;
        avr_cycle_timer_register(b->avr, in, encoder_edge, (void *)(uintptr_t)(i << 1 | slot));
    }
}

void board_power(int i, bool on) {
    struct board *b = &boards[i];
    b->unpowered = !on;
    if (!on) {
        memset(b->imu_reg, 0, sizeof b->imu_reg); /* a BNO055 powers up in CONFIGMODE */
        b->imu_reg[0] = 0xA0;
        b->imu_selected = false;
        return;
    }
    set_external(b, 'D', 0x08, b->ext_d); /* the reset cleared the pins' levels */
    drive_encoder(b, 0, true);
    drive_encoder(b, 1, true);
}

struct motor_sample board_sample(int i, int slot) {
    if (boards[i].unpowered) {
        return (struct motor_sample){0, 0}; /* no power: the H-bridge is off, it coasts */
    }
    const uint8_t *d = boards[i].avr->data;
    uint8_t tccr = d[R_TCCR0A], portd = d[R_PORTD], portb = d[R_PORTB];
    bool pwm = slot == 0 ? (tccr & 0x80u) : (tccr & 0x20u);
    uint8_t ocr = slot == 0 ? d[R_OCR0A] : d[R_OCR0B];
    bool en_pin = slot == 0 ? (portd & 0x40u) : (portd & 0x20u);
    bool ina = slot == 0 ? (portd & 0x10u) : (portb & 0x01u);
    bool inb = slot == 0 ? (portd & 0x80u) : (portb & 0x10u);
    int en = pwm ? ocr : (en_pin ? 255 : 0);
    struct motor_sample s = {0, 0};
    if (en == 0) {
        return s; /* off: coasting */
    }
    if (ina == inb) {
        s.drive = 1; /* brake */
        return s;
    }
    s.drive = 2;
    s.duty = (int16_t)(ina ? en : -en);
    return s;
}
