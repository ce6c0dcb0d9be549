/* A run of samples under one held input, integrated as one segment (sim_span,
 * rtcore_sim_internal.h): a recording sampled fast (1 kHz) holds a step's command for
 * hundreds of samples, and a step per sample would cost ten times the dynamics' own. Its
 * steps follow the dynamics, in whole sample periods from a sample on, up to the motion's
 * time scale (rtcore_sim_span_cap_s); the angle at each sample inside a step is the linear
 * part's exact response over those periods (propagators at whole periods, computed once
 * per run) to the step's own quadratic torque, the one ETDRK4's last stage integrates, so
 * a fast mode that a step passes over is still followed exactly. */
#include <math.h>

#include "rtcore_exact.h"
#include "rtcore_internal.h"
#include "rtcore_sim_internal.h"

/* a time within this fraction of a sample period of a sample is on it */
static const double SPAN_ALIGN = 1e-9;

/* Not with the pneumatic valve, whose pieces follow the regulator's period. Air drag's
 * slope, 2·c2·|θ'|, stays explicit over a span (rtcore_sim_drag_step_s bounds its steps), so
 * the propagators at whole periods hold: taken into each step's exact part, as a step per
 * sample takes it, it let a slow finger take long steps whose number, cut to whole periods,
 * moved with the parameters in jumps that a finite difference of 1e-6 saw (2 % on its
 * derivative at 1 kHz). Only on an under-damped finger: on an over-damped one the explicit
 * slope's bound follows the fast mode, −B/A, to steps far shorter than a sample (a 30 s,
 * 100 Hz ramp 0.6 → 8 ms a run), where a step per sample with the slope in its exact part
 * is both fast and exact. Dry friction's steps stay short while it slides
 * (rtcore_sim_damping_step_s) and its result as smooth as a step per sample's. */
int32_t rtcore_sim_span_eligible(const sim_plant *p)
{
    return p->finger->pneumatic.valve_model != RTCORE_VALVE_PNEUMATIC
           && !(p->finger->prbm.effects.quadratic_damping_nms2_per_rad2 > 0.0 && p->linear.disc_per_s2 >= 0.0);
}

/* The longest step over a span: the motion's time scale (1/|λ_slow| over-damped, 1/ω_n
 * under-damped), at least a sample period and at most RTCORE_SPAN_SAMPLES of them. Within
 * it the simulator's own bounds still apply (rtcore_sim_plant.c's integrate_segment): a moving finger
 * with effects steps a quarter of it, a settled one grows to it. */
double rtcore_sim_span_cap_s(const sim_plant *p, double dt_s)
{
    const double motion_per_s = hypot(p->linear.lambda_per_s[0], p->linear.lambda_per_s[1]);
    const double scale_s = motion_per_s > 0.0 ? 1.0 / motion_per_s : INFINITY;
    return fmin(fmax(scale_s, dt_s), (double)RTCORE_SPAN_SAMPLES * dt_s);
}

/* The step h_s asked for at t_s into the segment, made to fit the samples: from a sample,
 * whole periods (or less than one); between samples, to the next one at the latest. */
double rtcore_sim_span_step_s(const sim_span *span, double t_s, double h_s)
{
    const double to_next_s = (double)span->next * span->dt_s - (span->t0_s + t_s);
    double periods;
    if (to_next_s < span->dt_s * (1.0 - SPAN_ALIGN)) {
        return fmin(h_s, to_next_s);
    }
    periods = floor(h_s / span->dt_s * (1.0 + SPAN_ALIGN));
    if (periods < 1.0) {
        return h_s;
    }
    return fmin(periods, (double)RTCORE_SPAN_SAMPLES) * span->dt_s;
}

/* the quadratic through torque_nm[0..2] at 0, h/2 and h, at t */
static double quadratic_at(const double torque_nm[3], double t_over_h)
{
    const double slope = -3.0 * torque_nm[0] + 4.0 * torque_nm[1] - torque_nm[2];
    const double curve = 2.0 * (torque_nm[0] - 2.0 * torque_nm[1] + torque_nm[2]);
    return torque_nm[0] + t_over_h * (slope + t_over_h * curve);
}

/* the propagator of a step of tau_s: from the table at whole periods, else computed (a
 * step that began between samples, after a kink or a dead zone's crossing cut one) */
static const rtcore_propagator *propagator_at(sim_span *span, const rtcore_exact_plant *linear, double tau_s,
                                              rtcore_propagator *scratch)
{
    const double periods = floor(tau_s / span->dt_s + 0.5);
    const int32_t i = (int32_t)periods;
    if (periods >= 1.0 && periods < (double)RTCORE_SPAN_SAMPLES
        && fabs(tau_s - periods * span->dt_s) <= SPAN_ALIGN * span->dt_s) {
        if (!span->has[i]) {
            rtcore_exact_propagator(linear, periods * span->dt_s, &span->at[i]);
            span->has[i] = 1;
        }
        return &span->at[i];
    }
    rtcore_exact_propagator(linear, tau_s, scratch);
    return scratch;
}

/* After a step of h_s from (angle0, velocity0) at t_s into the segment, under the torque
 * quadratic through torque_nm at 0, h/2 and h, to angle1: the angle at every sample the
 * step reached. linear NULL: the cubic through the ends' angles and velocities. */
void rtcore_sim_span_emit(sim_span *span, const rtcore_exact_plant *linear, double t_s, double h_s,
                          double angle0_rad, double velocity0_rad_per_s, const double torque_nm[3],
                          double angle1_rad, double velocity1_rad_per_s)
{
    const double start_s = span->t0_s + t_s;
    const double tolerance_s = SPAN_ALIGN * span->dt_s;
    while (span->next <= span->count) {
        const double tau_s = (double)span->next * span->dt_s - start_s;
        double angle_rad = angle0_rad;
        double velocity_rad_per_s = velocity0_rad_per_s;
        if (tau_s > h_s + tolerance_s) {
            return;
        }
        if (tau_s >= h_s - tolerance_s) {
            angle_rad = angle1_rad; /* the step ends on it */
        } else if (tau_s > 0.0 && (linear == 0 || linear->damping_nms_per_rad != span->damping_nms_per_rad)) {
            /* a step whose exact part took dry friction's slope (B + c0, its own): the cubic
             * through its ends' angles and velocities, the velocity moving little within
             * such a step (rtcore_sim_damping_step_s bounds it); so too a piece of the
             * knee's passage (rtcore_sim_knee.c: its velocity moves by half of ω_s) */
            const double x = tau_s / h_s;
            const double y = 1.0 - x;
            angle_rad = y * y * ((1.0 + 2.0 * x) * angle0_rad + x * h_s * velocity0_rad_per_s)
                        + x * x * ((3.0 - 2.0 * x) * angle1_rad - y * h_s * velocity1_rad_per_s);
        } else if (tau_s > 0.0) {
            rtcore_propagator scratch;
            const rtcore_propagator *pr = propagator_at(span, linear, tau_s, &scratch);
            rtcore_exact_quadratic(pr, &angle_rad, &velocity_rad_per_s, torque_nm[0],
                                   quadratic_at(torque_nm, 0.5 * tau_s / h_s), quadratic_at(torque_nm, tau_s / h_s));
        }
        span->angle_out_deg[span->next - 1] = angle_rad * RTCORE_DEG_PER_RAD;
        span->next += 1;
    }
}
