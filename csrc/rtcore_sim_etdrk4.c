/* One step of the finger's dynamics (rtcore_sim_internal.h): the linear part exact, the
 * torque beyond it by ETDRK4; the plant with the damping a step integrates exactly. The
 * integration of a segment that takes these steps: rtcore_sim_plant.c. */
#include <math.h>

#include "rtcore_exact.h"
#include "rtcore_internal.h"
#include "rtcore_sim_internal.h"

/* The finger is A·θ'' + B·θ' + k·θ = u(t): a linear plant, integrated exactly for any step
 * (e^(L·h), L = [[0, 1], [−k/A, −B/A]], in closed form), driven by the torque
 * u = N·p_eff(t) + g(θ, θ'), where g is every torque beyond k·θ + B·θ' (the effects and
 * the contact). Over a step the chamber's torque is the quadratic through its exact values
 * at the start, middle and end; g is integrated by ETDRK4 (Cox & Matthews 2002), whose
 * last stage is the exact response to a quadratic torque too. The plain linear finger
 * without a valve lag is exact at any step; with effects the step resolves what the
 * explicit g needs (rtcore_sim_parameter_step_s, rtcore_sim_state_step_s), with a lag
 * the chamber's exponential (rtcore_sim_plant.c's integrate_segment). */

/* The same plant with the damping B + extra: the linear part a step integrates exactly. */
void rtcore_sim_with_damping(const sim_plant *base, double extra_nms_per_rad, sim_plant *out)
{
    *out = *base;
    if (extra_nms_per_rad == 0.0) {
        return;
    }
    rtcore_exact_plant_init(&out->linear, base->linear.inertia_kgm2, base->linear.damping_nms_per_rad + extra_nms_per_rad,
                            base->linear.stiffness_nm_per_rad);
}

/* One step h; the chamber's torque is p_start, p_mid and p_end at t = 0, h/2 and h, and
 * g_start = g(x) + c0·θ'. p is the plant with the damping B + c0, c0 =
 * linearized_nms_per_rad (the friction's and the drag's slopes, rtcore_sim_damping_step_s), which g gives
 * back. Without g: the exact response to that quadratic. With g, ETDRK4 (Cox &
 * Matthews 2002): stages a and b from x and c from a over h/2, each with the total torque
 * held (at x, at a, and 2·(at b) − (at x)), then the exact response to the quadratic
 * through the torque at x, the mean of those at a and b, and at c. */
void rtcore_sim_etdrk4_step(const sim_plant *p, const rtcore_sim_motion *from, rtcore_propagator_cache *cache,
                             double *angle_rad, double *velocity_rad_per_s, double h, double p_start, double p_mid,
                             double p_end, double g_start, int32_t touching, double linearized_nms_per_rad,
                             double torque_nm[3])
{
    const int32_t slot = rtcore_exact_propagators(&p->linear, cache, h, p->nonlinear);
    const rtcore_propagator *full = &cache->full[slot];
    const rtcore_propagator *half = &cache->half[slot];
    double th_a;
    double w_a;
    double th_b;
    double w_b;
    double th_c;
    double w_c;
    double n_x;
    double n_a;
    double n_b;
    double n_c;
    if (!p->nonlinear) {
        torque_nm[0] = p_start;
        torque_nm[1] = p_mid;
        torque_nm[2] = p_end;
        rtcore_exact_quadratic(full, angle_rad, velocity_rad_per_s, p_start, p_mid, p_end);
        return;
    }
    n_x = p_start + g_start;
    rtcore_exact_held(half, *angle_rad, *velocity_rad_per_s, n_x, &th_a, &w_a);
    n_a = p_mid + rtcore_sim_nonlinear_torque_nm(p, from, th_a, w_a, touching, p_mid, 0.5 * h) + linearized_nms_per_rad * w_a;
    rtcore_exact_held(half, *angle_rad, *velocity_rad_per_s, n_a, &th_b, &w_b);
    n_b = p_mid + rtcore_sim_nonlinear_torque_nm(p, from, th_b, w_b, touching, p_mid, 0.5 * h) + linearized_nms_per_rad * w_b;
    rtcore_exact_held(half, th_a, w_a, 2.0 * n_b - n_x, &th_c, &w_c);
    n_c = p_end + rtcore_sim_nonlinear_torque_nm(p, from, th_c, w_c, touching, p_end, h) + linearized_nms_per_rad * w_c;
    torque_nm[0] = n_x;
    torque_nm[1] = 0.5 * (n_a + n_b);
    torque_nm[2] = n_c;
    rtcore_exact_quadratic(full, angle_rad, velocity_rad_per_s, n_x, torque_nm[1], n_c);
}
