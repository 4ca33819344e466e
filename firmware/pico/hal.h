/* The PICO board's hardware, as the board logic sees it. hal_avr.c implements it on
 * the ATmega328p (pins in docs/board-bus.md, "The reference PICO board"); the host
 * build of the tests (host/host_hal.c) implements it in virtual time. Nothing here
 * blocks. */
#ifndef PICO_HAL_H
#define PICO_HAL_H

#include <stdbool.h>
#include <stdint.h>

#define HAL_RX_ERROR 0x100 /* set in a received value: the byte was damaged or lost */
#define HAL_TICKS_PER_US 2u

/* What an H-bridge output does (docs/board-bus.md, "H-bridge"). */
enum hal_drive {
    HAL_OFF = 0, /* EN low: both half-bridges off, the motor coasts (never commanded) */
    HAL_BRAKE,   /* INA = INB = 0, EN high: both low-side switches on */
    HAL_RUN,     /* INA/INB by the sign, EN = |duty| */
};

/* ADC inputs: the two sensor connectors, and the two motors' current sense. */
#define HAL_ADC_SENSOR(slot) (slot)
#define HAL_ADC_CURRENT(slot) (2u + (slot))

void hal_init(void);
/* The board id from EEPROM (docs/board-bus.md, "Board id"), or 0 when none is set. */
uint8_t hal_board_id(void);
/* Milliseconds since boot (the 1 kHz tick), and the free-running 2 MHz counter. */
uint32_t hal_ms(void);
uint16_t hal_ticks(void);

/* RS485: the next received byte (with HAL_RX_ERROR when damaged), or -1; timer ticks
 * at which the last byte arrived. */
int16_t hal_bus_getc(void);
uint16_t hal_bus_rx_at(void);
/* Send n bytes (the driver on while they go out, off after the last stop bit). */
void hal_bus_send(const uint8_t *p, uint8_t n);
bool hal_bus_tx_busy(void);

/* Motor `slot`: drive = HAL_RUN with duty -255..255 (sign = direction). */
void hal_motor(uint8_t slot, enum hal_drive drive, int16_t duty);
/* The latest 10-bit reading of ADC input `input` (HAL_ADC_*). */
uint16_t hal_adc(uint8_t input);
/* The running quadrature count of motor `slot`'s encoder (wraps). */
int16_t hal_encoder(uint8_t slot);
/* The IMU's latest heading, roll, pitch in 1/16 degree; true when a read has
 * succeeded since the last call (false: no new reading, `out` holds the last good one,
 * or 0 before any). The first call starts reading the IMU (every 10 ms from then on). */
bool hal_imu(int16_t out[3]);
/* The H-bridge reports a fault (over-current, over-temperature). */
bool hal_fault(void);

/* Reset the AVR's watchdog; wait for the next interrupt (idle sleep). */
void hal_feed(void);
void hal_idle(void);
/* A status LED. */
void hal_led(bool on);
/* The lowest SRAM address the stack has reached (painted stack), 0 where unknown. */
uint16_t hal_stack_low(void);
/* The MCU status register at the last reset (PORF, EXTRF, BORF, WDRF bits). */
uint8_t hal_reset_cause(void);

/* State kept across a watchdog or brown-out reset (not across power-on): the logic
 * puts what it must not lose here; hal_init() says whether it survived. */
bool hal_warm_boot(void);

#endif
