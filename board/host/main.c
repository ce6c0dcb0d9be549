/* board-host: the valve-board firmware core as a Linux process, linked with the physical
 * plant and run at real time, on a pseudo-terminal (serial-v1, or can-v1 behind an SLCAN
 * adapter). `board-host --help` says how to run it. */
#include <errno.h>
#include <poll.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "board.h"
#include "hal.h"
#include "host.h"

static const char USAGE[] =
    "usage: board-host --port PATH [--wire serial|slcan] [options]\n"
    "\n"
    "Run the reference valve-board firmware (board/core) on this machine, with a simulated\n"
    "hand behind it (board/plant: the pneumatics as physics driving each finger's PRBM, read\n"
    "through an ADC). It creates a pseudo-terminal, makes PATH a symlink to it and prints\n"
    "\"ready: PATH\"; the host opens PATH as it would a USB serial port. This is a test image:\n"
    "it answers the host's fault requests (docs/board.md).\n"
    "\n"
    "  --port PATH              the symlink to create (an existing file that is not one is refused)\n"
    "  --wire serial|slcan      serial-v1 (serial-v1.yaml), or can-v1 behind an SLCAN adapter\n"
    "                           (can-v1-slcan.yaml); default serial\n"
    "  --fingers N              the first N fingers of the default hand (1..5, default 5)\n"
    "  --rate-hz HZ             the sample rate: the profile's control.rate_hz (default 100)\n"
    "  --watchdog-ms MS         the profile's safety.firmware_watchdog_ms (default 100)\n"
    "  --protocol-version N     the protocol to speak (default 1; another tests the host's refusal)\n"
    "  --firmware-version X.Y.Z the version to report (default 1.0.0)\n"
    "  --pressure-limit-kpa P   vent and report over_pressure above it (default 300)\n"
    "  --seed N                 the plant's sensor noise seed (default 1)\n"
    "  --seconds S              stop after S seconds (default: run until SIGTERM)\n";

static volatile sig_atomic_t stop_requested;

static void on_signal(int sig)
{
    (void)sig;
    stop_requested = 1;
}

static int fail(const char *message, const char *value)
{
    fprintf(stderr, "board-host: %s%s%s (see --help)\n", message, value ? ": " : "", value ? value : "");
    return 2;
}

static int number(const char *text, double low, double high, double *out)
{
    char *end = NULL;
    errno = 0;
    const double v = strtod(text, &end);
    if (errno != 0 || end == text || *end != '\0' || !(v >= low && v <= high)) {
        return -1;
    }
    *out = v;
    return 0;
}

