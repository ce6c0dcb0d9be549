/* The chamber pressure regulator (regulator.h). */
#include "regulator.h"

#include <math.h>

#define FULL_PERMILLE 1000u

void regulator_vent(struct regulator *r)
{
    r->inlet_permille = 0u;
    r->exhaust_permille = FULL_PERMILLE;
}

static uint16_t duty_permille(const struct regulator_config *cfg, float error_kpa)
{
    const float wanted = cfg->gain_permille_per_kpa * error_kpa;
    float min_duty = 0.0f;
    if (cfg->pwm_period_us > 0u) {
        min_duty = (float)cfg->min_pulse_us * (float)FULL_PERMILLE / (float)cfg->pwm_period_us;
    }
    float duty = wanted > min_duty ? wanted : min_duty;
    if (!(duty < (float)FULL_PERMILLE)) {
        duty = (float)FULL_PERMILLE;
    }
    return (uint16_t)(duty + 0.5f);
}

void regulator_step(struct regulator *r, const struct regulator_config *cfg, float target_kpa,
                    float measured_kpa)
{
    if (!isfinite(target_kpa) || !isfinite(measured_kpa) || target_kpa <= cfg->vent_below_kpa) {
        regulator_vent(r);
        return;
    }
    const float error_kpa = target_kpa - measured_kpa;
    if (error_kpa > cfg->deadband_kpa) {
        r->inlet_permille = duty_permille(cfg, error_kpa);
        r->exhaust_permille = 0u;
    } else if (error_kpa < -cfg->deadband_kpa) {
        r->inlet_permille = 0u;
        r->exhaust_permille = duty_permille(cfg, -error_kpa);
    } else {
        r->inlet_permille = 0u;
        r->exhaust_permille = 0u;
    }
}
