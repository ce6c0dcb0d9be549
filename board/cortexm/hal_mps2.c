/* The HAL (core/hal.h) of the Cortex-M port on QEMU's mps2-an500: serial-v1 on UART0 (the
 * receive side in its interrupt, into a ring), the microsecond clock from SysTick, the
 * CMSDK watchdog, and the ADC and valve PWM wired to the physical plant (board/plant)
 * linked into the image, stepped from the same clock. */
#include <string.h>

#include "finger.h"
#include "hal.h"
#include "host.h"
#include "mps2.h"
#include "plant.h"
#include "port.h"

#define SYSTICK_RELOAD 0xFFFFFFu /* the largest: 24 bits */
#define TICKS_PER_US (MPS2_SYSCLK_HZ / 1000000u)
#define UART_BAUDDIV_115200 (MPS2_SYSCLK_HZ / 115200u)
/* the watchdog's period: NMI after one, reset after two (0.5 s of a stuck main loop) */
#define WDOG_PERIOD_TICKS (MPS2_SYSCLK_HZ / 4u)

static uint32_t last_ticks; /* SysTick's count at the previous read */
static uint32_t tick_rem;   /* ticks not yet a whole microsecond */
static uint32_t clock_us;

static volatile uint8_t rx_ring[PORT_RX_BYTES];
static volatile uint32_t rx_head; /* written by the interrupt */
static volatile uint32_t rx_tail; /* written by the main loop */

static uint8_t tx_ring[PORT_TX_BYTES];
static uint32_t tx_head, tx_tail;

static int have_watchdog;

static struct plant plant;
static uint16_t duty_pending[PLANT_MAX_FINGERS][2];
static uint16_t duty_latched[PLANT_MAX_FINGERS][2];
static uint32_t plant_time_us;  /* the plant has been advanced to here (hal clock) */
static uint32_t pwm_phase_us;   /* where in the PWM period the plant is */
static uint32_t pwm_period_us;
static struct port_stats stats;

static void rx_drain(void)
{
    while (UART_STATE(UART0_BASE) & UART_STATE_RX_FULL) {
        const uint8_t byte = (uint8_t)UART_DATA(UART0_BASE);
        const uint32_t head = rx_head;
        if (head - rx_tail < PORT_RX_BYTES) {
            rx_ring[head % PORT_RX_BYTES] = byte;
            rx_head = head + 1u;
        } else {
            stats.rx_dropped++;
        }
    }
}

void uart0_rx_handler(void)
{
    /* clear first, then empty the data register: a byte that lands after the last read
     * raises the interrupt again. (Cleared after, it could be left unread with its
     * interrupt gone, and the UART, full, would take no more.) */
    UART_INTCLEAR(UART0_BASE) = UART_INT_RX;
    rx_drain();
}

void timer0_handler(void)
{
    TIMER0_INTCLEAR = 1u; /* nothing else: its work is to end the main loop's WFI */
}

void port_idle(void)
{
    /* sleep until an interrupt (a received byte, or timer 0's tick) unless a byte already
     * waits. A busy-polling vCPU would hold QEMU's I/O thread off the pty (every UART and
     * SysTick access takes QEMU's big lock), and the host's bytes would trickle in. WFI
     * wakes on an interrupt that is pending even while PRIMASK masks it. */
    __asm__ volatile("cpsid i" ::: "memory");
    if (rx_head == rx_tail) {
        __asm__ volatile("dsb\n\twfi" ::: "memory");
    }
    __asm__ volatile("cpsie i" ::: "memory");
}

uint32_t hal_time_us(void)
{
    const uint32_t now_ticks = SYST_CVR;
    tick_rem += (last_ticks - now_ticks) & SYSTICK_RELOAD;
    last_ticks = now_ticks;
    clock_us += tick_rem / TICKS_PER_US;
    tick_rem %= TICKS_PER_US;
    return clock_us;
}

uint16_t hal_adc_read(uint8_t channel)
{
    return plant_adc(&plant, channel);
}

void hal_valve_pwm(uint8_t chamber, uint8_t valve, uint16_t duty_permille)
{
    if (chamber < PLANT_MAX_FINGERS && valve < 2u) {
        duty_pending[chamber][valve] = duty_permille > 1000u ? 1000u : duty_permille;
        if (duty_permille == 0u || duty_permille >= 1000u) {
            /* held shut or open (a vent): the timer's output forced at once */
            duty_latched[chamber][valve] = duty_pending[chamber][valve];
        }
    }
}

uint16_t hal_serial_read(uint8_t *buf, uint16_t max_len)
{
    uint16_t n = 0u;
    uint32_t tail = rx_tail;
    const uint32_t head = rx_head;
    while (n < max_len && tail != head) {
        buf[n++] = rx_ring[tail % PORT_RX_BYTES];
        tail++;
    }
    rx_tail = tail;
    return n;
}

