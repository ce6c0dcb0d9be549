/* The firmware core in a Python process (hand_service/firmware/board.py, through cffi): the
 * test image of board/core against the simulated hand (host/hal_plant.c), on a clock the
 * caller gives, its link a pair of queues the caller fills and drains (CAN frames, or
 * serial-v1 bytes). Each instance is caller-allocated (inprocess_size bytes); calls on
 * different instances must not overlap (the HAL reaches the instance being run through
 * one pointer), which the Python side ensures with a lock.
 *
 *     inprocess_init(ip, &cfg, now_us);
 *     loop: inprocess_can_push(...) / inprocess_serial_push(...)   what arrived
 *           inprocess_run(ip, now_us)                              the board catches up to now
 *           inprocess_can_pop(...) / inprocess_serial_pop(...)     what it sent
 *           wait until inprocess_next_event_us(ip) or input
 */
#ifndef BOARD_INPROCESS_H
#define BOARD_INPROCESS_H

#include <stddef.h>
#include <stdint.h>

/* BEGIN CDEF */
struct inprocess;

struct inprocess_config {
    uint8_t can;                  /* 1: can-v1 frames; 0: serial-v1 bytes */
    uint8_t n_fingers;            /* the first n fingers of the default hand (1..5) */
    uint16_t protocol_version;
    uint8_t firmware_version[3];
    uint32_t sample_period_us;    /* 1 / the profile's control.rate_hz */
    uint32_t watchdog_us;         /* the profile's safety.firmware_watchdog_ms */
    uint32_t seed;                /* the plant's sensor noise */
    uint8_t can_error_frames;     /* the link hands CAN error frames to the host */
    uint8_t broken;               /* enum inject_broken: a rule this board breaks on purpose */
};

enum inprocess_frame_kind { INPROCESS_DATA = 0, INPROCESS_BUS_ERROR = 1, INPROCESS_BUS_OFF = 2 };

struct inprocess_frame {
    uint8_t kind;                 /* enum inprocess_frame_kind */
    uint16_t id;
    uint8_t len;
    uint8_t data[8];
};

/* What the tests may look at: the truth behind the wire. */
struct inprocess_view {
    uint8_t state;                /* enum board_state */
    uint8_t fault_code;
    uint32_t vent_count;          /* watchdog vents since init */
    uint64_t vent_at_us;          /* the caller's clock at the newest one */
    float command_kpa[8];         /* the setpoints the board applies */
    double angle_deg[8];          /* the simulated fingers */
};

size_t inprocess_size(void);
/* 0, or -1 when the firmware refuses the configuration. */
int inprocess_init(struct inprocess *ip, const struct inprocess_config *cfg, uint64_t now_us);
/* Run the board to now_us in steps of its inner period; what was pushed is received at the
 * end, or, after a longer gap (the calling process held up), spread over the gap. */
void inprocess_run(struct inprocess *ip, uint64_t now_us);
/* When the board next has something to do on its own (a sample, the watchdog, a held frame). */
uint64_t inprocess_next_event_us(const struct inprocess *ip);
/* 1 if queued, 0 if the receive queue is full (the frame is lost, as on a busy controller). */
int inprocess_can_push(struct inprocess *ip, uint16_t id, const uint8_t *data, uint8_t len);
/* How many of the bytes fit the receive buffer. */
uint32_t inprocess_serial_push(struct inprocess *ip, const uint8_t *data, uint32_t len);
int inprocess_can_pop(struct inprocess *ip, struct inprocess_frame *frame);
uint32_t inprocess_serial_pop(struct inprocess *ip, uint8_t *out, uint32_t max_len);
void inprocess_view(const struct inprocess *ip, struct inprocess_view *view);
/* END CDEF */

#endif
