/* The control step for the whole hand (configuration and reset: rtcore_config.c). */
#include <math.h>

#include "rtcore_internal.h"
#include "rtcore_step.h"

/* Impedance mode's lead on the springs' rate takes at most this share of the finger's
 * spring k (measured: at half of k the slow push against a wall chatters at K_max/10 on
 * the thumb, the angle's noise through the lead starting it; docs/results.md) */
#define IMPEDANCE_LEAD_MAX_SHARE 0.25

/* Keep value as the held reference when it is usable; report 1 when it is not. */
static uint32_t hold_reference(double *held, double value)
{
    if (isfinite(value) && fabs(value) <= RTCORE_SANE_LIMIT) {
        *held = value;
        return 0u;
    }
    return 1u;
}

/* Keep value as the held impedance gain when it is usable and not negative. */
static uint32_t hold_gain(double *held, double value)
{
    if (isfinite(value) && value >= 0.0 && value <= RTCORE_SANE_LIMIT) {
        *held = value;
        return 0u;
    }
    return 1u;
}

static double clamp_symmetric(double x, double limit)
{
    if (x > limit) {
        return limit;
    }
    if (x < -limit) {
        return -limit;
    }
    return x;
}

/* Calibrate, filter and differentiate the sensor; returns the calibrated angle. */
static double update_angle(const rtcore_finger_config *c, rtcore_finger_state *s, double mv,
                           double dt_s, uint32_t *flags)
{
    double angle = c->sensor_gain_deg_per_mv * mv + c->sensor_offset_deg;
    double filtered;
    double velocity;
    int32_t k;

    if (!isfinite(angle) || fabs(angle) > RTCORE_SANE_LIMIT) {
        *flags |= (uint32_t)RTCORE_FLAG_SENSOR_REJECTED;
        angle = c->sensor_gain_deg_per_mv * s->last_good_mv + c->sensor_offset_deg;
    } else {
        s->last_good_mv = mv;
    }
    if (!s->filter_primed) {
        double x = angle;
        for (k = 0; k < s->n_sections; ++k) {
            rtcore_biquad *bq = &s->section[k];
            rtcore_biquad_prime(bq, x);
            x = (bq->b0 + bq->b1 + bq->b2) / (1.0 + bq->a1 + bq->a2) * x;
        }
        s->angle_filt_deg = x;
        s->velocity_deg_per_s = 0.0;
        s->accel_deg_per_s2 = 0.0;
        s->filter_primed = 1;
    }
    filtered = angle;
    for (k = 0; k < s->n_sections; ++k) {
        filtered = rtcore_biquad_run(&s->section[k], filtered);
    }
    velocity = s->velocity_alpha * s->velocity_deg_per_s
               + (1.0 - s->velocity_alpha) * (filtered - s->angle_filt_deg) / dt_s;
    s->accel_deg_per_s2 = s->velocity_alpha * s->accel_deg_per_s2
                          + (1.0 - s->velocity_alpha) * (velocity - s->velocity_deg_per_s) / dt_s;
    s->velocity_deg_per_s = velocity;
    s->angle_filt_deg = filtered;
    return angle;
}

