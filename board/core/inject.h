/* Fault injection for test images only (compiled with -DBOARD_TEST_IMAGE): the host's
 * FaultRequest (serial-v1 type 0x7E, can-v1 FaultInject 0x7E0) makes the board misbehave on
 * purpose (docs/firmware.md lists every kind), so the host's detection can be tested
 * against the real firmware. A release image has none of it:
 * the request is then an unknown message, counted in rx_errors.
 *
 * struct board_unit (one outgoing frame) is used by every image.
 */
#ifndef BOARD_INJECT_H
#define BOARD_INJECT_H

#include <stdint.h>

#include "serial_v1.h"

#define INJECT_KINDS 19u      /* FaultKind 0..18 (hand_service/wire/messages.py) */
#ifndef INJECT_QUEUE_UNITS
#define INJECT_QUEUE_UNITS 48u /* DELAY holds this many frames at most (then drops) */
#endif
#define INJECT_ALL_FINGERS 255u

enum inject_kind {
    INJECT_CLEAR = 0, INJECT_DROP = 1, INJECT_DELAY = 2, INJECT_CORRUPT = 3, INJECT_STUCK_SENSOR = 4,
    INJECT_SENSOR_OUT_OF_RANGE = 5, INJECT_SILENCE = 6, INJECT_REBOOT = 7, INJECT_FIRMWARE_FAULT = 8,
    INJECT_PRESSURE_NAN = 9, INJECT_PRESSURE_STUCK = 10, INJECT_VALVES_IGNORED = 11,
    INJECT_PROTOCOL_CHANGE = 12, INJECT_SEQUENCE_STUCK = 13, INJECT_CAN_ERROR_FRAMES = 14,
    INJECT_BUS_OFF = 15, INJECT_CLOCK_DRIFT = 16, INJECT_SENSOR_NAN = 17,
    INJECT_SENSOR_DRIFT = 18
};

/* A rule of the protocol a test image breaks on purpose for as long as it runs
 * (board_config.broken), so that the host's board-check can be shown to catch it
 * (tests/boardcheck/; `hand-service mock-firmware --broken NAME`). */
enum inject_broken {
    INJECT_BROKEN_NONE = 0,
    INJECT_BROKEN_NO_WATCHDOG = 1,    /* never vents when the commands stop */
    INJECT_BROKEN_WRONG_CRC = 2,      /* serial-v1 with CRC-16/XMODEM (init 0); can-v1's E2E byte inverted */
    INJECT_BROKEN_STUCK_SEQUENCE = 3, /* every sample carries the same sequence number */
    INJECT_BROKEN_ECHO_VERSION = 4,   /* answers a VersionRequest with the protocol the host asked for */
    INJECT_BROKEN_SILENT_REBOOT = 5,  /* does not announce itself (VersionInfo) when it boots */
    INJECT_BROKEN_QUIET_IDLE = 6,     /* sends no samples unless RUNNING */
    INJECT_BROKEN_COUNTS_RUBBISH = 7, /* counts rubbish bytes and other nodes' frames in rx_errors */
    INJECT_BROKEN_ZERO_VENTS = 8,     /* takes a command of 0 kPa on every finger for a vent: leaves
                                       * RUNNING for WATCHDOG_VENTED (0 kPa is a valid setpoint) */
    INJECT_BROKEN_VALVES_DEAD = 9,    /* no valve ever opens: no chamber follows its setpoint */
    INJECT_BROKEN_VALVE_STUCK = 10,   /* INJECT_BROKEN_FINGER's valves never open */
    INJECT_BROKEN_PRESSURE_NAN = 11,  /* reports NaN (not measured) for every chamber */
    INJECT_BROKEN_PRESSURE_X2 = 12,   /* reports every chamber at twice its pressure */
    INJECT_BROKEN_FLEX_STUCK = 13,    /* INJECT_BROKEN_FINGER's flex reading never moves */
    INJECT_BROKEN_FLEX_X2 = 14        /* INJECT_BROKEN_FINGER's flex reading is twice its mV */
};
#define INJECT_BROKEN_RULES 15u
#define INJECT_BROKEN_FINGER 1u /* the finger a one-finger rule breaks (the hand's second) */

/* One outgoing frame: serial-v1 bytes, or a CAN frame (id, up to 8 bytes). */
struct board_unit {
    uint16_t can_id;
    uint8_t len;
    uint8_t data[SERIAL_V1_MAX_FRAME];
};

struct inject_fault {
    uint8_t active;
    uint8_t finger;           /* 255: every finger */
    uint16_t value;
    uint8_t forever;          /* duration 0: until a clear */
    uint32_t until_us;
    uint32_t since_us;        /* when it was asked for (SENSOR_DRIFT ramps from here) */
    uint32_t order;           /* the newest request is the one the status names */
    uint8_t held_valid;       /* STUCK_SENSOR, PRESSURE_STUCK: the readings it froze */
    float held[8];
};

struct inject {
    struct inject_fault faults[INJECT_KINDS];
    uint32_t order;
    uint32_t rng;
    struct board_unit queue[INJECT_QUEUE_UNITS]; /* DELAY: first in, first out */
    uint32_t due_us[INJECT_QUEUE_UNITS];
    uint16_t head;
    uint16_t count;
    uint32_t queue_dropped;
    uint64_t error_credit;    /* CAN_ERROR_FRAMES: error frames owed, in frames/s * us */
};

void inject_init(struct inject *in, uint32_t seed);
void inject_clear(struct inject *in);
void inject_request(struct inject *in, uint8_t kind, uint8_t finger, uint16_t duration_ms, uint16_t value,
                    uint32_t now_us);
/* End the faults whose time is up; returns how many ended. */
uint8_t inject_expire(struct inject *in, uint32_t now_us);
const struct inject_fault *inject_active(const struct inject *in, uint8_t kind);
/* The active fault's value (`fallback` for 0), or -1 when it is not active. */
int32_t inject_value(const struct inject *in, uint8_t kind, uint16_t fallback);
/* The kind the status reports in fault_active: the newest active one, 0 for none. */
uint8_t inject_current(const struct inject *in);
/* Does the fault apply to finger i? */
int inject_hits(const struct inject_fault *f, uint8_t finger);
/* An outgoing unit: 1 to send it now (perhaps corrupted in place), 0 if dropped or held. */
int inject_outgoing(struct inject *in, struct board_unit *unit, uint32_t now_us);
/* A held unit whose time has come: 1 and *unit filled, or 0. */
int inject_release(struct inject *in, uint32_t now_us, struct board_unit *unit);

#endif
