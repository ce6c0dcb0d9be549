/* Where a kink or a jump of the torques beyond the linear part cuts a simulated step
 * (rtcore_sim_internal.h; the step that is cut: rtcore_sim_plant.c). */
#include "rtcore_internal.h"
#include "rtcore_sim_internal.h"

/* Where g has a kink or a jump (the object's surface, the contact force reaching 0 as
 * the finger leaves, θ = 0 with an asymmetric stiffness, the contact effect's onset and its
 * push reaching 0) a step is only as accurate as that allows: a step that crosses one is
 * cut where it does, by linear interpolation between its ends. The fraction of the step
 * before the first crossing (1 for none), and in *surface the side that one changes (its
 * bit of `touching`: the object's surface, or the onset of a contact with a damper; 0 for
 * a kink that changes none). */
double rtcore_sim_before_kink(const sim_plant *p, int32_t touching, double angle0_rad, double velocity0_rad_per_s,
                              double angle1_rad, double velocity1_rad_per_s, int32_t *surface)
{
    const rtcore_sim_finger *f = p->finger;
    double fraction = 1.0;
    *surface = 0;
    if (f->contact_stiffness_n_per_m > 0.0) {
        const double surface_rad = f->contact_angle_deg * RTCORE_RAD_PER_DEG;
        const double depth0 = angle0_rad - surface_rad;
        const double depth1 = angle1_rad - surface_rad;
        const int32_t object = (touching & SIM_TOUCH_OBJECT) != 0;
        if (object ? depth1 < 0.0 && depth0 > 0.0 : depth1 > 0.0 && depth0 < 0.0) {
            fraction = depth0 / (depth0 - depth1);
            *surface = SIM_TOUCH_OBJECT;
        }
        if (object && f->contact_damping_ns_per_m > 0.0) {
            const double push0 = f->contact_stiffness_n_per_m * depth0 + f->contact_damping_ns_per_m * velocity0_rad_per_s;
            const double push1 = f->contact_stiffness_n_per_m * depth1 + f->contact_damping_ns_per_m * velocity1_rad_per_s;
            if (((push0 > 0.0 && push1 < 0.0) || (push0 < 0.0 && push1 > 0.0)) && push0 / (push0 - push1) < fraction) {
                fraction = push0 / (push0 - push1);
                *surface = 0;
            }
        }
    }
    if (f->prbm.effects.asymmetric_stiffness_ratio != 1.0
        && ((angle0_rad < 0.0 && angle1_rad > 0.0) || (angle0_rad > 0.0 && angle1_rad < 0.0))
        && angle0_rad / (angle0_rad - angle1_rad) < fraction) {
        fraction = angle0_rad / (angle0_rad - angle1_rad);
        *surface = 0;
    }
    if (f->prbm.effects.contact_stiffness_nm_per_radn > 0.0) {
        const rtcore_effects *e = &f->prbm.effects;
        const double depth0 = angle0_rad - e->contact_onset_deg * RTCORE_RAD_PER_DEG;
        const double depth1 = angle1_rad - e->contact_onset_deg * RTCORE_RAD_PER_DEG;
        const int32_t damped = e->contact_damping_nms_per_rad > 0.0;
        const int32_t in_contact = (touching & SIM_TOUCH_CONTACT) != 0;
        /* with a damper the push jumps at the onset: a side, left only from the one the step
         * is on (as the object's surface); without, a kink either way */
        const int32_t crosses = damped ? (in_contact ? depth0 > 0.0 && depth1 < 0.0 : depth0 < 0.0 && depth1 > 0.0)
                                       : (depth0 < 0.0 && depth1 > 0.0) || (depth0 > 0.0 && depth1 < 0.0);
        if (crosses && depth0 / (depth0 - depth1) < fraction) {
            fraction = depth0 / (depth0 - depth1);
            *surface = damped ? SIM_TOUCH_CONTACT : 0;
        }
        if (damped && in_contact) {
            const double push0 = rtcore_contact_push_nm(e, angle0_rad, velocity0_rad_per_s);
            const double push1 = rtcore_contact_push_nm(e, angle1_rad, velocity1_rad_per_s);
            if (((push0 > 0.0 && push1 < 0.0) || (push0 < 0.0 && push1 > 0.0)) && push0 / (push0 - push1) < fraction) {
                fraction = push0 / (push0 - push1);
                *surface = 0;
            }
        }
    }
    return fraction;
}
