/* The simulated hand: PRBM dynamics with the shared torque model (its linear part exact,
 * the rest by ETD2RK), the valve (lag behind a dead time, integrated exactly), an optional
 * object, and the flex sensor. */
#include <math.h>
#include <string.h>

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
#define PROPAGATOR_CACHE 4

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

/* Roots of A·λ² + B·λ + k for A > 0, B >= 0 and k of either sign, as (re, im) pairs: real
 * ones slow first (the slow one as −k/(A·(σ + d)), free of the cancellation in −σ + d),
 * complex ones with the positive imaginary part first. */
static void eigenvalues(double inertia, double damping, double stiffness, double lambda_per_s[4])
{
    const double sigma = 0.5 * damping / inertia;
    const double disc = sigma * sigma - stiffness / inertia;
    if (disc >= 0.0) {
        const double d = sqrt(disc);
        lambda_per_s[0] = sigma + d > 0.0 ? -(stiffness / inertia) / (sigma + d) : 0.0;
        lambda_per_s[1] = 0.0;
        lambda_per_s[2] = -sigma - d;
        lambda_per_s[3] = 0.0;
    } else {
        const double w = sqrt(-disc);
        lambda_per_s[0] = -sigma;
        lambda_per_s[1] = w;
        lambda_per_s[2] = -sigma;
        lambda_per_s[3] = -w;
    }
}

/* One finger's linear plant and the bounds on g's slopes, derived once per sample. */
typedef struct {
    const rtcore_sim_finger *finger;
    double inertia_kgm2;
    double damping_nms_per_rad;
    double stiffness_nm_per_rad;
    double half_decay_per_s; /* σ = B/(2A) */
    double disc_per_s2; /* d² = σ² − k/A: > 0 over-damped, < 0 under-damped */
    double lambda_per_s[4]; /* the plant's eigenvalues (eigenvalues()) */
    int32_t nonlinear; /* g is not identically zero */
    int32_t state_dependent; /* a slope of g grows without bound with the state */
    int32_t kinks; /* g has kinks (before_kink) */
    double damping_slope_nms_per_rad; /* bound on −dg/dθ' (>= 0: g only damps) everywhere */
    double stiffness_slope_nm_per_rad; /* bound on |dg/dθ| everywhere */
} sim_plant;

static double shift_per_s(const sim_plant *p, double damping, double stiffness)
{
    double lambda_per_s[4];
    double first;
    double second;
    eigenvalues(p->inertia_kgm2, damping, stiffness, lambda_per_s);
    first = hypot(lambda_per_s[0] - p->lambda_per_s[0], lambda_per_s[1] - p->lambda_per_s[1]);
    second = hypot(lambda_per_s[2] - p->lambda_per_s[2], lambda_per_s[3] - p->lambda_per_s[3]);
    return first > second ? first : second;
}

/* The longest step for explicit slopes of g: a damping-like c >= 0 and a stiffness-like
 * ±K, each by how far it moves the plant's eigenvalues. */
static double slope_step_s(const sim_plant *p, double damping_slope, double stiffness_slope)
{
    const double damping_per_s = shift_per_s(p, p->damping_nms_per_rad + damping_slope,
                                             p->stiffness_nm_per_rad);
    const double stiffer_per_s = shift_per_s(p, p->damping_nms_per_rad, p->stiffness_nm_per_rad + stiffness_slope);
    const double softer_per_s = shift_per_s(p, p->damping_nms_per_rad, p->stiffness_nm_per_rad - stiffness_slope);
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
    p->inertia_kgm2 = m->inertia_kgm2;
    p->damping_nms_per_rad = m->damping_nms_per_rad;
    p->stiffness_nm_per_rad = m->stiffness_nm_per_rad;
    p->half_decay_per_s = 0.5 * m->damping_nms_per_rad / m->inertia_kgm2;
    p->disc_per_s2 = p->half_decay_per_s * p->half_decay_per_s - m->stiffness_nm_per_rad / m->inertia_kgm2;
    eigenvalues(p->inertia_kgm2, p->damping_nms_per_rad, p->stiffness_nm_per_rad, p->lambda_per_s);
    p->state_dependent = e->quadratic_damping_nms2_per_rad2 > 0.0 || e->cubic_stiffness_nm_per_rad3 != 0.0;
    p->nonlinear = p->state_dependent || contact || e->coulomb_torque_nm > 0.0 || e->gravity_torque_nm != 0.0
                   || e->asymmetric_stiffness_ratio != 1.0;
    p->kinks = contact || e->asymmetric_stiffness_ratio != 1.0;
    p->damping_slope_nms_per_rad = contact ? f->contact_damping_ns_per_m * r2 : 0.0;
    if (e->coulomb_torque_nm > 0.0) {
        /* Tc·tanh(ω/ω_s) is steepest at ω = 0 */
        p->damping_slope_nms_per_rad += e->coulomb_torque_nm
                                        / (e->coulomb_smoothing_deg_per_s * RTCORE_RAD_PER_DEG);
    }
    p->stiffness_slope_nm_per_rad = fabs(e->asymmetric_stiffness_ratio - 1.0) * m->stiffness_nm_per_rad
                                    + fabs(e->gravity_torque_nm)
                                    + (contact ? f->contact_stiffness_n_per_m * r2 : 0.0);
}

