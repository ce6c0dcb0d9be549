/* The step in closed loop with an RK4 finger (position and force), and a fuzz of
 * hostile inputs: outputs always finite and in range. */
#include "check.h"

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
    double torque = c->prbm.pressure_gain_nm_per_kpa * p_kpa - c->prbm.stiffness_nm_per_rad * x->angle_rad
                    - c->prbm.damping_nms_per_rad * x->velocity_rad_per_s;
    if (x->angle_rad > contact_rad) {
        torque -= contact_stiffness * (x->angle_rad - contact_rad)
                  + contact_damping * x->velocity_rad_per_s;
    }
    dx->angle_rad = x->velocity_rad_per_s;
    dx->velocity_rad_per_s = torque / c->prbm.inertia_kgm2;
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
    true_force_n = contact_stiffness * (x.angle_rad - contact_rad) / h.finger[0].prbm.lever_arm_m;
    CHECK(fabs(true_force_n - 1.0) < 0.02, "presses with %g N", true_force_n);
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
        h.finger[i].prbm.effects.coulomb_torque_nm = 0.002 * (i % 3);
        h.finger[i].prbm.effects.cubic_stiffness_nm_per_rad3 = 0.01 * (i % 2);
        h.finger[i].prbm.effects.pressure_deadzone_kpa = 3.0 * (i % 2);
        h.finger[i].prbm.effects.valve_lag_tau_s = 0.03 * (i % 2);
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
                || !isfinite(out.velocity_deg_per_s[i]) || !isfinite(out.force_magnitude_n[i])
                || !isfinite(out.feedforward_kpa[i]) || !isfinite(out.pid_kpa[i])) {
                ++bad;
            }
        }
    }
    CHECK(bad == 0, "%d non-finite or out-of-range outputs", bad);
}

void run_loop_tests(void)
{
    test_closed_loop_position();
    test_closed_loop_force();
    test_fuzz();
}
