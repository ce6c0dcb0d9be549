/* Dry friction's knee crossed as one event (rtcore_sim_internal.h): a finger whose drive
 * carries it through zero speed, integrated with the velocity as the independent variable
 * (the step that calls it: rtcore_sim_plant.c's integrate_segment). */
#include <math.h>

#include "rtcore_internal.h"
#include "rtcore_sim_internal.h"

/* The knee is crossed from |ω| = KNEE_EDGE·ω_s on one side to the same on the other, only
 * where the torque beyond the friction stays above KNEE_MARGIN·Tc (then the friction,
 * at most Tc, cannot hold the finger and the velocity moves one way throughout) and
 * within KNEE_DRIFT of where it started (so that the time and the angle are smooth in
 * the velocity: a vanishing friction's knee is crossed where the drive is steady, not
 * where the finger turns under a torque that itself passes through 0), in RK4 steps of
 * at most KNEE_STEP·ω_s of velocity. */
static const double KNEE_EDGE = 3.0;
static const double KNEE_MARGIN = 1.5;
static const double KNEE_DRIFT = 0.25;
static const double KNEE_STEP = 0.5; /* SIM_KNEE_NODES holds 2·KNEE_EDGE/KNEE_STEP + 1 */

/* the drive at t into the passage: the chamber's torque with the segment's external one */
static double drive_at(const sim_knee_drive *d, double t_s)
{
    if (!d->moving) {
        return d->torque_nm;
    }
    return rtcore_sim_pressure_torque_nm(d->finger, rtcore_sim_chamber_at(d->start_kpa, d->input_kpa, d->tau_s,
                                                                          d->t0_s + t_s))
           + d->external_torque_nm;
}

/* A·θ'' = the torque out of balance at (t, θ, ω), the friction's included (its
 * tanh(ω/ω_s) given: rtcore_model_friction_tanh) */
static double net_torque_nm(const sim_plant *p, const rtcore_sim_motion *from, int32_t touching,
                            const sim_knee_drive *d, double t_s, double angle_rad, double velocity_rad_per_s,
                            double friction_tanh)
{
    const double drive_nm = drive_at(d, t_s);
    return drive_nm
           + rtcore_sim_nonlinear_torque_with_nm(p, from, angle_rad, velocity_rad_per_s, touching, drive_nm, t_s,
                                                 friction_tanh)
           - p->linear.stiffness_nm_per_rad * angle_rad - p->linear.damping_nms_per_rad * velocity_rad_per_s;
}

/* d(t, θ)/dω = (A, A·ω)/net; 0 where the torque beyond the friction has fallen below
 * KNEE_MARGIN·Tc on the passage's side or moved from its start, beyond0_nm, by more than
 * KNEE_DRIFT of it (friction_tanh: tanh(ω/ω_s), taken once for each ω the RK4 step visits) */
static int32_t slopes(const sim_plant *p, const rtcore_sim_motion *from, int32_t touching, const sim_knee_drive *d,
                      double beyond0_nm, double velocity_rad_per_s, double friction_tanh, const double y[2],
                      double out[2])
{
    const rtcore_effects *e = &p->finger->prbm.effects;
    const double net_nm = net_torque_nm(p, from, touching, d, y[0], y[1], velocity_rad_per_s, friction_tanh);
    const double beyond_nm = net_nm + e->coulomb_torque_nm * friction_tanh;
    if (!(fabs(beyond_nm) > KNEE_MARGIN * e->coulomb_torque_nm
          && fabs(beyond_nm - beyond0_nm) <= KNEE_DRIFT * fabs(beyond0_nm))) {
        return 0;
    }
    out[0] = p->linear.inertia_kgm2 / net_nm;
    out[1] = velocity_rad_per_s * out[0];
    return 1;
}

