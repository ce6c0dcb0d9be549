/* The simulated finger's torques beyond its linear part (the effects, the object, the
 * hysteresis loop and the creep branch as they move over a step) and its local linear plant
 * with the bounds on those torques' slopes (sim_plant), which rtcore_sim_plant.c integrates. */
#include <math.h>

#include "rtcore_internal.h"
#include "rtcore_sim_internal.h"

/* The object's normal force at the force point while touching: the spring-damper,
 * pushing only (>= 0), continued across the surface so that a step keeps one formula. */
static double touching_force_n(const rtcore_sim_finger *f, double angle_rad, double velocity_rad_per_s)
{
    const double force_n = f->prbm.lever_arm_m
                           * (f->contact_stiffness_n_per_m * (angle_rad - f->contact_angle_deg * RTCORE_RAD_PER_DEG)
                              + f->contact_damping_ns_per_m * velocity_rad_per_s);
    return force_n > 0.0 ? force_n : 0.0;
}

static int32_t object_touches(const rtcore_sim_finger *f, double angle_rad)
{
    return f->contact_stiffness_n_per_m > 0.0
           && f->prbm.lever_arm_m * (angle_rad - f->contact_angle_deg * RTCORE_RAD_PER_DEG) > 0.0;
}

/* The sides at angle_rad: SIM_TOUCH_OBJECT where the object is touched, SIM_TOUCH_CONTACT
 * where the contact effect is past its onset. */
int32_t rtcore_sim_touches(const rtcore_sim_finger *f, double angle_rad)
{
    return (object_touches(f, angle_rad) ? SIM_TOUCH_OBJECT : 0)
           | (rtcore_contact_reached(&f->prbm.effects, angle_rad) ? SIM_TOUCH_CONTACT : 0);
}

/* normal force of the object on the finger at the force point (>= 0, pushes back) */
double rtcore_sim_contact_force_n(const rtcore_sim_finger *f, double angle_rad, double velocity_rad_per_s)
{
    return object_touches(f, angle_rad) ? touching_force_n(f, angle_rad, velocity_rad_per_s) : 0.0;
}

/* The loop's z at angle_rad, from `from` (the state at a step's start) moving one way:
 * Dahl's dz/dθ = (sign(dθ) − z)/d solved over the travel, so a step that does not turn
 * integrates it exactly (a turn inside a step is resolved by the step's bound on the loop's
 * slope, rtcore_sim_plant_for). */
double rtcore_sim_loop_z(const rtcore_sim_finger *f, const rtcore_sim_motion *from, double angle_rad)
{
    const double travel_rad = angle_rad - from->angle_rad;
    const double toward = travel_rad > 0.0 ? 1.0 : -1.0;
    if (travel_rad == 0.0) {
        return from->hysteresis_z;
    }
    return toward + (from->hysteresis_z - toward) * exp(-fabs(travel_rad) / (f->hysteresis_travel_deg * RTCORE_RAD_PER_DEG));
}

/* The creep branch's dashpot x at angle_rad, elapsed_s after `from` (the state at the
 * step's start), the angle taken as moving linearly over that time: T·x' = θ − x solved
 * exactly for it, x = x0·d + θ − θ0·d − (θ − θ0)·(T/t)·(1 − d), d = e^(−t/T). */
double rtcore_sim_creep_angle_rad(const rtcore_effects *e, const rtcore_sim_motion *from, double angle_rad,
                              double elapsed_s)
{
    const double time_s = e->creep_time_s;
    double decay;
    if (!(elapsed_s > 0.0)) {
        return from->creep_angle_rad;
    }
    decay = exp(-elapsed_s / time_s);
    return from->creep_angle_rad * decay + angle_rad - from->angle_rad * decay
           + (angle_rad - from->angle_rad) * (time_s / elapsed_s) * expm1(-elapsed_s / time_s);
}

/* g(θ, θ'): the torque beyond N·p_eff − k·θ − B·θ', with the object touching or not and
 * the contact effect in contact or not as a step has them (`touching`'s bits: a damper
 * makes the force jump as the finger reaches the surface or the onset, so a step that
 * reaches one ends there and the next one starts on its far side), and the loop's as it
 * has moved from `from`, the state at the step's start. rtcore_model_torque_nm (shared
 * with the controller) includes the plain k·θ, which the linear part takes. drive_nm is
 * the drive at that instant, N·p_eff plus the segment's external torque: the pressure's
 * stiffening, k·c·(p_eff/p_ref)·θ, takes p_eff from it; the creep branch, β·k·(θ − x),
 * its dashpot x elapsed_s after `from`. */
