/* The simulated finger's dynamics under a held valve input (rtcore_sim_internal.h's
 * rtcore_sim_integrate_held): the steps a segment takes and the chamber they follow (one
 * ETDRK4 step: rtcore_sim_etdrk4.c; the torques beyond the linear part and the local linear
 * plant: rtcore_sim_torque.c; the step sizes: rtcore_sim_step_size.c; where a kink cuts a
 * step: rtcore_sim_kink.c; one finger alone, the API of rtcore_sim_plant.h:
 * rtcore_sim_motion.c). */
#include <math.h>

#include "rtcore_exact.h"
#include "rtcore_internal.h"
#include "rtcore_sim_internal.h"

/* the cuts of a step toward a damped contact's onset (rtcore_sim_before_kink's interpolation repeated) */
static const int32_t ONSET_REFINEMENTS = 4;

/* The step that cubic stiffness's slope allows at the angle the finger may reach under
 * the held input: the present one plus the torque out of balance over k, with the chamber
 * now and at the segment's end (rtcore_sim_state_step_s); at least floor_s. With `en_route`
 * (a later step inside a span) the torque out of balance without the damper's share too: an
 * over-damped finger on its way has its drive balanced by B·θ' far from where it goes. */
static double state_cap_s(const sim_plant *p, const rtcore_sim_motion *s, double torque_now_nm,
                          double torque_last_nm, double step_cap_s, double floor_s, int32_t en_route, double g_nm)
{
    const double spring_nm = p->linear.stiffness_nm_per_rad * s->angle_rad;
    const double linear_nm = spring_nm + p->linear.damping_nms_per_rad * s->velocity_rad_per_s;
    double accel_nm = fmax(fabs(torque_now_nm + g_nm - linear_nm), fabs(torque_last_nm + g_nm - linear_nm));
    if (en_route) {
        accel_nm = fmax(accel_nm, fmax(fabs(torque_now_nm + g_nm - spring_nm), fabs(torque_last_nm + g_nm - spring_nm)));
    }
    return fmin(step_cap_s, fmax(rtcore_sim_state_step_s(p, s->angle_rad, accel_nm), floor_s));
}

/* g at the state `s` with the sides the angle is on (rtcore_sim_touches), under the drive
 * torque_now_nm: what state_cap_s takes */
static double g_here_nm(const sim_plant *p, const rtcore_sim_motion *s, double torque_now_nm)
{
    return rtcore_sim_nonlinear_torque_nm(p, s, s->angle_rad, s->velocity_rad_per_s,
                                          rtcore_sim_touches(p->finger, s->angle_rad), torque_now_nm, 0.0);
}

/* The finger at the end of a step of elapsed_s (or a knee's passage) from `s`: the loop
 * and the creep branch moved with it. */
static void finish_step(const rtcore_sim_finger *f, rtcore_sim_motion *s, double angle_rad, double velocity_rad_per_s,
                        double elapsed_s)
{
    if (f->hysteresis_torque_nm > 0.0) {
        s->hysteresis_z = rtcore_sim_loop_z(f, s, angle_rad);
    }
    if (f->prbm.effects.creep_stiffness_ratio > 0.0) {
        s->creep_angle_rad = rtcore_sim_creep_angle_rad(&f->prbm.effects, s, angle_rad, elapsed_s);
    }
    s->angle_rad = angle_rad;
    s->velocity_rad_per_s = velocity_rad_per_s;
}

/* Integrate over duration_s with the valve input held at input_kpa and the external torque
 * at external_torque_nm (both in the drive u), in steps of at most
 * step_cap_s (longer for a settled finger, or one that dry friction holds: up to
 * request_cap_s), and of what rtcore_sim_state_step_s allows for the state at the start (the input is
 * held, so what the segment will reach is known there). The chamber follows its exact
 * solution, on one side of the dead zone's threshold throughout (rtcore_sim_integrate_held
 * splits there). While its torque moves the step is at most LAG_STEP_FRACTION·τ·(S/|p − u|)^(1/3),
 * S the supply's span and p − u what the chamber still lacks of its input: what the
 * quadratic misses of the exponential, ∝ |p − u|·(h/τ)³, stays as small as in the first
 * step of a full-span change (τ/16), so a change costs about 3/LAG_STEP_FRACTION = 48
 * steps however long it is held, and a nearly settled chamber (every later sample period)
 * costs none. That keeps the angle within about 5e-7 of its range, so that an effect
 * switched on, whose shorter steps follow the lag more closely, moves the result by no
 * more. The
 * last step ends the segment exactly and a kink cuts a step where it lies, so the steps
 * and the result move continuously with every parameter. Over a span of samples (span not
 * NULL: rtcore_sim_span.c) the steps fit the samples and the angle at each is written. */
