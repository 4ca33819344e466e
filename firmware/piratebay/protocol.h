/* The bridge side of wire protocol v1.2 (docs/protocol.md; a 1.1 host gets 1.1): the checks every
 * received frame goes through, in order; sessions (HELLO), the duplicate filter
 * with remembered answers, SETPOINT and BULK_SETPOINTS (all or nothing), the
 * e-stop and its reset, heartbeats, COUNTERS; and the STATE frame. */
#ifndef PB_PROTOCOL_H
#define PB_PROTOCOL_H

#include <stdbool.h>
#include <stdint.h>

/* Bridge flags (arg of STATE, BRIDGE_HEARTBEAT, HELLO_REPLY). */
#define FLAG_ESTOP 0x01u
#define FLAG_WATCHDOG 0x02u
#define FLAG_BUS_FAULT 0x04u
#define FLAG_NO_SESSION 0x08u
#define FLAG_ESTOP_INPUT 0x10u /* protocol 1.2: the hardware e-stop input */

#ifndef PB_FIRMWARE_VERSION
#define PB_FIRMWARE_VERSION 0x0100u /* release 1.0, high byte major */
#endif

void protocol_init(void);
/* One byte from the host link; `damaged`: the USART flagged it (its frame is dropped). */
void protocol_rx_byte(uint8_t byte, bool damaged, uint32_t now_ms);
/* Encode this period's STATE. */
void protocol_send_state(void);
uint8_t protocol_flags(void);

#endif
