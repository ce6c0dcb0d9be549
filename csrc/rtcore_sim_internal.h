/* What the finger's dynamics (csrc/rtcore_sim_motion.c, the API of rtcore_sim_plant.h, over
 * rtcore_sim_plant.c and its steps, rtcore_sim_etdrk4.c) share with the units below them, rtcore_sim_step_size.c (the step sizes) and rtcore_sim_span.c (a run of
 * samples as one segment), and offer the valve above them (rtcore_sim_advance.c, its own
 * rtcore_sim_advance.h) and the simulated hand (rtcore_sim.c). Not part of the API: nothing
 * here is in the cffi cdef. Names keep the rtcore_sim_ prefix because they have external
 * linkage inside the extension module. */
#ifndef RTCORE_SIM_INTERNAL_H
#define RTCORE_SIM_INTERNAL_H

#include <math.h>
#include <stdint.h>

#include "rtcore_exact.h"
#include "rtcore_sim_plant.h"

/* Step sizes, as fractions of the time scales they resolve:
 * - the motion's own, 1/|λ_slow| over-damped or 1/ω_n under-damped, when g is not zero;
 * - 1/(the shift of the plant's eigenvalues by g's damping-like slopes): as for RK4,
 *   h·|λ| <= 1 keeps such a mode accurate (and an explicit slope c against the exact B
 *   is stable at long steps only while c < B, so this bound stays however damped the
 *   plant);
 * - 1/(the shift by g's stiffness-like slopes);
 * - dry friction's slope, taken into the exact part at each step's start, by how fast
 *   the velocity can leave the band where that slope still holds (rtcore_sim_damping_step_s);
 * - the valve lag τ (LAG_STEP_FRACTION·τ at first, see integrate_segment in rtcore_sim_plant.c). */
static const double MOTION_STEP_FRACTION = 0.25;
static const double DAMPING_STEP_FRACTION = 1.0;
static const double STIFFNESS_STEP_FRACTION = 0.25;
static const double LAG_STEP_FRACTION = 0.0625;
/* of the creep's bound, B + c0's own (integrate_segment) */
static const double CREEP_STEP_SHARE = 0.25;
/* a state-dependent slope (quadratic damping, cubic stiffness) shortens the step at most
 * this much, and no held segment takes more than 2^20 steps, so a run that diverges ends */
static const double STATE_STEP_SHRINK = 256.0;
static const double MIN_STEP_PER_SEGMENT = 1.0 / 1048576.0;
/* a shorter segment (a dead time a hair past a whole number of periods) changes nothing
 * and is skipped: its step's h³ would underflow in the propagator */
static const double MIN_SEGMENT_S = 1e-30;
/* a kink this close to either end of a step is left there (rtcore_sim_before_kink) */
static const double KINK_MIN_FRACTION = 1e-3;

/* the chamber t after the start of a held segment: its exact first-order solution */
static inline double rtcore_sim_chamber_at(double start_kpa, double input_kpa, double tau_s, double t_s)
{
    return input_kpa + (start_kpa - input_kpa) * exp(-t_s / tau_s);
}

/* The sides a step keeps throughout (rtcore_sim_touches): the object touched, the contact
 * effect past its onset; each a bit of `touching`. */
#define SIM_TOUCH_OBJECT 1
#define SIM_TOUCH_CONTACT 2

/* One finger's linear plant and the bounds on g's slopes, derived once per sample. */
typedef struct {
    const rtcore_sim_finger *finger;
    rtcore_exact_plant linear; /* A, B, k: the part integrated exactly */
    int32_t nonlinear; /* g is not identically zero */
    int32_t state_dependent; /* a slope of g grows without bound with the state */
    int32_t kinks; /* g has kinks (rtcore_sim_before_kink) */
    double damping_slope_nms_per_rad; /* bound on −dg/dθ' (>= 0: g only damps) everywhere,
                                       * the friction's apart (rtcore_sim_damping_step_s) */
    double stiffness_slope_nm_per_rad; /* bound on |dg/dθ| everywhere */
    double external_torque_nm; /* the segment's, held: the drive less it is N·p_eff */
} sim_plant;

/* rtcore_sim_step_size.c */
double rtcore_sim_friction_slope_nms_per_rad(const rtcore_effects *e, double velocity_rad_per_s);
double rtcore_sim_velocity_reach_rad_per_s(const sim_plant *local, double velocity_rad_per_s, double friction0,
                                           double step_s, int32_t drag_exact);
double rtcore_sim_drag_step_s(const sim_plant *p, double velocity_rad_per_s, double balance_nm, double drift_nm);
double rtcore_sim_damping_step_s(const sim_plant *local, double velocity_rad_per_s, double reach, double net_nm,
                                 double drift_nm, double drift_rate_nm_per_s, double h_cap_s);
double rtcore_sim_parameter_step_s(const sim_plant *p);
double rtcore_sim_state_step_s(const sim_plant *p, double angle_rad, double accel_torque_nm);
double rtcore_sim_settle_range_rad_for(const sim_plant *p);
double rtcore_sim_settled_step_s(const sim_plant *p, const rtcore_sim_motion *s, double cap_s,
                                 double request_cap_s, double range_rad, double drive_nm, double drift_nm);

/* A run of samples under one held input, integrated as one segment whose steps may span
 * several sample periods (rtcore_sim_span.c): the state at the samples inside a step from
 * the exact propagators of the linear part at whole sample periods (computed once per run,
 * RTCORE_SPAN_SAMPLES of them), under the step's own quadratic torque. */
