/* The exact part of the simulator: the linear finger A·θ'' + B·θ' + k·θ = u(t) over a
 * step h, its transition e^(L·h) and its responses to a held and a quadratic torque, in
 * closed form for every damping (under-, critically and over-damped, B/A in the tens of
 * thousands per second), and a small cache of them. The functions are internal to the
 * simulator (rtcore_sim*.c); the cache's types are in the cffi interface (the block between
 * the CDEF markers, read by rtcore/_build.py), as a caller of rtcore_sim_plant.h keeps one
 * per finger between calls. */
#ifndef RTCORE_EXACT_H
#define RTCORE_EXACT_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* BEGIN CDEF */
#define RTCORE_PROPAGATOR_CACHE 4

/* The linear plant and what its propagators need. */
typedef struct {
    double inertia_kgm2;
    double damping_nms_per_rad;
    double stiffness_nm_per_rad;
    double half_decay_per_s; /* σ = B/(2A) */
    double disc_per_s2; /* d² = σ² − k/A: > 0 over-damped, < 0 under-damped */
    double lambda_per_s[4]; /* the eigenvalues (rtcore_exact_eigenvalues) */
} rtcore_exact_plant;

/* One step h of the linear plant: x(h) = E·x(0) + G0·u for a torque u held over the
 * step, and x(h) = E·x(0) + Q_start·u_start + Q_mid·u_mid + Q_end·u_end for the torque
 * quadratic through u_start, u_mid, u_end at t = 0, h/2, h. */
typedef struct {
    double e[4]; /* E = e^(L·h), row-major: θ from (θ, θ'), then θ' from (θ, θ') */
    double g0[2]; /* (θ, θ') after the step from rest under a unit torque */
    double q[3][2]; /* the same under the quadratic through 1, 0, 0; 0, 1, 0; 0, 0, 1 */
} rtcore_propagator;

/* the propagators of a step and of its half (ETDRK4's stages), the half only when needed,
 * for the last few (step, damping) pairs; count = next = 0 before the first use */
typedef struct {
    double step_s[RTCORE_PROPAGATOR_CACHE];
    double damping_nms_per_rad[RTCORE_PROPAGATOR_CACHE];
    int32_t has_half[RTCORE_PROPAGATOR_CACHE];
    rtcore_propagator full[RTCORE_PROPAGATOR_CACHE];
    rtcore_propagator half[RTCORE_PROPAGATOR_CACHE];
    int32_t count;
    int32_t next;
} rtcore_propagator_cache;
/* END CDEF */

/* Roots of A·λ² + B·λ + k (A > 0, B >= 0, k of either sign) as (re, im) pairs. */
void rtcore_exact_eigenvalues(double inertia, double damping, double stiffness, double lambda_per_s[4]);
void rtcore_exact_plant_init(rtcore_exact_plant *p, double inertia_kgm2, double damping_nms_per_rad,
                             double stiffness_nm_per_rad);
/* E, G0 and the Q's of a step h of plant p */
void rtcore_exact_propagator(const rtcore_exact_plant *p, double h, rtcore_propagator *out);
/* The slot of the cache for step h of plant p, computed if it is not there (the half too
 * if asked). */
int32_t rtcore_exact_propagators(const rtcore_exact_plant *p, rtcore_propagator_cache *cache, double h,
                                 int32_t need_half);
/* the state after a step under the torque quadratic through u_start, u_mid and u_end */
void rtcore_exact_quadratic(const rtcore_propagator *pr, double *angle_rad, double *velocity_rad_per_s,
                            double u_start, double u_mid, double u_end);
/* the state after a step under the torque u held */
void rtcore_exact_held(const rtcore_propagator *pr, double angle_rad, double velocity_rad_per_s, double u,
                       double *angle_out_rad, double *velocity_out_rad_per_s);

#ifdef __cplusplus
}
#endif

#endif
