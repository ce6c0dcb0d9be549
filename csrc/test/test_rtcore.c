/*
 * Plain-C tests of the rtcore step. Built and run by tests/test_c_driver.py, once with
 * -O2 and once with -fsanitize=address,undefined. Exit status 0 when every check holds.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "../rtcore.h"

static int failures = 0;
static int checks = 0;

#define CHECK(cond, ...)                                                  \
    do {                                                                  \
        ++checks;                                                         \
        if (!(cond)) {                                                    \
            ++failures;                                                   \
            fprintf(stderr, "FAIL %s:%d: %s: ", __FILE__, __LINE__, #cond); \
            fprintf(stderr, __VA_ARGS__);                                 \
            fprintf(stderr, "\n");                                        \
        }                                                                 \
    } while (0)

#define PI 3.14159265358979323846

/* xorshift64*: deterministic, no global state */
static double uniform(uint64_t *s)
{
    *s ^= *s >> 12;
    *s ^= *s << 25;
    *s ^= *s >> 27;
    return (double)((*s * 2685821657736338717ULL) >> 11) / 9007199254740992.0;
}

/* the index finger of physics.md */
static rtcore_finger_config index_finger(void)
{
    rtcore_finger_config c;
    memset(&c, 0, sizeof(c));
    c.sensor_gain_deg_per_mv = 0.1;
    c.sensor_offset_deg = -5.0;
    c.filter_order = 2;
    c.filter_cutoff_hz = 25.0;
    c.velocity_cutoff_hz = 25.0;
    c.inertia_kgm2 = 1.617e-4;
    c.damping_nms_per_rad = 0.0031;
    c.stiffness_nm_per_rad = 0.570;
    c.pressure_gain_nm_per_kpa = 8.954e-3;
    c.lever_arm_m = 0.040375;
    c.effects.asymmetric_stiffness_ratio = 1.0;
    c.effects.coulomb_smoothing_deg_per_s = 2.0;
    c.feedforward = RTCORE_FF_DYNAMIC;
    c.kp_kpa_per_deg = 0.2;
    c.ki_kpa_per_deg_s = 2.0;
    c.kd_kpa_s_per_deg = 0.0;
    c.derivative_cutoff_hz = 10.0;
    c.integrator_limit_kpa = 50.0;
    c.force_kp_kpa_per_n = 2.0;
    c.force_ki_kpa_per_n_s = 20.0;
    c.pressure_min_kpa = 0.0;
    c.pressure_max_kpa = 200.0;
    c.pressure_rate_max_kpa_per_s = 2000.0;
    return c;
}

static rtcore_hand_config one_finger(void)
{
    rtcore_hand_config h;
    memset(&h, 0, sizeof(h));
    h.n_fingers = 1;
    h.sample_rate_hz = 100.0;
    h.finger[0] = index_finger();
    return h;
}

static void clear_inputs(rtcore_inputs *in)
{
    int i;
    memset(in, 0, sizeof(*in));
    for (i = 0; i < RTCORE_MAX_FINGERS; ++i) {
        in->pressure_meas_kpa[i] = NAN;
        in->sensor_mv[i] = 50.0; /* 0 deg with the calibration above */
    }
}

static double mv_for_deg(const rtcore_finger_config *c, double deg)
{
    return (deg - c->sensor_offset_deg) / c->sensor_gain_deg_per_mv;
}

static void test_butter_design(void)
{
    double sos[12];
    int32_t n;
    int k;
    n = rtcore_butter_design(4, 20.0, 100.0, sos, 2);
    CHECK(n == 2, "n=%d", (int)n);
    for (k = 0; k < n; ++k) {
        const double dc = (sos[6 * k] + sos[6 * k + 1] + sos[6 * k + 2])
                          / (1.0 + sos[6 * k + 4] + sos[6 * k + 5]);
        CHECK(fabs(dc - 1.0) < 1e-12, "section %d dc gain %g", k, dc);
    }
    CHECK(rtcore_butter_design(3, 20.0, 100.0, sos, 2) == RTCORE_ERR_FILTER_ORDER, "order 3");
    CHECK(rtcore_butter_design(2, 50.0, 100.0, sos, 2) == RTCORE_ERR_FILTER_CUTOFF, "at Nyquist");
    CHECK(rtcore_butter_design(2, NAN, 100.0, sos, 2) == RTCORE_ERR_FILTER_CUTOFF, "NaN cutoff");
    CHECK(rtcore_butter_design(2, 10.0, -1.0, sos, 2) == RTCORE_ERR_SAMPLE_RATE, "negative rate");
    CHECK(rtcore_butter_design(4, 10.0, 100.0, sos, 1) == RTCORE_ERR_FILTER_ORDER, "no room");
    CHECK(rtcore_butter_design(2, 10.0, 100.0, 0, 1) == RTCORE_ERR_NULL, "null");
}

