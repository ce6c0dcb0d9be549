/* The simulator's step sizes: the longest step the finger's parameters allow, the bounds
 * the state and dry friction's slope set within a held segment, and the longer steps of a
 * settled finger (the fractions of the time scales they take: rtcore_sim_internal.h; the
 * integration that takes them: rtcore_sim_plant.c). */
#include <math.h>

#include "rtcore_exact.h"
#include "rtcore_internal.h"
#include "rtcore_sim_internal.h"

/* |re + i·im|: hypot(re, ±0) is |re| (C99 F.9.4.3), which real eigenvalues, an
 * over-damped plant's, take without hypot's scaling */
static double modulus(double re, double im)
{
    return im == 0.0 ? fabs(re) : hypot(re, im);
}

static double shift_per_s(const sim_plant *p, double damping, double stiffness)
{
    double lambda_per_s[4];
    double first;
    double second;
    rtcore_exact_eigenvalues(p->linear.inertia_kgm2, damping, stiffness, lambda_per_s);
    first = modulus(lambda_per_s[0] - p->linear.lambda_per_s[0], lambda_per_s[1] - p->linear.lambda_per_s[1]);
    second = modulus(lambda_per_s[2] - p->linear.lambda_per_s[2], lambda_per_s[3] - p->linear.lambda_per_s[3]);
    return first > second ? first : second;
}

/* The longest step for explicit slopes of g: a damping-like c >= 0 and a stiffness-like
 * ±K, each by how far it moves the plant's eigenvalues. A slope of 0 moves none: its
 * shift is 0 without the three eigenvalue solutions (dry friction asks at every step). */
static double slope_step_s(const sim_plant *p, double damping_slope, double stiffness_slope)
{
    const double damping_per_s = damping_slope != 0.0 ? shift_per_s(p, p->linear.damping_nms_per_rad + damping_slope,
                                                                     p->linear.stiffness_nm_per_rad)
                                                      : 0.0;
    const double stiffer_per_s = stiffness_slope != 0.0 ? shift_per_s(p, p->linear.damping_nms_per_rad,
                                                                      p->linear.stiffness_nm_per_rad + stiffness_slope)
                                                        : 0.0;
    const double softer_per_s = stiffness_slope != 0.0 ? shift_per_s(p, p->linear.damping_nms_per_rad,
                                                                     p->linear.stiffness_nm_per_rad - stiffness_slope)
                                                       : 0.0;
    const double stiffness_per_s = softer_per_s > stiffer_per_s ? softer_per_s : stiffer_per_s;
    double step_s = INFINITY;
    if (damping_per_s > 0.0) {
        step_s = DAMPING_STEP_FRACTION / damping_per_s;
    }
    if (stiffness_per_s > 0.0) {
        step_s = fmin(step_s, STIFFNESS_STEP_FRACTION / stiffness_per_s);
    }
    return step_s;
}

/* The friction Tc·tanh(ω/ω_s) damps like a slope c(ω) = (Tc/ω_s)·sech²(ω/ω_s), up to
 * Tc/ω_s at rest: for a small ω_s far beyond B, a stiffness no explicit step could take at
 * the sample rate (a finger that sticks is a finger damped without bound). So each step
 * takes the slope at its start, c0, into the linear part it integrates exactly (damping
 * B + c0), and only what the slope changes within the step, c(ω) − c0, is left explicit
 * (a Rosenbrock-type linearisation). The step keeps that change within
 * FRICTION_SLOPE_SHARE of the exact damping B + c0 over the velocities it can reach: a
 * quarter. A larger share takes fewer steps but lets a weak friction (c0 < B) on an
 * over-damped finger let go from rest carry a span's first step far past the knee with the
 * slope of rest (tests/rtcore/test_sim_spans.py). Every step also moves the velocity by no
 * more than KNEE_REACH·ω_s inside the knee, |ω| < KNEE_SPAN·ω_s (from outside, to its edge
 * or that far in): where all of c0 is within the share (c0 < B/3) the slope bounds no reach
 * at all, and without this bound a span misses the fine reference.
 * Air drag's slope, 2·c2·|θ'|, keeps to a quarter too: at half, an over-damped finger's
 * drag misses the fine reference by more than its tolerance. */
static const double FRICTION_SLOPE_SHARE = 0.25;
static const double DRAG_SLOPE_SHARE = 0.25;
/* The knee: |ω| < KNEE_SPAN·ω_s (sech² above 0.07 of its peak), crossed KNEE_REACH·ω_s a step */
static const double KNEE_SPAN = 2.0;
static const double KNEE_REACH = 1.0;

