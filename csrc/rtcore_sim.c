/* The simulated hand: PRBM dynamics with the shared torque model (its linear part exact,
 * dry friction's slope linearised into it step by step, the rest by ETDRK4), the valve (lag behind a dead time, integrated exactly), an optional
 * object, and the flex sensor. */
#include <math.h>
#include <string.h>

#include "rtcore_exact.h"
#include "rtcore_internal.h"
#include "rtcore_sim.h"

/* ---- random numbers: xorshift64* and Box-Muller, state in the caller's struct ------- */

static uint64_t next_u64(rtcore_sim *sim)
{
    uint64_t x = sim->rng_state;
    x ^= x >> 12;
    x ^= x << 25;
    x ^= x >> 27;
    sim->rng_state = x;
    return x * 2685821657736338717ULL;
}

static double next_uniform(rtcore_sim *sim)
{
    /* in (0, 1]: never 0, so the logarithm below is finite */
    return ((double)(next_u64(sim) >> 11) + 1.0) / 9007199254740992.0;
}

static double next_gaussian(rtcore_sim *sim)
{
    double radius;
    double angle;
    if (sim->rng_has_spare) {
        sim->rng_has_spare = 0;
        return sim->rng_spare;
    }
    radius = sqrt(-2.0 * log(next_uniform(sim)));
    angle = 2.0 * RTCORE_PI * next_uniform(sim);
    sim->rng_spare = radius * sin(angle);
    sim->rng_has_spare = 1;
    return radius * cos(angle);
}

/* ---- dynamics ---------------------------------------------------------------------- */

/* The finger is A·θ'' + B·θ' + k·θ = u(t): a linear plant, integrated exactly for any step
 * (e^(L·h), L = [[0, 1], [−k/A, −B/A]], in closed form), driven by the torque
 * u = N·p_eff(t) + g(θ, θ'), where g is every torque beyond k·θ + B·θ' (the effects and
 * the contact). Over a step the chamber's torque is the quadratic through its exact values
 * at the start, middle and end; g is integrated by ETDRK4 (Cox & Matthews 2002), whose
 * last stage is the exact response to a quadratic torque too. The plain linear finger
 * without a valve lag is exact at any step; with effects the step resolves what the
 * explicit g needs (parameter_step_s, state_step_s), with a lag the chamber's exponential
 * (integrate_segment). */

/* Step sizes, as fractions of the time scales they resolve:
 * - the motion's own, 1/|λ_slow| over-damped or 1/ω_n under-damped, when g is not zero;
 * - 1/(the shift of the plant's eigenvalues by g's damping-like slopes): as for RK4,
 *   h·|λ| <= 1 keeps such a mode accurate (and an explicit slope c against the exact B
 *   is stable at long steps only while c < B, so this bound stays however damped the
 *   plant);
 * - 1/(the shift by g's stiffness-like slopes);
 * - dry friction's slope, taken into the exact part at each step's start, by how fast
 *   the velocity can leave the band where that slope still holds (damping_step_s);
 * - the valve lag τ (LAG_STEP_FRACTION·τ at first, see integrate_segment). */
static const double MOTION_STEP_FRACTION = 0.25;
static const double DAMPING_STEP_FRACTION = 1.0;
static const double STIFFNESS_STEP_FRACTION = 0.25;
static const double LAG_STEP_FRACTION = 0.0625;
/* a state-dependent slope (quadratic damping, cubic stiffness) shortens the step at most
 * this much, and no held segment takes more than 2^20 steps, so a run that diverges ends */
static const double STATE_STEP_SHRINK = 256.0;
static const double MIN_STEP_PER_SEGMENT = 1.0 / 1048576.0;
/* a shorter segment (a dead time a hair past a whole number of periods) changes nothing
 * and is skipped: its step's h³ would underflow in the propagator */
static const double MIN_SEGMENT_S = 1e-30;
/* a kink this close to either end of a step is left there (before_kink) */
static const double KINK_MIN_FRACTION = 1e-3;

/* The object's normal force at the force point while touching: the spring-damper,
 * pushing only (>= 0), continued across the surface so that a step keeps one formula. */
static double touching_force_n(const rtcore_sim_finger *f, double angle_rad, double velocity_rad_per_s)
{
    const double force_n = f->prbm.lever_arm_m
                           * (f->contact_stiffness_n_per_m * (angle_rad - f->contact_angle_deg * RTCORE_RAD_PER_DEG)
                              + f->contact_damping_ns_per_m * velocity_rad_per_s);
    return force_n > 0.0 ? force_n : 0.0;
}

static int32_t touches(const rtcore_sim_finger *f, double angle_rad)
{
    return f->contact_stiffness_n_per_m > 0.0
           && f->prbm.lever_arm_m * (angle_rad - f->contact_angle_deg * RTCORE_RAD_PER_DEG) > 0.0;
}

/* normal force of the object on the finger at the force point (>= 0, pushes back) */
static double contact_force_n(const rtcore_sim_finger *f, double angle_rad, double velocity_rad_per_s)
{
    return touches(f, angle_rad) ? touching_force_n(f, angle_rad, velocity_rad_per_s) : 0.0;
}

/* g(θ, θ'): the torque beyond N·p_eff − k·θ − B·θ', with the object touching or not as a
 * step has it (the damper makes the force jump as the finger reaches the surface, so a
 * step that reaches it ends there and the next one starts touching). rtcore_model_torque_nm
 * (shared with the controller) includes the plain k·θ, which the linear part takes. */