static void test_configure_rejects(void)
{
    rtcore_hand hand;
    rtcore_hand_config h;
    rtcore_inputs in;
    rtcore_outputs out;

    h = one_finger();
    h.n_fingers = 9;
    CHECK(rtcore_hand_configure(&hand, &h) == RTCORE_ERR_FINGER_COUNT, "9 fingers");
    h = one_finger();
    h.sample_rate_hz = INFINITY;
    CHECK(rtcore_hand_configure(&hand, &h) == RTCORE_ERR_SAMPLE_RATE, "inf rate");
    h = one_finger();
    h.finger[0].sensor_gain_deg_per_mv = 0.0;
    CHECK(rtcore_hand_configure(&hand, &h) == RTCORE_ERR_SENSOR, "zero gain");
    CHECK(hand.error_finger == 0, "error finger %d", (int)hand.error_finger);
    h = one_finger();
    h.finger[0].pressure_gain_nm_per_kpa = 0.0;
    CHECK(rtcore_hand_configure(&hand, &h) == RTCORE_ERR_MODEL, "zero N");
    h = one_finger();
    h.finger[0].kp_kpa_per_deg = NAN;
    CHECK(rtcore_hand_configure(&hand, &h) == RTCORE_ERR_GAINS, "NaN kp");
    h = one_finger();
    h.finger[0].pressure_min_kpa = 10.0;
    h.finger[0].pressure_max_kpa = 5.0;
    CHECK(rtcore_hand_configure(&hand, &h) == RTCORE_ERR_PRESSURE_LIMITS, "min > max");
    h = one_finger();
    h.finger[0].effects.asymmetric_stiffness_ratio = 0.0;
    CHECK(rtcore_hand_configure(&hand, &h) == RTCORE_ERR_EFFECTS, "ratio 0");
    h = one_finger();
    h.finger[0].feedforward = 7;
    CHECK(rtcore_hand_configure(&hand, &h) == RTCORE_ERR_FEEDFORWARD, "ff 7");
    CHECK(rtcore_hand_configure(0, &h) == RTCORE_ERR_NULL, "null hand");
    CHECK(strlen(rtcore_error_name(RTCORE_ERR_MODEL)) > 0, "error name");

    /* an unconfigured hand vents */
    clear_inputs(&in);
    in.mode[0] = RTCORE_MODE_PRESSURE;
    in.pressure_ref_kpa[0] = 100.0;
    CHECK(rtcore_hand_step(&hand, &in, &out) == RTCORE_FLAG_NOT_CONFIGURED, "not configured");
    CHECK(out.pressure_cmd_kpa[0] == 0.0, "vented");
}

static void test_limits(void)
{
    rtcore_hand hand;
    rtcore_hand_config h = one_finger();
    rtcore_inputs in;
    rtcore_outputs out;
    int t;
    uint32_t flags;

    CHECK(rtcore_hand_configure(&hand, &h) == RTCORE_OK, "configure");
    clear_inputs(&in);
    in.mode[0] = RTCORE_MODE_PRESSURE;
    in.pressure_ref_kpa[0] = 150.0;
    flags = rtcore_hand_step(&hand, &in, &out);
    /* 2000 kPa/s at 100 Hz: 20 kPa per tick from 0 */
    CHECK(fabs(out.pressure_cmd_kpa[0] - 20.0) < 1e-12, "rate limit %g", out.pressure_cmd_kpa[0]);
    CHECK(flags & RTCORE_FLAG_RATE_LIMITED, "rate flag");
    for (t = 0; t < 20; ++t) {
        rtcore_hand_step(&hand, &in, &out);
    }
    CHECK(fabs(out.pressure_cmd_kpa[0] - 150.0) < 1e-12, "reaches ref %g", out.pressure_cmd_kpa[0]);
    in.pressure_ref_kpa[0] = 500.0;
    for (t = 0; t < 20; ++t) {
        flags = rtcore_hand_step(&hand, &in, &out);
    }
    CHECK(out.pressure_cmd_kpa[0] == 200.0, "saturates at max %g", out.pressure_cmd_kpa[0]);
    CHECK(flags & RTCORE_FLAG_SATURATED, "saturation flag");
    in.mode[0] = RTCORE_MODE_VENT;
    rtcore_hand_step(&hand, &in, &out);
    CHECK(out.pressure_cmd_kpa[0] == 0.0, "vent is immediate");
}

