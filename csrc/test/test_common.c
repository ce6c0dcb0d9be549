/* Helpers shared by the C tests, and the counters CHECK updates. */
#include "check.h"

int failures = 0;
int checks = 0;

/* xorshift64*: deterministic, no global state */
double uniform(uint64_t *s)
{
    *s ^= *s >> 12;
    *s ^= *s << 25;
    *s ^= *s >> 27;
    return (double)((*s * 2685821657736338717ULL) >> 11) / 9007199254740992.0;
}

/* the index finger of docs/physics.md */
rtcore_finger_config index_finger(void)
{
    rtcore_finger_config c;
    memset(&c, 0, sizeof(c));
    c.sensor_gain_deg_per_mv = 0.1;
    c.sensor_offset_deg = -5.0;
    c.filter_order = 2;
    c.filter_cutoff_hz = 25.0;
    c.velocity_cutoff_hz = 25.0;
    c.prbm.inertia_kgm2 = 1.617e-4;
    c.prbm.damping_nms_per_rad = 0.0031;
    c.prbm.stiffness_nm_per_rad = 0.570;
    c.prbm.pressure_gain_nm_per_kpa = 8.954e-3;
    c.prbm.lever_arm_m = 0.040375;
    c.prbm.effects.asymmetric_stiffness_ratio = 1.0;
    c.prbm.effects.coulomb_smoothing_deg_per_s = 2.0;
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

rtcore_hand_config one_finger(void)
{
    rtcore_hand_config h;
    memset(&h, 0, sizeof(h));
    h.n_fingers = 1;
    h.sample_rate_hz = 100.0;
    h.finger[0] = index_finger();
    return h;
}

void clear_inputs(rtcore_inputs *in)
{
    int i;
    memset(in, 0, sizeof(*in));
    for (i = 0; i < RTCORE_MAX_FINGERS; ++i) {
        in->pressure_meas_kpa[i] = NAN;
        in->sensor_mv[i] = 50.0; /* 0 deg with the calibration above */
    }
}

double mv_for_deg(const rtcore_finger_config *c, double deg)
{
    return (deg - c->sensor_offset_deg) / c->sensor_gain_deg_per_mv;
}
