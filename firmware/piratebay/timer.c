/* Timer0: CTC at 1 kHz (16 MHz / 64 / 250) counts milliseconds. Timer1: normal
 * mode at clk/8, a free-running 2 MHz counter read directly. */
#include "timer.h"

#include <assert.h>
#include <avr/interrupt.h>
#include <avr/io.h>
#include <util/atomic.h>

static_assert(F_CPU == 16000000UL, "the timer settings assume 16 MHz");

static volatile uint32_t ms;

void timer_init(void) {
    TCCR0A = _BV(WGM01);
    OCR0A = 249;
    TCCR0B = _BV(CS01) | _BV(CS00);
    TIMSK0 = _BV(OCIE0A);
    TCCR1A = 0;
    TCCR1B = _BV(CS11);
}

ISR(TIMER0_COMPA_vect) { ms++; }

/* Only wakes the main loop; disarms itself. */
ISR(TIMER1_COMPA_vect) { TIMSK1 &= (uint8_t)~_BV(OCIE1A); }

void timer_wake_at(uint16_t ticks) {
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
        OCR1A = ticks;
        TIFR1 = _BV(OCF1A);
        TIMSK1 |= _BV(OCIE1A);
    }
}

uint32_t timer_ms(void) {
    uint32_t now;
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { now = ms; }
    return now;
}

uint16_t timer_ticks(void) {
    uint16_t t;
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { t = TCNT1; }
    return t;
}