static void test_anti_windup(void)
{
    rtcore_hand hand;
    rtcore_hand_config h = one_finger();
    rtcore_inputs in;
    rtcore_outputs out;
    int t;

    h.finger[0].pressure_max_kpa = 20.0; /* far too little to reach 90 deg */
    h.finger[0].integrator_limit_kpa = 1000.0;
    CHECK(rtcore_hand_configure(&hand, &h) == RTCORE_OK, "configure");
    clear_inputs(&in);
    in.mode[0] = RTCORE_MODE_POSITION;
    in.angle_ref_deg[0] = 90.0;
    for (t = 0; t < 1000; ++t) {
        rtcore_hand_step(&hand, &in, &out);
    }
    CHECK(out.pressure_cmd_kpa[0] == 20.0, "held at max");
    CHECK(out.flags[0] & RTCORE_FLAG_INTEGRATOR_HELD, "integrator held");
    CHECK(fabs(hand.finger[0].integrator_kpa) < 1.0, "no windup: %g", hand.finger[0].integrator_kpa);
    /* reverse the error: the command leaves saturation on the next tick */
    in.angle_ref_deg[0] = 0.0;
    rtcore_hand_step(&hand, &in, &out);
    CHECK(out.pressure_cmd_kpa[0] < 20.0, "recovers at once: %g", out.pressure_cmd_kpa[0]);
}

static void test_nan_inputs(void)
{
    rtcore_hand hand;
    rtcore_hand_config h = one_finger();
    rtcore_inputs in;
    rtcore_outputs out;
    double held;
    int t;

    CHECK(rtcore_hand_configure(&hand, &h) == RTCORE_OK, "configure");
    clear_inputs(&in);
    in.mode[0] = RTCORE_MODE_POSITION;
    in.sensor_mv[0] = mv_for_deg(&h.finger[0], 30.0);
    in.angle_ref_deg[0] = 30.0;
    for (t = 0; t < 50; ++t) {
        rtcore_hand_step(&hand, &in, &out);
    }
    held = out.angle_filt_deg[0];
    in.sensor_mv[0] = NAN;
    in.angle_ref_deg[0] = INFINITY;
    rtcore_hand_step(&hand, &in, &out);
    CHECK(out.flags[0] & RTCORE_FLAG_SENSOR_REJECTED, "sensor flag");
    CHECK(out.flags[0] & RTCORE_FLAG_REFERENCE_REJECTED, "reference flag");
    CHECK(fabs(out.angle_deg[0] - 30.0) < 1e-9, "held angle %g", out.angle_deg[0]);
    CHECK(fabs(out.angle_filt_deg[0] - held) < 1e-6, "filter not poisoned");
    CHECK(isfinite(out.pressure_cmd_kpa[0]), "finite command");
    in.sensor_mv[0] = 1e300;
    rtcore_hand_step(&hand, &in, &out);
    CHECK(out.flags[0] & RTCORE_FLAG_SENSOR_REJECTED, "huge sensor rejected");
    in.mode[0] = 42;
    rtcore_hand_step(&hand, &in, &out);
    CHECK(out.flags[0] & RTCORE_FLAG_MODE_REJECTED, "bad mode flagged");
    CHECK(out.pressure_cmd_kpa[0] == 0.0, "bad mode vents");
}

