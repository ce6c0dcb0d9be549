/* The HAL (core/hal.h) of the AVR port: an ATmega328P at 16 MHz (Arduino Nano or Uno) on
 * its registers, without the Arduino core. docs/board.md ("The AVR build") has the wiring.
 *
 *   serial-v1   USART0 (D0/D1, the board's USB serial), AVR_BAUD, both directions in
 *               interrupts through rings
 *   clock       Timer1 free-running at 2 MHz; its overflow (every 32.768 ms) counted in an
 *               interrupt: microseconds = overflows * 32768 + count / 2, which wraps at 2^32
 *   ADC         channel 2i (chamber i's pressure sensor) on A0..A4; channel 2i+1 (finger i's
 *               flex sensor) through a 74HC4051 8:1 analog multiplexer (S0..S2 on D2..D4)
 *               into A6. AVcc reference (5 V), 10 bits
 *   valves      ten outputs (inlet, exhaust of chambers 0..4) to the MOSFET gates: D5..D13,
 *               A5, in software PWM from Timer2 at 5 kHz (200 us steps of the 10 ms period)
 *   watchdog    the AVR's watchdog timer, 250 ms: a stuck main loop resets the MCU, which
 *               boots vented (every output low: inlet shut, exhaust shut until the core
 *               opens it in board_init)
 */
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/wdt.h>
#include <string.h>

#include "avr_port.h"
#include "hal.h"

#define PWM_STEP_US 200u
#define ADC_FLEX_INPUT 6u /* A6: the multiplexer's output */

struct valve_pin {
    volatile uint8_t *port;
    uint8_t mask;
};

/* chamber i's inlet is valve 2i, its exhaust 2i+1 */
static const struct valve_pin VALVE_PINS[2u * AVR_MAX_FINGERS] = {
    {&PORTD, 1u << PD5}, {&PORTD, 1u << PD6}, /* D5, D6 */
    {&PORTD, 1u << PD7}, {&PORTB, 1u << PB0}, /* D7, D8 */
    {&PORTB, 1u << PB1}, {&PORTB, 1u << PB2}, /* D9, D10 */
    {&PORTB, 1u << PB3}, {&PORTB, 1u << PB4}, /* D11, D12 */
    {&PORTB, 1u << PB5}, {&PORTC, 1u << PC5}, /* D13, A5 */
};

static volatile uint32_t t1_overflows;

static volatile uint8_t rx_ring[AVR_RX_BYTES];
static volatile uint8_t rx_head, rx_tail;
static volatile uint8_t tx_ring[AVR_TX_BYTES];
static volatile uint8_t tx_head, tx_tail;

static uint16_t pwm_period_steps;
static volatile uint16_t pwm_step;
static volatile uint8_t duty_steps_pending[2u * AVR_MAX_FINGERS];
static volatile uint8_t duty_steps[2u * AVR_MAX_FINGERS];

ISR(TIMER1_OVF_vect)
{
    t1_overflows++;
}

ISR(USART_RX_vect)
{
    const uint8_t byte = UDR0;
    const uint8_t next = (uint8_t)((rx_head + 1u) % AVR_RX_BYTES);
    if (next != rx_tail) { /* a full ring drops the byte, as a UART overrun would */
        rx_ring[rx_head] = byte;
        rx_head = next;
    }
}

ISR(USART_UDRE_vect)
{
    if (tx_tail == tx_head) {
        UCSR0B &= (uint8_t)~(1u << UDRIE0);
        return;
    }
    UDR0 = tx_ring[tx_tail];
    tx_tail = (uint8_t)((tx_tail + 1u) % AVR_TX_BYTES);
}

static void valve_write(uint8_t valve, uint8_t open)
{
    const struct valve_pin *pin = &VALVE_PINS[valve];
    if (open) {
        *pin->port |= pin->mask;
    } else {
        *pin->port &= (uint8_t)~pin->mask;
    }
}

ISR(TIMER2_COMPA_vect)
{
    uint16_t step = pwm_step;
    if (step == 0u) { /* a new PWM period: the duties set during the last one take effect */
        for (uint8_t v = 0u; v < 2u * AVR_MAX_FINGERS; v++) {
            duty_steps[v] = duty_steps_pending[v];
        }
    }
    for (uint8_t v = 0u; v < 2u * AVR_MAX_FINGERS; v++) {
        valve_write(v, step < duty_steps[v]);
    }
    step++;
    pwm_step = step >= pwm_period_steps ? 0u : step;
}

