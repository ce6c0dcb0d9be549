/* The plant half of the HAL (hal_plant.h). */
#include "hal_plant.h"

#include <string.h>

#include "hal.h"

struct hal_plant *hal_plant_current;

int hal_plant_init(struct hal_plant *p, uint32_t pwm_period_us, const struct finger_params *fingers,
                   int n_fingers, uint32_t seed, uint64_t now_us)
{
    memset(p, 0, sizeof *p);
    p->pwm_period_us = pwm_period_us > 0u ? pwm_period_us : 1u;
    p->time_us = now_us;
    return plant_init(&p->plant, fingers, n_fingers, seed);
}

uint16_t hal_adc_read(uint8_t channel)
{
    return plant_adc(&hal_plant_current->plant, channel);
}

void hal_valve_pwm(uint8_t chamber, uint8_t valve, uint16_t duty_permille)
{
    struct hal_plant *p = hal_plant_current;
    if (chamber < PLANT_MAX_FINGERS && valve < 2u) {
        p->duty_pending[chamber][valve] = duty_permille > 1000u ? 1000u : duty_permille;
        if (duty_permille == 0u || duty_permille >= 1000u) {
            /* held shut or open (a vent): a timer output forced at once, not at the period's end */
            p->duty_latched[chamber][valve] = p->duty_pending[chamber][valve];
        }
    }
}

void hal_plant_advance(struct hal_plant *p, uint64_t now_us)
{
    const uint32_t period_us = p->pwm_period_us;
    int open[PLANT_MAX_FINGERS][2];
    if (now_us > p->time_us + HAL_PLANT_CATCH_UP_US) {
        p->time_us = now_us - HAL_PLANT_CATCH_UP_US;
    }
    while (p->time_us + HAL_PLANT_STEP_US <= now_us) {
        const uint32_t phase_us = (uint32_t)(p->time_us % period_us);
        if (phase_us < HAL_PLANT_STEP_US) { /* a new PWM period: the shadow registers load */
            memcpy(p->duty_latched, p->duty_pending, sizeof p->duty_latched);
        }
        for (int i = 0; i < p->plant.n_fingers; i++) {
            for (int v = 0; v < 2; v++) {
                open[i][v] = (uint64_t)phase_us * 1000u < (uint64_t)p->duty_latched[i][v] * period_us;
            }
        }
        plant_step(&p->plant, (const int(*)[2])open, HAL_PLANT_STEP_US * 1e-6);
        p->time_us += HAL_PLANT_STEP_US;
    }
}