static double nonlinear_torque_nm(const rtcore_sim_finger *f, double angle_rad, double velocity_rad_per_s,
                                  int32_t touching)
{
    const rtcore_prbm *m = &f->prbm;
    const double torque_nm = m->stiffness_nm_per_rad * angle_rad
                             - rtcore_model_torque_nm(m, angle_rad, velocity_rad_per_s);
    return touching ? torque_nm - m->lever_arm_m * touching_force_n(f, angle_rad, velocity_rad_per_s) : torque_nm;
}

static double pressure_torque_nm(const rtcore_sim_finger *f, double chamber_kpa)
{
    return f->prbm.pressure_gain_nm_per_kpa
           * rtcore_effective_pressure_kpa(&f->prbm.effects, chamber_kpa);
}

/* One finger's linear plant and the bounds on g's slopes, derived once per sample. */
typedef struct {
    const rtcore_sim_finger *finger;
    rtcore_exact_plant linear; /* A, B, k: the part integrated exactly */
    int32_t nonlinear; /* g is not identically zero */
    int32_t state_dependent; /* a slope of g grows without bound with the state */
    int32_t kinks; /* g has kinks (before_kink) */
    double damping_slope_nms_per_rad; /* bound on −dg/dθ' (>= 0: g only damps) everywhere,
                                       * the friction's apart (damping_step_s) */
    double stiffness_slope_nm_per_rad; /* bound on |dg/dθ| everywhere */
} sim_plant;

static double shift_per_s(const sim_plant *p, double damping, double stiffness)
{
    double lambda_per_s[4];
    double first;
    double second;
    rtcore_exact_eigenvalues(p->linear.inertia_kgm2, damping, stiffness, lambda_per_s);
    first = hypot(lambda_per_s[0] - p->linear.lambda_per_s[0], lambda_per_s[1] - p->linear.lambda_per_s[1]);
    second = hypot(lambda_per_s[2] - p->linear.lambda_per_s[2], lambda_per_s[3] - p->linear.lambda_per_s[3]);
    return first > second ? first : second;
}

/* The longest step for explicit slopes of g: a damping-like c >= 0 and a stiffness-like
 * ±K, each by how far it moves the plant's eigenvalues. */
