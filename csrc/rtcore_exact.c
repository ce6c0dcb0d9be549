/* The exact part of the simulator (rtcore_exact.h): e^(L·h) and the forced responses of
 * the linear finger in closed form. */
#include <math.h>

#include "rtcore_exact.h"

/* Roots of A·λ² + B·λ + k for A > 0, B >= 0 and k of either sign, as (re, im) pairs: real
 * ones slow first (the slow one as −k/(A·(σ + d)), free of the cancellation in −σ + d),
 * complex ones with the positive imaginary part first. */
void rtcore_exact_eigenvalues(double inertia, double damping, double stiffness, double lambda_per_s[4])
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

void rtcore_exact_plant_init(rtcore_exact_plant *p, double inertia_kgm2, double damping_nms_per_rad,
                             double stiffness_nm_per_rad)
{
    p->inertia_kgm2 = inertia_kgm2;
    p->damping_nms_per_rad = damping_nms_per_rad;
    p->stiffness_nm_per_rad = stiffness_nm_per_rad;
    p->half_decay_per_s = 0.5 * damping_nms_per_rad / inertia_kgm2;
    p->disc_per_s2 = p->half_decay_per_s * p->half_decay_per_s - stiffness_nm_per_rad / inertia_kgm2;
    rtcore_exact_eigenvalues(inertia_kgm2, damping_nms_per_rad, stiffness_nm_per_rad, p->lambda_per_s);
}

/* E = e^(−σh)·[[C + σS, S], [−(k/A)·S, C − σS]] with C, S = cosh(dh), sinh(dh)/d
 * over-damped and cos(ωh), sin(ωh)/ω under-damped (ω² = −d²), both from their series in
 * d²h² near critical damping; for dh > 1 the same from the two real modes
 * e^(λ_slow·h), e^(λ_fast·h), so that nothing overflows however long the step. */
static void transition(const rtcore_exact_plant *p, double h, double e[4])
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

/* φ_k(z) = Σ_m z^m/(m + k)! for k = 1, 2, 3 at once ((e^z − 1)/z, (e^z − 1 − z)/z²,
 * (e^z − 1 − z − z²/2)/z³): for |z| < 1 φ_3 from its series, summed until a term no
 * longer changes it, and φ_2 = 1/2 + z·φ_3, φ_1 = 1 + z·φ_2 (no cancellation: |z·φ_3| <
 * 1/5); beyond, φ_1 from one expm1 and φ_(k+1) = (φ_k − 1/k!)/z. */
static void phis(double z, double out[3])
{
    if (fabs(z) < 1.0) {
        double term = 1.0 / 6.0;
        double sum = 0.0;
        int32_t m;
        for (m = 0; m < 24 && sum + term != sum; ++m) {
            sum += term;
            term *= z / (double)(m + 4);
        }
        out[2] = sum;
        out[1] = 0.5 + z * sum;
        out[0] = 1.0 + z * out[1];
        return;
    }
    out[0] = expm1(z) / z;
    out[1] = (out[0] - 1.0) / z;
    out[2] = (out[1] - 0.5) / z;
}

/* G_j = ∫_0^h e^(L(h−s))·b·s^j ds, b = (0, 1/A), the response to the torque t^j, each
 * accurate to its own size (the Q's divide them by h and h²):
 * - a short step, ‖L‖·h <= 1: G_j = j!·h^(j+1)·φ_(j+1)(Lh)·b, φ_3 from its series and
 *   the others from φ_k(M) = I/k! + M·φ_(k+1)(M);
 * - over-damped with distinct modes (|λ_fast| >= 3·|λ_slow|): from the modes,
 *   G_j = [(1, λ1)·I_j(λ1) − (1, λ2)·I_j(λ2)]/(A·(λ1 − λ2)), I_j(λ) = j!·h^(j+1)·φ_(j+1)(λh);
 * - otherwise (ringing or near critical damping, where the particular solution's terms are
 *   of the size of the response): G_j = x_p(h) − E·x_p(0) from the particular solution of
 *   A·θ'' + B·θ' + k·θ = t^j: θ_p = 1/k; t/k − B/k²; t²/k − 2B·t/k² + 2B²/k³ − 2A/k². */
