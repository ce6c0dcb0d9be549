/* Configuration and reset of the hand, and the names of configuration errors. */
#include <math.h>
#include <string.h>

#include "rtcore_internal.h"
#include "rtcore_step.h"

static int finite_at_least(double x, double lowest)
{
    return isfinite(x) && x >= lowest;
}

static int finite_above(double x, double lowest)
{
    return isfinite(x) && x > lowest;
}

static int32_t validate_finger(const rtcore_finger_config *c, double sample_rate_hz)
{
    rtcore_biquad sections[RTCORE_MAX_SECTIONS];
    int32_t n_sections;

    if (!isfinite(c->sensor_gain_deg_per_mv) || c->sensor_gain_deg_per_mv == 0.0
        || !isfinite(c->sensor_offset_deg)) {
        return RTCORE_ERR_SENSOR;
    }
    n_sections = rtcore_butter_sections(sections, RTCORE_MAX_SECTIONS, c->filter_order,
                                        c->filter_cutoff_hz, sample_rate_hz);
    if (n_sections < 0) {
        return n_sections;
    }
    if (!finite_above(c->velocity_cutoff_hz, 0.0)) {
        return RTCORE_ERR_VELOCITY_CUTOFF;
    }
    if (!finite_at_least(c->prbm.inertia_kgm2, 0.0) || !finite_at_least(c->prbm.damping_nms_per_rad, 0.0)
        || !finite_above(c->prbm.stiffness_nm_per_rad, 0.0)
        || !finite_above(c->prbm.pressure_gain_nm_per_kpa, 0.0)
        || !finite_above(c->prbm.lever_arm_m, 0.0)) {
        return RTCORE_ERR_MODEL;
    }
    if (!rtcore_effects_valid(&c->prbm.effects)) {
        return RTCORE_ERR_EFFECTS;
    }
    if (c->feedforward < RTCORE_FF_NONE || c->feedforward > RTCORE_FF_DYNAMIC
        || (c->force_estimate_dynamic != 0 && c->force_estimate_dynamic != 1)
        || (c->force_estimate_hysteresis != 0 && c->force_estimate_hysteresis != 1)) {
        return RTCORE_ERR_FEEDFORWARD;
    }
    if (!finite_at_least(c->kp_kpa_per_deg, 0.0) || !finite_at_least(c->ki_kpa_per_deg_s, 0.0)
        || !finite_at_least(c->kd_kpa_s_per_deg, 0.0)
        || !finite_above(c->derivative_cutoff_hz, 0.0)
        || !finite_at_least(c->integrator_limit_kpa, 0.0)
        || !finite_at_least(c->force_kp_kpa_per_n, 0.0)
        || !finite_at_least(c->force_ki_kpa_per_n_s, 0.0)) {
        return RTCORE_ERR_GAINS;
    }
    if (!isfinite(c->pressure_min_kpa) || !isfinite(c->pressure_max_kpa)
        || c->pressure_min_kpa > c->pressure_max_kpa
        || fabs(c->pressure_min_kpa) > RTCORE_SANE_LIMIT
        || fabs(c->pressure_max_kpa) > RTCORE_SANE_LIMIT
        || !finite_above(c->pressure_rate_max_kpa_per_s, 0.0)) {
        return RTCORE_ERR_PRESSURE_LIMITS;
    }
    return RTCORE_OK;
}

void rtcore_finger_reset(rtcore_hand *hand, int32_t finger)
{
    rtcore_finger_state *s;
    int32_t k;

    if (hand == 0 || finger < 0 || finger >= RTCORE_MAX_FINGERS) {
        return;
    }
    s = &hand->finger[finger];
    for (k = 0; k < RTCORE_MAX_SECTIONS; ++k) {
        s->section[k].z1 = 0.0;
        s->section[k].z2 = 0.0;
    }
    s->filter_primed = 0;
    s->mode = RTCORE_MODE_VENT;
    s->last_good_mv = s->rest_mv;
    s->angle_filt_deg = 0.0;
    s->velocity_deg_per_s = 0.0;
    s->accel_deg_per_s2 = 0.0;
    s->integrator_kpa = 0.0;
    s->derivative_deg_per_s = 0.0;
    s->pressure_cmd_kpa = 0.0;
    s->chamber_model_kpa = 0.0;
    s->angle_ref_deg = 0.0;
    s->velocity_ref_deg_per_s = 0.0;
    s->accel_ref_deg_per_s2 = 0.0;
    s->jerk_ref_deg_per_s3 = 0.0;
    s->force_ref_n = 0.0;
    s->pressure_ref_kpa = 0.0;
    s->impedance_stiffness_n_per_deg = 0.0;
    s->impedance_damping_n_s_per_deg = 0.0;
    s->creep_ref_deg = 0.0;
    s->hysteresis_ref_z = 0.0;
    s->hysteresis_ref_angle_deg = 0.0;
    s->hysteresis_z = 0.0;
    s->hysteresis_angle_deg = NAN;
}