static uint32_t step_finger(rtcore_hand *hand, int32_t i, const rtcore_inputs *in,
                            rtcore_outputs *out)
{
    const rtcore_finger_config *c = &hand->config.finger[i];
    rtcore_finger_state *s = &hand->finger[i];
    const double dt_s = hand->dt_s;
    const double previous_kpa = s->pressure_cmd_kpa;
    const int32_t previous_mode = s->mode;
    uint32_t flags = 0u;
    int32_t mode = in->mode[i];
    uint32_t rejected_position;
    uint32_t rejected_force;
    uint32_t rejected_pressure;
    uint32_t rejected_impedance;
    double angle_deg;
    double angle_rad;
    double chamber_kpa;
    double force_n;
    double loop_z;
    double feedforward_kpa = 0.0;
    double pid_kpa = 0.0;
    double command_kpa = 0.0;
    int32_t changed;

    if (mode < RTCORE_MODE_VENT || mode > RTCORE_MODE_IMPEDANCE) {
        mode = RTCORE_MODE_VENT;
        flags |= (uint32_t)RTCORE_FLAG_MODE_REJECTED;
    }
    changed = mode != previous_mode;
    if (changed) {
        flags |= (uint32_t)RTCORE_FLAG_MODE_CHANGED;
    }
    s->mode = mode;

    angle_deg = update_angle(c, s, in->sensor_mv[i], dt_s, &flags);
    angle_rad = s->angle_filt_deg * RTCORE_RAD_PER_DEG;

    rejected_position = hold_reference(&s->angle_ref_deg, in->angle_ref_deg[i])
                        | hold_reference(&s->velocity_ref_deg_per_s, in->velocity_ref_deg_per_s[i])
                        | hold_reference(&s->accel_ref_deg_per_s2, in->accel_ref_deg_per_s2[i])
                        | hold_reference(&s->jerk_ref_deg_per_s3, in->jerk_ref_deg_per_s3[i]);
    rejected_force = hold_reference(&s->force_ref_n, in->force_ref_n[i]);
    rejected_pressure = hold_reference(&s->pressure_ref_kpa, in->pressure_ref_kpa[i]);
    rejected_impedance = hold_gain(&s->impedance_stiffness_n_per_deg, in->impedance_stiffness_n_per_deg[i])
                         | hold_gain(&s->impedance_damping_n_s_per_deg, in->impedance_damping_n_s_per_deg[i]);
    if ((mode == RTCORE_MODE_POSITION && rejected_position)
        || (mode == RTCORE_MODE_IMPEDANCE && (rejected_position || rejected_impedance))
        || (mode == RTCORE_MODE_FORCE && rejected_force)
        || (mode == RTCORE_MODE_PRESSURE && rejected_pressure)) {
        flags |= (uint32_t)RTCORE_FLAG_REFERENCE_REJECTED;
    }

    /* chamber pressure: measured when the board reports it, else a first-order model
     * of the valve driven by the command in force since the last tick */
    s->chamber_model_kpa = previous_kpa
                           + (s->chamber_model_kpa - previous_kpa)
                                 * (previous_kpa < s->chamber_model_kpa ? s->chamber_vent_alpha : s->chamber_alpha);
    chamber_kpa = in->pressure_meas_kpa[i];
    if (!isfinite(chamber_kpa) || fabs(chamber_kpa) > RTCORE_SANE_LIMIT) {
        chamber_kpa = s->chamber_model_kpa;
    }
    rtcore_hysteresis_angle_update(c, s);
    loop_z = c->force_estimate_hysteresis ? s->hysteresis_z : 0.0;
    force_n = rtcore_force_normal_n(c, chamber_kpa, angle_rad,
                                    s->velocity_deg_per_s * RTCORE_RAD_PER_DEG,
                                    s->accel_deg_per_s2 * RTCORE_RAD_PER_DEG, loop_z);
    if (!isfinite(force_n)) {
        force_n = 0.0;
        flags |= (uint32_t)RTCORE_FLAG_OUTPUT_REJECTED;
    }

    if (mode == RTCORE_MODE_VENT) {
        s->integrator_kpa = 0.0;
        s->derivative_deg_per_s = 0.0;
    } else if (mode == RTCORE_MODE_PRESSURE) {
        const rtcore_limited lim = rtcore_limit_command(c, s->pressure_ref_kpa, previous_kpa, dt_s,
                                                        0.0, 0.0, 0.0);
        s->integrator_kpa = 0.0;
        s->derivative_deg_per_s = 0.0;
        feedforward_kpa = s->pressure_ref_kpa;
        command_kpa = lim.command_kpa;
        flags |= lim.flags;
    } else {
        double error;
        double proportional_kpa;
        double derivative_kpa = 0.0;
        double integrator_new_kpa;
        double integral_gain;
        rtcore_limited lim;

        if (mode == RTCORE_MODE_POSITION) {
            const double rate_error = s->velocity_ref_deg_per_s - s->velocity_deg_per_s;
            rtcore_creep_reference_update(c, s, changed, dt_s);
            rtcore_hysteresis_reference_update(c, s, changed);
            feedforward_kpa = rtcore_position_feedforward_kpa(c, s);
            error = s->angle_ref_deg - s->angle_filt_deg;
            proportional_kpa = c->kp_kpa_per_deg * error;
            s->derivative_deg_per_s = changed ? rate_error
                                              : s->derivative_alpha * s->derivative_deg_per_s
                                                    + (1.0 - s->derivative_alpha) * rate_error;
            derivative_kpa = c->kd_kpa_s_per_deg * s->derivative_deg_per_s;
            integral_gain = c->ki_kpa_per_deg_s;
        } else {
            /* force, or impedance: force control on a virtual spring and damper's force */
            const double force_ref_n =
                mode == RTCORE_MODE_FORCE
                    ? s->force_ref_n
                    : s->impedance_stiffness_n_per_deg * (s->angle_ref_deg - s->angle_filt_deg)
                          + s->impedance_damping_n_s_per_deg
                                * (s->velocity_ref_deg_per_s - s->velocity_deg_per_s);
            double torque_rate_nm_per_s = 0.0;
            double integral_share = 1.0;
            if (mode == RTCORE_MODE_IMPEDANCE) {
                /* the valve lags the feedforward's spring k th and virtual spring
                 * r K (th_ref - th); the force PI's integrator turns the lag's error into a
                 * stiffness error (k / (r K) - 1) times the lag's share, large at a small K.
                 * The lead takes the rate of the spring's part beyond 2 r K (nothing at
                 * K_max: the lag's damping stays there), at most IMPEDANCE_LEAD_MAX_SHARE of
                 * k, and the reference's rate (docs/replicate.md) */
                const double virtual_nm_per_deg = c->prbm.lever_arm_m * s->impedance_stiffness_n_per_deg;
                const double spring_nm_per_deg = rtcore_model_stiffness_nm_per_rad(&c->prbm, angle_rad) * RTCORE_RAD_PER_DEG;
                const double led_nm_per_deg =
                    fmin(fmax(spring_nm_per_deg - 2.0 * virtual_nm_per_deg, 0.0), IMPEDANCE_LEAD_MAX_SHARE * spring_nm_per_deg);
                torque_rate_nm_per_s =
                    led_nm_per_deg * s->velocity_deg_per_s + virtual_nm_per_deg * s->velocity_ref_deg_per_s;
                /* the integrator turns the lag's velocity error, (V - 1)(k - r K) th, into a
                 * stiffness error of T ki' (k / (r K) - 1) / (1 + kp')^2 of K above its corner
                 * ki' / (1 + kp') (ki' = N ki / r, T the lag): a dip in the band at a small K.
                 * Below K_max (r K < k / 2) the integral gain falls as (2 r K / k)^3, a power
                 * measured: 1 holds that error at K_max's but leaves the dip at 0.2 Hz; at a
                 * stiff wall the gain only lowers (docs/replicate.md) */
                if (spring_nm_per_deg > 2.0 * virtual_nm_per_deg) {
                    const double below = 2.0 * virtual_nm_per_deg / spring_nm_per_deg;
                    integral_share = below * below * below;
                }
            }
            s->derivative_deg_per_s = 0.0;
            feedforward_kpa = rtcore_force_feedforward_kpa(c, angle_rad, force_ref_n, loop_z, torque_rate_nm_per_s);
            error = force_ref_n - force_n;
            proportional_kpa = c->force_kp_kpa_per_n * error;
            integral_gain = c->force_ki_kpa_per_n_s * integral_share;
        }
        if (changed) {
            /* bumpless: between active modes the integrator takes up the difference so
             * the command is continuous; out of VENT it starts empty and the rate limit
             * ramps the command up from 0 kPa */
            s->integrator_kpa = previous_mode == RTCORE_MODE_VENT
                                    ? 0.0
                                    : clamp_symmetric(previous_kpa - feedforward_kpa
                                                          - proportional_kpa - derivative_kpa,
                                                      c->integrator_limit_kpa);
        }
        integrator_new_kpa = s->integrator_kpa + integral_gain * error * dt_s;
        pid_kpa = proportional_kpa + integrator_new_kpa + derivative_kpa;
        lim = rtcore_limit_command(c, feedforward_kpa + pid_kpa, previous_kpa, dt_s, error,
                                   s->integrator_kpa, integrator_new_kpa);
        s->integrator_kpa = lim.integrator_kpa;
        command_kpa = lim.command_kpa;
        flags |= lim.flags;
    }

    if (!isfinite(command_kpa) || !isfinite(s->integrator_kpa)
        || !isfinite(s->derivative_deg_per_s) || !isfinite(feedforward_kpa)
        || !isfinite(pid_kpa)) {
        command_kpa = 0.0;
        feedforward_kpa = 0.0;
        pid_kpa = 0.0;
        s->integrator_kpa = 0.0;
        s->derivative_deg_per_s = 0.0;
        flags |= (uint32_t)RTCORE_FLAG_OUTPUT_REJECTED;
    }
    s->pressure_cmd_kpa = command_kpa;

    out->pressure_cmd_kpa[i] = command_kpa;
    out->angle_deg[i] = angle_deg;
    out->angle_filt_deg[i] = s->angle_filt_deg;
    out->velocity_deg_per_s[i] = s->velocity_deg_per_s;
    out->accel_deg_per_s2[i] = s->accel_deg_per_s2;
    out->feedforward_kpa[i] = feedforward_kpa;
    out->pid_kpa[i] = pid_kpa;
    out->chamber_pressure_kpa[i] = chamber_kpa;
    out->force_normal_n[i] = force_n;
    out->force_est_x_n[i] = -force_n * sin(angle_rad);
    out->force_est_y_n[i] = force_n * cos(angle_rad);
    out->force_magnitude_n[i] = fabs(force_n);
    out->flags[i] = flags;
    return flags;
}

uint32_t rtcore_hand_step(rtcore_hand *hand, const rtcore_inputs *in, rtcore_outputs *out)
{
    uint32_t all_flags = 0u;
    int32_t i;

    if (hand == 0 || in == 0 || out == 0) {
        return (uint32_t)RTCORE_FLAG_NOT_CONFIGURED;
    }
    if (!hand->configured) {
        for (i = 0; i < RTCORE_MAX_FINGERS; ++i) {
            out->pressure_cmd_kpa[i] = 0.0;
            out->flags[i] = (uint32_t)RTCORE_FLAG_NOT_CONFIGURED;
        }
        return (uint32_t)RTCORE_FLAG_NOT_CONFIGURED;
    }
    for (i = 0; i < hand->config.n_fingers; ++i) {
        all_flags |= step_finger(hand, i, in, out);
    }
    hand->ticks += 1u;
    return all_flags;
}