static double slope_step_s(const sim_plant *p, double damping_slope, double stiffness_slope)
{
    const double damping_per_s = shift_per_s(p, p->linear.damping_nms_per_rad + damping_slope,
                                             p->linear.stiffness_nm_per_rad);
    const double stiffer_per_s = shift_per_s(p, p->linear.damping_nms_per_rad, p->linear.stiffness_nm_per_rad + stiffness_slope);
    const double softer_per_s = shift_per_s(p, p->linear.damping_nms_per_rad, p->linear.stiffness_nm_per_rad - stiffness_slope);
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

static void plant_for(const rtcore_sim_finger *f, sim_plant *p)
{
    const rtcore_prbm *m = &f->prbm;
    const rtcore_effects *e = &m->effects;
    const int32_t contact = f->contact_stiffness_n_per_m > 0.0;
    const double r2 = m->lever_arm_m * m->lever_arm_m;
    p->finger = f;
    rtcore_exact_plant_init(&p->linear, m->inertia_kgm2, m->damping_nms_per_rad, m->stiffness_nm_per_rad);
    p->state_dependent = e->quadratic_damping_nms2_per_rad2 > 0.0 || e->cubic_stiffness_nm_per_rad3 != 0.0;
    p->nonlinear = p->state_dependent || contact || e->coulomb_torque_nm > 0.0 || e->gravity_torque_nm != 0.0
                   || e->asymmetric_stiffness_ratio != 1.0;
    p->kinks = contact || e->asymmetric_stiffness_ratio != 1.0;
    p->damping_slope_nms_per_rad = contact ? f->contact_damping_ns_per_m * r2 : 0.0;
    p->stiffness_slope_nm_per_rad = fabs(e->asymmetric_stiffness_ratio - 1.0) * m->stiffness_nm_per_rad
                                    + fabs(e->gravity_torque_nm)
                                    + (contact ? f->contact_stiffness_n_per_m * r2 : 0.0);
}

/* The same plant with the damping B + extra: the linear part a step integrates exactly. */
static void with_damping(const sim_plant *base, double extra_nms_per_rad, sim_plant *out)
{
    *out = *base;
    if (extra_nms_per_rad == 0.0) {
        return;
    }
    rtcore_exact_plant_init(&out->linear, base->linear.inertia_kgm2, base->linear.damping_nms_per_rad + extra_nms_per_rad,
                            base->linear.stiffness_nm_per_rad);
}

/* The friction Tc·tanh(ω/ω_s) damps like a slope c(ω) = (Tc/ω_s)·sech²(ω/ω_s), up to
 * Tc/ω_s at rest: for a small ω_s far beyond B, a stiffness no explicit step could take at
 * the sample rate (a finger that sticks is a finger damped without bound). So each step
 * takes the slope at its start, c0, into the linear part it integrates exactly (damping
 * B + c0), and only what the slope changes within the step, c(ω) − c0, is left explicit
 * (a Rosenbrock-type linearisation). The step keeps that change within
 * FRICTION_SLOPE_SHARE of the exact damping B + c0 over the velocities it can reach. */
static const double FRICTION_SLOPE_SHARE = 0.25;

static double friction_slope_nms_per_rad(const rtcore_effects *e, double velocity_rad_per_s)
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
 * at the step's start, the friction's c_f and the drag's 2·c2·|θ'|, change by more than
 * FRICTION_SLOPE_SHARE of the exact damping B + c0 (half of it each when both act). A floor
 * of 1e-3 of critical damping (and 1e-6 of the friction's peak slope) keeps a plant
 * without damping, at rest, from steps of nothing. */
static double velocity_reach_rad_per_s(const sim_plant *local, double velocity_rad_per_s, double friction0)
{
    const rtcore_effects *e = &local->finger->prbm.effects;
    const int32_t friction = e->coulomb_torque_nm > 0.0;
    const int32_t drag = e->quadratic_damping_nms2_per_rad2 > 0.0;
    const double floor_nms_per_rad
        = fmax(1e-3 * sqrt(local->linear.stiffness_nm_per_rad * local->linear.inertia_kgm2),
               friction ? 1e-6 * e->coulomb_torque_nm / (e->coulomb_smoothing_deg_per_s * RTCORE_RAD_PER_DEG) : 0.0);
    const double allowed = FRICTION_SLOPE_SHARE * fmax(local->linear.damping_nms_per_rad, floor_nms_per_rad)
                           / (friction && drag ? 2.0 : 1.0);
    double reach = INFINITY;
    if (friction) {
        reach = friction_reach_rad_per_s(e, velocity_rad_per_s, friction0, allowed);
    }
    if (drag) {
        reach = fmin(reach, allowed / (2.0 * e->quadratic_damping_nms2_per_rad2));
    }
    return reach;
}

/* The longest step, up to h_cap, over which the velocity stays within `reach`. The torque
 * out of balance is net_nm at the start and moves by drift_nm (the chamber's torque) plus
 * k·|θ'|·h (the spring, as the finger moves) within the step; it moves the velocity by at
 * most its size·h/A, and, when the plant with B + c0 is over-damped, by no more than its
 * size/(B + c0), where that damping has caught up. */
static double damping_step_s(const sim_plant *local, double velocity_rad_per_s, double reach, double net_nm,
                             double drift_nm, double h_cap_s)
{
    const double spring_nm_per_s = local->linear.stiffness_nm_per_rad * fabs(velocity_rad_per_s);
    const double torque_nm = fabs(net_nm) + fabs(drift_nm);
    double rate;
    if (local->linear.disc_per_s2 > 0.0 && torque_nm + spring_nm_per_s * h_cap_s <= reach * local->linear.damping_nms_per_rad) {
        return INFINITY;
    }
    /* the root h of (spring·h² + torque·h)/A = reach */
    rate = torque_nm / local->linear.inertia_kgm2;
    return 2.0 * reach / (rate + sqrt(rate * rate + 4.0 * spring_nm_per_s * reach / local->linear.inertia_kgm2));
}

/* The longest step the parameters allow: infinite for the plain linear finger (exact at
 * any step), else a fraction of the motion's time scale and of what g's slopes need. */
static double parameter_step_s(const sim_plant *p)
{
    const double motion_per_s = hypot(p->linear.lambda_per_s[0], p->linear.lambda_per_s[1]);
    double step_s;
    if (!p->nonlinear) {
        return INFINITY;
    }
    step_s = slope_step_s(p, p->damping_slope_nms_per_rad, p->stiffness_slope_nm_per_rad);
    if (motion_per_s > 0.0) {
        step_s = fmin(step_s, MOTION_STEP_FRACTION / motion_per_s);
    }
    return step_s;
}

/* The step where a slope of g grows with the state, 3·|k3|·θ², taken at the angle the
 * finger may reach: the present one plus what the torque out of balance, accel_torque =
 * A·θ'', drives (an angle of accel_torque/k). (The drag's slope, 2·c2·|θ'|, is taken into
 * the exact part at each step: damping_step_s.) */
static double state_step_s(const sim_plant *p, double angle_rad, double accel_torque_nm)
{
    const rtcore_effects *e = &p->finger->prbm.effects;
    const double angle = fabs(angle_rad) + fabs(accel_torque_nm) / p->linear.stiffness_nm_per_rad;
    return slope_step_s(p, p->damping_slope_nms_per_rad,
                        p->stiffness_slope_nm_per_rad + 3.0 * fabs(e->cubic_stiffness_nm_per_rad3) * angle * angle);
}

/* One step h; the chamber's torque is p_start, p_mid and p_end at t = 0, h/2 and h, and
 * g_start = g(x) + c0·θ'. p is the plant with the damping B + c0, c0 =
 * linearized_nms_per_rad (the friction's and the drag's slopes, damping_step_s), which g gives back. Without g: the exact response to that quadratic. With g, ETDRK4 (Cox &
 * Matthews 2002): stages a and b from x and c from a over h/2, each with the total torque
 * held (at x, at a, and 2·(at b) − (at x)), then the exact response to the quadratic
 * through the torque at x, the mean of those at a and b, and at c. */
static void step(const sim_plant *p, rtcore_propagator_cache *cache, double *angle_rad, double *velocity_rad_per_s,
                 double h, double p_start, double p_mid, double p_end, double g_start, int32_t touching,
                 double linearized_nms_per_rad)
{
    const rtcore_sim_finger *f = p->finger;
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
        rtcore_exact_quadratic(full, angle_rad, velocity_rad_per_s, p_start, p_mid, p_end);
        return;
    }
    n_x = p_start + g_start;
    rtcore_exact_held(half, *angle_rad, *velocity_rad_per_s, n_x, &th_a, &w_a);
    n_a = p_mid + nonlinear_torque_nm(f, th_a, w_a, touching) + linearized_nms_per_rad * w_a;
    rtcore_exact_held(half, *angle_rad, *velocity_rad_per_s, n_a, &th_b, &w_b);
    n_b = p_mid + nonlinear_torque_nm(f, th_b, w_b, touching) + linearized_nms_per_rad * w_b;
    rtcore_exact_held(half, th_a, w_a, 2.0 * n_b - n_x, &th_c, &w_c);
    n_c = p_end + nonlinear_torque_nm(f, th_c, w_c, touching) + linearized_nms_per_rad * w_c;
    rtcore_exact_quadratic(full, angle_rad, velocity_rad_per_s, n_x, 0.5 * (n_a + n_b), n_c);
}

/* Where g has a kink or a jump (the object's surface, the contact force reaching 0 as
 * the finger leaves, θ = 0 with an asymmetric stiffness) a step is only as accurate as
 * that allows: a step that crosses one is cut where it does, by linear interpolation
 * between its ends. The fraction of the step before the first crossing (1 for none), and
 * in *surface whether that one is the object's surface. */
static double before_kink(const sim_plant *p, int32_t touching, double angle0_rad, double velocity0_rad_per_s,
                          double angle1_rad, double velocity1_rad_per_s, int32_t *surface)
{
    const rtcore_sim_finger *f = p->finger;
    double fraction = 1.0;
    *surface = 0;
    if (f->contact_stiffness_n_per_m > 0.0) {
        const double surface_rad = f->contact_angle_deg * RTCORE_RAD_PER_DEG;
        const double depth0 = angle0_rad - surface_rad;
        const double depth1 = angle1_rad - surface_rad;
        if (touching ? depth1 < 0.0 && depth0 > 0.0 : depth1 > 0.0 && depth0 < 0.0) {
            fraction = depth0 / (depth0 - depth1);
            *surface = 1;
        }
        if (touching && f->contact_damping_ns_per_m > 0.0) {
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
    return fraction;
}

/* A finger that has settled under a held input needs no short steps: the explicit torque
 * g hardly changes over a step, and ETDRK4's error, about the motion left times (h/T)^5,
 * T the motion's time scale, shrinks with that motion. The step grows beyond the
 * parameters' bound (cap_s) by (range/left)^(1/4), up to what the caller asks: `left`
 * is the motion the finger still has to make, the torque out of balance over k (with the
 * chamber's change over the segment) and the velocity times T, in angle; `range` the
 * deflection the supply's full span gives. Only where g's explicit slopes stay well below
 * k and B (settle_range_rad_for returns 0 otherwise: no growth), so that a long step
 * stays stable; the state-dependent slopes (drag, cubic stiffness) at the state now. Not
 * with dry friction: a finger held by it creeps, far from settled, with nothing out of
 * balance (damping_step_s sets its steps). */
static const double SETTLED_SLOPE_SHARE = 0.5;

static double settle_range_rad_for(const sim_plant *p)
{
    const rtcore_sim_finger *f = p->finger;
    if (!p->nonlinear || p->kinks || f->prbm.effects.coulomb_torque_nm > 0.0 || !(p->linear.stiffness_nm_per_rad > 0.0)
        || p->stiffness_slope_nm_per_rad >= SETTLED_SLOPE_SHARE * p->linear.stiffness_nm_per_rad
        || p->damping_slope_nms_per_rad >= SETTLED_SLOPE_SHARE * p->linear.damping_nms_per_rad) {
        return 0.0;
    }
    return fmax(f->prbm.pressure_gain_nm_per_kpa * (f->supply_max_kpa - f->supply_min_kpa), 1e-300)
           / p->linear.stiffness_nm_per_rad;
}

static double settled_step_s(const sim_plant *p, const rtcore_sim_finger_state *s, double cap_s,
                             double request_cap_s, double range_rad, double drive_nm, double drift_nm)
{
    const rtcore_effects *e = &p->finger->prbm.effects;
    const double k = p->linear.stiffness_nm_per_rad;
    const double motion_per_s = hypot(p->linear.lambda_per_s[0], p->linear.lambda_per_s[1]);
    const double net_nm = drive_nm - k * s->angle_rad - p->linear.damping_nms_per_rad * s->velocity_rad_per_s;
    const double left_rad = (fabs(net_nm) + drift_nm) / k
                            + (motion_per_s > 0.0 ? fabs(s->velocity_rad_per_s) / motion_per_s : 0.0);
    if (p->state_dependent
        && p->stiffness_slope_nm_per_rad + 3.0 * fabs(e->cubic_stiffness_nm_per_rad3) * s->angle_rad * s->angle_rad
               >= SETTLED_SLOPE_SHARE * k) {
        return cap_s;
    }
    if (!(left_rad > 0.0)) {
        return left_rad == 0.0 ? request_cap_s : cap_s;
    }
    return fmin(request_cap_s, cap_s * fmax(sqrt(sqrt(range_rad / left_rad)), 1.0));
}

/* the chamber t after the start of a held segment: its exact first-order solution */
static double chamber_at(double start_kpa, double input_kpa, double tau_s, double t_s)
{
    return input_kpa + (start_kpa - input_kpa) * exp(-t_s / tau_s);
}

/* Integrate over duration_s with the valve input held at input_kpa, in steps of at most
 * step_cap_s, and of what state_step_s allows for the state at the start (the input is
 * held, so what the segment will reach is known there). The chamber follows its exact
 * solution, on one side of the dead zone's threshold throughout (integrate_held splits
 * there). While its torque moves the step is at most LAG_STEP_FRACTION·τ·(S/|p − u|)^(1/3),
 * S the supply's span and p − u what the chamber still lacks of its input: what the
 * quadratic misses of the exponential, ∝ |p − u|·(h/τ)³, stays as small as in the first
 * step of a full-span change (τ/16), so a change costs about 3/LAG_STEP_FRACTION = 48
 * steps however long it is held, and a nearly settled chamber (every later sample period)
 * costs none. That keeps the angle within about 5e-7 of its range, so that an effect
 * switched on, whose shorter steps follow the lag more closely, moves the result by no
 * more. The
 * last step ends the segment exactly and a kink cuts a step where it lies, so the steps
 * and the result move continuously with every parameter. */
static void integrate_segment(const sim_plant *p, rtcore_sim_finger_state *s, rtcore_propagator_cache *cache,
                              double input_kpa, double duration_s, double request_cap_s)
{
    const rtcore_sim_finger *f = p->finger;
    const double tau_s = f->prbm.effects.valve_lag_tau_s;
    const double start_kpa = tau_s > 0.0 ? s->chamber_kpa : input_kpa;
    const double end_kpa = tau_s > 0.0 ? chamber_at(start_kpa, input_kpa, tau_s, duration_s) : input_kpa;
    const double deadzone_kpa = f->prbm.effects.pressure_deadzone_kpa;
    /* the torque is constant without a lag, without a gain, at the input already, or below
     * the dead zone throughout (the chamber is monotonic within a segment) */
    const int32_t moving = tau_s > 0.0 && f->prbm.pressure_gain_nm_per_kpa > 0.0 && start_kpa != input_kpa
                           && !(deadzone_kpa > 0.0 && start_kpa <= deadzone_kpa && end_kpa <= deadzone_kpa);
    const double min_step_s = duration_s * MIN_STEP_PER_SEGMENT;
    const double lag_span_kpa = fmax(f->supply_max_kpa - f->supply_min_kpa, 1.0);
    const double torque_last = pressure_torque_nm(f, end_kpa);
    double torque_start = pressure_torque_nm(f, start_kpa);
    const double step_cap_s = fmin(request_cap_s, s->max_step_s);
    const double settle_range_rad = settle_range_rad_for(p);
    double cap_s = step_cap_s;
    double t_s = 0.0;
    int32_t last = 0;
    int32_t next_touching = -1; /* after a step cut at the surface: the side it goes on to */

    if (!(duration_s > MIN_SEGMENT_S)) {
        s->chamber_kpa = end_kpa;
        return;
    }
    if (p->state_dependent) {
        /* the torque out of balance at the start, with the chamber now and at the end */
        const double g_nm = nonlinear_torque_nm(f, s->angle_rad, s->velocity_rad_per_s, touches(f, s->angle_rad));
        const double linear_nm = p->linear.stiffness_nm_per_rad * s->angle_rad + p->linear.damping_nms_per_rad * s->velocity_rad_per_s;
        const double accel_nm = fmax(fabs(torque_start + g_nm - linear_nm), fabs(torque_last + g_nm - linear_nm));
        cap_s = fmin(step_cap_s, fmax(state_step_s(p, s->angle_rad, accel_nm),
                                      step_cap_s / STATE_STEP_SHRINK));
    }
    while (!last) {
        const double remaining_s = duration_s - t_s;
        int32_t touching = next_touching >= 0 ? next_touching : touches(f, s->angle_rad);
        double g_start = p->nonlinear ? nonlinear_torque_nm(f, s->angle_rad, s->velocity_rad_per_s, touching) : 0.0;
        double h = settle_range_rad > 0.0 && cap_s < request_cap_s
                       ? settled_step_s(p, s, cap_s, request_cap_s, settle_range_rad,
                                        torque_start + g_start, fabs(torque_last - torque_start))
                       : cap_s;
        double slope0 = 0.0; /* the friction's slope here, integrated exactly over the step */
        sim_plant local;
        double torque_mid = torque_start;
        double torque_end = torque_start;
        int32_t cut = 0; /* the step was shortened to end at a kink */
        int32_t flipped = 0; /* the step was taken again on the far side of the surface */

        next_touching = -1;
        if (moving) {
            /* from how far the chamber still is from its input, not from when this
             * segment began: a chamber nearly settled (every sample period after a step)
             * needs no short steps, and a new segment does not restart them */
            const double gap_kpa = fabs(chamber_at(start_kpa, input_kpa, tau_s, t_s) - input_kpa);
            if (gap_kpa > 0.0) {
                h = fmin(h, LAG_STEP_FRACTION * tau_s * cbrt(lag_span_kpa / gap_kpa));
            }
        }
        if (f->prbm.effects.coulomb_torque_nm > 0.0 || f->prbm.effects.quadratic_damping_nms2_per_rad2 > 0.0) {
            const double net_nm = torque_start + g_start - p->linear.stiffness_nm_per_rad * s->angle_rad
                                  - p->linear.damping_nms_per_rad * s->velocity_rad_per_s;
            const double friction0 = f->prbm.effects.coulomb_torque_nm > 0.0
                                         ? friction_slope_nms_per_rad(&f->prbm.effects, s->velocity_rad_per_s)
                                         : 0.0;
            slope0 = friction0 + 2.0 * f->prbm.effects.quadratic_damping_nms2_per_rad2 * fabs(s->velocity_rad_per_s);
            with_damping(p, slope0, &local);
            h = fmin(h, damping_step_s(&local, s->velocity_rad_per_s,
                                       velocity_reach_rad_per_s(&local, s->velocity_rad_per_s, friction0), net_nm,
                                       torque_last - torque_start, h));
            g_start += slope0 * s->velocity_rad_per_s;
        } else {
            local = *p;
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
            int32_t surface = 0;
            if (moving) {
                torque_mid = pressure_torque_nm(f, chamber_at(start_kpa, input_kpa, tau_s, t_s + 0.5 * h));
                torque_end = last ? torque_last
                                  : pressure_torque_nm(f, chamber_at(start_kpa, input_kpa, tau_s, t_s + h));
            }
            step(&local, cache, &angle_rad, &velocity_rad_per_s, h, torque_start, torque_mid, torque_end, g_start,
                 touching, slope0);
            if (p->kinks && !cut) {
                fraction = before_kink(p, touching, s->angle_rad, s->velocity_rad_per_s, angle_rad,
                                       velocity_rad_per_s, &surface);
            }
            if (fraction < 1.0 && fraction > KINK_MIN_FRACTION) {
                h *= fraction; /* the next step starts at the kink, past the surface if it is that */
                last = 0;
                cut = 1;
                next_touching = surface ? !touching : -1;
                continue;
            }
            if (fraction < 1.0 && surface && !flipped) {
                touching = !touching; /* the surface is where the step starts: take it past */
                flipped = 1;
                g_start = nonlinear_torque_nm(f, s->angle_rad, s->velocity_rad_per_s, touching)
                          + slope0 * s->velocity_rad_per_s;
                continue;
            }
            s->angle_rad = angle_rad;
            s->velocity_rad_per_s = velocity_rad_per_s;
            break;
        }
        torque_start = torque_end;
        t_s += h;
        if (!(isfinite(s->angle_rad) && isfinite(s->velocity_rad_per_s))) {
            break; /* diverged: the state stays non-finite, the chamber still follows */
        }
    }
    s->chamber_kpa = end_kpa;
}

/* A held segment, split where the chamber crosses the dead zone's threshold, so that the
 * torque is smooth within each part. */
static void integrate_held(const sim_plant *p, rtcore_sim_finger_state *s, rtcore_propagator_cache *cache,
                           double input_kpa, double duration_s, double request_cap_s)
{
    const double tau_s = p->finger->prbm.effects.valve_lag_tau_s;
    const double deadzone_kpa = p->finger->prbm.effects.pressure_deadzone_kpa;
    const double start_kpa = s->chamber_kpa;
    if (tau_s > 0.0 && deadzone_kpa > 0.0
        && ((start_kpa < deadzone_kpa && input_kpa > deadzone_kpa)
            || (start_kpa > deadzone_kpa && input_kpa < deadzone_kpa))) {
        const double cross_s = tau_s * log((start_kpa - input_kpa) / (deadzone_kpa - input_kpa));
        if (cross_s > 0.0 && cross_s < duration_s) {
            integrate_segment(p, s, cache, input_kpa, cross_s, request_cap_s);
            integrate_segment(p, s, cache, input_kpa, duration_s - cross_s, request_cap_s);
            return;
        }
    }
    integrate_segment(p, s, cache, input_kpa, duration_s, request_cap_s);
}

/* The valve regulates within its supply; a garbled (NaN) command vents to the floor. */
static double saturate(const rtcore_sim_finger *f, double command_kpa)
{
    if (isnan(command_kpa) || command_kpa < f->supply_min_kpa) {
        return f->supply_min_kpa;
    }
    return command_kpa > f->supply_max_kpa ? f->supply_max_kpa : command_kpa;
}

static double delayed_command(const rtcore_sim_finger_state *s, int32_t samples_back)
{
    return s->command_kpa[(s->head - samples_back + RTCORE_SIM_HISTORY) % RTCORE_SIM_HISTORY];
}

/* The pneumatic valve mode (rtcore_pneumatic.h): the chamber's physics and the board's
 * regulator replace the lag and the dead time. The period is cut into pieces of the
 * regulator's period; over each the finger is driven by the chamber's mean pressure there,
 * the chamber by the finger's volume at the piece's start. */
static void advance_pneumatic(const rtcore_sim_finger *f, rtcore_sim_finger_state *s, rtcore_propagator_cache *cache,
                              double command_kpa, double dt_s, double step_cap_s)
{
    rtcore_sim_finger held = *f;
    sim_plant plant;
    const double piece_s = (double)f->pneumatic.regulator_period_us * 1e-6;
    const int32_t pieces = (int32_t)ceil(dt_s / piece_s - 1e-9);
    int32_t k;
    held.prbm.effects.valve_lag_tau_s = 0.0; /* the segment's input is the chamber itself */
    plant_for(&held, &plant);
    for (k = 0; k < pieces; ++k) {
        const double mean_kpa = rtcore_pneumatic_advance(&f->pneumatic, f->prbm.pressure_gain_nm_per_kpa,
                                                         &s->pneumatic, command_kpa, s->angle_rad,
                                                         s->velocity_rad_per_s, dt_s / (double)pieces);
        integrate_segment(&plant, s, cache, mean_kpa, dt_s / (double)pieces, step_cap_s);
    }
    s->chamber_kpa = s->pneumatic.chamber_kpa;
    s->contact_force_n = contact_force_n(f, s->angle_rad, s->velocity_rad_per_s);
}

/* One sample period after pushing command_kpa: the dead time puts at most one breakpoint
 * inside the period, where the older command gives way to the newer one. The step is at
 * most dt/substeps (what the caller asks for) and what the finger's parameters allow
 * (more, up to dt/substeps, once the finger has settled: settled_step_s). */
static void advance_sample(const rtcore_sim_finger *f, rtcore_sim_finger_state *s, rtcore_propagator_cache *cache,
                           double command_kpa, double dt_s, int32_t substeps)
{
    const double step_cap_s = dt_s / (double)substeps; /* the parameters' bound applies inside */
    sim_plant plant;
    if (f->pneumatic.valve_model == RTCORE_VALVE_PNEUMATIC) {
        advance_pneumatic(f, s, cache, command_kpa, dt_s, step_cap_s);
        return;
    }
    plant_for(f, &plant);
    s->head = (s->head + 1) % RTCORE_SIM_HISTORY;
    s->command_kpa[s->head] = saturate(f, command_kpa);
    if (s->delay_fraction > 0.0) {
        const double first_s = s->delay_fraction * dt_s;
        integrate_held(&plant, s, cache, delayed_command(s, s->delay_samples + 1), first_s, step_cap_s);
        integrate_held(&plant, s, cache, delayed_command(s, s->delay_samples), dt_s - first_s, step_cap_s);
    } else {
        integrate_held(&plant, s, cache, delayed_command(s, s->delay_samples), dt_s, step_cap_s);
    }
    s->contact_force_n = contact_force_n(f, s->angle_rad, s->velocity_rad_per_s);
}

/* ---- configuration ----------------------------------------------------------------- */

static int32_t validate_sim_finger(const rtcore_sim_finger *f)
{
    const rtcore_prbm *m = &f->prbm;
    if (!(isfinite(m->inertia_kgm2) && m->inertia_kgm2 > 0.0) || !(isfinite(m->damping_nms_per_rad)
        && m->damping_nms_per_rad >= 0.0) || !(isfinite(m->stiffness_nm_per_rad)
        && m->stiffness_nm_per_rad > 0.0) || !(isfinite(m->pressure_gain_nm_per_kpa)
        && m->pressure_gain_nm_per_kpa >= 0.0) || !(isfinite(m->lever_arm_m) && m->lever_arm_m >= 0.0)) {
        return RTCORE_ERR_MODEL;
    }
    if (!rtcore_effects_valid(&m->effects)) {
        return RTCORE_ERR_EFFECTS;
    }
    if (!rtcore_pneumatic_valid(&f->pneumatic)) {
        return RTCORE_ERR_MODEL;
    }
    if (!isfinite(f->supply_min_kpa) || !isfinite(f->supply_max_kpa)
        || f->supply_min_kpa > f->supply_max_kpa) {
        return RTCORE_ERR_PRESSURE_LIMITS;
    }
    if (!isfinite(f->contact_angle_deg) || !(isfinite(f->contact_stiffness_n_per_m)
        && f->contact_stiffness_n_per_m >= 0.0) || !(isfinite(f->contact_damping_ns_per_m)
        && f->contact_damping_ns_per_m >= 0.0)) {
        return RTCORE_ERR_MODEL;
    }
    /* a lever arm of 0 is a free finger with no force point: it can meet no object */
    if ((f->contact_stiffness_n_per_m > 0.0 || f->contact_damping_ns_per_m > 0.0)
        && !(m->lever_arm_m > 0.0)) {
        return RTCORE_ERR_MODEL;
    }
    if (!isfinite(f->sensor_gain_deg_per_mv) || f->sensor_gain_deg_per_mv == 0.0
        || !isfinite(f->sensor_offset_deg) || !(isfinite(f->sensor_noise_deg) && f->sensor_noise_deg >= 0.0)
        || !(isfinite(f->adc_step_mv) && f->adc_step_mv >= 0.0)
        || !(isfinite(f->pressure_noise_kpa) && f->pressure_noise_kpa >= 0.0)) {
        return RTCORE_ERR_SENSOR;
    }
    return RTCORE_OK;
}

static int32_t prepare_state(const rtcore_sim_finger *f, rtcore_sim_finger_state *s, double dt_s)
{
    const double delay = f->prbm.effects.dead_time_s / dt_s;
    sim_plant plant;
    plant_for(f, &plant);
    s->max_step_s = parameter_step_s(&plant);
    s->delay_samples = (int32_t)floor(delay);
    s->delay_fraction = delay - floor(delay);
    if (s->delay_samples + 2 >= RTCORE_SIM_HISTORY) {
        return RTCORE_ERR_SIM_HISTORY;
    }
    return RTCORE_OK;
}

static void place(rtcore_sim_finger_state *s, double angle_rad, double velocity_rad_per_s,
                  double chamber_kpa)
{
    int32_t k;
    s->angle_rad = angle_rad;
    s->velocity_rad_per_s = velocity_rad_per_s;
    s->chamber_kpa = chamber_kpa;
    rtcore_pneumatic_reset(&s->pneumatic, chamber_kpa);
    for (k = 0; k < RTCORE_SIM_HISTORY; ++k) {
        s->command_kpa[k] = chamber_kpa;
    }
    s->head = 0;
}

int32_t rtcore_sim_configure(rtcore_sim *sim, const rtcore_sim_config *config)
{
    int32_t i;
    if (sim == 0 || config == 0) {
        return RTCORE_ERR_NULL;
    }
    sim->configured = 0;
    sim->error_finger = -1;
    if (config->n_fingers < 1 || config->n_fingers > RTCORE_MAX_FINGERS) {
        return RTCORE_ERR_FINGER_COUNT;
    }
    if (!(isfinite(config->sample_rate_hz) && config->sample_rate_hz > 0.0)
        || config->substeps < 1 || config->substeps > 10000) {
        return RTCORE_ERR_SAMPLE_RATE;
    }
    for (i = 0; i < config->n_fingers; ++i) {
        int32_t err = validate_sim_finger(&config->finger[i]);
        if (err == RTCORE_OK) {
            err = prepare_state(&config->finger[i], &sim->finger[i], 1.0 / config->sample_rate_hz);
        }
        if (err != RTCORE_OK) {
            sim->error_finger = i;
            return err;
        }
    }
    memcpy(&sim->config, config, sizeof(*config));
    sim->dt_s = 1.0 / config->sample_rate_hz;
    sim->time_s = 0.0;
    sim->rng_state = config->seed ^ 0x9E3779B97F4A7C15ULL;
    if (sim->rng_state == 0u) {
        sim->rng_state = 1u;
    }
    sim->rng_has_spare = 0;
    sim->rng_spare = 0.0;
    for (i = 0; i < config->n_fingers; ++i) {
        place(&sim->finger[i], 0.0, 0.0, 0.0);
        sim->finger[i].contact_force_n = 0.0;
    }
    sim->configured = 1;
    return RTCORE_OK;
}

void rtcore_sim_set_state(rtcore_sim *sim, int32_t finger, double angle_deg, double velocity_deg_per_s,
                          double chamber_kpa)
{
    rtcore_sim_finger_state *s;
    if (sim == 0 || !sim->configured || finger < 0 || finger >= sim->config.n_fingers
        || !isfinite(angle_deg) || !isfinite(velocity_deg_per_s) || !isfinite(chamber_kpa)) {
        return;
    }
    s = &sim->finger[finger];
    place(s, angle_deg * RTCORE_RAD_PER_DEG, velocity_deg_per_s * RTCORE_RAD_PER_DEG, chamber_kpa);
    s->contact_force_n = contact_force_n(&sim->config.finger[finger], s->angle_rad,
                                         s->velocity_rad_per_s);
}

void rtcore_sim_sample(rtcore_sim *sim, rtcore_sim_outputs *out)
{
    int32_t i;
    if (sim == 0 || out == 0 || !sim->configured) {
        return;
    }
    for (i = 0; i < sim->config.n_fingers; ++i) {
        const rtcore_sim_finger *f = &sim->config.finger[i];
        const rtcore_sim_finger_state *s = &sim->finger[i];
        const double angle_deg = s->angle_rad * RTCORE_DEG_PER_RAD;
        double mv = (angle_deg + f->sensor_noise_deg * next_gaussian(sim) - f->sensor_offset_deg)
                    / f->sensor_gain_deg_per_mv;
        if (f->adc_step_mv > 0.0) {
            mv = f->adc_step_mv * floor(mv / f->adc_step_mv + 0.5);
        }
        out->sensor_mv[i] = mv;
        out->pressure_meas_kpa[i] = s->chamber_kpa + f->pressure_noise_kpa * next_gaussian(sim);
        out->angle_deg[i] = angle_deg;
        out->velocity_deg_per_s[i] = s->velocity_rad_per_s * RTCORE_DEG_PER_RAD;
        out->chamber_pressure_kpa[i] = s->chamber_kpa;
        out->contact_force_n[i] = s->contact_force_n;
    }
}

void rtcore_sim_step(rtcore_sim *sim, const double *pressure_cmd_kpa, rtcore_sim_outputs *out)
{
    int32_t i;
    if (sim == 0 || pressure_cmd_kpa == 0 || !sim->configured) {
        return;
    }
    for (i = 0; i < sim->config.n_fingers; ++i) {
        rtcore_propagator_cache cache;
        cache.count = 0;
        cache.next = 0;
        advance_sample(&sim->config.finger[i], &sim->finger[i], &cache, pressure_cmd_kpa[i], sim->dt_s,
                       sim->config.substeps);
    }
    sim->time_s += sim->dt_s;
    rtcore_sim_sample(sim, out);
}

int32_t rtcore_sim_run(const rtcore_sim_finger *finger, double sample_rate_hz, int32_t substeps,
                       int32_t n_samples, const double *pressure_cmd_kpa, double angle0_deg,
                       double velocity0_deg_per_s, double chamber0_kpa, double *angle_out_deg,
                       double *chamber_out_kpa)
{
    rtcore_sim_finger_state s;
    rtcore_propagator_cache cache;
    double dt_s;
    int32_t err;
    int32_t k;

    if (finger == 0 || pressure_cmd_kpa == 0 || angle_out_deg == 0) {
        return RTCORE_ERR_NULL;
    }
    if (!(isfinite(sample_rate_hz) && sample_rate_hz > 0.0) || substeps < 1 || substeps > 10000
        || n_samples < 1) {
        return RTCORE_ERR_SAMPLE_RATE;
    }
    err = validate_sim_finger(finger);
    if (err != RTCORE_OK) {
        return err;
    }
    if (!isfinite(angle0_deg) || !isfinite(velocity0_deg_per_s) || !isfinite(chamber0_kpa)) {
        return RTCORE_ERR_MODEL;
    }
    dt_s = 1.0 / sample_rate_hz;
    err = prepare_state(finger, &s, dt_s);
    if (err != RTCORE_OK) {
        return err;
    }
    place(&s, angle0_deg * RTCORE_RAD_PER_DEG, velocity0_deg_per_s * RTCORE_RAD_PER_DEG, chamber0_kpa);
    angle_out_deg[0] = angle0_deg;
    if (chamber_out_kpa != 0) {
        chamber_out_kpa[0] = chamber0_kpa;
    }
    cache.count = 0;
    cache.next = 0;
    for (k = 0; k + 1 < n_samples; ++k) {
        advance_sample(finger, &s, &cache, pressure_cmd_kpa[k], dt_s, substeps);
        angle_out_deg[k + 1] = s.angle_rad * RTCORE_DEG_PER_RAD;
        if (chamber_out_kpa != 0) {
            chamber_out_kpa[k + 1] = s.chamber_kpa;
        }
    }
    return RTCORE_OK;
}
