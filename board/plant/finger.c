/* The finger's PRBM (finger.h). */
#include "finger.h"

#include <math.h>
#include <string.h>

double finger_inertia_kgm2(const struct finger_params *f)
{
    return 7.0 / 12.0 * f->mass_kg * pow(f->gamma, 3.0) * f->length_m * f->length_m;
}

void finger_dynamics(const struct finger_params *f, double supply_kpa, rtcore_sim_finger *out)
{
    memset(out, 0, sizeof *out);
    out->prbm.inertia_kgm2 = finger_inertia_kgm2(f);
    out->prbm.damping_nms_per_rad = f->damping_nms_per_rad;
    out->prbm.stiffness_nm_per_rad = f->stiffness_nm_per_rad;
    out->prbm.pressure_gain_nm_per_kpa = f->pressure_gain_nm_per_kpa;
    out->prbm.lever_arm_m = 0.0; /* no force point: the host's hand touches nothing */
    out->prbm.effects.asymmetric_stiffness_ratio = 1.0; /* the effects all off (0 but this ratio) */
    out->supply_min_kpa = 0.0;
    out->supply_max_kpa = supply_kpa;
    out->sensor_gain_deg_per_mv = f->sensor_gain_deg_per_mv;
    out->sensor_offset_deg = f->sensor_offset_deg;
    out->pneumatic.valve_model = RTCORE_VALVE_FIRST_ORDER;
}
