/* The control step: filter design, configuration, limits, anti-windup, NaN, the force
 * estimate and bumpless switching. */
#include "check.h"

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
    h.finger[0].prbm.pressure_gain_nm_per_kpa = 0.0;
    CHECK(rtcore_hand_configure(&hand, &h) == RTCORE_ERR_MODEL, "zero N");
    h = one_finger();
    h.finger[0].kp_kpa_per_deg = NAN;
    CHECK(rtcore_hand_configure(&hand, &h) == RTCORE_ERR_GAINS, "NaN kp");
    h = one_finger();
    h.finger[0].pressure_min_kpa = 10.0;
    h.finger[0].pressure_max_kpa = 5.0;
    CHECK(rtcore_hand_configure(&hand, &h) == RTCORE_ERR_PRESSURE_LIMITS, "min > max");
    h = one_finger();
    h.finger[0].prbm.effects.asymmetric_stiffness_ratio = 0.0;
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
    expected_n = (c->prbm.pressure_gain_nm_per_kpa * pressure_kpa
                  - c->prbm.stiffness_nm_per_rad * angle_deg * PI / 180.0) / c->prbm.lever_arm_m;
    CHECK(fabs(out.force_normal_n[0] - expected_n) < 1e-9, "F_n %g vs %g", out.force_normal_n[0],
          expected_n);
    CHECK(fabs(out.force_est_x_n[0] + expected_n * sin(angle_deg * PI / 180.0)) < 1e-9, "F_x");
    CHECK(fabs(out.force_est_y_n[0] - expected_n * cos(angle_deg * PI / 180.0)) < 1e-9, "F_y");
    CHECK(fabs(out.force_magnitude_n[0] - fabs(expected_n)) < 1e-9, "|F|");
}

/* With a hysteresis loop in the model, the estimate takes H z off, z Dahl's state driven by
 * the filtered angle from the middle at the first angle: replayed here over the filtered
 * angles of a step from rest to 60 deg (through the filter's overshoot and back, so z ends
 * short of +1), once the config asks for it (force_estimate_hysteresis). */
static void test_force_estimate_hysteresis(void)
{
    rtcore_hand hand;
    rtcore_hand_config h = one_finger();
    rtcore_inputs in;
    rtcore_outputs out;
    const double pressure_kpa = 120.0;
    const double torque_nm = 0.02;
    const double travel_deg = 20.0;
    double plain_n;
    double z = 0.0;
    double last_deg;
    int t;

    CHECK(rtcore_hand_configure(&hand, &h) == RTCORE_OK, "configure");
    clear_inputs(&in);
    in.pressure_meas_kpa[0] = pressure_kpa;
    in.sensor_mv[0] = mv_for_deg(&hand.config.finger[0], 60.0);
    for (t = 0; t < 200; ++t) {
        rtcore_hand_step(&hand, &in, &out);
    }
    plain_n = out.force_normal_n[0];
    h.finger[0].prbm.effects.hysteresis_torque_nm = torque_nm;
    h.finger[0].prbm.effects.hysteresis_travel_deg = travel_deg;
    h.finger[0].force_estimate_hysteresis = 1;
    CHECK(rtcore_hand_configure(&hand, &h) == RTCORE_OK, "configure with a loop");
    in.sensor_mv[0] = mv_for_deg(&hand.config.finger[0], 0.0);
    rtcore_hand_step(&hand, &in, &out);
    last_deg = out.angle_filt_deg[0];
    in.sensor_mv[0] = mv_for_deg(&hand.config.finger[0], 60.0);
    for (t = 0; t < 200; ++t) {
        double travel_deg_now;
        rtcore_hand_step(&hand, &in, &out);
        travel_deg_now = out.angle_filt_deg[0] - last_deg;
        if (travel_deg_now != 0.0) {
            const double toward = travel_deg_now > 0.0 ? 1.0 : -1.0;
            z = toward + (z - toward) * exp(-fabs(travel_deg_now) / travel_deg);
        }
        last_deg = out.angle_filt_deg[0];
    }
    CHECK(z > 0.1 && fabs(hand.finger[0].hysteresis_z - z) < 1e-9, "z %g vs %g", hand.finger[0].hysteresis_z, z);
    CHECK(fabs(out.force_normal_n[0] - (plain_n - torque_nm * z / hand.config.finger[0].prbm.lever_arm_m)) < 1e-9,
          "F_n with the loop %g vs %g", out.force_normal_n[0], plain_n);
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

void run_step_tests(void)
{
    test_butter_design();
    test_configure_rejects();
    test_limits();
    test_anti_windup();
    test_nan_inputs();
    test_force_estimate();
    test_force_estimate_hysteresis();
    test_bumpless();
}