double rtcore_sim_friction_slope_nms_per_rad(const rtcore_effects *e, double velocity_rad_per_s)
{
    const double smoothing_rad_per_s = e->coulomb_smoothing_deg_per_s * RTCORE_RAD_PER_DEG;
    const double c = cosh(velocity_rad_per_s / smoothing_rad_per_s);
    return e->coulomb_torque_nm / (smoothing_rad_per_s * c * c);
}

/* |ω|/ω_s where the slope is `slope` (0 < slope <= Tc/ω_s): sech²(x) = slope·ω_s/Tc */
static double friction_speed_at(double peak_slope, double slope)
{
    return acosh(sqrt(peak_slope / slope));
}

/* How far the velocity may move from ω before the friction's slope leaves c0 ± allowed,
 * either way (infinite when it never does). */
static double friction_reach_rad_per_s(const rtcore_effects *e, double velocity_rad_per_s, double slope0,
                                       double allowed)
{
    const double smoothing_rad_per_s = e->coulomb_smoothing_deg_per_s * RTCORE_RAD_PER_DEG;
    const double peak = e->coulomb_torque_nm / smoothing_rad_per_s;
    const double x = fabs(velocity_rad_per_s) / smoothing_rad_per_s;
    const double x_low = slope0 - allowed > 0.0 ? friction_speed_at(peak, slope0 - allowed) : INFINITY;
    /* towards rest the slope rises: to its bound, or over the peak and down the far side */
    const double toward = slope0 + allowed < peak ? x - friction_speed_at(peak, slope0 + allowed) : x + x_low;
    const double away = x_low - x;
    return fmax(fmin(toward, away), 0.0) * smoothing_rad_per_s;
}

/* How far the velocity may move before the damping-like slopes taken into the exact part
 * at the step's start, the friction's c_f and the drag's 2·c2·|θ'| (when drag_exact: a step
 * per sample; over a span it is explicit, rtcore_sim_drag_step_s), change by more than
 * FRICTION_SLOPE_SHARE and DRAG_SLOPE_SHARE of the exact damping B + c0 (half of each when
 * both act; the friction's of B + c0 or of A/step_s, the larger, step_s the step proposed
 * before this bound), and, with friction, no further than KNEE_REACH·ω_s within its knee. A floor
 * of 1e-3 of critical damping (and 1e-6 of the friction's peak slope) keeps a plant
 * without damping, at rest, from steps of nothing. */
double rtcore_sim_velocity_reach_rad_per_s(const sim_plant *local, double velocity_rad_per_s, double friction0,
                                           double step_s, int32_t drag_exact)
{
    const rtcore_effects *e = &local->finger->prbm.effects;
    const int32_t friction = e->coulomb_torque_nm > 0.0;
    const int32_t drag = drag_exact && e->quadratic_damping_nms2_per_rad2 > 0.0;
    const double floor_nms_per_rad
        = fmax(1e-3 * sqrt(local->linear.stiffness_nm_per_rad * local->linear.inertia_kgm2),
               friction ? 1e-6 * e->coulomb_torque_nm / (e->coulomb_smoothing_deg_per_s * RTCORE_RAD_PER_DEG) : 0.0);
    const double exact_nms_per_rad = fmax(local->linear.damping_nms_per_rad, floor_nms_per_rad)
                                     / (friction && drag ? 2.0 : 1.0);
    /* the damping A/h that a step of h, or any shorter one, takes explicitly as accurately as
     * the motion's own (h·c/A within the share) */
    const double inertial_nms_per_rad = step_s > 0.0 ? local->linear.inertia_kgm2 / step_s / (friction && drag ? 2.0 : 1.0)
                                                     : 0.0;
    const double allowed = FRICTION_SLOPE_SHARE * fmax(exact_nms_per_rad, inertial_nms_per_rad);
    const double allowed_drag = DRAG_SLOPE_SHARE * exact_nms_per_rad;
    double reach = INFINITY;
    if (friction) {
        const double smoothing_rad_per_s = e->coulomb_smoothing_deg_per_s * RTCORE_RAD_PER_DEG;
        reach = friction_reach_rad_per_s(e, velocity_rad_per_s, friction0, allowed);
        /* and across the knee by no more than a fraction of its width: where the friction
         * is weak (c0 within the share) the slope never bounds the reach, and a step that
         * carried the velocity past the knee at once would take the torque's turn as a
         * jump within it */
        reach = fmin(reach, fmax(KNEE_REACH * smoothing_rad_per_s,
                                 fabs(velocity_rad_per_s) - KNEE_SPAN * smoothing_rad_per_s));
    }
    if (drag) {
        reach = fmin(reach, allowed_drag / (2.0 * e->quadratic_damping_nms2_per_rad2));
    }
    return reach;
}