void rtcore_hand_reset(rtcore_hand *hand)
{
    int32_t i;
    if (hand == 0) {
        return;
    }
    for (i = 0; i < RTCORE_MAX_FINGERS; ++i) {
        rtcore_finger_reset(hand, i);
    }
    hand->ticks = 0u;
}

/* a first-order lag's factor per tick of dt_s (0 for no lag) */
static double lag_alpha(double tau_s, double dt_s)
{
    return tau_s > 0.0 ? exp(-dt_s / tau_s) : 0.0;
}

int32_t rtcore_hand_configure(rtcore_hand *hand, const rtcore_hand_config *config)
{
    int32_t i;
    double dt_s;

    if (hand == 0 || config == 0) {
        return RTCORE_ERR_NULL;
    }
    hand->configured = 0;
    hand->error_finger = -1;
    if (config->n_fingers < 1 || config->n_fingers > RTCORE_MAX_FINGERS) {
        return RTCORE_ERR_FINGER_COUNT;
    }
    if (!finite_above(config->sample_rate_hz, 0.0) || config->sample_rate_hz > 1.0e5) {
        return RTCORE_ERR_SAMPLE_RATE;
    }
    for (i = 0; i < config->n_fingers; ++i) {
        const int32_t err = validate_finger(&config->finger[i], config->sample_rate_hz);
        if (err != RTCORE_OK) {
            hand->error_finger = i;
            return err;
        }
    }
    memcpy(&hand->config, config, sizeof(*config));
    dt_s = 1.0 / config->sample_rate_hz;
    hand->dt_s = dt_s;
    for (i = 0; i < config->n_fingers; ++i) {
        const rtcore_finger_config *c = &hand->config.finger[i];
        rtcore_finger_state *s = &hand->finger[i];

        s->n_sections = rtcore_butter_sections(s->section, RTCORE_MAX_SECTIONS, c->filter_order,
                                               c->filter_cutoff_hz, config->sample_rate_hz);
        s->velocity_alpha = rtcore_first_order_alpha(c->velocity_cutoff_hz, dt_s);
        s->derivative_alpha = rtcore_first_order_alpha(c->derivative_cutoff_hz, dt_s);
        s->chamber_alpha = lag_alpha(rtcore_valve_tau_s(&c->prbm.effects, 1.0), dt_s);
        s->chamber_vent_alpha = lag_alpha(rtcore_valve_tau_s(&c->prbm.effects, -1.0), dt_s);
        s->rest_mv = -c->sensor_offset_deg / c->sensor_gain_deg_per_mv;
    }
    rtcore_hand_reset(hand);
    hand->configured = 1;
    return RTCORE_OK;
}

const char *rtcore_error_name(int32_t code)
{
    switch (code) {
    case RTCORE_OK: return "ok";
    case RTCORE_ERR_NULL: return "null pointer";
    case RTCORE_ERR_FINGER_COUNT: return "finger count must be 1 to 8";
    case RTCORE_ERR_SAMPLE_RATE: return "sample rate must be positive and at most 100 kHz";
    case RTCORE_ERR_FILTER_ORDER: return "filter order must be 2 or 4";
    case RTCORE_ERR_FILTER_CUTOFF: return "filter cutoff must lie between 0 and half the sample rate";
    case RTCORE_ERR_VELOCITY_CUTOFF: return "velocity cutoff must be positive";
    case RTCORE_ERR_SENSOR: return "sensor calibration must be finite with a non-zero gain";
    case RTCORE_ERR_MODEL: return "model: inertia and damping >= 0; stiffness, pressure gain and lever arm > 0";
    case RTCORE_ERR_GAINS: return "controller gains, limits and the derivative cutoff must be finite and non-negative";
    case RTCORE_ERR_PRESSURE_LIMITS: return "pressure limits: min <= max and a positive rate limit";
    case RTCORE_ERR_EFFECTS: return "effects: parameters out of range";
    case RTCORE_ERR_FEEDFORWARD: return "feedforward must be none, quasi-static or dynamic";
    default: return "unknown error";
    }
}