#define RTCORE_SPAN_SAMPLES 32
typedef struct {
    double dt_s;
    int32_t count; /* samples in the span: outputs 1..count */
    int32_t next; /* the next sample to output */
    double t0_s; /* the segment's start, from the span's */
    double *angle_out_deg; /* count of them */
    double damping_nms_per_rad; /* the finger's B, whose propagators these are */
    int32_t has[RTCORE_SPAN_SAMPLES];
    rtcore_propagator at[RTCORE_SPAN_SAMPLES]; /* at[i]: a step of i sample periods (i >= 1) */
} sim_span;

/* rtcore_sim_span.c */
double rtcore_sim_span_step_s(const sim_span *out, double t_s, double h_s);
void rtcore_sim_span_emit(sim_span *out, const rtcore_exact_plant *linear, double t_s, double h_s,
                          double angle0_rad, double velocity0_rad_per_s, const double torque_nm[3],
                          double angle1_rad, double velocity1_rad_per_s);
int32_t rtcore_sim_span_eligible(const sim_plant *p);
double rtcore_sim_span_cap_s(const sim_plant *p, double dt_s);

/* rtcore_sim_torque.c: g(θ, θ') and its parts, and the finger's local plant */
double rtcore_sim_contact_force_n(const rtcore_sim_finger *f, double angle_rad, double velocity_rad_per_s);
int32_t rtcore_sim_touches(const rtcore_sim_finger *f, double angle_rad);
/* The fraction of a step from (angle0, velocity0) to (angle1, velocity1) before the first
 * kink or jump of g it crosses (1 for none), and in *surface the side that one changes
 * (rtcore_sim_kink.c). */
double rtcore_sim_before_kink(const sim_plant *p, int32_t touching, double angle0_rad, double velocity0_rad_per_s,
                              double angle1_rad, double velocity1_rad_per_s, int32_t *surface);
double rtcore_sim_loop_z(const rtcore_sim_finger *f, const rtcore_sim_motion *from, double angle_rad);
double rtcore_sim_creep_angle_rad(const rtcore_effects *e, const rtcore_sim_motion *from, double angle_rad,
                                  double elapsed_s);
double rtcore_sim_nonlinear_torque_nm(const sim_plant *p, const rtcore_sim_motion *from, double angle_rad,
                                      double velocity_rad_per_s, int32_t touching, double drive_nm,
                                      double elapsed_s);
double rtcore_sim_nonlinear_torque_with_nm(const sim_plant *p, const rtcore_sim_motion *from, double angle_rad,
                                           double velocity_rad_per_s, int32_t touching, double drive_nm,
                                           double elapsed_s, double friction_tanh);
double rtcore_sim_pressure_torque_nm(const rtcore_sim_finger *f, double chamber_kpa);
void rtcore_sim_plant_for(const rtcore_sim_finger *f, sim_plant *p);

/* rtcore_sim_etdrk4.c: the plant with the damping B + extra (the part a step integrates
 * exactly), and one step h of it from `from` to (*angle_rad, *velocity_rad_per_s), the
 * chamber's torque p_start, p_mid, p_end at t = 0, h/2, h, g_start = g(from) +
 * linearized·θ'; the step's total torque at its start, middle and end in torque_nm (the
 * quadratic a span's samples inside the step follow) */
void rtcore_sim_with_damping(const sim_plant *base, double extra_nms_per_rad, sim_plant *out);
void rtcore_sim_etdrk4_step(const sim_plant *p, const rtcore_sim_motion *from, rtcore_propagator_cache *cache,
                            double *angle_rad, double *velocity_rad_per_s, double h, double p_start, double p_mid,
                            double p_end, double g_start, int32_t touching, double linearized_nms_per_rad,
                            double torque_nm[3]);

/* The drive over a knee's passage that starts t0_s into a held segment: the chamber's
 * torque (moving toward input_kpa with the lag tau_s from start_kpa, or torque_nm held)
 * with the segment's external torque. */
typedef struct {
    const rtcore_sim_finger *finger;
    int32_t moving;
    double start_kpa;
    double input_kpa;
    double tau_s;
    double t0_s;
    double torque_nm;
    double external_torque_nm;
    double drive0_nm; /* the drive at the passage's start (t0_s) */
    double g0_nm; /* g at the passage's start under torque_nm, on its sides */
} sim_knee_drive;

/* A knee's passage: the state at `count` nodes, the first the start, the last its end. */
#define SIM_KNEE_NODES 13
typedef struct {
    int32_t count;
    double time_s[SIM_KNEE_NODES];
    double angle_rad[SIM_KNEE_NODES];
    double velocity_rad_per_s[SIM_KNEE_NODES];
} sim_knee_path;

/* rtcore_sim_knee.c: 1 and the path through dry friction's knee from `s`, ending before
 * limit_s, where the drive carries the finger through it; 0 where it may not */
int32_t rtcore_sim_knee_passage(const sim_plant *p, const rtcore_sim_motion *s, int32_t touching,
                                const sim_knee_drive *d, double limit_s, sim_knee_path *path);

/* rtcore_sim_plant.c: a held valve input over duration_s, cut where the chamber crosses the
 * dead zone's threshold (steps of at most request_cap_s and what the dynamics allow; over a
 * span of samples when span is not NULL) */
void rtcore_sim_integrate_held(const sim_plant *p, rtcore_sim_motion *s, rtcore_propagator_cache *cache,
                               double input_kpa, double external_torque_nm, double duration_s, double request_cap_s,
                               sim_span *span);

#endif /* RTCORE_SIM_INTERNAL_H */
