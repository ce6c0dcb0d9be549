/* The HAL of the host build (core/hal.h): the clock and the pty; the plant is hal_plant.c's. */
#include <errno.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "hal.h"
#include "host.h"

struct host_world host;

static uint64_t monotonic_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint64_t)ts.tv_sec * 1000000000u + (uint64_t)ts.tv_nsec;
}

uint64_t host_now_us(void)
{
    return (monotonic_ns() - host.t0_ns) / 1000u;
}

double host_monotonic_s(void)
{
    return (double)monotonic_ns() / 1e9;
}

uint32_t hal_time_us(void)
{
    return (uint32_t)host_now_us();
}

void host_pump_input(void)
{
    uint8_t chunk[4096];
    for (;;) {
        const ssize_t got = read(host.fd, chunk, sizeof chunk);
        if (got <= 0) {
            return; /* EAGAIN: nothing more; EIO: no one holds the other end */
        }
        for (ssize_t i = 0; i < got; i++) {
            if (!host.slcan) {
                if (host.rx_pos == host.rx_len) {
                    host.rx_pos = host.rx_len = 0u;
                }
                if (host.rx_len < HOST_RX_BYTES) {
                    host.rx[host.rx_len++] = chunk[i];
                }
            } else if (chunk[i] == '\r') {
                host.line[host.line_len] = '\0';
                host_slcan_line(host.line);
                host.line_len = 0u;
            } else if (host.line_len + 1u < sizeof host.line) {
                host.line[host.line_len++] = (char)chunk[i];
            }
        }
    }
}

uint16_t hal_serial_read(uint8_t *buf, uint16_t max_len)
{
    uint32_t n = host.rx_len - host.rx_pos;
    if (n > max_len) {
        n = max_len;
    }
    memcpy(buf, host.rx + host.rx_pos, n);
    host.rx_pos += n;
    return (uint16_t)n;
}

void hal_serial_write(const uint8_t *buf, uint16_t len)
{
    host_pty_write(host.fd, buf, len);
}

uint8_t hal_can_read(uint16_t *id, uint8_t *data, uint8_t *len)
{
    if (host.can_count == 0u) {
        return 0u;
    }
    const struct host_can_frame *f = &host.can_rx[host.can_head];
    *id = f->id;
    *len = f->len;
    memcpy(data, f->data, f->len);
    host.can_head = (host.can_head + 1u) % HOST_CAN_QUEUE;
    host.can_count--;
    return 1u;
}

void hal_can_write(uint16_t id, const uint8_t *data, uint8_t len)
{
    host_slcan_send(id, data, len);
}

void hal_can_error(uint8_t bus_off)
{
    (void)bus_off; /* the Lawicel SLCAN protocol has no error frame */
}

void hal_watchdog_kick(void)
{
    /* a Linux process has no hardware watchdog: a hung host build is ended by its tests */
}