static void test_force_estimate(void)
{
    rtcore_hand hand;
    rtcore_hand_config h = one_finger();
    rtcore_inputs in;
    rtcore_outputs out;
    const double angle_deg = 60.0;
    const double pressure_kpa = 120.0;
    const rtcore_finger_config *c;
    double expected_n;
    int t;

    CHECK(rtcore_hand_configure(&hand, &h) == RTCORE_OK, "configure");
    c = &hand.config.finger[0];
    clear_inputs(&in);
    in.sensor_mv[0] = mv_for_deg(c, angle_deg);
    in.pressure_meas_kpa[0] = pressure_kpa;
    for (t = 0; t < 200; ++t) {
        rtcore_hand_step(&hand, &in, &out);
    }
    /* (J^T)+ (N p - k th) with J = r [-sin, cos]: F = n (N p - k th) / r */
    expected_n = (c->pressure_gain_nm_per_kpa * pressure_kpa
                  - c->stiffness_nm_per_rad * angle_deg * PI / 180.0) / c->lever_arm_m;
    CHECK(fabs(out.force_normal_n[0] - expected_n) < 1e-9, "F_n %g vs %g", out.force_normal_n[0],
          expected_n);
    CHECK(fabs(out.force_est_x_n[0] + expected_n * sin(angle_deg * PI / 180.0)) < 1e-9, "F_x");
    CHECK(fabs(out.force_est_y_n[0] - expected_n * cos(angle_deg * PI / 180.0)) < 1e-9, "F_y");
    CHECK(fabs(out.force_est_n[0] - fabs(expected_n)) < 1e-9, "|F|");
}

/* RK4 on the PRBM with a contact spring, 1 ms steps, chamber pressure = command */
typedef struct {
    double angle_rad;
    double velocity_rad_per_s;
} plant_state;

/* contact: a spring-damper past contact_rad, its damping a fixed fraction of critical */
static void plant_deriv(const rtcore_finger_config *c, double p_kpa, double contact_rad,
                        double contact_stiffness, const plant_state *x, plant_state *dx)
{
    const double contact_damping = 0.02 * contact_stiffness;
    double torque = c->pressure_gain_nm_per_kpa * p_kpa - c->stiffness_nm_per_rad * x->angle_rad
                    - c->damping_nms_per_rad * x->velocity_rad_per_s;
    if (x->angle_rad > contact_rad) {
        torque -= contact_stiffness * (x->angle_rad - contact_rad)
                  + contact_damping * x->velocity_rad_per_s;
    }
    dx->angle_rad = x->velocity_rad_per_s;
    dx->velocity_rad_per_s = torque / c->inertia_kgm2;
}

static void plant_advance(const rtcore_finger_config *c, double p_kpa, double contact_rad,
                          double contact_stiffness, plant_state *x, double dt_s)
{
    const int sub = 10;
    const double h = dt_s / sub;
    int k;
    for (k = 0; k < sub; ++k) {
        plant_state k1, k2, k3, k4, y;
        plant_deriv(c, p_kpa, contact_rad, contact_stiffness, x, &k1);
        y.angle_rad = x->angle_rad + 0.5 * h * k1.angle_rad;
        y.velocity_rad_per_s = x->velocity_rad_per_s + 0.5 * h * k1.velocity_rad_per_s;
        plant_deriv(c, p_kpa, contact_rad, contact_stiffness, &y, &k2);
        y.angle_rad = x->angle_rad + 0.5 * h * k2.angle_rad;
        y.velocity_rad_per_s = x->velocity_rad_per_s + 0.5 * h * k2.velocity_rad_per_s;
        plant_deriv(c, p_kpa, contact_rad, contact_stiffness, &y, &k3);
        y.angle_rad = x->angle_rad + h * k3.angle_rad;
        y.velocity_rad_per_s = x->velocity_rad_per_s + h * k3.velocity_rad_per_s;
        plant_deriv(c, p_kpa, contact_rad, contact_stiffness, &y, &k4);
        x->angle_rad += h / 6.0 * (k1.angle_rad + 2.0 * k2.angle_rad + 2.0 * k3.angle_rad + k4.angle_rad);
        x->velocity_rad_per_s += h / 6.0 * (k1.velocity_rad_per_s + 2.0 * k2.velocity_rad_per_s
                                            + 2.0 * k3.velocity_rad_per_s + k4.velocity_rad_per_s);
    }
}