static void integrate_segment(const sim_plant *p, rtcore_sim_motion *s, rtcore_propagator_cache *cache,
                              double input_kpa, double external_torque_nm, double duration_s, double request_cap_s,
                              sim_span *span)
{
    const rtcore_sim_finger *f = p->finger;
    sim_plant segment = *p; /* with this segment's external torque (the pressure's stiffening) */
    /* the chamber moves toward the input on one side of it throughout: one lag, the fill's
     * or the vent's */
    const double tau_s = rtcore_valve_tau_s(&f->prbm.effects, input_kpa - s->chamber_kpa);
    const double start_kpa = tau_s > 0.0 ? s->chamber_kpa : input_kpa;
    const double end_kpa = tau_s > 0.0 ? rtcore_sim_chamber_at(start_kpa, input_kpa, tau_s, duration_s) : input_kpa;
    const double deadzone_kpa = f->prbm.effects.pressure_deadzone_kpa;
    /* the torque is constant without a lag, without a gain, at the input already, or below
     * the dead zone throughout (the chamber is monotonic within a segment) */
    const int32_t moving = tau_s > 0.0 && f->prbm.pressure_gain_nm_per_kpa > 0.0 && start_kpa != input_kpa
                           && !(deadzone_kpa > 0.0 && start_kpa <= deadzone_kpa && end_kpa <= deadzone_kpa);
    /* over a span, the sample period sets the scale of the shortest steps, not the span's
     * length (hundreds of periods): a step per sample's bounds, whatever the span */
    const double unit_s = span != 0 ? fmin(duration_s, span->dt_s) : duration_s;
    const double min_step_s = unit_s * MIN_STEP_PER_SEGMENT;
    const double lag_span_kpa = fmax(f->supply_max_kpa - f->supply_min_kpa, 1.0);
    const double torque_last = rtcore_sim_pressure_torque_nm(f, end_kpa) + external_torque_nm;
    double torque_start = rtcore_sim_pressure_torque_nm(f, start_kpa) + external_torque_nm;
    const double step_cap_s = fmin(request_cap_s, s->max_step_s);
    const double state_floor_s = (span != 0 ? fmin(step_cap_s, span->dt_s) : step_cap_s) / STATE_STEP_SHRINK;
    const double settle_range_rad = rtcore_sim_settle_range_rad_for(p);
    const double lag_step_s = LAG_STEP_FRACTION * tau_s;
    /* (LAG_STEP_FRACTION·τ)³·S: a step h with h³·|p − u| below it is shorter than the lag's
     * bound, which then need not be taken (a cube root per step saved; the same h) */
    const double lag_cube_s3_kpa = lag_step_s * lag_step_s * lag_step_s * lag_span_kpa * (1.0 - 1e-9);
    double chamber_now_kpa = moving ? rtcore_sim_chamber_at(start_kpa, input_kpa, tau_s, 0.0) : input_kpa;
    double cap_s = step_cap_s;
    double t_s = 0.0;
    int32_t last = 0;
    int32_t next_touching = -1; /* after a step cut at the surface: the side it goes on to */
    const int32_t drag_explicit = span != 0 && f->prbm.effects.quadratic_damping_nms2_per_rad2 > 0.0;

    segment.external_torque_nm = external_torque_nm;
    p = &segment;

    if (!(duration_s > MIN_SEGMENT_S)) {
        s->chamber_kpa = end_kpa;
        return;
    }
    if (p->state_dependent) {
        cap_s = state_cap_s(p, s, torque_start, torque_last, step_cap_s, state_floor_s, 0,
                            g_here_nm(p, s, torque_start));
    }
    while (!last) {
        const double remaining_s = duration_s - t_s;
        const int32_t sides = rtcore_sim_touches(f, s->angle_rad);
        int32_t touching = next_touching >= 0 ? next_touching : sides;
        /* g at the step's start, on the sides the step keeps: the step's g_start, the knee's
         * first torque and (on the sides the angle is on) the state's bounds, computed once */
        double g_start = p->nonlinear
                             ? rtcore_sim_nonlinear_torque_nm(p, s, s->angle_rad, s->velocity_rad_per_s, touching, torque_start, 0.0)
                             : 0.0;
        const double g_sides = touching == sides || !p->state_dependent ? g_start : g_here_nm(p, s, torque_start);
        if (p->state_dependent && span != 0 && t_s > 0.0) {
            /* a span lasts many periods: the reach from the state now, as a step per
             * sample would take it at each sample */
            cap_s = state_cap_s(p, s, torque_start, torque_last, step_cap_s, state_floor_s, 1, g_sides);
        }
        if (f->prbm.effects.coulomb_torque_nm > 0.0) {
            /* a drive that carries the finger through the friction's knee: crossed as one
             * event (rtcore_sim_knee.c), where the steps below would climb its slope a
             * share at a time */
            sim_knee_drive drive;
            sim_knee_path path;
            drive.finger = f;
            drive.moving = moving;
            drive.start_kpa = start_kpa;
            drive.input_kpa = input_kpa;
            drive.tau_s = tau_s;
            drive.t0_s = t_s;
            drive.torque_nm = torque_start;
            drive.external_torque_nm = external_torque_nm;
            /* the drive at the passage's start: the chamber now is the one at t_s (each
             * assignment below takes it at the t_s it moves to) */
            drive.drive0_nm = moving ? rtcore_sim_pressure_torque_nm(f, chamber_now_kpa) + external_torque_nm
                                     : torque_start;
            drive.g0_nm = g_start;
            if (rtcore_sim_knee_passage(p, s, touching, &drive, fmin(remaining_s * (1.0 - 1e-9), step_cap_s), &path)) {
                const double angle_rad = path.angle_rad[path.count - 1];
                const double velocity_rad_per_s = path.velocity_rad_per_s[path.count - 1];
                const double passed_s = path.time_s[path.count - 1];
                if (span != 0) {
                    int32_t i;
                    for (i = 1; i < path.count; ++i) {
                        rtcore_sim_span_emit(span, 0, t_s + path.time_s[i - 1],
                                             path.time_s[i] - path.time_s[i - 1], path.angle_rad[i - 1],
                                             path.velocity_rad_per_s[i - 1], 0, path.angle_rad[i],
                                             path.velocity_rad_per_s[i]);
                    }
                }
                finish_step(f, s, angle_rad, velocity_rad_per_s, passed_s);
                t_s += passed_s;
                if (moving) {
                    chamber_now_kpa = rtcore_sim_chamber_at(start_kpa, input_kpa, tau_s, t_s);
                    torque_start = rtcore_sim_pressure_torque_nm(f, chamber_now_kpa) + external_torque_nm;
                }
                continue;
            }
        }
        const double friction0 = f->prbm.effects.coulomb_torque_nm > 0.0
                                     ? rtcore_sim_friction_slope_nms_per_rad(&f->prbm.effects, s->velocity_rad_per_s)
                                     : 0.0;
        /* a contact's damper in contact: its Cc, taken into the exact part whole (g gives back
         * only what the push's limit to pushing leaves of it, a kink that cuts the step) */
        const double damper0 = (touching & SIM_TOUCH_CONTACT) && f->prbm.effects.contact_stiffness_nm_per_radn > 0.0
                                   ? f->prbm.effects.contact_damping_nms_per_rad
                                   : 0.0;
        /* the friction's, the drag's and the damper's slopes here, integrated exactly over the
         * step: the plant with B + slope0; over a span the drag's stays explicit (drag_explicit) */
        const double slope0
            = friction0 + (drag_explicit ? 0.0 : 2.0 * f->prbm.effects.quadratic_damping_nms2_per_rad2 * fabs(s->velocity_rad_per_s))
              + damper0;
        sim_plant local;
        rtcore_sim_with_damping(p, slope0, &local);
        double h = settle_range_rad > 0.0 && cap_s < request_cap_s
                       ? rtcore_sim_settled_step_s(p, s, cap_s, request_cap_s, settle_range_rad,
                                                   torque_start + g_start, fabs(torque_last - torque_start))
                       : cap_s;
        if (friction0 > 0.0) {
            /* a finger that dry friction holds creeps on the time scale of the plant with
             * B + c0 (and the drag's slope), the one each step integrates exactly, far
             * slower than the free finger's: a share of that plant's bounds, the parameters'
             * and, with a cubic spring, the state's (so the steps move continuously as one
             * switches on). The reach below still keeps the velocity where c0 holds and cuts
             * the step where the finger breaks away; the error grows about as the share
             * (2.3e-4 of the range at the whole bound, 6.5e-5 at a quarter, on a stiff finger
             * held at 0.25 Hz). Over a span, no longer than a sample period: the samples
             * inside a step that took c0 are a cubic between its ends (rtcore_sim_span_emit),
             * which a creep turning over several periods leaves (2e-5 of the range at
             * 100 Hz, against 1e-6) */
            double creep_s = rtcore_sim_parameter_step_s(&local);
            if (p->state_dependent) {
                creep_s = fmin(creep_s, state_cap_s(&local, s, torque_start, torque_last, INFINITY, 0.0,
                                                    span != 0 && t_s > 0.0, g_sides));
            }
            h = fmax(h, fmin(fmin(request_cap_s, span != 0 ? span->dt_s : INFINITY), CREEP_STEP_SHARE * creep_s));
        }
        double torque_mid = torque_start;
        double torque_end = torque_start;
        double chamber_end_kpa = chamber_now_kpa;
        int32_t cut = 0; /* the times the step was shortened to end at a kink */
        int32_t refining = 0; /* the last cut was at a damped contact's onset */
        int32_t flipped = 0; /* the step was taken again on the far side of the surface */

        next_touching = -1;
        if (moving) {
            /* from how far the chamber still is from its input, not from when this
             * segment began: a chamber nearly settled (every sample period after a step)
             * needs no short steps, and a new segment does not restart them (the chamber
             * now is the one the last step ended at, rtcore_sim_chamber_at(t_s)) */
            const double gap_kpa = fabs(chamber_now_kpa - input_kpa);
            if (gap_kpa > 0.0 && !(h * h * h * gap_kpa < lag_cube_s3_kpa)) {
                h = fmin(h, lag_step_s * cbrt(lag_span_kpa / gap_kpa));
            }
        }
        if (drag_explicit) {
            /* the chamber's torque moves within the step by no more than over h from now */
            const double drift_nm = moving ? rtcore_sim_pressure_torque_nm(f, rtcore_sim_chamber_at(start_kpa, input_kpa, tau_s,
                                                                              fmin(t_s + h, duration_s)))
                                                 + external_torque_nm - torque_start
                                           : 0.0;
            h = fmin(h, rtcore_sim_drag_step_s(p, s->velocity_rad_per_s,
                                               torque_start + g_start - p->linear.stiffness_nm_per_rad * s->angle_rad,
                                               drift_nm));
        }
        if (f->prbm.effects.coulomb_torque_nm > 0.0 || (f->prbm.effects.quadratic_damping_nms2_per_rad2 > 0.0 && !drag_explicit)) {
            const double net_nm = torque_start + g_start - p->linear.stiffness_nm_per_rad * s->angle_rad
                                  - p->linear.damping_nms_per_rad * s->velocity_rad_per_s;
            /* the chamber's torque moves within the step by no more than over h from now (it
             * is monotonic): over a span of held samples the segment's whole change would
             * hold every step to what the chamber does in the first */
            const double drift_nm = moving ? rtcore_sim_pressure_torque_nm(f, rtcore_sim_chamber_at(start_kpa, input_kpa, tau_s,
                                                                              fmin(t_s + h, duration_s)))
                                                 + external_torque_nm - torque_start
                                           : 0.0;
            /* its rate now, which an exponential does not exceed later (the dead zone's
             * slope is at most 1) */
            const double drift_rate_nm_per_s = moving ? f->prbm.pressure_gain_nm_per_kpa
                                                            * fabs(input_kpa - chamber_now_kpa) / tau_s
                                                      : 0.0;
            h = fmin(h, rtcore_sim_damping_step_s(&local, s->velocity_rad_per_s,
                                                  rtcore_sim_velocity_reach_rad_per_s(&local, s->velocity_rad_per_s, friction0, h, !drag_explicit), net_nm,
                                                  drift_nm, drift_rate_nm_per_s, h));
        }
        g_start += slope0 * s->velocity_rad_per_s;
        if (span != 0) {
            h = rtcore_sim_span_step_s(span, t_s, h);
        }
        h = fmax(h, min_step_s);
        if (!(h * (1.0 + 1e-9) < remaining_s)) { /* no sliver of a step after this one */
            h = remaining_s;
            last = 1;
        }
        for (;;) {
            double angle_rad = s->angle_rad;
            double velocity_rad_per_s = s->velocity_rad_per_s;
            double fraction = 1.0;
            double torque_nm[3];
            int32_t surface = 0;
            if (moving) {
                torque_mid = rtcore_sim_pressure_torque_nm(f, rtcore_sim_chamber_at(start_kpa, input_kpa, tau_s, t_s + 0.5 * h))
                             + external_torque_nm;
                if (!last) {
                    chamber_end_kpa = rtcore_sim_chamber_at(start_kpa, input_kpa, tau_s, t_s + h);
                }
                torque_end = last ? torque_last : rtcore_sim_pressure_torque_nm(f, chamber_end_kpa) + external_torque_nm;
            }
            rtcore_sim_etdrk4_step(&local, s, cache, &angle_rad, &velocity_rad_per_s, h, torque_start, torque_mid,
                                   torque_end, g_start, touching, slope0, torque_nm);
            if (p->kinks && (!cut || (refining && cut < ONSET_REFINEMENTS))) {
                fraction = rtcore_sim_before_kink(p, touching, s->angle_rad, s->velocity_rad_per_s, angle_rad,
                                       velocity_rad_per_s, &surface);
                if (cut && !(fraction > KINK_MIN_FRACTION)) {
                    fraction = 1.0; /* a refined step that ends at the onset */
                } else if (cut && fraction == 1.0) {
                    next_touching = -1; /* it ends short of it: the next step meets it at its start */
                }
            }
            if (fraction < 1.0 && fraction > KINK_MIN_FRACTION) {
                h *= fraction; /* the next step starts at the kink, past the surface if it is that */
                last = 0;
                cut += 1;
                /* a damped contact's push jumps at its onset: the step that ends there is cut
                 * again until it ends at the onset (linear interpolation, repeated) */
                refining = surface == SIM_TOUCH_CONTACT;
                next_touching = surface ? touching ^ surface : -1;
                continue;
            }
            if (fraction < 1.0 && surface && !flipped) {
                touching ^= surface; /* the surface is where the step starts: take it past */
                flipped = 1;
                g_start = rtcore_sim_nonlinear_torque_nm(p, s, s->angle_rad, s->velocity_rad_per_s, touching, torque_start, 0.0)
                          + slope0 * s->velocity_rad_per_s;
                continue;
            }
            if (span != 0) {
                rtcore_sim_span_emit(span, &local.linear, t_s, h, s->angle_rad, s->velocity_rad_per_s, torque_nm,
                                     angle_rad, velocity_rad_per_s);
            }
            finish_step(f, s, angle_rad, velocity_rad_per_s, h);
            break;
        }
        torque_start = torque_end;
        chamber_now_kpa = chamber_end_kpa;
        t_s += h;
        if (!(isfinite(s->angle_rad) && isfinite(s->velocity_rad_per_s))) {
            break; /* diverged: the state stays non-finite, the chamber still follows */
        }
    }
    s->chamber_kpa = end_kpa;
}

