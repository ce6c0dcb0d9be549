/* One finger alone (rtcore_sim_plant.h): its dynamics checked, its motion started and
 * advanced under a held valve input and external torque (the integration itself:
 * rtcore_sim_plant.c). */
#include <math.h>

#include "rtcore_internal.h"
#include "rtcore_sim_internal.h"

int32_t rtcore_sim_dynamics_valid(const rtcore_sim_finger *f)
{
    const rtcore_prbm *m;
    if (f == 0) {
        return RTCORE_ERR_NULL;
    }
    m = &f->prbm;
    if (!(isfinite(m->inertia_kgm2) && m->inertia_kgm2 > 0.0) || !(isfinite(m->damping_nms_per_rad)
        && m->damping_nms_per_rad >= 0.0) || !(isfinite(m->stiffness_nm_per_rad)
        && m->stiffness_nm_per_rad > 0.0) || !(isfinite(m->pressure_gain_nm_per_kpa)
        && m->pressure_gain_nm_per_kpa >= 0.0) || !(isfinite(m->lever_arm_m) && m->lever_arm_m >= 0.0)) {
        return RTCORE_ERR_MODEL;
    }
    if (!rtcore_effects_valid(&m->effects)) {
        return RTCORE_ERR_EFFECTS;
    }
    if (!isfinite(f->contact_angle_deg) || !(isfinite(f->contact_stiffness_n_per_m)
        && f->contact_stiffness_n_per_m >= 0.0) || !(isfinite(f->contact_damping_ns_per_m)
        && f->contact_damping_ns_per_m >= 0.0)) {
        return RTCORE_ERR_MODEL;
    }
    if (!(isfinite(f->hysteresis_torque_nm) && f->hysteresis_torque_nm >= 0.0)
        || (f->hysteresis_torque_nm > 0.0
            && !(isfinite(f->hysteresis_travel_deg) && f->hysteresis_travel_deg > 0.0))) {
        return RTCORE_ERR_MODEL;
    }
    /* a lever arm of 0 is a free finger with no force point: it can meet no object */
    if ((f->contact_stiffness_n_per_m > 0.0 || f->contact_damping_ns_per_m > 0.0)
        && !(m->lever_arm_m > 0.0)) {
        return RTCORE_ERR_MODEL;
    }
    return RTCORE_OK;
}

int32_t rtcore_sim_motion_start(const rtcore_sim_finger *f, rtcore_sim_motion *s, rtcore_propagator_cache *cache,
                                double angle_deg, double velocity_deg_per_s, double chamber_kpa)
{
    sim_plant plant;
    int32_t err;
    if (s == 0) {
        return RTCORE_ERR_NULL;
    }
    err = rtcore_sim_dynamics_valid(f);
    if (err != RTCORE_OK) {
        return err;
    }
    if (!isfinite(angle_deg) || !isfinite(velocity_deg_per_s) || !isfinite(chamber_kpa)) {
        return RTCORE_ERR_MODEL;
    }
    rtcore_sim_plant_for(f, &plant);
    s->angle_rad = angle_deg * RTCORE_RAD_PER_DEG;
    s->velocity_rad_per_s = velocity_deg_per_s * RTCORE_RAD_PER_DEG;
    s->chamber_kpa = chamber_kpa;
    s->hysteresis_z = 0.0;
    s->creep_angle_rad = s->angle_rad; /* at rest there: the creep branch relaxed */
    s->max_step_s = rtcore_sim_parameter_step_s(&plant);
    if (cache != 0) {
        cache->count = 0;
        cache->next = 0;
    }
    return RTCORE_OK;
}

void rtcore_sim_motion_advance(const rtcore_sim_finger *f, rtcore_sim_motion *s, rtcore_propagator_cache *cache,
                               double input_kpa, double external_torque_nm, double duration_s)
{
    rtcore_propagator_cache own;
    sim_plant plant;
    if (f == 0 || s == 0 || !isfinite(input_kpa) || !isfinite(external_torque_nm) || !(duration_s > 0.0)
        || !isfinite(duration_s)) {
        return;
    }
    if (cache == 0) {
        own.count = 0;
        own.next = 0;
        cache = &own;
    }
    rtcore_sim_plant_for(f, &plant);
    rtcore_sim_integrate_held(&plant, s, cache, input_kpa, external_torque_nm, duration_s, duration_s, 0);
}

void rtcore_sim_motion_advance_many(const rtcore_sim_finger *fingers, rtcore_sim_motion *motions,
                                    rtcore_propagator_cache *caches, const double *input_kpa,
                                    const double *external_torque_nm, int32_t count, double duration_s)
{
    int32_t i;
    if (fingers == 0 || motions == 0 || input_kpa == 0 || external_torque_nm == 0) {
        return;
    }
    for (i = 0; i < count; ++i) {
        rtcore_sim_motion_advance(&fingers[i], &motions[i], caches != 0 ? &caches[i] : 0, input_kpa[i],
                                  external_torque_nm[i], duration_s);
    }
}