static void test_closed_loop_position(void)
{
    rtcore_hand hand;
    rtcore_hand_config h = one_finger();
    rtcore_inputs in;
    rtcore_outputs out;
    plant_state x = {0.0, 0.0};
    double worst_hold_deg = 0.0;
    int t;

    CHECK(rtcore_hand_configure(&hand, &h) == RTCORE_OK, "configure");
    clear_inputs(&in);
    in.mode[0] = RTCORE_MODE_POSITION;
    in.angle_ref_deg[0] = 45.0;
    for (t = 0; t < 500; ++t) {
        in.sensor_mv[0] = mv_for_deg(&h.finger[0], x.angle_rad * 180.0 / PI);
        rtcore_hand_step(&hand, &in, &out);
        plant_advance(&h.finger[0], out.pressure_cmd_kpa[0], 1e9, 0.0, &x, 0.01);
        if (t >= 300) {
            const double err = fabs(x.angle_rad * 180.0 / PI - 45.0);
            worst_hold_deg = err > worst_hold_deg ? err : worst_hold_deg;
        }
    }
    CHECK(worst_hold_deg < 0.05, "holds 45 deg within %g deg", worst_hold_deg);
}

static void test_closed_loop_force(void)
{
    rtcore_hand hand;
    rtcore_hand_config h = one_finger();
    rtcore_inputs in;
    rtcore_outputs out;
    plant_state x = {0.0, 0.0};
    const double contact_rad = 40.0 * PI / 180.0;
    const double contact_stiffness = 2.0;
    double true_force_n = 0.0;
    int t;

    CHECK(rtcore_hand_configure(&hand, &h) == RTCORE_OK, "configure");
    clear_inputs(&in);
    in.mode[0] = RTCORE_MODE_FORCE;
    in.force_ref_n[0] = 1.0;
    for (t = 0; t < 600; ++t) {
        in.sensor_mv[0] = mv_for_deg(&h.finger[0], x.angle_rad * 180.0 / PI);
        rtcore_hand_step(&hand, &in, &out);
        plant_advance(&h.finger[0], out.pressure_cmd_kpa[0], contact_rad, contact_stiffness, &x, 0.01);
    }
    true_force_n = contact_stiffness * (x.angle_rad - contact_rad) / h.finger[0].lever_arm_m;
    CHECK(fabs(true_force_n - 1.0) < 0.02, "presses with %g N", true_force_n);
}

static void test_bumpless(void)
{
    rtcore_hand hand;
    rtcore_hand_config h = one_finger();
    rtcore_inputs in;
    rtcore_outputs out;
    double before;
    int t;

    CHECK(rtcore_hand_configure(&hand, &h) == RTCORE_OK, "configure");
    clear_inputs(&in);
    in.sensor_mv[0] = mv_for_deg(&h.finger[0], 20.0);
    in.mode[0] = RTCORE_MODE_PRESSURE;
    in.pressure_ref_kpa[0] = 60.0;
    for (t = 0; t < 20; ++t) {
        rtcore_hand_step(&hand, &in, &out);
    }
    before = out.pressure_cmd_kpa[0];
    in.mode[0] = RTCORE_MODE_POSITION;
    in.angle_ref_deg[0] = 20.0;
    rtcore_hand_step(&hand, &in, &out);
    CHECK(out.flags[0] & RTCORE_FLAG_MODE_CHANGED, "mode change flagged");
    CHECK(fabs(out.pressure_cmd_kpa[0] - before) < 0.5, "bumpless: %g -> %g", before,
          out.pressure_cmd_kpa[0]);
}