double rtcore_sim_nonlinear_torque_nm(const sim_plant *p, const rtcore_sim_motion *from, double angle_rad,
                                  double velocity_rad_per_s, int32_t touching, double drive_nm, double elapsed_s)
{
    return rtcore_sim_nonlinear_torque_with_nm(p, from, angle_rad, velocity_rad_per_s, touching, drive_nm, elapsed_s,
                                               rtcore_model_friction_tanh(&p->finger->prbm.effects, velocity_rad_per_s));
}

/* The same with dry friction's tanh(θ'/ω_s) given (rtcore_model_friction_tanh) */
double rtcore_sim_nonlinear_torque_with_nm(const sim_plant *p, const rtcore_sim_motion *from, double angle_rad,
                                           double velocity_rad_per_s, int32_t touching, double drive_nm,
                                           double elapsed_s, double friction_tanh)
{
    const rtcore_sim_finger *f = p->finger;
    const rtcore_prbm *m = &f->prbm;
    double torque_nm = m->stiffness_nm_per_rad * angle_rad
                       - rtcore_model_side_torque_with_nm(m, angle_rad, velocity_rad_per_s, (touching & SIM_TOUCH_CONTACT) != 0,
                                                          friction_tanh);
    if (m->effects.pressure_stiffening_gain > 0.0 && m->pressure_gain_nm_per_kpa > 0.0) {
        torque_nm -= rtcore_stiffening_torque_nm(m, angle_rad,
                                                 (drive_nm - p->external_torque_nm) / m->pressure_gain_nm_per_kpa);
    }
    if (m->effects.creep_stiffness_ratio > 0.0) {
        torque_nm -= m->effects.creep_stiffness_ratio * m->stiffness_nm_per_rad
                     * (angle_rad - rtcore_sim_creep_angle_rad(&m->effects, from, angle_rad, elapsed_s));
    }
    if (f->hysteresis_torque_nm > 0.0) {
        torque_nm -= f->hysteresis_torque_nm * rtcore_sim_loop_z(f, from, angle_rad);
    }
    return (touching & SIM_TOUCH_OBJECT) ? torque_nm - m->lever_arm_m * touching_force_n(f, angle_rad, velocity_rad_per_s)
                                          : torque_nm;
}

double rtcore_sim_pressure_torque_nm(const rtcore_sim_finger *f, double chamber_kpa)
{
    return f->prbm.pressure_gain_nm_per_kpa
           * rtcore_effective_pressure_kpa(&f->prbm.effects, chamber_kpa);
}

void rtcore_sim_plant_for(const rtcore_sim_finger *f, sim_plant *p)
{
    const rtcore_prbm *m = &f->prbm;
    const rtcore_effects *e = &m->effects;
    const int32_t contact = f->contact_stiffness_n_per_m > 0.0;
    const double r2 = m->lever_arm_m * m->lever_arm_m;
    p->finger = f;
    rtcore_exact_plant_init(&p->linear, m->inertia_kgm2, m->damping_nms_per_rad, m->stiffness_nm_per_rad);
    p->state_dependent = e->quadratic_damping_nms2_per_rad2 > 0.0 || e->cubic_stiffness_nm_per_rad3 != 0.0
                         || e->contact_stiffness_nm_per_radn > 0.0;
    p->nonlinear = p->state_dependent || contact || e->coulomb_torque_nm > 0.0 || e->gravity_torque_nm != 0.0
                   || e->asymmetric_stiffness_ratio != 1.0 || f->hysteresis_torque_nm > 0.0
                   || e->pressure_stiffening_gain > 0.0 || e->creep_stiffness_ratio > 0.0;
    p->external_torque_nm = 0.0;
    p->kinks = contact || e->asymmetric_stiffness_ratio != 1.0 || e->contact_stiffness_nm_per_radn > 0.0;
    /* (the contact effect's damper is integrated exactly in contact: integrate_segment) */
    p->damping_slope_nms_per_rad = contact ? f->contact_damping_ns_per_m * r2 : 0.0;
    p->stiffness_slope_nm_per_rad = fabs(e->asymmetric_stiffness_ratio - 1.0) * m->stiffness_nm_per_rad
                                    + fabs(e->gravity_torque_nm)
                                    + (contact ? f->contact_stiffness_n_per_m * r2 : 0.0)
                                    + (f->hysteresis_torque_nm > 0.0
                                           ? f->hysteresis_torque_nm / (f->hysteresis_travel_deg * RTCORE_RAD_PER_DEG)
                                           : 0.0) /* the loop's steepest, just after a turn */
                                    + (e->pressure_stiffening_gain > 0.0
                                           ? rtcore_stiffening_torque_nm(m, 1.0, fmax(f->supply_max_kpa, 0.0))
                                           : 0.0) /* the pressure's, at the supply's most */
                                    + e->creep_stiffness_ratio * m->stiffness_nm_per_rad; /* the creep branch's spring */
}
