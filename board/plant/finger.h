/* One finger as the project models it: the pseudo-rigid-body model of docs/physics.md
 * section 1 without the effects,
 *
 *     A * theta'' + B * theta' + k * theta = N * p
 *
 * A = (7/12) * m * gamma^3 * l^2 (the paper's inertia from mass and geometry), p the chamber
 * pressure in kPa. The board's description of it (the profile's numbers); the equation is
 * stepped by the project's one finger simulator, csrc/rtcore_sim_plant.h, exactly at any
 * step (plant.c).
 */
#ifndef BOARD_FINGER_H
#define BOARD_FINGER_H

#include "rtcore_sim_plant.h"

struct finger_params {
    double mass_kg;
    double length_m;
    double gamma;
    double stiffness_nm_per_rad;
    double damping_nms_per_rad;
    double pressure_gain_nm_per_kpa;
    double sensor_gain_deg_per_mv;   /* the flex sensor: angle_deg = gain * mV + offset */
    double sensor_offset_deg;
};

double finger_inertia_kgm2(const struct finger_params *f);

/* The finger for the simulator's dynamics: its PRBM without effects, no object, no loop,
 * the chamber driven directly (no valve lag: the board's pneumatics give the pressure), its
 * supply 0..supply_kpa. */
void finger_dynamics(const struct finger_params *f, double supply_kpa, rtcore_sim_finger *out);

#endif
