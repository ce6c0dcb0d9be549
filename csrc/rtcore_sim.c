/* The simulated hand: PRBM dynamics with the shared torque model, the valve (lag behind
 * a dead time, integrated exactly), an optional object, and the flex sensor. */
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

/* normal force of the object on the finger at the force point (>= 0, pushes back) */
static double contact_force_n(const rtcore_sim_finger *f, double angle_rad, double velocity_rad_per_s)
{
    double depth_m;
    double force_n;
    if (f->contact_stiffness_n_per_m <= 0.0) {
        return 0.0;
    }
    depth_m = f->prbm.lever_arm_m * (angle_rad - f->contact_angle_deg * RTCORE_RAD_PER_DEG);
    if (depth_m <= 0.0) {
        return 0.0;
    }
    force_n = f->contact_stiffness_n_per_m * depth_m
              + f->contact_damping_ns_per_m * f->prbm.lever_arm_m * velocity_rad_per_s;
    return force_n > 0.0 ? force_n : 0.0;
}

/* angular acceleration: (N p_eff - B w - tau(th, w) - r F_contact) / A */
static double acceleration(const rtcore_sim_finger *f, double angle_rad, double velocity_rad_per_s,
                           double chamber_kpa)
{
    const rtcore_prbm *m = &f->prbm;
    const double torque = m->pressure_gain_nm_per_kpa
                              * rtcore_effective_pressure_kpa(&m->effects, chamber_kpa)
                          - m->damping_nms_per_rad * velocity_rad_per_s
                          - rtcore_model_torque_nm(m, angle_rad, velocity_rad_per_s)
                          - m->lever_arm_m * contact_force_n(f, angle_rad, velocity_rad_per_s);
    return torque / m->inertia_kgm2;
}

/* Integrate over duration_s with the valve input held at input_kpa: the chamber follows
 * its exact first-order solution, the finger RK4 in n_steps equal steps. */
static void integrate_segment(const rtcore_sim_finger *f, rtcore_sim_finger_state *s,
                              double input_kpa, double duration_s, int32_t n_steps)
{
    const double h = duration_s / (double)n_steps;
    const double tau_s = f->prbm.effects.valve_lag_tau_s;
    const double decay_half = tau_s > 0.0 ? exp(-0.5 * h / tau_s) : 0.0;
    int32_t k;

    for (k = 0; k < n_steps; ++k) {
        const double p0 = tau_s > 0.0 ? s->chamber_kpa : input_kpa; /* no lag: at once */
        const double p_half = input_kpa + (p0 - input_kpa) * decay_half;
        const double p_end = input_kpa + (p0 - input_kpa) * decay_half * decay_half;
        const double th = s->angle_rad;
        const double w = s->velocity_rad_per_s;
        const double a1 = acceleration(f, th, w, p0);
        const double th2 = th + 0.5 * h * w;
        const double w2 = w + 0.5 * h * a1;
        const double a2 = acceleration(f, th2, w2, p_half);
        const double th3 = th + 0.5 * h * w2;
        const double w3 = w + 0.5 * h * a2;
        const double a3 = acceleration(f, th3, w3, p_half);
        const double th4 = th + h * w3;
        const double w4 = w + h * a3;
        const double a4 = acceleration(f, th4, w4, p_end);
        s->angle_rad = th + h / 6.0 * (w + 2.0 * w2 + 2.0 * w3 + w4);
        s->velocity_rad_per_s = w + h / 6.0 * (a1 + 2.0 * a2 + 2.0 * a3 + a4);
        s->chamber_kpa = p_end;
    }
}

static int32_t steps_for(double duration_s, double step_s)
{
    const double n = ceil(duration_s / step_s - 1e-9);
    return n < 1.0 ? 1 : (int32_t)n;
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
 * inside the period, where the older command gives way to the newer one. */
static void advance_sample(const rtcore_sim_finger *f, rtcore_sim_finger_state *s, double command_kpa,
                           double dt_s, int32_t substeps)
{
    const double nominal_step_s = dt_s / (double)substeps;
    const double step_s = s->max_step_s < nominal_step_s ? s->max_step_s : nominal_step_s;
    s->head = (s->head + 1) % RTCORE_SIM_HISTORY;
    s->command_kpa[s->head] = saturate(f, command_kpa);
    if (s->delay_fraction > 0.0) {
        const double first_s = s->delay_fraction * dt_s;
        integrate_segment(f, s, delayed_command(s, s->delay_samples + 1), first_s,
                          steps_for(first_s, step_s));
        integrate_segment(f, s, delayed_command(s, s->delay_samples), dt_s - first_s,
                          steps_for(dt_s - first_s, step_s));
    } else {
        integrate_segment(f, s, delayed_command(s, s->delay_samples), dt_s, steps_for(dt_s, step_s));
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

/* The fastest rate in the finger's linearised dynamics, |λ| <= c/A + sqrt(K/A), where c
 * gathers every damping-like slope (viscous, dry friction's tanh slope Tc/ω_s near zero
 * velocity, the contact damper) and K every stiffness (the finger's, the contact's).
 * RK4 with h·|λ| <= 1 follows that mode closely (its amplification 0.375 for e^-1 =
 * 0.368); with the 2 deg/s friction smoothing a large Tc needs steps well under 1 ms. */
static double accurate_step_s(const rtcore_sim_finger *f)
{
    const rtcore_prbm *m = &f->prbm;
    const double r2 = m->lever_arm_m * m->lever_arm_m;
    const double ratio = m->effects.asymmetric_stiffness_ratio > 1.0 ? m->effects.asymmetric_stiffness_ratio
                                                                     : 1.0;
    double damping = m->damping_nms_per_rad + f->contact_damping_ns_per_m * r2;
    const double stiffness = m->stiffness_nm_per_rad * ratio + f->contact_stiffness_n_per_m * r2;
    if (m->effects.coulomb_torque_nm > 0.0) {
        damping += m->effects.coulomb_torque_nm
                   / (m->effects.coulomb_smoothing_deg_per_s * RTCORE_RAD_PER_DEG);
    }
    return 1.0 / (damping / m->inertia_kgm2 + sqrt(stiffness / m->inertia_kgm2));
}

static int32_t prepare_state(const rtcore_sim_finger *f, rtcore_sim_finger_state *s, double dt_s)
{
    const double delay = f->prbm.effects.dead_time_s / dt_s;
    s->max_step_s = accurate_step_s(f);
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
        advance_sample(&sim->config.finger[i], &sim->finger[i], pressure_cmd_kpa[i], sim->dt_s,
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
    for (k = 0; k + 1 < n_samples; ++k) {
        advance_sample(finger, &s, pressure_cmd_kpa[k], dt_s, substeps);
        angle_out_deg[k + 1] = s.angle_rad * RTCORE_DEG_PER_RAD;
        if (chamber_out_kpa != 0) {
            chamber_out_kpa[k + 1] = s.chamber_kpa;
        }
    }
    return RTCORE_OK;
}
