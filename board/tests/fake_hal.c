/* The fake HAL (fake_hal.h). */
#include "fake_hal.h"

#include <string.h>

#include "hal.h"

struct fake_hal fake;

void fake_reset(void)
{
    memset(&fake, 0, sizeof fake);
}

void fake_input(const uint8_t *data, uint32_t len)
{
    if (fake.in_pos == fake.in_len) {
        fake.in_pos = fake.in_len = 0;
    }
    memcpy(fake.in + fake.in_len, data, len);
    fake.in_len += len;
}

void fake_can_input(uint16_t id, const uint8_t *data, uint8_t len)
{
    if (fake.can_in_pos == fake.can_in_len) {
        fake.can_in_pos = fake.can_in_len = 0;
    }
    struct fake_frame *f = &fake.can_in[fake.can_in_len++];
    f->id = id;
    f->len = len;
    memcpy(f->data, data, len);
}

uint32_t hal_time_us(void)
{
    return fake.time_us;
}

uint16_t hal_adc_read(uint8_t channel)
{
    return fake.adc_counts[channel];
}

void hal_valve_pwm(uint8_t chamber, uint8_t valve, uint16_t duty_permille)
{
    fake.duty_permille[chamber][valve] = duty_permille;
}

uint16_t hal_serial_read(uint8_t *buf, uint16_t max_len)
{
    uint32_t n = fake.in_len - fake.in_pos;
    if (n > max_len) {
        n = max_len;
    }
    memcpy(buf, fake.in + fake.in_pos, n);
    fake.in_pos += n;
    return (uint16_t)n;
}

void hal_serial_write(const uint8_t *buf, uint16_t len)
{
    if (fake.out_len + len <= FAKE_OUT_BYTES) {
        memcpy(fake.out + fake.out_len, buf, len);
        fake.out_len += len;
    }
}

uint8_t hal_can_read(uint16_t *id, uint8_t *data, uint8_t *len)
{
    if (fake.can_in_pos == fake.can_in_len) {
        return 0;
    }
    const struct fake_frame *f = &fake.can_in[fake.can_in_pos++];
    *id = f->id;
    *len = f->len;
    memcpy(data, f->data, f->len);
    return 1;
}

void hal_can_write(uint16_t id, const uint8_t *data, uint8_t len)
{
    if (fake.can_out_len < FAKE_FRAMES) {
        struct fake_frame *f = &fake.can_out[fake.can_out_len++];
        f->id = id;
        f->len = len;
        memcpy(f->data, data, len);
    }
}

void hal_can_error(uint8_t bus_off)
{
    fake.can_errors[bus_off ? 1 : 0]++;
}

void hal_watchdog_kick(void)
{
    fake.kicks++;
}