static void tx_drain(void)
{
    while (tx_tail != tx_head && !(UART_STATE(UART0_BASE) & UART_STATE_TX_FULL)) {
        UART_DATA(UART0_BASE) = tx_ring[tx_tail % PORT_TX_BYTES];
        tx_tail++;
    }
}

void hal_serial_write(const uint8_t *buf, uint16_t len)
{
    for (uint16_t i = 0u; i < len; i++) {
        if (tx_head - tx_tail < PORT_TX_BYTES) {
            tx_ring[tx_head % PORT_TX_BYTES] = buf[i];
            tx_head++;
        } else {
            stats.tx_dropped++;
        }
    }
    tx_drain();
}

void hal_watchdog_kick(void)
{
    if (have_watchdog) {
        WDOG_LOCK = WDOG_UNLOCK_KEY; /* the lock guards every register, INTCLR too */
        WDOG_INTCLR = 1u;            /* any write reloads the counter */
        WDOG_LOCK = 0u;
    }
}

static void uart_init(uint32_t base, uint32_t ctrl)
{
    UART_BAUDDIV(base) = UART_BAUDDIV_115200;
    UART_CTRL(base) = ctrl;
}

int port_init(uint32_t pwm_period, int n_fingers, uint32_t seed)
{
    pwm_period_us = pwm_period > 0u ? pwm_period : 1u;
    plant_init(&plant, host_default_hand, n_fingers, seed);
    uart_init(UART1_BASE, UART_CTRL_TX_EN);
    uart_init(UART0_BASE, UART_CTRL_TX_EN | UART_CTRL_RX_EN | UART_CTRL_RX_INT_EN);
    TIMER0_RELOAD = MPS2_SYSCLK_HZ / 1000000u * PORT_WAKE_US - 1u;
    TIMER0_CTRL = TIMER_CTRL_EN | TIMER_CTRL_IRQ_EN;
    NVIC_ISER0 = (1u << NVIC_UART0_RX_IRQ) | (1u << NVIC_TIMER0_IRQ);
    SYST_RVR = SYSTICK_RELOAD;
    SYST_CVR = 0u;
    SYST_CSR = SYST_CSR_ENABLE | SYST_CSR_CLKSOURCE_CPU; /* free-running, no interrupt */
    last_ticks = SYST_CVR;
    have_watchdog = (WDOG_PERIPHID0 & 0xFFu) == WDOG_PERIPHID0_VALUE;
    if (have_watchdog) {
        WDOG_LOCK = WDOG_UNLOCK_KEY;
        WDOG_LOAD = WDOG_PERIOD_TICKS;
        WDOG_CTRL = WDOG_CTRL_INTEN | WDOG_CTRL_RESEN;
        WDOG_LOCK = 0u;
    }
    plant_time_us = hal_time_us();
    return have_watchdog;
}

static void advance_plant(void)
{
    int open[PLANT_MAX_FINGERS][2];
    const uint32_t now_us = hal_time_us();
    if (now_us - plant_time_us > PORT_PLANT_CATCH_UP_US) {
        const uint32_t skip_us = now_us - plant_time_us - PORT_PLANT_CATCH_UP_US;
        stats.plant_skipped_us += skip_us;
        plant_time_us += skip_us;
        pwm_phase_us = (pwm_phase_us + skip_us) % pwm_period_us;
    }
    while (now_us - plant_time_us >= PORT_PLANT_STEP_US) {
        if (pwm_phase_us < PORT_PLANT_STEP_US) { /* a new PWM period: the shadow registers load */
            memcpy(duty_latched, duty_pending, sizeof duty_latched);
        }
        for (int i = 0; i < plant.n_fingers; i++) {
            for (int v = 0; v < 2; v++) {
                open[i][v] = pwm_phase_us * 1000u < (uint32_t)duty_latched[i][v] * pwm_period_us;
            }
        }
        plant_step(&plant, (const int(*)[2])open, PORT_PLANT_STEP_US * 1e-6);
        plant_time_us += PORT_PLANT_STEP_US;
        pwm_phase_us = (pwm_phase_us + PORT_PLANT_STEP_US) % pwm_period_us;
        stats.plant_steps++;
    }
}

void port_service(void)
{
    __asm__ volatile("cpsid i" ::: "memory");
    rx_drain(); /* what the interrupt has not taken yet */
    __asm__ volatile("cpsie i" ::: "memory");
    tx_drain();
    advance_plant();
}

void port_log(const char *text)
{
    for (; *text != '\0'; text++) {
        while (UART_STATE(UART1_BASE) & UART_STATE_TX_FULL) {
        }
        UART_DATA(UART1_BASE) = (uint8_t)*text;
    }
}

void port_log_u32(uint32_t value)
{
    char digits[11];
    int n = 0;
    do {
        digits[n++] = (char)('0' + value % 10u);
        value /= 10u;
    } while (value != 0u);
    char text[11];
    for (int i = 0; i < n; i++) {
        text[i] = digits[n - 1 - i];
    }
    text[n] = '\0';
    port_log(text);
}

const struct port_stats *port_stats(void)
{
    return &stats;
}
