/*
 * rtcore_sim_plant: the simulated finger's dynamics, the one place the project steps a
 * finger's equation of motion. The PRBM A·θ'' + B·θ' + k·θ = N·p_eff + g(θ, θ') + τ_ext
 * (docs/physics.md): its linear part integrated exactly whatever the step, the rest of the
 * torque (the effects, the object, the hysteresis loop) by ETDRK4, the chamber following
 * the valve's first-order lag toward a held input (csrc/rtcore_sim_motion.c over
 * rtcore_sim_plant.c and rtcore_sim_etdrk4.c).
 *
 * The simulated hand (rtcore_sim.h) adds the valve's dead time, its pneumatic mode and the
 * sensors on top. A caller that drives the chamber itself steps a finger here alone: the
 * valve board's host plant (board/plant, its chamber from the board's pneumatics) and the
 * pinch experiment (hand_service/pinch, its contact torque as τ_ext).
 *
 * The block between the CDEF markers is read verbatim by rtcore/_build.py.
 */
#ifndef RTCORE_SIM_PLANT_H
#define RTCORE_SIM_PLANT_H

#include <stdint.h>

#include "rtcore_exact.h"
#include "rtcore_pneumatic.h"
#include "rtcore_step.h"

#ifdef __cplusplus
extern "C" {
#endif

/* BEGIN CDEF */
typedef struct {
    rtcore_prbm prbm; /* the truth: the controller's PRBM struct (rtcore_step.h) */
    /* the valve regulates within what the supply allows */
    double supply_min_kpa;
    double supply_max_kpa;
    /* an object touched past contact_angle_deg; stiffness 0 means no object */
    double contact_angle_deg;
    double contact_stiffness_n_per_m;
    double contact_damping_ns_per_m;
    /* a rate-independent loop (hysteresis in the material; the controller's copy, which the
     * simulator ignores, is rtcore_effects.hysteresis_*):
     * the torque -hysteresis_torque_nm*z, z in [-1, 1] turning toward the direction of
     * travel, e-fold every hysteresis_travel_deg moved (Dahl's form); torque 0 means none */
    double hysteresis_torque_nm;
    double hysteresis_travel_deg;
    /* the sensor: mv = (angle_deg + noise - offset) / gain, quantised to adc_step_mv */
    double sensor_gain_deg_per_mv;
    double sensor_offset_deg;
    double sensor_noise_deg;
    double adc_step_mv;
    double pressure_noise_kpa;
    /* the valve: first-order lag + dead time (the effects'), or pneumatic (rtcore_pneumatic.h) */
    rtcore_pneumatic_config pneumatic;
} rtcore_sim_finger;

/* One finger's motion: what its dynamics integrate. */
typedef struct {
    double angle_rad;
    double velocity_rad_per_s;
    double chamber_kpa; /* the chamber now (with a valve lag it lags the held input) */
    double hysteresis_z; /* the loop's state, in [-1, 1] */
    double creep_angle_rad; /* the creep branch's dashpot: where its spring is relaxed */
    /* longest step the finger's parameters allow (infinite for the plain linear finger);
     * a settled finger and one that dry friction holds step longer (rtcore_sim_plant.c) */
    double max_step_s;
} rtcore_sim_motion;

/* RTCORE_OK when the finger's dynamics can run (its PRBM, effects, object and loop finite
 * and physical), else RTCORE_ERR_MODEL or RTCORE_ERR_EFFECTS. The valve's supply, its
 * pneumatic mode and the sensor are the simulated hand's (rtcore_sim_configure). */
int32_t rtcore_sim_dynamics_valid(const rtcore_sim_finger *finger);
/* The finger at angle_deg, velocity_deg_per_s, its chamber at chamber_kpa, the loop at its
 * middle, the propagators' cache emptied (cache may be NULL); RTCORE_OK, or the error of
 * rtcore_sim_dynamics_valid or of a non-finite state (RTCORE_ERR_MODEL), nothing then
 * touched. */
int32_t rtcore_sim_motion_start(const rtcore_sim_finger *finger, rtcore_sim_motion *motion,
                                rtcore_propagator_cache *cache, double angle_deg, double velocity_deg_per_s,
                                double chamber_kpa);
/* Advance duration_s with the valve's input held at input_kpa (the chamber itself when the
 * finger's valve_lag_tau_s is 0) and an external torque held at external_torque_nm (a
 * contact computed by the caller; positive bends the finger). cache: this finger's own,
 * kept between calls since rtcore_sim_motion_start (steps of one length then cost one
 * propagator), or NULL (each call computes its own). A finger that diverges stays
 * non-finite; a non-finite input or torque, or a duration not above 0, changes nothing. */
void rtcore_sim_motion_advance(const rtcore_sim_finger *finger, rtcore_sim_motion *motion,
                               rtcore_propagator_cache *cache, double input_kpa, double external_torque_nm,
                               double duration_s);
/* rtcore_sim_motion_advance for count fingers at once, each with its own input, torque
 * and cache (caches may be NULL). */
void rtcore_sim_motion_advance_many(const rtcore_sim_finger *fingers, rtcore_sim_motion *motions,
                                    rtcore_propagator_cache *caches, const double *input_kpa,
                                    const double *external_torque_nm, int32_t count, double duration_s);
/* END CDEF */

#ifdef __cplusplus
}
#endif

#endif /* RTCORE_SIM_PLANT_H */