/* every input drawn from a hostile mix; every output must stay finite and in range */
static void test_fuzz(void)
{
    static const double specials[] = {NAN, INFINITY, -INFINITY, 1e308, -1e308, 0.0, -0.0, 1e-310};
    rtcore_hand hand;
    rtcore_hand_config h;
    rtcore_inputs in;
    rtcore_outputs out;
    uint64_t seed = 0x9E3779B97F4A7C15ULL;
    int t;
    int i;
    int bad = 0;

    memset(&h, 0, sizeof(h));
    h.n_fingers = RTCORE_MAX_FINGERS;
    h.sample_rate_hz = 100.0;
    for (i = 0; i < RTCORE_MAX_FINGERS; ++i) {
        h.finger[i] = index_finger();
        h.finger[i].filter_order = (i % 2) ? 4 : 2;
        h.finger[i].effects.coulomb_torque_nm = 0.002 * (i % 3);
        h.finger[i].effects.cubic_stiffness_nm_per_rad3 = 0.01 * (i % 2);
        h.finger[i].effects.pressure_deadzone_kpa = 3.0 * (i % 2);
        h.finger[i].effects.valve_lag_tau_s = 0.03 * (i % 2);
        h.finger[i].force_estimate_dynamic = i % 2;
    }
    CHECK(rtcore_hand_configure(&hand, &h) == RTCORE_OK, "configure");
    clear_inputs(&in);
    for (t = 0; t < 100000; ++t) {
        for (i = 0; i < RTCORE_MAX_FINGERS; ++i) {
            double *fields[8];
            int f;
            fields[0] = &in.sensor_mv[i];
            fields[1] = &in.pressure_meas_kpa[i];
            fields[2] = &in.angle_ref_deg[i];
            fields[3] = &in.velocity_ref_deg_per_s[i];
            fields[4] = &in.accel_ref_deg_per_s2[i];
            fields[5] = &in.jerk_ref_deg_per_s3[i];
            fields[6] = &in.force_ref_n[i];
            fields[7] = &in.pressure_ref_kpa[i];
            for (f = 0; f < 8; ++f) {
                const double u = uniform(&seed);
                if (u < 0.05) {
                    *fields[f] = specials[(int)(uniform(&seed) * 8.0) % 8];
                } else {
                    *fields[f] = (uniform(&seed) - 0.5) * 2000.0;
                }
            }
            in.mode[i] = (int32_t)(uniform(&seed) * 5.0) - 1 + (uniform(&seed) < 0.01 ? 100 : 0);
        }
        rtcore_hand_step(&hand, &in, &out);
        for (i = 0; i < RTCORE_MAX_FINGERS; ++i) {
            const double p = out.pressure_cmd_kpa[i];
            if (!isfinite(p) || p > 200.0 || p < 0.0 || !isfinite(out.angle_filt_deg[i])
                || !isfinite(out.velocity_deg_per_s[i]) || !isfinite(out.force_est_n[i])
                || !isfinite(out.feedforward_kpa[i]) || !isfinite(out.pid_kpa[i])) {
                ++bad;
            }
        }
    }
    CHECK(bad == 0, "%d non-finite or out-of-range outputs", bad);
}

