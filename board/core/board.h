/* The valve-board firmware core: protocol (serial-v1 or can-v1), sampling, the chamber
 * pressure regulators, the watchdog and the board's own faults. Portable C99: no heap, no
 * RTOS, no stdio; all state in one caller-allocated struct board; hardware through hal.h.
 *
 *     static struct board b;
 *     board_init(&b, &config);           // config: board_config_defaults() then edits
 *     for (;;) board_poll(&b);           // the main loop; never blocks
 */
#ifndef BOARD_BOARD_H
#define BOARD_BOARD_H

#include <stdint.h>

#include "regulator.h"
#include "serial_v1.h"
#include "inject.h"

#define BOARD_MAX_FINGERS 8u
#define BOARD_CAN_UNIT_BYTES 8u

/* FirmwareState on the wire (hand_service/wire/messages.py) */
enum board_state {
    BOARD_BOOTING = 0,         /* silent, valves vented */
    BOARD_IDLE = 1,            /* vented, waiting for the first valid command */
    BOARD_RUNNING = 2,         /* regulating to the host's setpoints */
    BOARD_WATCHDOG_VENTED = 3, /* no valid command within the watchdog time */
    BOARD_FAULT = 4            /* a fault of the board's own: vented, commands ignored */
};

/* FirmwareFault on the wire */
enum board_fault {
    BOARD_FAULT_NONE = 0,
    BOARD_FAULT_VALVE_DRIVER = 1,
    BOARD_FAULT_PRESSURE_SENSOR = 2,
    BOARD_FAULT_OVER_PRESSURE = 3,
    BOARD_FAULT_INTERNAL = 4
};

enum board_wire { BOARD_WIRE_SERIAL = 0, BOARD_WIRE_CAN = 1 };

struct board_config {
    uint8_t wire;                   /* enum board_wire */
    uint8_t n_fingers;              /* the profile's hand: order, count */
    uint16_t protocol_version;      /* the protocol this board speaks */
    uint8_t firmware_version[3];    /* major, minor, patch */
    uint32_t sample_period_us;      /* 1 / the profile's control.rate_hz */
    uint32_t watchdog_us;           /* the profile's safety.firmware_watchdog_ms */
    uint32_t inner_period_us;       /* the pressure loop's period (<= 2000: >= 500 Hz) */
    uint8_t status_every_samples;   /* heartbeat: every this many samples (10: 10 Hz at 100 Hz) */
    uint16_t adc_max_counts;        /* full scale of the ADC (4095: 12 bits) */
    float adc_ref_mv;               /* the ADC's reference: full scale in mV */
    /* the chamber pressure sensor: kPa = (mV - offset) / sensitivity */
    float pressure_offset_mv;
    float pressure_sensitivity_mv_per_kpa;
    float pressure_valid_min_mv;    /* outside [min, max]: an open or shorted sensor */
    float pressure_valid_max_mv;
    uint16_t pressure_fault_ticks;  /* that many inner ticks in a row outside it: a fault */
    float pressure_limit_kpa;       /* above it: vent, fault OVER_PRESSURE */
    uint32_t fault_clear_us;        /* a sensor or pressure fault clears after this long gone */
    uint8_t can_error_frames;       /* the CAN link hands error frames to the host (hal_can_error) */
    uint8_t broken;                 /* test images: enum inject_broken, a rule broken on purpose */
    struct regulator_config regulator;
};

/* One received valve command being reassembled (can-v1 sends one frame per finger). */
struct board_partial_command {
    uint8_t active;
    uint8_t sequence;
    uint8_t received_mask;
    float pressure_kpa[BOARD_MAX_FINGERS];
};

struct board {
    struct board_config cfg;
    uint8_t state;                  /* enum board_state */
    uint8_t fault_code;             /* enum board_fault (or an injected code) */
    uint8_t fault_injected;         /* the fault is the test image's FIRMWARE_FAULT */
    uint8_t refused;                /* the host asked for a protocol this board does not speak */
    uint16_t echo_protocol;         /* INJECT_BROKEN_ECHO_VERSION: the version it answers with */
    uint8_t sequence;               /* sample counter, from 0 at boot */
    uint8_t command_sequence;       /* the newest valid command's sequence */
    uint8_t tx_frame_sequence;      /* serial-v1 frame header counter */
    uint16_t samples_since_status;
    uint32_t rx_errors;             /* bad frames received (sent saturated at 255) */
    uint32_t hal_last_us;           /* hal_time_us() at the previous poll */
    int32_t drift_remainder;        /* CLOCK_DRIFT (test images): the sub-us part, in us*ppm */
    uint32_t uptime_ms;             /* since the announce (counts on past the clock's wrap) */
    uint32_t uptime_rem_us;
    uint32_t last_poll_us;
    uint32_t boot_end_us;           /* BOOTING until then */
    uint32_t last_command_us;
    uint32_t next_sample_us;
    uint32_t next_inner_us;
    uint32_t now_us;                /* the board's clock: hal_time_us(), or drifting (test images) */
    uint32_t fault_seen_us;         /* last time the fault's condition held */
    uint16_t pressure_bad_ticks[BOARD_MAX_FINGERS];
    float command_kpa[BOARD_MAX_FINGERS];
    float pressure_kpa[BOARD_MAX_FINGERS];   /* measured at the newest inner tick */
    float pressure_sum_kpa[BOARD_MAX_FINGERS]; /* the valid ones since the last sample: its mean */
    uint16_t pressure_ticks[BOARD_MAX_FINGERS];
    struct regulator regulators[BOARD_MAX_FINGERS];
    struct serial_v1_decoder decoder;
    struct board_partial_command partial;
    uint32_t vent_count;            /* watchdog vents since power-up (for the host build's log) */
    uint32_t vent_us;               /* hal time of the newest watchdog vent */
#ifdef BOARD_TEST_IMAGE
    struct inject inject;
    float broken_flex_mv;           /* INJECT_BROKEN_FLEX_STUCK: the reading it froze at */
    uint8_t broken_flex_held;
#endif
};

struct board_config board_config_defaults(void);

/* 0 on success; -1 if the configuration is out of range (then the board stays vented). */
int board_init(struct board *b, const struct board_config *cfg);

/* One pass of the main loop: receive, regulate, sample, send. Call as often as possible
 * (at least once per inner period). */
void board_poll(struct board *b);

/* Uptime in ms as the status reports it. */
uint32_t board_uptime_ms(const struct board *b);

#endif