int32_t rtcore_sim_knee_passage(const sim_plant *p, const rtcore_sim_motion *s, int32_t touching,
                                const sim_knee_drive *d, double limit_s, sim_knee_path *path)
{
    const rtcore_effects *e = &p->finger->prbm.effects;
    const double torque_c_nm = e->coulomb_torque_nm;
    const double smoothing_rad_per_s = e->coulomb_smoothing_deg_per_s * RTCORE_RAD_PER_DEG;
    const double w0 = s->velocity_rad_per_s;
    double tanh0;
    double net0_nm;
    double beyond_nm;
    double side;
    double w_exit;
    double y[2];
    double w;
    double dw;
    int32_t n;
    int32_t i;
    /* not across a kink, nor with the loop, whose turn a passage through zero speed holds */
    if (!(torque_c_nm > 0.0) || p->kinks || p->finger->hysteresis_torque_nm > 0.0
        || !(fabs(w0) < KNEE_EDGE * smoothing_rad_per_s)) {
        return 0;
    }
    /* the torque beyond the friction's at the start */
    tanh0 = rtcore_model_friction_tanh(e, w0);
    {
        /* the drive at the start is the step's (d->torque_nm, whose g is d->g0_nm) but for
         * a moving chamber's rounding */
        const double drive_nm = d->drive0_nm;
        const double g_nm = drive_nm == d->torque_nm
                                ? d->g0_nm
                                : rtcore_sim_nonlinear_torque_with_nm(p, s, s->angle_rad, w0, touching, drive_nm, 0.0,
                                                                      tanh0);
        net0_nm = drive_nm + g_nm - p->linear.stiffness_nm_per_rad * s->angle_rad - p->linear.damping_nms_per_rad * w0;
        beyond_nm = net0_nm + torque_c_nm * tanh0;
    }
    if (!(fabs(beyond_nm) > KNEE_MARGIN * torque_c_nm)) {
        return 0;
    }
    side = beyond_nm > 0.0 ? 1.0 : -1.0;
    w_exit = side * KNEE_EDGE * smoothing_rad_per_s;
    n = (int32_t)ceil(fabs(w_exit - w0) / (KNEE_STEP * smoothing_rad_per_s));
    if (n > SIM_KNEE_NODES - 1) {
        n = SIM_KNEE_NODES - 1; /* |ω0| a rounding short of the edge: the path's room */
    }
    dw = (w_exit - w0) / (double)n;
    y[0] = 0.0;
    y[1] = s->angle_rad;
    w = w0;
    path->time_s[0] = 0.0;
    path->angle_rad[0] = y[1];
    path->velocity_rad_per_s[0] = w0;
    for (i = 0; i < n; ++i) {
        const double tanh_mid = rtcore_model_friction_tanh(e, w + 0.5 * dw);
        double k1[2];
        double k2[2];
        double k3[2];
        double k4[2];
        double mid[2];
        if (i == 0) { /* at the start: slopes' torque is net0_nm, which passed its tests above */
            k1[0] = p->linear.inertia_kgm2 / net0_nm;
            k1[1] = w * k1[0];
        } else if (!slopes(p, s, touching, d, beyond_nm, w, rtcore_model_friction_tanh(e, w), y, k1)) {
            return 0;
        }
        mid[0] = y[0] + 0.5 * dw * k1[0];
        mid[1] = y[1] + 0.5 * dw * k1[1];
        if (!slopes(p, s, touching, d, beyond_nm, w + 0.5 * dw, tanh_mid, mid, k2)) {
            return 0;
        }
        mid[0] = y[0] + 0.5 * dw * k2[0];
        mid[1] = y[1] + 0.5 * dw * k2[1];
        if (!slopes(p, s, touching, d, beyond_nm, w + 0.5 * dw, tanh_mid, mid, k3)) {
            return 0;
        }
        mid[0] = y[0] + dw * k3[0];
        mid[1] = y[1] + dw * k3[1];
        if (!slopes(p, s, touching, d, beyond_nm, w + dw, rtcore_model_friction_tanh(e, w + dw), mid, k4)) {
            return 0;
        }
        y[0] += dw * (k1[0] + 2.0 * k2[0] + 2.0 * k3[0] + k4[0]) / 6.0;
        y[1] += dw * (k1[1] + 2.0 * k2[1] + 2.0 * k3[1] + k4[1]) / 6.0;
        w = i + 1 < n ? w0 + (double)(i + 1) * dw : w_exit;
        path->time_s[i + 1] = y[0];
        path->angle_rad[i + 1] = y[1];
        path->velocity_rad_per_s[i + 1] = w;
    }
    if (!(y[0] > 0.0 && y[0] < limit_s)) {
        return 0;
    }
    path->count = n + 1;
    return 1;
}
