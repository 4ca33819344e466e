/* The hardware e-stop input (docs/firmware.md, "E-stop input"): a normally-closed
 * mushroom-button contact between Mega pin D22 and GND, with the pin's pull-up. Open
 * (pressed, or a broken wire) reads high and stops the robot.
 *
 * Sampled once per millisecond. Asymmetric debounce: the input trips after 2
 * consecutive open samples (a stop must not wait: 1-2 ms, which also ignores a
 * sub-millisecond spike from a motor), and counts as released only after 50
 * consecutive closed samples. A trip latches the e-stop exactly as a host ESTOP does
 * (the stop category goes on the bus within the same main-loop turn). The latch is
 * released only by the host's ESTOP_RESET, which is refused (NOT_READY) while the
 * input is still open. Protocol 1.2 reports it in the bridge flag ESTOP_INPUT. */
#ifndef PB_ESTOP_INPUT_H
#define PB_ESTOP_INPUT_H

#include <stdbool.h>
#include <stdint.h>

#define ESTOP_TRIP_SAMPLES 2u
#define ESTOP_RELEASE_SAMPLES 50u

/* Build option: `make firmware ESTOP_INPUT=none` for a bridge without a button (the
 * input is then never active). With a button input an unwired D22 reads open: fit
 * the button, or a wire from D22 to GND. */
#ifndef PB_ESTOP_INPUT
#define PB_ESTOP_INPUT 1
#endif

void estop_input_init(void);
/* Sample the input when a new millisecond has begun; a trip latches the e-stop. */
void estop_input_poll(uint32_t now_ms);
/* The input is open now (debounced). */
bool estop_input_pressed(void);
/* Pressed now, or it latched the e-stop and no ESTOP_RESET released it since (the
 * ESTOP_INPUT flag). */
bool estop_input_active(void);
/* An ESTOP_RESET released the latch: forget the trip. */
void estop_input_reset(void);

#endif
