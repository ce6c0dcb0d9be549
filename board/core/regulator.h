/* One chamber's pressure regulator: an on/off inlet valve and an on/off exhaust valve
 * driven by PWM, run at the inner-loop rate (board.c calls it every inner_period_us).
 *
 *   error = target - measured
 *   |error| <= deadband          both valves shut (hold: no chatter around the target)
 *   error > deadband             inlet at duty = gain * |error|, exhaust shut
 *   error < -deadband            exhaust at that duty, inlet shut
 *   target <= vent_below_kpa     exhaust held open, inlet shut (the vent)
 *
 * A duty whose pulse would be shorter than min_pulse_us is raised to it: a solenoid valve
 * needs a few ms to open at all, so a shorter pulse would do nothing and the error would
 * never close. The duty is capped at full (1000 per mille).
 */
#ifndef BOARD_REGULATOR_H
#define BOARD_REGULATOR_H

#include <stdint.h>

struct regulator_config {
    float deadband_kpa;
    float gain_permille_per_kpa;
    uint32_t pwm_period_us;
    uint32_t min_pulse_us;
    float vent_below_kpa;
};

struct regulator {
    uint16_t inlet_permille;
    uint16_t exhaust_permille;
};

/* Duties for one tick; a NaN measurement (a failed sensor) vents. */
void regulator_step(struct regulator *r, const struct regulator_config *cfg, float target_kpa,
                    float measured_kpa);

void regulator_vent(struct regulator *r);

#endif
