/* valve_board: the valve-board firmware core (board/core) as an Arduino sketch for an
 * Arduino Nano (ATmega328P, 16 MHz), serial-v1 over the board's USB serial, with the
 * Arduino core as its hardware layer. It is the same board as board/avr/ (the same pins,
 * the same wiring, docs/board.md), built on the Arduino core instead of bare registers:
 *
 *   serial-v1   Serial (HardwareSerial on USART0, D0/D1), VALVE_BOARD_BAUD; the Arduino
 *               core is built with 128-byte receive and transmit rings (SERIAL_RX_BUFFER_SIZE,
 *               SERIAL_TX_BUFFER_SIZE), and a frame that does not fit the transmit ring
 *               is dropped whole (Serial.write would wait for room; hal.h forbids that)
 *   clock       micros() (Timer0, 4 us steps), which wraps at 2^32 as hal.h asks
 *   ADC         analogRead(): chamber i's pressure sensor on A0..A4; finger i's flex
 *               sensor through a 74HC4051 8:1 analog multiplexer (S0..S2 on D2..D4) into
 *               A6, the first conversion after a switch discarded. The ADC clock is set to
 *               250 kHz (prescaler 64) after the core's init(), as in board/avr
 *   valves      ten outputs to the MOSFET gates, chamber i's inlet then exhaust: D5, D6;
 *               D7, D8; D9, D10; D11, D12; D13, A5. Software PWM from Timer2's compare
 *               interrupt at 5 kHz (200 us steps of the regulator's 10 ms period), written
 *               through the registers the Arduino core names for each pin
 *               (portOutputRegister, digitalPinToBitMask). analogWrite() is not used: its
 *               hardware PWM runs at 490/980 Hz on six pins only, and an on/off solenoid
 *               valve needs a period long beside its opening time (min_pulse_us)
 *   watchdog    avr/wdt.h, 250 ms: a stuck loop() resets the MCU, which boots vented
 *   CAN         none (docs/board.md, "No can-v1 on the AVR builds")
 *
 * The profile's numbers are fixed at build time, as in board/avr: VALVE_BOARD_FINGERS,
 * VALVE_BOARD_RATE_HZ, VALVE_BOARD_WATCHDOG_MS, VALVE_BOARD_BAUD (make -C board arduino
 * ARDUINO_DEFS="-DVALVE_BOARD_FINGERS=3"). Every function is defined before its first use,
 * so the sketch needs no generated prototypes: `#include <Arduino.h>` in front is all the
 * preprocessing it takes (board/Makefile does that).
 */
#include <avr/wdt.h>

extern "C" {
#include "board.h"
#include "hal.h"
}

#ifndef VALVE_BOARD_FINGERS
#define VALVE_BOARD_FINGERS 5u
#endif
#ifndef VALVE_BOARD_RATE_HZ
#define VALVE_BOARD_RATE_HZ 100u
#endif
#ifndef VALVE_BOARD_WATCHDOG_MS
#define VALVE_BOARD_WATCHDOG_MS 100u
#endif
#ifndef VALVE_BOARD_BAUD
#define VALVE_BOARD_BAUD 500000ul /* exact at 16 MHz (U2X, UBRR 3); the profile's baudrate_bps */
#endif

#define VALVE_BOARD_MAX_FINGERS 5u
#define VALVE_COUNT (2u * VALVE_BOARD_MAX_FINGERS)
#define PWM_STEP_US 200u
#define PWM_MAX_STEPS 250u /* the step counter and the duties are 8-bit */

#if VALVE_BOARD_FINGERS < 1 || VALVE_BOARD_FINGERS > VALVE_BOARD_MAX_FINGERS
#error "VALVE_BOARD_FINGERS must be 1..5 (the pins of the Nano, docs/board.md)"
#endif

/* chamber i's inlet is valve 2i, its exhaust 2i+1 */
static const uint8_t VALVE_PINS[VALVE_COUNT] = {5, 6, 7, 8, 9, 10, 11, 12, 13, A5};
static const uint8_t PRESSURE_PINS[VALVE_BOARD_MAX_FINGERS] = {A0, A1, A2, A3, A4};
static const uint8_t MUX_SELECT_PINS[3] = {2, 3, 4};
static const uint8_t FLEX_PIN = A6; /* the multiplexer's output */

static struct board b;

/* each valve's output register and bit, looked up once: the PWM interrupt writes them */
static volatile uint8_t *valve_port[VALVE_COUNT];
static uint8_t valve_mask[VALVE_COUNT];

static uint8_t pwm_period_steps = 1u;
static volatile uint8_t pwm_step;
static volatile uint8_t duty_steps_pending[VALVE_COUNT];
static volatile uint8_t duty_steps[VALVE_COUNT];

/* a watchdog reset leaves the watchdog running (at its shortest time-out): stop it before
 * the Arduino core's init() and the constructors run, as avr-libc's documentation shows */
static void watchdog_off_at_reset(void) __attribute__((naked, used, section(".init3")));
static void watchdog_off_at_reset(void)
{
    MCUSR = 0u;
    wdt_disable();
}

static void valve_write(uint8_t valve, uint8_t open)
{
    if (open) {
        *valve_port[valve] |= valve_mask[valve];
    } else {
        *valve_port[valve] &= (uint8_t)~valve_mask[valve];
    }
}