void rtcore_sim_integrate_held(const sim_plant *p, rtcore_sim_motion *s, rtcore_propagator_cache *cache,
                               double input_kpa, double external_torque_nm, double duration_s, double request_cap_s,
                               sim_span *span)
{
    /* split where the chamber crosses the dead zone's threshold, so that the torque is
     * smooth within each part */
    const double deadzone_kpa = p->finger->prbm.effects.pressure_deadzone_kpa;
    const double start_kpa = s->chamber_kpa;
    const double tau_s = rtcore_valve_tau_s(&p->finger->prbm.effects, input_kpa - start_kpa);
    if (tau_s > 0.0 && deadzone_kpa > 0.0
        && ((start_kpa < deadzone_kpa && input_kpa > deadzone_kpa)
            || (start_kpa > deadzone_kpa && input_kpa < deadzone_kpa))) {
        const double cross_s = tau_s * log((start_kpa - input_kpa) / (deadzone_kpa - input_kpa));
        if (cross_s > 0.0 && cross_s < duration_s) {
            integrate_segment(p, s, cache, input_kpa, external_torque_nm, cross_s, request_cap_s, span);
            if (span != 0) {
                span->t0_s = cross_s;
            }
            integrate_segment(p, s, cache, input_kpa, external_torque_nm, duration_s - cross_s, request_cap_s, span);
            return;
        }
    }
    integrate_segment(p, s, cache, input_kpa, external_torque_nm, duration_s, request_cap_s, span);
}
