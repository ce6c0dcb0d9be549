/* The plant half of the HAL (hal_adc_read, hal_valve_pwm) for the builds that run the
 * firmware against the simulated hand on a computer: the host process (main.c) and the
 * in-process build (inprocess/). Each valve opens and shuts by its PWM duty, latched at
 * each PWM period as a timer's shadow register is; the owner advances the plant to its
 * clock with hal_plant_advance and points hal_plant_current at it. */
#ifndef BOARD_HAL_PLANT_H
#define BOARD_HAL_PLANT_H

#include <stdint.h>

#include "plant.h"

#define HAL_PLANT_STEP_US 50u
#define HAL_PLANT_CATCH_UP_US 200000u /* after a stall, the plant catches up this much at most */

struct hal_plant {
    uint32_t pwm_period_us;
    uint16_t duty_pending[PLANT_MAX_FINGERS][2];
    uint16_t duty_latched[PLANT_MAX_FINGERS][2];
    uint64_t time_us; /* the plant has been advanced to here */
    struct plant plant;
};

/* the plant hal_adc_read and hal_valve_pwm act on */
extern struct hal_plant *hal_plant_current;

/* 0, or -1 for a finger the simulator cannot run (plant_init) */
int hal_plant_init(struct hal_plant *p, uint32_t pwm_period_us, const struct finger_params *fingers,
                   int n_fingers, uint32_t seed, uint64_t now_us);

/* Advance the plant to now_us, each valve opened and shut by its PWM. */
void hal_plant_advance(struct hal_plant *p, uint64_t now_us);

#endif
