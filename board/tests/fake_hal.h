/* A fake HAL for the core's C tests: a clock the test sets, ADC counts it sets, the valve
 * duties and every byte and frame the core sent, and input it queues. */
#ifndef BOARD_FAKE_HAL_H
#define BOARD_FAKE_HAL_H

#include <stdint.h>

#define FAKE_OUT_BYTES 65536
#define FAKE_FRAMES 4096

struct fake_frame {
    uint16_t id;
    uint8_t len;
    uint8_t data[8];
};

struct fake_hal {
    uint32_t time_us;
    uint16_t adc_counts[16];
    uint16_t duty_permille[8][2];
    uint8_t in[4096];
    uint32_t in_len, in_pos;
    uint8_t out[FAKE_OUT_BYTES];
    uint32_t out_len;
    struct fake_frame can_in[256];
    uint32_t can_in_len, can_in_pos;
    struct fake_frame can_out[FAKE_FRAMES];
    uint32_t can_out_len;
    uint32_t can_errors[2];   /* hal_can_error: bus errors, bus-offs */
    uint32_t kicks;
};

extern struct fake_hal fake;

void fake_reset(void);
void fake_input(const uint8_t *data, uint32_t len);
void fake_can_input(uint16_t id, const uint8_t *data, uint8_t len);

#endif
