/* The simulated hand: PRBM dynamics with the shared torque model (its linear part exact,
 * dry friction's slope linearised into it step by step, the rest by ETDRK4), the valve (lag
 * behind a dead time, integrated exactly), an optional object, and the flex sensor. This
 * unit: the random numbers, the configuration and the public functions of rtcore_sim.h. It
 * calls down: a sample period's valve in rtcore_sim_advance.c (rtcore_sim_advance.h), the
 * finger's dynamics in rtcore_sim_plant.c (rtcore_sim_plant.h), their step sizes in
 * rtcore_sim_step_size.c, what those share in rtcore_sim_internal.h. */
#include <math.h>
#include <string.h>

#include "rtcore_exact.h"
#include "rtcore_internal.h"
#include "rtcore_sim.h"
#include "rtcore_sim_advance.h"
#include "rtcore_sim_internal.h"

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

/* ---- configuration ----------------------------------------------------------------- */

static int32_t validate_sim_finger(const rtcore_sim_finger *f)
{
    const int32_t err = rtcore_sim_dynamics_valid(f);
    if (err != RTCORE_OK) {
        return err;
    }
    if (!rtcore_pneumatic_valid(&f->pneumatic)) {
        return RTCORE_ERR_MODEL;
    }
    if (!isfinite(f->supply_min_kpa) || !isfinite(f->supply_max_kpa)
        || f->supply_min_kpa > f->supply_max_kpa) {
        return RTCORE_ERR_PRESSURE_LIMITS;
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
    s->delay_samples = (int32_t)floor(delay);
    s->delay_fraction = delay - floor(delay);
    if (s->delay_samples + 2 >= RTCORE_SIM_HISTORY) {
        return RTCORE_ERR_SIM_HISTORY;
    }
    return RTCORE_OK;
}

/* the finger at rest or where it was placed, its dead time's history full of chamber_kpa
 * (the finger was validated: rtcore_sim_motion_start accepts it) */
static void place(const rtcore_sim_finger *f, rtcore_sim_finger_state *s, double angle_deg,
                  double velocity_deg_per_s, double chamber_kpa)
{
    int32_t k;
    (void)rtcore_sim_motion_start(f, &s->motion, 0, angle_deg, velocity_deg_per_s, chamber_kpa);
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
        place(&config->finger[i], &sim->finger[i], 0.0, 0.0, 0.0);
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
    place(&sim->config.finger[finger], s, angle_deg, velocity_deg_per_s, chamber_kpa);
    s->contact_force_n = rtcore_sim_contact_force_n(&sim->config.finger[finger], s->motion.angle_rad,
                                                    s->motion.velocity_rad_per_s);
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
        const double angle_deg = s->motion.angle_rad * RTCORE_DEG_PER_RAD;
        double mv = (angle_deg + f->sensor_noise_deg * next_gaussian(sim) - f->sensor_offset_deg)
                    / f->sensor_gain_deg_per_mv;
        if (f->adc_step_mv > 0.0) {
            mv = f->adc_step_mv * floor(mv / f->adc_step_mv + 0.5);
        }
        out->sensor_mv[i] = mv;
        out->pressure_meas_kpa[i] = s->motion.chamber_kpa + f->pressure_noise_kpa * next_gaussian(sim);
        out->angle_deg[i] = angle_deg;
        out->velocity_deg_per_s[i] = s->motion.velocity_rad_per_s * RTCORE_DEG_PER_RAD;
        out->chamber_pressure_kpa[i] = s->motion.chamber_kpa;
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
        sim_plant plant;
        cache.count = 0;
        cache.next = 0;
        rtcore_sim_plant_for(&sim->config.finger[i], &plant);
        rtcore_sim_advance_sample(&plant, &sim->finger[i], &cache, pressure_cmd_kpa[i], sim->dt_s,
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
    sim_plant plant;
    sim_span span;
    int32_t spans;
    double dt_s;
    int32_t err;
    int32_t k;

    if (finger == 0 || pressure_cmd_kpa == 0 || angle_out_deg == 0) {
        return RTCORE_ERR_NULL;
    }
    if (!(isfinite(sample_rate_hz) && sample_rate_hz > 0.0) || substeps < 0 || substeps > 10000
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
    place(finger, &s, angle0_deg, velocity0_deg_per_s, chamber0_kpa);
    angle_out_deg[0] = angle0_deg;
    if (chamber_out_kpa != 0) {
        chamber_out_kpa[0] = chamber0_kpa;
    }
    cache.count = 0;
    cache.next = 0;
    rtcore_sim_plant_for(finger, &plant); /* the finger's alone: once for the whole run */
    spans = substeps == 0 && rtcore_sim_span_eligible(&plant);
    memset(span.has, 0, sizeof span.has);
    span.dt_s = dt_s;
    span.damping_nms_per_rad = plant.linear.damping_nms_per_rad;
    for (k = 0; k + 1 < n_samples;) {
        double held_kpa = 0.0;
        const int32_t count = spans ? rtcore_sim_held_samples(finger, &s, pressure_cmd_kpa + k, n_samples - 1 - k,
                                                              &held_kpa)
                                    : 0;
        if (count >= 2) {
            span.angle_out_deg = angle_out_deg + k + 1;
            rtcore_sim_advance_span(&plant, &s, &cache, &span, pressure_cmd_kpa + k, count, held_kpa,
                                    chamber_out_kpa != 0 ? chamber_out_kpa + k + 1 : 0);
            k += count;
            continue;
        }
        rtcore_sim_advance_sample(&plant, &s, &cache, pressure_cmd_kpa[k], dt_s, substeps > 0 ? substeps : 1);
        angle_out_deg[k + 1] = s.motion.angle_rad * RTCORE_DEG_PER_RAD;
        if (chamber_out_kpa != 0) {
            chamber_out_kpa[k + 1] = s.motion.chamber_kpa;
        }
        k += 1;
    }
    return RTCORE_OK;
}
