/* handboard: the valve-board firmware core (board/core) on an ATmega328P (Arduino Nano or
 * Uno), serial-v1 over the board's USB serial. A release image: no fault injection, no
 * plant (the real board reads real sensors). The profile's numbers are fixed at build
 * time: the defaults are the shipped serial-v1.yaml's (5 fingers, 100 Hz, a 100 ms
 * watchdog). The pressure loops run at 500 Hz (the core's lowest): a 16 MHz AVR without an
 * FPU has not the time for 1 kHz with five chambers. */
#include <stdint.h>

#include "avr_port.h"
#include "board.h"

#ifndef AVR_FINGERS
#define AVR_FINGERS 5u
#endif
#ifndef AVR_RATE_HZ
#define AVR_RATE_HZ 100u
#endif
#ifndef AVR_WATCHDOG_MS
#define AVR_WATCHDOG_MS 100u
#endif

#if AVR_FINGERS < 1 || AVR_FINGERS > AVR_MAX_FINGERS
#error "AVR_FINGERS must be 1..5 (the pins of the ATmega328P, docs/board.md)"
#endif

static struct board b;

int main(void)
{
    struct board_config cfg = board_config_defaults();
    cfg.wire = BOARD_WIRE_SERIAL;
    cfg.n_fingers = (uint8_t)AVR_FINGERS;
    cfg.sample_period_us = 1000000u / AVR_RATE_HZ;
    cfg.watchdog_us = AVR_WATCHDOG_MS * 1000u;
    cfg.inner_period_us = 2000u;
    cfg.adc_max_counts = 1023u; /* 10 bits over AVcc (5 V) */
    cfg.adc_ref_mv = 5000.0f;
    avr_port_init(cfg.regulator.pwm_period_us);
    if (board_init(&b, &cfg) != 0) {
        for (;;) { /* not kicked: the watchdog resets the MCU, which boots vented */
        }
    }
    for (;;) {
        board_poll(&b);
    }
}
