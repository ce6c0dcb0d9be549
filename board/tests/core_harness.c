/* The core's C tests' shared fixture and drivers (core_harness.h). */
#include <string.h>

#include "board.h"
#include "board_internal.h"
#include "can_v1.h"
#include "core_harness.h"
#include "fake_hal.h"
#include "hal.h"

int failures;


struct board b;

struct sent sent[SENT_FRAMES];
int n_sent;

void collect(void)
{
    struct serial_v1_decoder d;
    struct serial_v1_frame f;
    serial_v1_decoder_init(&d);
    n_sent = 0;
    for (uint32_t i = 0; i < fake.out_len; i++) {
        serial_v1_feed(&d, fake.out[i]);
        while (serial_v1_next(&d, &f) && n_sent < SENT_FRAMES) {
            sent[n_sent].type = f.type;
            sent[n_sent].length = f.length;
            memcpy(sent[n_sent].payload, f.payload, f.length);
            n_sent++;
        }
    }
}

int count_type(uint8_t type)
{
    int n = 0;
    for (int i = 0; i < n_sent; i++) {
        n += sent[i].type == type;
    }
    return n;
}

const struct sent *last_of(uint8_t type)
{
    for (int i = n_sent - 1; i >= 0; i--) {
        if (sent[i].type == type) {
            return &sent[i];
        }
    }
    return NULL;
}

void set_pressure(uint8_t i, float kpa)
{
    const float mv = 200.0f + 6.4f * kpa;
    fake.adc_counts[2 * i] = (uint16_t)(mv * 4095.0f / 5000.0f + 0.5f);
}

void run_for_us(uint32_t us)
{
    const uint32_t end = fake.time_us + us;
    while ((int32_t)(end - fake.time_us) > 0) {
        fake.time_us += 100u;
        board_poll(&b);
    }
}

void boot(uint8_t wire)
{
    struct board_config cfg = board_config_defaults();
    cfg.wire = wire;
    boot_with(&cfg);
}

void boot_with(const struct board_config *cfg)
{
    fake_reset();
    fake.time_us = 0xFFFF0000u; /* the clock wraps during the tests */
    for (uint8_t i = 0; i < 5; i++) {
        set_pressure(i, 0.0f);
        fake.adc_counts[2 * i + 1] = 2000;
    }
    CHECK(board_init(&b, cfg) == 0);
    board_poll(&b);
}

void send_command(uint8_t sequence, float kpa, uint8_t n)
{
    uint8_t payload[64];
    uint8_t frame[SERIAL_V1_MAX_FRAME];
    payload[0] = sequence;
    payload[1] = n;
    for (uint8_t i = 0; i < n; i++) {
        serial_v1_put_f32(payload + 2 + 4 * i, kpa);
    }
    const uint16_t len = serial_v1_encode(frame, 0, SERIAL_V1_VALVE_COMMAND, payload, (uint8_t)(2 + 4 * n));
    fake_input(frame, len);
}

void send_simple(uint8_t type, const uint8_t *payload, uint8_t length)
{
    uint8_t frame[SERIAL_V1_MAX_FRAME];
    const uint16_t len = serial_v1_encode(frame, 0, type, payload, length);
    fake_input(frame, len);
}