/* Air drag left explicit (over a span, where the propagators at whole periods are the
 * finger's own): the step that its slope 2·c2·|θ'| allows by how far it moves the plant's
 * eigenvalues, at the fastest the finger can move within the step. Under a held drive the
 * energy ½·A·θ'² + ½·k·(θ − θ_eq)² does not grow (the damping, the drag's too, only takes
 * it), so |θ'| <= sqrt(θ'² + (u − k·θ)²/(k·A)), u − k·θ the torque out of balance without
 * the damper (balance_nm, taken whole: with the drag's own torque, c2·θ'², added), and a
 * change of the drive by drift_nm within the step adds at most |drift|/sqrt(k·A). */
double rtcore_sim_drag_step_s(const sim_plant *p, double velocity_rad_per_s, double balance_nm, double drift_nm)
{
    const double c2 = p->finger->prbm.effects.quadratic_damping_nms2_per_rad2;
    const double k_a = p->linear.stiffness_nm_per_rad * p->linear.inertia_kgm2;
    double balance;
    double fastest;
    if (!(c2 > 0.0)) {
        return INFINITY;
    }
    balance = fabs(balance_nm) + c2 * velocity_rad_per_s * velocity_rad_per_s;
    fastest = sqrt(velocity_rad_per_s * velocity_rad_per_s + balance * balance / k_a) + fabs(drift_nm) / sqrt(k_a);
    return slope_step_s(p, 2.0 * c2 * fastest, 0.0);
}

/* The longest step, up to h_cap, over which the velocity stays within `reach`. The torque
 * out of balance is net_nm at the start and moves by drift_nm (the chamber's torque over
 * h_cap) plus k·|θ'|·h (the spring, as the finger moves) within the step; it moves the
 * velocity by at most its size·h/A, and, when the plant with B + c0 is over-damped, by no
 * more than its size/(B + c0), where that damping has caught up. The chamber's torque moves
 * no faster than drift_rate_nm_per_s (its rate now: an exponential slows), so over a
 * shorter step it moves by no more than that rate times the step: of the bounds with the
 * drift held at drift_nm and with it growing at that rate, the longer holds. The damper's
 * bound with a growing torque: A·θ'' + D·θ' = u(t) gives |Δθ'| <= max|u − u0 + net|/D, the
 * spring's share taken at the fastest the finger can move within the step. */
double rtcore_sim_damping_step_s(const sim_plant *local, double velocity_rad_per_s, double reach, double net_nm,
                                 double drift_nm, double drift_rate_nm_per_s, double h_cap_s)
{
    const double inertia_kgm2 = local->linear.inertia_kgm2;
    const double damping_nms_per_rad = local->linear.damping_nms_per_rad;
    const double spring_nm_per_s = local->linear.stiffness_nm_per_rad * fabs(velocity_rad_per_s);
    const double torque_nm = fabs(net_nm) + fabs(drift_nm);
    const double growth_nm_per_s = spring_nm_per_s + drift_rate_nm_per_s;
    double rate;
    double step_s;
    double growing_s;
    if (local->linear.disc_per_s2 > 0.0 && torque_nm + spring_nm_per_s * h_cap_s <= reach * damping_nms_per_rad) {
        return INFINITY;
    }
    /* the root h of (spring·h² + torque·h)/A = reach */
    rate = torque_nm / inertia_kgm2;
    step_s = 2.0 * reach / (rate + sqrt(rate * rate + 4.0 * spring_nm_per_s * reach / inertia_kgm2));
    /* the root h of ((spring + drift rate)·h² + |net|·h)/A = reach */
    rate = fabs(net_nm) / inertia_kgm2;
    growing_s = 2.0 * reach / (rate + sqrt(rate * rate + 4.0 * growth_nm_per_s * reach / inertia_kgm2));
    step_s = fmax(step_s, growing_s);
    if (local->linear.disc_per_s2 > 0.0 && fabs(net_nm) < reach * damping_nms_per_rad) {
        /* (|net| + (k·(|θ'| + reach) + drift rate)·h)/(B + c0) = reach */
        const double damped_growth_nm_per_s
            = local->linear.stiffness_nm_per_rad * (fabs(velocity_rad_per_s) + reach) + drift_rate_nm_per_s;
        step_s = fmax(step_s, (reach * damping_nms_per_rad - fabs(net_nm)) / damped_growth_nm_per_s);
    }
    return step_s;
}

/* The longest step the parameters allow: infinite for the plain linear finger (exact at
 * any step), else a fraction of the motion's time scale and of what g's slopes need. */
