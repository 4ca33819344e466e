/* Time base: a millisecond tick (Timer0, CTC, 1 kHz interrupt) and a free-running
 * 2 MHz counter (Timer1, clk/8, 0.5 us per tick, wraps every 32.768 ms) for the
 * board bus's sub-millisecond timeouts and for cycle measurements; its compare unit A
 * wakes the sleeping main loop at such a timeout. */
#ifndef PB_TIMER_H
#define PB_TIMER_H

#include <stdint.h>

#define TIMER_TICKS_PER_US 2u

void timer_init(void);
/* Milliseconds since boot (wraps after 49 days). */
uint32_t timer_ms(void);
/* The 2 MHz counter. */
uint16_t timer_ticks(void);
/* Wake the CPU from idle sleep when the 2 MHz counter reaches `ticks` (a reply's
 * timeout, the bus's quiet time): the 1 ms tick alone would be up to 1 ms late. */
void timer_wake_at(uint16_t ticks);

#endif
