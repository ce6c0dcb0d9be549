/* The finger's PRBM (finger.h). */
#include "finger.h"

#include <math.h>

double finger_inertia_kgm2(const struct finger_params *f)
{
    return 7.0 / 12.0 * f->mass_kg * pow(f->gamma, 3.0) * f->length_m * f->length_m;
}

void finger_step(const struct finger_params *f, struct finger_state *s, double pressure_kpa, double dt_s)
{
    if (!isfinite(pressure_kpa) || !(dt_s > 0.0)) {
        return;
    }
    const double inertia_kgm2 = finger_inertia_kgm2(f);
    const double torque_nm = f->pressure_gain_nm_per_kpa * pressure_kpa - f->stiffness_nm_per_rad * s->angle_rad
                             - f->damping_nms_per_rad * s->velocity_rad_per_s;
    s->velocity_rad_per_s += torque_nm / inertia_kgm2 * dt_s;
    s->angle_rad += s->velocity_rad_per_s * dt_s;
}
