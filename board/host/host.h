/* The host build: the firmware core on Linux, its HAL backed by a pseudo-terminal and the
 * physical plant (plant/), run at real time. */
#ifndef BOARD_HOST_H
#define BOARD_HOST_H

#include <stdint.h>

#include "finger.h"
#include "hal_plant.h"
#include "plant.h"

#define HOST_DEFAULT_FINGERS 5
#define HOST_RX_BYTES 8192u
#define HOST_CAN_QUEUE 256u

extern const struct finger_params host_default_hand[HOST_DEFAULT_FINGERS];
extern const char *const host_default_finger_names[HOST_DEFAULT_FINGERS];

struct host_can_frame {
    uint16_t id;
    uint8_t len;
    uint8_t data[8];
};

/* The HAL's world: what hal_host.c reads and writes. */
struct host_world {
    int fd;                        /* the pty's master end */
    int slcan;                     /* 1: can-v1 behind an SLCAN adapter on the pty */
    int slcan_open;                /* the host opened the channel ('O') */
    uint8_t rx[HOST_RX_BYTES];     /* serial: bytes read, not yet taken by the core */
    uint32_t rx_len, rx_pos;
    char line[64];                 /* SLCAN: the line being received */
    uint32_t line_len;
    struct host_can_frame can_rx[HOST_CAN_QUEUE];
    uint32_t can_head, can_count;
    uint64_t dropped_bytes;
    uint64_t t0_ns;                /* CLOCK_MONOTONIC at start */
    struct hal_plant plant;        /* hal_plant_current points here */
};

extern struct host_world host;

uint64_t host_now_us(void);
double host_monotonic_s(void);

/* Read what the pty has (serial bytes into rx, or SLCAN lines into CAN frames). */
void host_pump_input(void);

/* pty.c */
int host_pty_open(const char *link_path, char *device, uint32_t device_len);
void host_pty_write(int fd, const uint8_t *data, uint32_t len);

/* slcan.c */
void host_slcan_line(const char *line);
void host_slcan_send(uint16_t id, const uint8_t *data, uint8_t len);

#endif