static void test_gate(void)
{
    rtcore_gate gate;
    rtcore_gate_result r;
    rtcore_inputs in;
    rtcore_outputs out;
    double sent[RTCORE_MAX_FINGERS];
    int i;
    int t;

    memset(&gate, 0, sizeof(gate));
    memset(&out, 0, sizeof(out));
    gate.config.n_fingers = 2;
    gate.config.angle_min_deg = -60.0;
    gate.config.angle_max_deg = 200.0;
    gate.config.leak_tolerance_kpa = 30.0;
    gate.config.leak_ticks = 5;
    for (i = 0; i < 2; ++i) {
        gate.config.pressure_min_kpa[i] = 10.0;
        gate.config.pressure_max_kpa[i] = 200.0;
        gate.config.follow_alpha[i] = 1.0;
        sent[i] = 0.0;
    }
    rtcore_gate_reset(&gate);
    clear_inputs(&in);
    CHECK(rtcore_gate_inputs(&gate, &in, &r) == RTCORE_GATE_OK, "clean inputs");
    in.sensor_mv[1] = NAN;
    CHECK(rtcore_gate_inputs(&gate, &in, &r) == RTCORE_GATE_NON_FINITE && r.finger == 1, "NaN sensor");
    in.sensor_mv[1] = 50.0;
    in.pressure_meas_kpa[0] = INFINITY;
    CHECK(rtcore_gate_inputs(&gate, &in, &r) == RTCORE_GATE_NON_FINITE && r.finger == 0, "inf pressure");
    in.pressure_meas_kpa[0] = NAN; /* not reported: fine */
    CHECK(rtcore_gate_inputs(&gate, &in, &r) == RTCORE_GATE_OK, "NaN pressure is 'not reported'");

    out.angle_deg[1] = 250.0;
    CHECK(rtcore_gate_outputs(&gate, &out, &r) == RTCORE_GATE_ANGLE_OUT_OF_RANGE && r.limit == 200.0,
          "angle range");
    out.angle_deg[1] = 30.0;
    out.pressure_cmd_kpa[0] = 200.5;
    CHECK(rtcore_gate_outputs(&gate, &out, &r) == RTCORE_GATE_PRESSURE_OVER_LIMIT && r.finger == 0,
          "over the limit");
    out.pressure_cmd_kpa[0] = 0.0; /* a vent, below the 10 kPa minimum, is allowed */
    CHECK(rtcore_gate_outputs(&gate, &out, &r) == RTCORE_GATE_OK, "vent allowed");
    out.pressure_cmd_kpa[0] = 5.0;
    CHECK(rtcore_gate_outputs(&gate, &out, &r) == RTCORE_GATE_PRESSURE_OVER_LIMIT, "under the minimum");
    out.pressure_cmd_kpa[0] = NAN;
    CHECK(rtcore_gate_outputs(&gate, &out, &r) == RTCORE_GATE_NON_FINITE, "NaN command");

    /* the chamber stays at 0 while 100 kPa is sent: the first tick compares with the
     * expectation before the send, so the 5th tick outside the tolerance is tick 6 */
    sent[0] = 100.0;
    in.pressure_meas_kpa[0] = 0.0;
    for (t = 0; t < 5; ++t) {
        CHECK(rtcore_gate_follow(&gate, sent, &in, &r) == RTCORE_GATE_OK, "tick %d: not yet", t);
    }
    CHECK(rtcore_gate_follow(&gate, sent, &in, &r) == RTCORE_GATE_LEAK_OR_BURST && r.finger == 0
          && r.limit == 100.0, "leak on tick 6");
    in.pressure_meas_kpa[0] = 100.0;
    CHECK(rtcore_gate_follow(&gate, sent, &in, &r) == RTCORE_GATE_OK, "following again");
    CHECK(rtcore_gate_inputs(0, &in, &r) == RTCORE_GATE_NON_FINITE, "null gate refused");
}

static void test_ring_tick(void)
{
    static double rows[3 * 22];
    int64_t count = 0;
    rtcore_inputs in;
    rtcore_outputs out;
    double sent[RTCORE_MAX_FINGERS] = {7.0, 8.0};
    clear_inputs(&in);
    memset(&out, 0, sizeof(out));
    in.angle_ref_deg[1] = 42.0;
    in.mode[1] = RTCORE_MODE_POSITION;
    out.flags[0] = RTCORE_FLAG_SATURATED;
    out.force_est_n[1] = 1.5;
    CHECK(rtcore_ring_push_tick(rows, &count, 3, 22, 2, &in, &out, sent, 0.25, 4) == 1, "pushed");
    CHECK(rows[0] == 0.25 && rows[1] == 4.0, "head");
    CHECK(rows[2 + 1] == 42.0 && rows[2 + 2] == 7.0 && rows[2 + 6 * 2 + 1] == 1.5, "blocks");
    CHECK(rows[2 + 8 * 2 + 1] == 2.0 && rows[2 + 9 * 2] == 1.0, "mode and flags");
    CHECK(rtcore_ring_push_tick(rows, &count, 3, 21, 2, &in, &out, sent, 0.0, 0) == -1, "bad width");
    for (int k = 0; k < 5; ++k) {
        rtcore_ring_push_tick(rows, &count, 3, 22, 2, &in, &out, sent, 0.01 * k, 4);
    }
    CHECK(count == 6 && rows[22 * (5 % 3)] == 0.04, "wraps: count %lld", (long long)count);
}

int main(void)
{
    test_butter_design();
    test_configure_rejects();
    test_limits();
    test_anti_windup();
    test_nan_inputs();
    test_force_estimate();
    test_closed_loop_position();
    test_closed_loop_force();
    test_bumpless();
    test_fuzz();
    test_gate();
    test_ring_tick();
    printf("%d checks, %d failures\n", checks, failures);
    return failures == 0 ? 0 : 1;
}