double rtcore_sim_parameter_step_s(const sim_plant *p)
{
    const double motion_per_s = modulus(p->linear.lambda_per_s[0], p->linear.lambda_per_s[1]);
    double step_s;
    if (!p->nonlinear) {
        return INFINITY;
    }
    step_s = slope_step_s(p, p->damping_slope_nms_per_rad, p->stiffness_slope_nm_per_rad);
    if (motion_per_s > 0.0) {
        step_s = fmin(step_s, MOTION_STEP_FRACTION / motion_per_s);
    }
    if (p->finger->prbm.effects.creep_stiffness_ratio > 0.0) {
        step_s = fmin(step_s, MOTION_STEP_FRACTION * p->finger->prbm.effects.creep_time_s); /* the dashpot's */
    }
    return step_s;
}

/* The step where a slope of g grows with the state, 3·|k3|·θ² and the contact's, taken at the angle the
 * finger may reach: the present one plus what the torque out of balance, accel_torque =
 * A·θ'', drives (an angle of accel_torque/k). (The drag's slope, 2·c2·|θ'|, is taken into
 * the exact part at each step: rtcore_sim_damping_step_s.) */
double rtcore_sim_state_step_s(const sim_plant *p, double angle_rad, double accel_torque_nm)
{
    const rtcore_effects *e = &p->finger->prbm.effects;
    const double reach_rad = fabs(accel_torque_nm) / p->linear.stiffness_nm_per_rad;
    return slope_step_s(p, p->damping_slope_nms_per_rad,
                        p->stiffness_slope_nm_per_rad + rtcore_model_slope_bound_nm_per_rad(e, angle_rad, reach_rad));
}

/* A finger that has settled under a held input needs no short steps: the explicit torque
 * g hardly changes over a step, and ETDRK4's error, about the motion left times (h/T)^5,
 * T the motion's time scale, shrinks with that motion. The step grows beyond the
 * parameters' bound (cap_s) by (range/left)^(1/4), up to what the caller asks: `left`
 * is the motion the finger still has to make, the torque out of balance over k (with the
 * chamber's change over the segment) and the velocity times T, in angle; `range` the
 * deflection the supply's full span gives. Only where g's explicit slopes stay well below
 * k and B (rtcore_sim_settle_range_rad_for returns 0 otherwise: no growth), so that a long step
 * stays stable; the state-dependent slopes (drag, cubic stiffness) at the state now. Not
 * with dry friction: a finger held by it creeps, far from settled, with nothing out of
 * balance (its steps follow the creep's time scale, B + c0's, in rtcore_sim_plant.c's integrate_segment,
 * and rtcore_sim_damping_step_s bounds them). */
static const double SETTLED_SLOPE_SHARE = 0.5;

double rtcore_sim_settle_range_rad_for(const sim_plant *p)
{
    const rtcore_sim_finger *f = p->finger;
    if (!p->nonlinear || p->kinks || f->prbm.effects.coulomb_torque_nm > 0.0 || f->prbm.effects.creep_stiffness_ratio > 0.0
        || !(p->linear.stiffness_nm_per_rad > 0.0)
        || p->stiffness_slope_nm_per_rad >= SETTLED_SLOPE_SHARE * p->linear.stiffness_nm_per_rad
        || p->damping_slope_nms_per_rad >= SETTLED_SLOPE_SHARE * p->linear.damping_nms_per_rad) {
        return 0.0;
    }
    return fmax(f->prbm.pressure_gain_nm_per_kpa * (f->supply_max_kpa - f->supply_min_kpa), 1e-300)
           / p->linear.stiffness_nm_per_rad;
}

double rtcore_sim_settled_step_s(const sim_plant *p, const rtcore_sim_motion *s, double cap_s,
                                 double request_cap_s, double range_rad, double drive_nm, double drift_nm)
{
    const rtcore_effects *e = &p->finger->prbm.effects;
    const double k = p->linear.stiffness_nm_per_rad;
    const double motion_per_s = modulus(p->linear.lambda_per_s[0], p->linear.lambda_per_s[1]);
    const double net_nm = drive_nm - k * s->angle_rad - p->linear.damping_nms_per_rad * s->velocity_rad_per_s;
    const double left_rad = (fabs(net_nm) + drift_nm) / k
                            + (motion_per_s > 0.0 ? fabs(s->velocity_rad_per_s) / motion_per_s : 0.0);
    if (p->state_dependent
        && p->stiffness_slope_nm_per_rad + rtcore_model_slope_bound_nm_per_rad(e, s->angle_rad, 0.0)
               >= SETTLED_SLOPE_SHARE * k) {
        return cap_s;
    }
    if (!(left_rad > 0.0)) {
        return left_rad == 0.0 ? request_cap_s : cap_s;
    }
    return fmin(request_cap_s, cap_s * fmax(sqrt(sqrt(range_rad / left_rad)), 1.0));
}
