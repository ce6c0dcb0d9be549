/* The Cortex-M port (QEMU mps2-an500): what main.c calls of the HAL's side (hal_mps2.c). */
#ifndef BOARD_CORTEXM_PORT_H
#define BOARD_CORTEXM_PORT_H

#include <stdint.h>

/* the plant's step: 100 us, the longest pneumatics.h keeps accurate (the host build takes 50:
 * at 100 the image needs about a sixth of one of the machine's cores under QEMU, at 50 a quarter) */
#define PORT_PLANT_STEP_US 100u
/* a plant more than this behind the clock skips the rest (the image was stalled) */
#define PORT_PLANT_CATCH_UP_US 20000u
/* the main loop sleeps between passes; timer 0 wakes it at least this often */
#define PORT_WAKE_US 250u
#define PORT_RX_BYTES 1024u
#define PORT_TX_BYTES 2048u

struct port_stats {
    uint32_t plant_steps;      /* plant steps taken since boot */
    uint32_t plant_skipped_us; /* plant time skipped because the image fell behind */
    uint32_t rx_dropped;       /* received bytes lost to a full receive ring */
    uint32_t tx_dropped;       /* bytes dropped from a full transmit ring */
};

/* UARTs, SysTick (a free-running counter the clock extends to 32 bits), the
 * watchdog (when the machine models it: returns 1), the plant with n_fingers fingers. */
int port_init(uint32_t pwm_period_us, int n_fingers, uint32_t seed);

/* Once per main-loop pass: send what waits, advance the plant to the clock. */
void port_service(void);

/* Sleep until the next interrupt, unless a received byte waits. */
void port_idle(void);

/* The image's log lines, on UART1 (blocking: a log line is short and rare). */
void port_log(const char *text);
void port_log_u32(uint32_t value);

const struct port_stats *port_stats(void);

#endif