/* The longest step the parameters allow: infinite for the plain linear finger (exact at
 * any step), else a fraction of the motion's time scale and of what g's slopes need. */
static double parameter_step_s(const sim_plant *p)
{
    const double motion_per_s = hypot(p->lambda_per_s[0], p->lambda_per_s[1]);
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

/* The step where a slope of g grows with the state, 2·c2·|θ'| and 3·|k3|·θ², taken at
 * the velocity and the angle the finger may reach: the present ones plus what the torque
 * out of balance, accel_torque = A·θ'', drives (a velocity of about accel_torque/(B + √(kA)),
 * over-damped or ringing, and an angle of accel_torque/k). */
static double state_step_s(const sim_plant *p, double angle_rad, double velocity_rad_per_s,
                           double accel_torque_nm)
{
    const rtcore_effects *e = &p->finger->prbm.effects;
    const double torque = fabs(accel_torque_nm);
    const double velocity = fabs(velocity_rad_per_s)
                            + torque / (p->damping_nms_per_rad
                                        + sqrt(p->stiffness_nm_per_rad * p->inertia_kgm2));
    const double angle = fabs(angle_rad) + torque / p->stiffness_nm_per_rad;
    return slope_step_s(p, p->damping_slope_nms_per_rad + 2.0 * e->quadratic_damping_nms2_per_rad2 * velocity,
                        p->stiffness_slope_nm_per_rad
                            + 3.0 * fabs(e->cubic_stiffness_nm_per_rad3) * angle * angle);
}

/* One step h of the linear plant: x(h) = E·x(0) + G0·u for a torque u held over the
 * step, and x(h) = E·x(0) + Q_start·u_start + Q_mid·u_mid + Q_end·u_end for the torque
 * quadratic through u_start, u_mid, u_end at t = 0, h/2, h. */
typedef struct {
    double e[4]; /* E = e^(L·h), row-major: θ from (θ, θ'), then θ' from (θ, θ') */
    double g0[2]; /* (θ, θ') after the step from rest under a unit torque */
    double q[3][2]; /* the same under the quadratic through 1, 0, 0; 0, 1, 0; 0, 0, 1 */
} propagator;

/* the propagators of a step and of its half (ETDRK4's stages), the half only when needed */
typedef struct {
    double step_s[PROPAGATOR_CACHE];
    int32_t has_half[PROPAGATOR_CACHE];
    propagator full[PROPAGATOR_CACHE];
    propagator half[PROPAGATOR_CACHE];
    int32_t count;
    int32_t next;
} propagator_cache;

/* E = e^(−σh)·[[C + σS, S], [−(k/A)·S, C − σS]] with C, S = cosh(dh), sinh(dh)/d
 * over-damped and cos(ωh), sin(ωh)/ω under-damped (ω² = −d²), both from their series in
 * d²h² near critical damping; for dh > 1 the same from the two real modes
 * e^(λ_slow·h), e^(λ_fast·h), so that nothing overflows however long the step. */
static void transition(const sim_plant *p, double h, double e[4])
{
    const double sigma = p->half_decay_per_s;
    const double rate_k = p->stiffness_nm_per_rad / p->inertia_kgm2;
    const double y = p->disc_per_s2 * h * h;
    double c;
    double s;
    double decay;
    if (y > 1.0) {
        const double slow = p->lambda_per_s[0];
        const double fast = p->lambda_per_s[2];
        const double e_slow = exp(slow * h);
        const double e_fast = exp(fast * h);
        const double two_d = 2.0 * sqrt(p->disc_per_s2);
        e[0] = (-fast * e_slow + slow * e_fast) / two_d;
        e[1] = (e_slow - e_fast) / two_d;
        e[2] = -rate_k * e[1];
        e[3] = (slow * e_slow - fast * e_fast) / two_d;
        return;
    }
    if (fabs(y) < 1e-3) {
        c = 1.0 + y * (1.0 / 2.0 + y * (1.0 / 24.0 + y / 720.0));
        s = h * (1.0 + y * (1.0 / 6.0 + y * (1.0 / 120.0 + y / 5040.0)));
    } else if (y > 0.0) {
        const double d = sqrt(p->disc_per_s2);
        c = cosh(d * h);
        s = sinh(d * h) / d;
    } else {
        const double w = sqrt(-p->disc_per_s2);
        c = cos(w * h);
        s = sin(w * h) / w;
    }
    decay = exp(-sigma * h);
    e[0] = decay * (c + sigma * s);
    e[1] = decay * s;
    e[2] = -rate_k * decay * s;
    e[3] = decay * (c - sigma * s);
}

/* φ_k(z) = Σ_m z^m/(m + k)! for k = 1, 2, 3: (e^z − 1)/z, (e^z − 1 − z)/z²,
 * (e^z − 1 − z − z²/2)/z³, from the series where those would cancel. */
static double phi(int32_t k, double z)
{
    if (fabs(z) < 1.0) {
        double term = 1.0;
        double sum = 0.0;
        int32_t m;
        for (m = 1; m <= k; ++m) {
            term /= (double)m;
        }
        for (m = 0; m < 20; ++m) {
            sum += term;
            term *= z / (double)(m + k + 1);
        }
        return sum;
    }
    if (k == 1) {
        return expm1(z) / z;
    }
    if (k == 2) {
        return (expm1(z) - z) / (z * z);
    }
    return (expm1(z) - z - 0.5 * z * z) / (z * z * z);
}

/* G_j = ∫_0^h e^(L(h−s))·b·s^j ds, b = (0, 1/A), the response to the torque t^j, each
 * accurate to its own size (the Q's divide them by h and h²):
 * - a short step, ‖L‖·h <= 1: the series Σ_m (Lh)^m·b·h^(j+1)·j!/(m + j + 1)!;
 * - over-damped with distinct modes (|λ_fast| >= 3·|λ_slow|): from the modes,
 *   G_j = [(1, λ1)·I_j(λ1) − (1, λ2)·I_j(λ2)]/(A·(λ1 − λ2)), I_j(λ) = j!·h^(j+1)·φ_(j+1)(λh);
 * - otherwise (ringing or near critical damping, where the particular solution's terms are
 *   of the size of the response): G_j = x_p(h) − E·x_p(0) from the particular solution of
 *   A·θ'' + B·θ' + k·θ = t^j: θ_p = 1/k; t/k − B/k²; t²/k − 2B·t/k² + 2B²/k³ − 2A/k². */
static void forced_responses(const sim_plant *p, double h, const double e[4], double g[3][2])
{
    const double rate_k = p->stiffness_nm_per_rad / p->inertia_kgm2;
    const double rate_b = p->damping_nms_per_rad / p->inertia_kgm2;
    const double inv_a = 1.0 / p->inertia_kgm2;
    int32_t j;
    const double norm_h = (sqrt(rate_k) + rate_b) * h; /* bounds ‖Lh‖ with θ scaled by ω_n */
    if (norm_h <= 1.0) {
        double w[2]; /* (Lh)^m·b */
        double factorial; /* (m + j + 1)! */
        double bound; /* ‖Lh‖^m/(m + j + 1)!: the size of term m against the first */
        int32_t m;
        for (j = 0; j < 3; ++j) {
            const double scale = h * (j == 0 ? 1.0 : j == 1 ? h : 2.0 * h * h); /* h^(j+1)·j! */
            g[j][0] = 0.0;
            g[j][1] = 0.0;
            w[0] = 0.0;
            w[1] = inv_a;
            factorial = j == 0 ? 1.0 : j == 1 ? 2.0 : 6.0;
            bound = 1.0;
            for (m = 0; m < 24 && bound > 1e-18; ++m) {
                const double th = w[0];
                g[j][0] += w[0] / factorial;
                g[j][1] += w[1] / factorial;
                w[0] = h * w[1];
                w[1] = h * (-rate_k * th - rate_b * w[1]);
                factorial *= (double)(m + j + 2);
                bound *= norm_h / (double)(m + j + 2);
            }
            g[j][0] *= scale;
            g[j][1] *= scale;
        }
        return;
    }
    if (p->disc_per_s2 >= 0.25 * p->half_decay_per_s * p->half_decay_per_s) {
        const double slow = p->lambda_per_s[0];
        const double fast = p->lambda_per_s[2];
        const double inv = inv_a / (slow - fast);
        double power = h;
        for (j = 0; j < 3; ++j) {
            const double i_slow = power * phi(j + 1, slow * h);
            const double i_fast = power * phi(j + 1, fast * h);
            g[j][0] = inv * (i_slow - i_fast);
            g[j][1] = inv * (slow * i_slow - fast * i_fast);
            power *= h * (double)(j + 1);
        }
        return;
    }
    {
        const double inv_k = 1.0 / p->stiffness_nm_per_rad;
        const double b = p->damping_nms_per_rad;
        double coef[3][3]; /* θ_p(t) = coef[j][0] + coef[j][1]·t + coef[j][2]·t² */
        coef[0][0] = inv_k;
        coef[0][1] = 0.0;
        coef[0][2] = 0.0;
        coef[1][2] = 0.0;
        coef[1][1] = inv_k;
        coef[1][0] = -b * inv_k * inv_k;
        coef[2][2] = inv_k;
        coef[2][1] = -2.0 * b * inv_k * inv_k;
        coef[2][0] = (-2.0 * p->inertia_kgm2 * coef[2][2] - b * coef[2][1]) * inv_k;
        for (j = 0; j < 3; ++j) {
            const double th0 = coef[j][0];
            const double w0 = coef[j][1];
            const double th_h = coef[j][0] + h * (coef[j][1] + h * coef[j][2]);
            const double w_h = coef[j][1] + 2.0 * h * coef[j][2];
            g[j][0] = th_h - (e[0] * th0 + e[1] * w0);
            g[j][1] = w_h - (e[2] * th0 + e[3] * w0);
        }
    }
}

/* E, G0 and the Q's of a step: the quadratic through u_s, u_m, u_e is
 * u_s + (−3u_s + 4u_m − u_e)·t/h + 2(u_s − 2u_m + u_e)·t²/h². */
static void compute_propagator(const sim_plant *p, double h, propagator *out)
{
    double g[3][2];
    int32_t i;
    transition(p, h, out->e);
    forced_responses(p, h, out->e, g);
    for (i = 0; i < 2; ++i) {
        const double g1 = g[1][i] / h;
        const double g2 = g[2][i] / (h * h);
        out->g0[i] = g[0][i];
        out->q[0][i] = g[0][i] - 3.0 * g1 + 2.0 * g2;
        out->q[1][i] = 4.0 * g1 - 4.0 * g2;
        out->q[2][i] = -g1 + 2.0 * g2;
    }
}

/* The slot of the cache for step h, computed if it is not there (the half too if asked). */
static int32_t propagators_for(const sim_plant *p, propagator_cache *cache, double h, int32_t need_half)
{
    int32_t i;
    for (i = 0; i < cache->count; ++i) {
        if (cache->step_s[i] == h) {
            break;
        }
    }
    if (i == cache->count) {
        i = cache->next;
        cache->next = (cache->next + 1) % PROPAGATOR_CACHE;
        if (cache->count < PROPAGATOR_CACHE) {
            cache->count += 1;
        }
        cache->step_s[i] = h;
        cache->has_half[i] = 0;
        compute_propagator(p, h, &cache->full[i]);
    }
    if (need_half && !cache->has_half[i]) {
        compute_propagator(p, 0.5 * h, &cache->half[i]);
        cache->has_half[i] = 1;
    }
    return i;
}

/* the state after a step under the torque quadratic through u_start, u_mid and u_end at
 * t = 0, h/2 and h */
static void exact_quadratic(const propagator *pr, double *angle_rad, double *velocity_rad_per_s,
                            double u_start, double u_mid, double u_end)
{
    const double th = *angle_rad;
    const double w = *velocity_rad_per_s;
    *angle_rad = pr->e[0] * th + pr->e[1] * w + pr->q[0][0] * u_start + pr->q[1][0] * u_mid
                 + pr->q[2][0] * u_end;
    *velocity_rad_per_s = pr->e[2] * th + pr->e[3] * w + pr->q[0][1] * u_start + pr->q[1][1] * u_mid
                          + pr->q[2][1] * u_end;
}

/* the state after a step under the torque u held */
static void exact_held(const propagator *pr, double angle_rad, double velocity_rad_per_s, double u,
                       double *angle_out_rad, double *velocity_out_rad_per_s)
{
    *angle_out_rad = pr->e[0] * angle_rad + pr->e[1] * velocity_rad_per_s + pr->g0[0] * u;
    *velocity_out_rad_per_s = pr->e[2] * angle_rad + pr->e[3] * velocity_rad_per_s + pr->g0[1] * u;
}

/* One step h; the chamber's torque is p_start, p_mid and p_end at t = 0, h/2 and h, and
 * g_start = g(x). Without g: the exact response to that quadratic. With g, ETDRK4 (Cox &
 * Matthews 2002): stages a and b from x and c from a over h/2, each with the total torque
 * held (at x, at a, and 2·(at b) − (at x)), then the exact response to the quadratic
 * through the torque at x, the mean of those at a and b, and at c. */
static void step(const sim_plant *p, propagator_cache *cache, double *angle_rad, double *velocity_rad_per_s,
                 double h, double p_start, double p_mid, double p_end, double g_start, int32_t touching)
{
    const rtcore_sim_finger *f = p->finger;
    const int32_t slot = propagators_for(p, cache, h, p->nonlinear);
    const propagator *full = &cache->full[slot];
    const propagator *half = &cache->half[slot];
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
        exact_quadratic(full, angle_rad, velocity_rad_per_s, p_start, p_mid, p_end);
        return;
    }
    n_x = p_start + g_start;
    exact_held(half, *angle_rad, *velocity_rad_per_s, n_x, &th_a, &w_a);
    n_a = p_mid + nonlinear_torque_nm(f, th_a, w_a, touching);
    exact_held(half, *angle_rad, *velocity_rad_per_s, n_a, &th_b, &w_b);
    n_b = p_mid + nonlinear_torque_nm(f, th_b, w_b, touching);
    exact_held(half, th_a, w_a, 2.0 * n_b - n_x, &th_c, &w_c);
    n_c = p_end + nonlinear_torque_nm(f, th_c, w_c, touching);
    exact_quadratic(full, angle_rad, velocity_rad_per_s, n_x, 0.5 * (n_a + n_b), n_c);
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
static void integrate_segment(const sim_plant *p, rtcore_sim_finger_state *s, propagator_cache *cache,
                              double input_kpa, double duration_s, double step_cap_s)
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
        const double linear_nm = p->stiffness_nm_per_rad * s->angle_rad + p->damping_nms_per_rad * s->velocity_rad_per_s;
        const double accel_nm = fmax(fabs(torque_start + g_nm - linear_nm), fabs(torque_last + g_nm - linear_nm));
        cap_s = fmin(step_cap_s, fmax(state_step_s(p, s->angle_rad, s->velocity_rad_per_s, accel_nm),
                                      step_cap_s / STATE_STEP_SHRINK));
    }
    while (!last) {
        const double remaining_s = duration_s - t_s;
        int32_t touching = next_touching >= 0 ? next_touching : touches(f, s->angle_rad);
        double g_start = p->nonlinear ? nonlinear_torque_nm(f, s->angle_rad, s->velocity_rad_per_s, touching) : 0.0;
        double h = cap_s;
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
            step(p, cache, &angle_rad, &velocity_rad_per_s, h, torque_start, torque_mid, torque_end, g_start,
                 touching);
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
                g_start = nonlinear_torque_nm(f, s->angle_rad, s->velocity_rad_per_s, touching);
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
static void integrate_held(const sim_plant *p, rtcore_sim_finger_state *s, propagator_cache *cache,
                           double input_kpa, double duration_s, double step_cap_s)
{
    const double tau_s = p->finger->prbm.effects.valve_lag_tau_s;
    const double deadzone_kpa = p->finger->prbm.effects.pressure_deadzone_kpa;
    const double start_kpa = s->chamber_kpa;
    if (tau_s > 0.0 && deadzone_kpa > 0.0
        && ((start_kpa < deadzone_kpa && input_kpa > deadzone_kpa)
            || (start_kpa > deadzone_kpa && input_kpa < deadzone_kpa))) {
        const double cross_s = tau_s * log((start_kpa - input_kpa) / (deadzone_kpa - input_kpa));
        if (cross_s > 0.0 && cross_s < duration_s) {
            integrate_segment(p, s, cache, input_kpa, cross_s, step_cap_s);
            integrate_segment(p, s, cache, input_kpa, duration_s - cross_s, step_cap_s);
            return;
        }
    }
    integrate_segment(p, s, cache, input_kpa, duration_s, step_cap_s);
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

/* One sample period after pushing command_kpa: the dead time puts at most one breakpoint
 * inside the period, where the older command gives way to the newer one. The step is at
 * most dt/substeps (what the caller asks for) and what the finger's parameters allow. */
static void advance_sample(const rtcore_sim_finger *f, rtcore_sim_finger_state *s, propagator_cache *cache,
                           double command_kpa, double dt_s, int32_t substeps)
{
    const double step_cap_s = fmin(dt_s / (double)substeps, s->max_step_s);
    sim_plant plant;
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
        propagator_cache cache;
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
    propagator_cache cache;
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
