/* One cooperative main loop, nothing blocks: bytes from the host are handled as
 * they arrive (ESTOP takes effect in the same turn), the hardware e-stop input is
 * sampled every millisecond (a trip too takes effect in its turn), the board bus advances one
 * step, the host watchdog is checked every turn, every state period a STATE frame
 * is encoded and a new poll cycle starts, and the next frame is handed to the UART
 * when it is free. */
#include "bridge.h"

#include "estop_input.h"
#include "mcu.h"
#include "poller.h"
#include "protocol.h"
#include "safety.h"
#include "timer.h"
#include "txq.h"
#include "uart.h"

/* At most this many host bytes per turn, so the bus and the tick stay served even
 * at full line rate (a turn is far shorter than the 32 byte times it covers). */
#define RX_BURST 32u

static uint32_t next_period;
static uint32_t fed_ms;

void bridge_init(void) {
    mcu_init();
    timer_init();
    uart0_init(PB_BAUD);
    poller_init();
    txq_init();
    uint32_t now = timer_ms();
    protocol_init();
    safety_init(now);
    estop_input_init();
    next_period = now + PB_STATE_PERIOD_MS;
}

void bridge_turn(void) {
    uint32_t now = timer_ms();
    if (now != fed_ms) {
        /* once a millisecond is plenty against the 120 ms watchdog (and a WDR is
         * expensive to simulate) */
        fed_ms = now;
        mcu_feed();
    }
    for (uint8_t i = 0; i < RX_BURST; i++) {
        int16_t c = uart0_getc();
        if (c < 0) {
            break;
        }
        protocol_rx_byte((uint8_t)c, (c & UART_RX_ERROR) != 0, now);
    }
    estop_input_poll(now); /* a trip latches before the bus is served: same turn */
    poller_run();
    safety_watchdog_check(now);
    if ((int32_t)(now - next_period) >= 0) {
        next_period += PB_STATE_PERIOD_MS;
        if ((int32_t)(now - next_period) >= 0) {
            next_period = now + PB_STATE_PERIOD_MS; /* fell behind: back on a grid */
        }
        poller_period(now); /* closes the period: its readings go into this STATE */
        protocol_send_state();
        mcu_stack_check();
        struct uart_line_stats line;
        uart_line_stats(&line);
        pb_debug.rx_overruns = (uint16_t)(line.host_overrun + line.host_ring_full);
        pb_debug.host_framing = line.host_framing;
        pb_debug.bus_framing = line.bus_framing;
        pb_debug.bus_overrun = (uint16_t)(line.bus_overrun + line.bus_ring_full);
        pb_debug.bus_echo = line.bus_echo;
    }
    txq_pump(now, protocol_flags());
}
