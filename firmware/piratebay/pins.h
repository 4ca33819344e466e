/* The bridge's pin map on a stock Arduino Mega 2560 (docs/firmware.md, "Wiring"):
 * every pin the firmware uses is one the Mega breaks out, named here once.
 *
 *   Mega pin   AVR    use
 *   D0 / D1    PE0/1  USART0: the host link, through the Mega's ATmega16U2 (USB)
 *   D19 (RX1)  PD2    USART1 RXD1 <- RS485 module RO (internal pull-up: idle high
 *                     while the module's receiver is off)
 *   D18 (TX1)  PD3    USART1 TXD1 -> RS485 module DI
 *   D2         PE4    RS485 DE: high while the bridge drives the bus (10 kOhm
 *                     pull-down on the board: low through reset and the bootloader)
 *   D3         PE5    RS485 /RE: high while sending (no echo), low otherwise
 *   D22        PA0    hardware e-stop input: a normally-closed contact to GND,
 *                     internal pull-up; open (high) = stop
 *   D13        PB7    the Mega's LED: lit while the e-stop is latched
 *
 * The AVR registers are listed as (PORT, DDR, PIN, bit) so that the early boot code
 * in mcu.c can use them before the C runtime starts. */
#ifndef PB_PINS_H
#define PB_PINS_H

#ifdef __AVR__
#include <avr/io.h>

#define RS485_DE_PORT PORTE
#define RS485_DE_DDR DDRE
#define RS485_DE_BIT PE4 /* Mega D2 */
#define RS485_RE_PORT PORTE
#define RS485_RE_DDR DDRE
#define RS485_RE_BIT PE5 /* Mega D3, active low */
#define RS485_RX_PORT PORTD
#define RS485_RX_BIT PD2 /* RXD1, Mega D19: pull-up */

#define ESTOP_PORT PORTA
#define ESTOP_DDR DDRA
#define ESTOP_PIN PINA
#define ESTOP_BIT PA0 /* Mega D22 */

#define LED_PORT PORTB
#define LED_DDR DDRB
#define LED_BIT PB7 /* Mega D13 */
#endif

#endif
