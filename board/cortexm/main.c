/* board-cortexm: the valve-board firmware core (board/core) on a Cortex-M7, run under QEMU's
 * mps2-an500 machine with the physical plant (board/plant) linked in behind the HAL. UART0
 * carries serial-v1 (QEMU's `-serial pty`); UART1 carries the image's log lines: its
 * configuration, changes of state, each watchdog vent and once a second its statistics.
 * docs/board.md ("The Cortex-M build under QEMU") has the command lines.
 *
 * The profile's numbers are fixed at build time (a real board's are too): the defaults are
 * the shipped serial-v1.yaml's (5 fingers, 100 Hz, a 100 ms watchdog). */
#include <stdint.h>

#include "board.h"
#include "port.h"

#ifndef CORTEXM_FINGERS
#define CORTEXM_FINGERS 5
#endif
#ifndef CORTEXM_RATE_HZ
#define CORTEXM_RATE_HZ 100u
#endif
#ifndef CORTEXM_WATCHDOG_MS
#define CORTEXM_WATCHDOG_MS 100u
#endif
#define STATS_EVERY_US 1000000u

static const char *const STATES[] = {"booting", "idle", "running", "watchdog_vented", "fault"};

static void log_stats(const struct board *b)
{
    const struct port_stats *s = port_stats();
    port_log("stats: uptime_ms=");
    port_log_u32(board_uptime_ms(b));
    port_log(" plant_steps=");
    port_log_u32(s->plant_steps);
    port_log(" plant_skipped_us=");
    port_log_u32(s->plant_skipped_us);
    port_log(" rx_dropped=");
    port_log_u32(s->rx_dropped);
    port_log(" tx_dropped=");
    port_log_u32(s->tx_dropped);
    port_log(" rx_errors=");
    port_log_u32(b->rx_errors);
    port_log("\n");
}

int main(void)
{
    static struct board b;
    struct board_config cfg = board_config_defaults();
    cfg.wire = BOARD_WIRE_SERIAL;
    cfg.n_fingers = (uint8_t)CORTEXM_FINGERS;
    cfg.sample_period_us = 1000000u / CORTEXM_RATE_HZ;
    cfg.watchdog_us = CORTEXM_WATCHDOG_MS * 1000u;
    const int have_watchdog = port_init(cfg.regulator.pwm_period_us, CORTEXM_FINGERS, 1u);
    port_log("board-cortexm: firmware ");
    port_log_u32(cfg.firmware_version[0]);
    port_log(".");
    port_log_u32(cfg.firmware_version[1]);
    port_log(".");
    port_log_u32(cfg.firmware_version[2]);
    port_log(", protocol ");
    port_log_u32(cfg.protocol_version);
    port_log(", ");
    port_log_u32(cfg.n_fingers);
    port_log(" fingers, serial-v1 on UART0, ");
    port_log_u32(CORTEXM_RATE_HZ);
    port_log(" Hz, watchdog ");
    port_log_u32(CORTEXM_WATCHDOG_MS);
    port_log(" ms, hardware watchdog ");
    port_log(have_watchdog ? "cmsdk-apb-watchdog (reset after 0.5 s stuck)\n"
                           : "none modelled (kick is a no-op)\n");
    if (board_init(&b, &cfg) != 0) {
        port_log("error: the firmware refused its configuration\n");
        for (;;) {
            port_service(); /* the watchdog is not kicked: a real board resets */
        }
    }
    port_log("ready\n");

    uint32_t vents_logged = 0u;
    uint8_t state = b.state;
    uint8_t fault = b.fault_code;
    uint32_t stats_us = b.now_us;
    for (;;) {
        port_service();
        board_poll(&b);
        if (b.vent_count != vents_logged) {
            vents_logged = b.vent_count;
            port_log("watchdog: no valid command for ");
            port_log_u32((b.vent_us - b.last_command_us) / 1000u);
            port_log(" ms: vented every valve (uptime_ms=");
            port_log_u32(board_uptime_ms(&b));
            port_log(")\n");
        }
        if (b.state != state || b.fault_code != fault) {
            state = b.state;
            fault = b.fault_code;
            port_log("state: ");
            port_log(STATES[state < 5u ? state : 0u]);
            port_log(", fault_code ");
            port_log_u32(fault);
            port_log(", uptime ");
            port_log_u32(board_uptime_ms(&b));
            port_log(" ms\n");
        }
        if (b.now_us - stats_us >= STATS_EVERY_US) {
            stats_us += STATS_EVERY_US;
            log_stats(&b);
        }
        port_idle();
    }
}
