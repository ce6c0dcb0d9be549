/* One finger as the project models it: the pseudo-rigid-body model of docs/physics.md
 * section 1 (csrc/rtcore_sim_plant.c's plant without the effects),
 *
 *     A * theta'' + B * theta' + k * theta = N * p
 *
 * A = (7/12) * m * gamma^3 * l^2 (the paper's inertia from mass and geometry), p the chamber
 * pressure in kPa. Integrated semi-implicitly (velocity first), which is stable and accurate
 * at the plant's 50 us steps (omega_n * dt < 0.01 for every shipped finger).
 */
#ifndef BOARD_FINGER_H
#define BOARD_FINGER_H

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

struct finger_state {
    double angle_rad;
    double velocity_rad_per_s;
};

double finger_inertia_kgm2(const struct finger_params *f);

void finger_step(const struct finger_params *f, struct finger_state *s, double pressure_kpa, double dt_s);

#endif
