/* The physical plant of the host build: every finger's PRBM (finger.h) driven by its
 * chamber's pneumatics (pneumatics.h), read through an analog pressure sensor and a flex
 * sensor by a 12-bit ADC, as the board's HAL sees them (hal_adc_read's channels: 2*i the
 * pressure of chamber i, 2*i+1 the flex sensor of finger i).
 *
 * Sensors: the pressure sensor is an MPX5700-class part (0.2 V at 0 kPa gauge,
 * 6.4 mV/kPa, 5 V supply), with 0.5 kPa of Gaussian noise; the flex sensor gives the
 * finger's calibration line (mV = (angle_deg - offset_deg) / gain_deg_per_mv) with 0.3 deg
 * of noise: the shipped profile's simulation noise (firmware_profiles/sim.yaml).
 * The ADC: 12 bits over 5 V, clipped to its range.
 *
 * Each finger is stepped by the project's finger simulator (csrc/rtcore_sim_plant.h), its
 * chamber's pressure held over the step; the host build and the Cortex-M image link its
 * units (board/Makefile SIM_SRC).
 */
#ifndef BOARD_PLANT_H
#define BOARD_PLANT_H

#include <stdint.h>

#include "finger.h"
#include "pneumatics.h"

#define PLANT_MAX_FINGERS 8

struct plant_sensor_params {
    double pressure_offset_mv;
    double pressure_sensitivity_mv_per_kpa;
    double pressure_noise_kpa;
    double angle_noise_deg;
    double adc_ref_mv;
    uint16_t adc_max_counts;
};

struct plant {
    int n_fingers;
    struct finger_params fingers[PLANT_MAX_FINGERS];
    struct pneumatics_params pneumatics[PLANT_MAX_FINGERS];
    struct plant_sensor_params sensors;
    rtcore_sim_finger dynamics[PLANT_MAX_FINGERS]; /* finger_dynamics(fingers[i]) */
    rtcore_sim_motion motion[PLANT_MAX_FINGERS];
    rtcore_propagator_cache propagators[PLANT_MAX_FINGERS]; /* each finger's, kept between steps */
    struct pneumatics_state chamber[PLANT_MAX_FINGERS];
    uint32_t rng;
};

/* The pneumatics every chamber gets by default (each number's reason beside it in
 * plant.c), for a finger of pressure gain N (dV/dtheta = N). */
struct pneumatics_params plant_default_pneumatics(double pressure_gain_nm_per_kpa);
struct plant_sensor_params plant_default_sensors(void);

/* Fingers from `fingers`, the default pneumatics and sensors; at rest, vented. 0, or -1 for
 * a finger the simulator cannot run (a mass, length or stiffness not above 0, a non-finite
 * number): the plant then has no fingers. */
int plant_init(struct plant *p, const struct finger_params *fingers, int n_fingers, uint32_t seed);

/* valves_open[i][0]: chamber i's inlet open (commanded), [i][1] its exhaust. */
void plant_step(struct plant *p, const int valves_open[][2], double dt_s);

/* ADC counts of a channel, noise included. */
uint16_t plant_adc(struct plant *p, uint8_t channel);

#endif