uint32_t hal_time_us(void)
{
    const uint8_t sreg = SREG;
    cli();
    const uint16_t count = TCNT1;
    uint32_t overflows = t1_overflows;
    if ((TIFR1 & (1u << TOV1)) && count < 0x8000u) {
        overflows++; /* it overflowed after interrupts were disabled: not yet counted */
    }
    SREG = sreg;
    return overflows * 32768u + (uint32_t)(count >> 1);
}

static uint16_t adc_convert(uint8_t input)
{
    ADMUX = (uint8_t)((1u << REFS0) | (input & 0x0Fu)); /* AVcc reference */
    ADCSRA |= (1u << ADSC);
    while (ADCSRA & (1u << ADSC)) {
    }
    return ADC;
}

uint16_t hal_adc_read(uint8_t channel)
{
    const uint8_t finger = channel / 2u;
    if (finger >= AVR_MAX_FINGERS) {
        return 0u;
    }
    if (channel % 2u == 0u) {
        return adc_convert(finger); /* A0..A4 */
    }
    PORTD = (uint8_t)((PORTD & ~(7u << PD2)) | (finger << PD2)); /* the multiplexer's S0..S2 */
    (void)adc_convert(ADC_FLEX_INPUT); /* the first conversion after a switch settles the mux */
    return adc_convert(ADC_FLEX_INPUT);
}

void hal_valve_pwm(uint8_t chamber, uint8_t valve, uint16_t duty_permille)
{
    if (chamber >= AVR_MAX_FINGERS || valve > 1u) {
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
        valve_write(v, clamped == HAL_DUTY_FULL_PERMILLE);
    }
    SREG = sreg;
}

uint16_t hal_serial_read(uint8_t *buf, uint16_t max_len)
{
    uint16_t n = 0u;
    while (n < max_len && rx_tail != rx_head) {
        buf[n++] = rx_ring[rx_tail];
        rx_tail = (uint8_t)((rx_tail + 1u) % AVR_RX_BYTES);
    }
    return n;
}

void hal_serial_write(const uint8_t *buf, uint16_t len)
{
    for (uint16_t i = 0u; i < len; i++) {
        const uint8_t next = (uint8_t)((tx_head + 1u) % AVR_TX_BYTES);
        if (next == tx_tail) {
            break; /* the ring is full: the rest is dropped (hal.h) */
        }
        tx_ring[tx_head] = buf[i];
        tx_head = next;
    }
    UCSR0B |= (1u << UDRIE0);
}

void hal_watchdog_kick(void)
{
    wdt_reset();
}

void avr_port_init(uint32_t pwm_period_us)
{
    /* a watchdog reset leaves the watchdog running: clear its flag and stop it first */
    MCUSR = 0u;
    wdt_disable();
    /* valve outputs low (every valve shut), the multiplexer's select lines outputs */
    for (uint8_t v = 0u; v < 2u * AVR_MAX_FINGERS; v++) {
        valve_write(v, 0u);
    }
    DDRD |= (uint8_t)((1u << PD5) | (1u << PD6) | (1u << PD7) | (7u << PD2));
    DDRB |= (uint8_t)((1u << PB0) | (1u << PB1) | (1u << PB2) | (1u << PB3) | (1u << PB4) | (1u << PB5));
    DDRC |= (uint8_t)(1u << PC5);
    const uint32_t steps = pwm_period_us / PWM_STEP_US;
    pwm_period_steps = (uint16_t)(steps < 1u ? 1u : (steps > 250u ? 250u : steps));
    /* USART0: 8N1, double speed */
    UCSR0A = (1u << U2X0);
    UBRR0 = (uint16_t)((F_CPU + 4u * AVR_BAUD) / (8u * AVR_BAUD) - 1u);
    UCSR0C = (1u << UCSZ01) | (1u << UCSZ00);
    UCSR0B = (1u << RXEN0) | (1u << TXEN0) | (1u << RXCIE0);
    /* Timer1: normal mode, clk/8 (2 MHz), overflow interrupt */
    TCCR1A = 0u;
    TCCR1B = (1u << CS11);
    TIMSK1 = (1u << TOIE1);
    /* Timer2: CTC, clk/64, 50 counts: 5 kHz */
    TCCR2A = (1u << WGM21);
    TCCR2B = (1u << CS22);
    OCR2A = (uint8_t)(F_CPU / 64u / (1000000u / PWM_STEP_US) - 1u);
    TIMSK2 = (1u << OCIE2A);
    /* ADC: enabled, clk/64 (250 kHz: 52 us a conversion) */
    ADCSRA = (1u << ADEN) | (1u << ADPS2) | (1u << ADPS1);
    DIDR0 = 0x1Fu; /* A0..A4 analog only */
    wdt_enable(WDTO_250MS);
    sei();
}