static void forced_responses(const rtcore_exact_plant *p, double h, const double e[4], double g[3][2])
{
    const double rate_k = p->stiffness_nm_per_rad / p->inertia_kgm2;
    const double rate_b = p->damping_nms_per_rad / p->inertia_kgm2;
    const double inv_a = 1.0 / p->inertia_kgm2;
    int32_t j;
    const double norm_h = (sqrt(rate_k) + rate_b) * h; /* bounds ‖Lh‖ with θ scaled by ω_n */
    if (norm_h <= 1.0) {
        /* v3 = φ_3(Lh)·b from its series, then v2 = b/2 + Lh·v3 and v1 = b + Lh·v2 (the
         * angle's part of each is Lh's, h·θ', so nothing cancels), G_j = j!·h^(j+1)·v_(j+1) */
        double w[2] = {0.0, inv_a}; /* (Lh)^m·b/(m + 3)! */
        double v3[2] = {0.0, 0.0};
        double v2[2];
        double v1[2];
        double bound = 1.0; /* ‖Lh‖^m·3!/(m + 3)!: the size of term m against the first */
        int32_t m;
        w[1] /= 6.0;
        for (m = 0; m < 24 && bound > 1e-18; ++m) {
            const double th = w[0];
            v3[0] += w[0];
            v3[1] += w[1];
            w[0] = h * w[1] / (double)(m + 4);
            w[1] = h * (-rate_k * th - rate_b * w[1]) / (double)(m + 4);
            bound *= norm_h / (double)(m + 4);
        }
        v2[0] = h * v3[1];
        v2[1] = 0.5 * inv_a + h * (-rate_k * v3[0] - rate_b * v3[1]);
        v1[0] = h * v2[1];
        v1[1] = inv_a + h * (-rate_k * v2[0] - rate_b * v2[1]);
        for (j = 0; j < 2; ++j) {
            g[0][j] = h * v1[j];
            g[1][j] = h * h * v2[j];
            g[2][j] = 2.0 * h * h * h * v3[j];
        }
        return;
    }
    if (p->disc_per_s2 >= 0.25 * p->half_decay_per_s * p->half_decay_per_s) {
        const double slow = p->lambda_per_s[0];
        const double fast = p->lambda_per_s[2];
        const double inv = inv_a / (slow - fast);
        double power = h;
        double phi_slow[3];
        double phi_fast[3];
        phis(slow * h, phi_slow);
        phis(fast * h, phi_fast);
        for (j = 0; j < 3; ++j) {
            const double i_slow = power * phi_slow[j];
            const double i_fast = power * phi_fast[j];
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

/* E, G0 and the Q's of a step from its E and G's: the quadratic through u_s, u_m, u_e is
 * u_s + (−3u_s + 4u_m − u_e)·t/h + 2(u_s − 2u_m + u_e)·t²/h². */
static void finish_propagator(double h, const double e[4], double g[3][2], rtcore_propagator *out)
{
    int32_t i;
    for (i = 0; i < 4; ++i) {
        out->e[i] = e[i];
    }
    for (i = 0; i < 2; ++i) {
        const double g1 = g[1][i] / h;
        const double g2 = g[2][i] / (h * h);
        out->g0[i] = g[0][i];
        out->q[0][i] = g[0][i] - 3.0 * g1 + 2.0 * g2;
        out->q[1][i] = 4.0 * g1 - 4.0 * g2;
        out->q[2][i] = -g1 + 2.0 * g2;
    }
}

static void compute_propagator(const rtcore_exact_plant *p, double h, rtcore_propagator *out)
{
    double e[4];
    double g[3][2];
    transition(p, h, e);
    forced_responses(p, h, e, g);
    finish_propagator(h, e, g, out);
}

void rtcore_exact_propagator(const rtcore_exact_plant *p, double h, rtcore_propagator *out)
{
    compute_propagator(p, h, out);
}

/* A step h and its half at once (ETDRK4 takes both), the step from two halves:
 * E(h) = E(h/2)², and with s = h/2 + u over the second half, t^j's response
 * G_j(h) = E(h/2)·G_j(h/2) + Σ_i C(j, i)·(h/2)^(j−i)·G_i(h/2): G0 + G0', G1 + (h/2)·G0 + G1',
 * G2 + (h/2)²·G0 + h·G1 + G2' (the primes E(h/2)·). Every term of the size of the result
 * (the same sign for a short step), so each G stays accurate to its own size. */
static void compute_step_and_half(const rtcore_exact_plant *p, double h, rtcore_propagator *full,
                                  rtcore_propagator *half)
{
    const double a = 0.5 * h;
    double e[4];
    double g[3][2];
    double e2[4];
    double g2[3][2];
    int32_t j;
    transition(p, a, e);
    forced_responses(p, a, e, g);
    finish_propagator(a, e, g, half);
    e2[0] = e[0] * e[0] + e[1] * e[2];
    e2[1] = e[0] * e[1] + e[1] * e[3];
    e2[2] = e[2] * e[0] + e[3] * e[2];
    e2[3] = e[2] * e[1] + e[3] * e[3];
    for (j = 0; j < 3; ++j) {
        g2[j][0] = e[0] * g[j][0] + e[1] * g[j][1] + g[j][0];
        g2[j][1] = e[2] * g[j][0] + e[3] * g[j][1] + g[j][1];
    }
    for (j = 0; j < 2; ++j) {
        g2[2][j] += a * a * g[0][j] + h * g[1][j];
        g2[1][j] += a * g[0][j];
    }
    finish_propagator(h, e2, g2, full);
}

/* The slot of the cache for step h, computed if it is not there (the half too if asked). */
int32_t rtcore_exact_propagators(const rtcore_exact_plant *p, rtcore_propagator_cache *cache, double h, int32_t need_half)
{
    int32_t i;
    for (i = 0; i < cache->count; ++i) {
        if (cache->step_s[i] == h && cache->damping_nms_per_rad[i] == p->damping_nms_per_rad) {
            break;
        }
    }
    if (i == cache->count) {
        i = cache->next;
        cache->next = (cache->next + 1) % RTCORE_PROPAGATOR_CACHE;
        if (cache->count < RTCORE_PROPAGATOR_CACHE) {
            cache->count += 1;
        }
        cache->step_s[i] = h;
        cache->damping_nms_per_rad[i] = p->damping_nms_per_rad;
        cache->has_half[i] = 0;
        if (need_half) {
            compute_step_and_half(p, h, &cache->full[i], &cache->half[i]);
            cache->has_half[i] = 1;
            return i;
        }
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
void rtcore_exact_quadratic(const rtcore_propagator *pr, double *angle_rad, double *velocity_rad_per_s,
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
void rtcore_exact_held(const rtcore_propagator *pr, double angle_rad, double velocity_rad_per_s, double u,
                       double *angle_out_rad, double *velocity_out_rad_per_s)
{
    *angle_out_rad = pr->e[0] * angle_rad + pr->e[1] * velocity_rad_per_s + pr->g0[0] * u;
    *velocity_out_rad_per_s = pr->e[2] * angle_rad + pr->e[3] * velocity_rad_per_s + pr->g0[1] * u;
}

