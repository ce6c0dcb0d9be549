/* The AVR port (ATmega328P): what main.c calls of hal_avr.c. */
#ifndef BOARD_AVR_PORT_H
#define BOARD_AVR_PORT_H

#include <stdint.h>

#define AVR_MAX_FINGERS 5u /* the pins: A0..A4 for pressure, D5..D13 and A5 for ten valves */
#define AVR_RX_BYTES 128u  /* at most 256: the ring indices are 8-bit */
#define AVR_TX_BYTES 128u
#ifndef AVR_BAUD
#define AVR_BAUD 500000u   /* exact at 16 MHz (U2X, UBRR 3); the profile's baudrate_bps */
#endif

/* Pins, USART0, Timer1 (the clock), Timer2 (valve PWM), the ADC, the watchdog; enables
 * interrupts. */
void avr_port_init(uint32_t pwm_period_us);

#endif