ISR(TIMER2_COMPA_vect)
{
    const uint8_t step = pwm_step;
    if (step == 0u) { /* a new PWM period: the duties set during the last one take effect */
        for (uint8_t v = 0u; v < VALVE_COUNT; v++) {
            duty_steps[v] = duty_steps_pending[v];
        }
    }
    for (uint8_t v = 0u; v < VALVE_COUNT; v++) {
        valve_write(v, step < duty_steps[v]);
    }
    pwm_step = (uint8_t)(step + 1u >= pwm_period_steps ? 0u : step + 1u);
}

extern "C" uint32_t hal_time_us(void)
{
    return micros();
}

extern "C" uint16_t hal_adc_read(uint8_t channel)
{
    const uint8_t finger = channel / 2u;
    if (finger >= VALVE_BOARD_MAX_FINGERS) {
        return 0u;
    }
    if (channel % 2u == 0u) {
        return (uint16_t)analogRead(PRESSURE_PINS[finger]);
    }
    for (uint8_t bit = 0u; bit < 3u; bit++) {
        digitalWrite(MUX_SELECT_PINS[bit], (finger >> bit) & 1u ? HIGH : LOW);
    }
    (void)analogRead(FLEX_PIN); /* the first conversion after a switch settles the multiplexer */
    return (uint16_t)analogRead(FLEX_PIN);
}

extern "C" void hal_valve_pwm(uint8_t chamber, uint8_t valve, uint16_t duty_permille)
{
    if (chamber >= VALVE_BOARD_MAX_FINGERS || valve > 1u) {
        return;
    }
    const uint8_t v = (uint8_t)(2u * chamber + valve);
    const uint16_t clamped = duty_permille > HAL_DUTY_FULL_PERMILLE ? HAL_DUTY_FULL_PERMILLE : duty_permille;
    const uint8_t steps = (uint8_t)(((uint32_t)clamped * pwm_period_steps + 500u) / 1000u);
    const uint8_t sreg = SREG;
    cli();
    duty_steps_pending[v] = steps;
    if (duty_permille == 0u || duty_permille >= HAL_DUTY_FULL_PERMILLE) { /* held: at once (a vent) */
        duty_steps[v] = steps;
        valve_write(v, duty_permille != 0u);
    }
    SREG = sreg;
}

extern "C" uint16_t hal_serial_read(uint8_t *buf, uint16_t max_len)
{
    uint16_t n = 0u;
    while (n < max_len) {
        const int received = Serial.read();
        if (received < 0) {
            break;
        }
        buf[n++] = (uint8_t)received;
    }
    return n;
}

extern "C" void hal_serial_write(const uint8_t *buf, uint16_t len)
{
    /* Serial.write() waits while its ring is full; a frame that does not fit now is
     * dropped whole (the host sees a sequence gap, not a torn frame) */
    const int room = Serial.availableForWrite();
    if (room < 0 || (uint16_t)room < len) {
        return;
    }
    (void)Serial.write(buf, len);
}

extern "C" void hal_watchdog_kick(void)
{
    wdt_reset();
}

static void valves_init(uint32_t pwm_period_us)
{
    for (uint8_t v = 0u; v < VALVE_COUNT; v++) {
        digitalWrite(VALVE_PINS[v], LOW); /* every valve shut before it is an output */
        pinMode(VALVE_PINS[v], OUTPUT);
        // cppcheck-suppress cstyleCast ; the cast is inside the Arduino core's macro
        valve_port[v] = portOutputRegister(digitalPinToPort(VALVE_PINS[v]));
        valve_mask[v] = digitalPinToBitMask(VALVE_PINS[v]);
    }
    const uint32_t steps = pwm_period_us / PWM_STEP_US;
    pwm_period_steps = (uint8_t)(steps < 1u ? 1u : (steps > PWM_MAX_STEPS ? PWM_MAX_STEPS : steps));
    /* Timer2 (the core's init() set it up for analogWrite on D3 and D11, which this sketch
     * does not use): CTC, clk/64, 50 counts: an interrupt every 200 us */
    TCCR2A = (uint8_t)(1u << WGM21);
    TCCR2B = (uint8_t)(1u << CS22);
    OCR2A = (uint8_t)(F_CPU / 64u / (1000000u / PWM_STEP_US) - 1u);
    TCNT2 = 0u;
    TIMSK2 = (uint8_t)(1u << OCIE2A);
}

void setup()
{
    struct board_config cfg = board_config_defaults();
    cfg.wire = BOARD_WIRE_SERIAL;
    cfg.n_fingers = (uint8_t)VALVE_BOARD_FINGERS;
    cfg.sample_period_us = 1000000ul / VALVE_BOARD_RATE_HZ;
    cfg.watchdog_us = VALVE_BOARD_WATCHDOG_MS * 1000ul;
    cfg.inner_period_us = 2000u; /* 500 Hz, the core's lowest: no FPU, five chambers */
    cfg.adc_max_counts = 1023u;  /* 10 bits over AVcc (5 V): analogReference(DEFAULT) */
    cfg.adc_ref_mv = 5000.0f;
    valves_init(cfg.regulator.pwm_period_us);
    for (uint8_t bit = 0u; bit < 3u; bit++) {
        pinMode(MUX_SELECT_PINS[bit], OUTPUT);
    }
    ADCSRA = (uint8_t)((ADCSRA & ~0x07u) | (1u << ADPS2) | (1u << ADPS1)); /* clk/64: 250 kHz */
    DIDR0 = 0x1Fu; /* A0..A4 analog only: their digital input buffers off */
    Serial.begin(VALVE_BOARD_BAUD);
    wdt_enable(WDTO_250MS);
    if (board_init(&b, &cfg) != 0) {
        for (;;) { /* not kicked: the watchdog resets the MCU, which boots vented */
        }
    }
}

void loop()
{
    board_poll(&b);
}