int main(int argc, char **argv)
{
    struct board_config cfg = board_config_defaults();
    const char *port = NULL;
    double seconds = -1.0;
    double seed = 1.0;
    int n_fingers = HOST_DEFAULT_FINGERS;
    for (int i = 1; i < argc; i++) {
        const char *opt = argv[i];
        if (strcmp(opt, "--help") == 0 || strcmp(opt, "-h") == 0) {
            fputs(USAGE, stdout);
            return 0;
        }
        if (i + 1 >= argc) {
            return fail("missing value or unknown option", opt);
        }
        const char *val = argv[++i];
        double v = 0.0;
        if (strcmp(opt, "--port") == 0) {
            port = val;
        } else if (strcmp(opt, "--wire") == 0) {
            if (strcmp(val, "serial") != 0 && strcmp(val, "slcan") != 0) {
                return fail("--wire must be serial or slcan, not", val);
            }
            cfg.wire = strcmp(val, "slcan") == 0 ? BOARD_WIRE_CAN : BOARD_WIRE_SERIAL;
        } else if (strcmp(opt, "--fingers") == 0) {
            if (number(val, 1, HOST_DEFAULT_FINGERS, &v) != 0 || v != (int)v) {
                return fail("--fingers must be a whole number from 1 to 5, not", val);
            }
            n_fingers = (int)v;
        } else if (strcmp(opt, "--rate-hz") == 0) {
            if (number(val, 1.0, 1000.0, &v) != 0) {
                return fail("--rate-hz must be 1 to 1000, not", val);
            }
            cfg.sample_period_us = (uint32_t)(1e6 / v + 0.5);
        } else if (strcmp(opt, "--watchdog-ms") == 0) {
            if (number(val, 1.0, 60000.0, &v) != 0) {
                return fail("--watchdog-ms must be 1 to 60000, not", val);
            }
            cfg.watchdog_us = (uint32_t)(v * 1e3 + 0.5);
        } else if (strcmp(opt, "--protocol-version") == 0) {
            if (number(val, 1, 65535, &v) != 0 || v != (int)v) {
                return fail("--protocol-version must be a whole number from 1 to 65535, not", val);
            }
            cfg.protocol_version = (uint16_t)v;
        } else if (strcmp(opt, "--firmware-version") == 0) {
            unsigned major, minor, patch;
            char extra;
            if (sscanf(val, "%u.%u.%u%c", &major, &minor, &patch, &extra) != 3 || major > 255 || minor > 255
                || patch > 255) {
                return fail("--firmware-version must be X.Y.Z with numbers below 256, not", val);
            }
            cfg.firmware_version[0] = (uint8_t)major;
            cfg.firmware_version[1] = (uint8_t)minor;
            cfg.firmware_version[2] = (uint8_t)patch;
        } else if (strcmp(opt, "--pressure-limit-kpa") == 0) {
            if (number(val, 1.0, 650.0, &v) != 0) {
                return fail("--pressure-limit-kpa must be 1 to 650, not", val);
            }
            cfg.pressure_limit_kpa = (float)v;
        } else if (strcmp(opt, "--seed") == 0) {
            if (number(val, 0, 4294967295.0, &v) != 0 || v != (double)(uint32_t)v) {
                return fail("--seed must be a whole number from 0 to 4294967295, not", val);
            }
            seed = v;
        } else if (strcmp(opt, "--seconds") == 0) {
            if (number(val, 0.001, 1e7, &v) != 0) {
                return fail("--seconds must be a positive number, not", val);
            }
            seconds = v;
        } else {
            return fail("unknown option", opt);
        }
    }
    if (port == NULL) {
        return fail("--port PATH is required", NULL);
    }
    cfg.n_fingers = (uint8_t)n_fingers;

    memset(&host, 0, sizeof host);
    char device[128];
    host.fd = host_pty_open(port, device, sizeof device);
    if (host.fd < 0) {
        fprintf(stderr, "board-host: cannot create the pseudo-terminal at %s: %s\n", port, strerror(errno));
        return 2;
    }
    host.slcan = cfg.wire == BOARD_WIRE_CAN;
    host.t0_ns = 0u;
    host.t0_ns = (uint64_t)(host_monotonic_s() * 1e9);
    if (hal_plant_init(&host.plant, cfg.regulator.pwm_period_us, host_default_hand, n_fingers, (uint32_t)seed,
                       0u) != 0) {
        fprintf(stderr, "board-host: the default hand's fingers cannot be simulated\n");
        unlink(port);
        return 2;
    }
    hal_plant_current = &host.plant;

    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sigaction(SIGTERM, &sa, NULL);
    sigaction(SIGINT, &sa, NULL);

    static struct board b;
    if (board_init(&b, &cfg) != 0) {
        fprintf(stderr, "board-host: the firmware refused its configuration\n");
        unlink(port);
        return 2;
    }
    printf("board-host: firmware %u.%u.%u, protocol %u, %d fingers, %s on %s (%s), %.0f Hz, watchdog %.0f ms\n",
           cfg.firmware_version[0], cfg.firmware_version[1], cfg.firmware_version[2], cfg.protocol_version,
           n_fingers, host.slcan ? "can-v1 behind SLCAN" : "serial-v1", port, device, 1e6 / cfg.sample_period_us,
           cfg.watchdog_us / 1e3);
    printf("ready: %s\n", port);
    fflush(stdout);

    uint32_t vents_logged = 0u;
    uint8_t state = b.state;
    uint8_t fault = b.fault_code;
    static const char *const STATES[] = {"booting", "idle", "running", "watchdog_vented", "fault"};
    while (!stop_requested && (seconds < 0.0 || host_now_us() < (uint64_t)(seconds * 1e6))) {
        struct pollfd pfd = {host.fd, POLLIN, 0};
        /* wake for input, or at the next inner tick (1 ms) at the latest */
        const int32_t until_tick_us = (int32_t)(b.next_inner_us - (uint32_t)host_now_us());
        const int timeout_ms = until_tick_us <= 0 ? 0 : (until_tick_us + 999) / 1000;
        (void)poll(&pfd, 1, timeout_ms);
        host_pump_input();
        hal_plant_advance(&host.plant, host_now_us());
        board_poll(&b);
        if (b.vent_count != vents_logged) {
            vents_logged = b.vent_count;
            printf("watchdog: no valid command for %.0f ms: vented every valve (t_monotonic_s=%.6f)\n",
                   (double)(b.vent_us - b.last_command_us) / 1e3,
                   host_monotonic_s() - (double)(uint32_t)(b.now_us - b.vent_us) / 1e6);
            fflush(stdout);
        }
        if (b.state != state || b.fault_code != fault) {
            printf("state: %s, fault_code %u, uptime %u ms\n", STATES[b.state < 5u ? b.state : 0u],
                   (unsigned)b.fault_code, (unsigned)board_uptime_ms(&b));
            fflush(stdout);
            state = b.state;
            fault = b.fault_code;
        }
    }
    unlink(port);
    printf("stopped: %llu bytes dropped (no reader)\n", (unsigned long long)host.dropped_bytes);
    return 0;
}
