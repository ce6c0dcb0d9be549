/* What the supervisor calls beside the step: the safety gate and the tick's ring row. */
#include "check.h"

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
    out.pressure_cmd_kpa[0] = 5.0; /* the rate-limited ramp out of a vent */
    CHECK(rtcore_gate_outputs(&gate, &out, &r) == RTCORE_GATE_OK, "ramp below the minimum");
    out.pressure_cmd_kpa[0] = -1.0; /* a vacuum the profile does not allow */
    CHECK(rtcore_gate_outputs(&gate, &out, &r) == RTCORE_GATE_PRESSURE_OVER_LIMIT && r.limit == 0.0,
          "below zero with a positive minimum");
    gate.config.pressure_min_kpa[0] = -20.0;
    out.pressure_cmd_kpa[0] = -15.0;
    CHECK(rtcore_gate_outputs(&gate, &out, &r) == RTCORE_GATE_OK, "vacuum within a negative minimum");
    out.pressure_cmd_kpa[0] = -25.0;
    CHECK(rtcore_gate_outputs(&gate, &out, &r) == RTCORE_GATE_PRESSURE_OVER_LIMIT && r.limit == -20.0,
          "vacuum beyond it");
    out.pressure_cmd_kpa[0] = 5.0;
    /* a sensor the step keeps rejecting (held angle) is a fault after 3 ticks in a row */
    gate.config.sensor_rejected_ticks = 3;
    out.flags[1] = RTCORE_FLAG_SENSOR_REJECTED;
    CHECK(rtcore_gate_outputs(&gate, &out, &r) == RTCORE_GATE_OK, "1 tick held");
    CHECK(rtcore_gate_outputs(&gate, &out, &r) == RTCORE_GATE_OK, "2 ticks held");
    CHECK(rtcore_gate_outputs(&gate, &out, &r) == RTCORE_GATE_SENSOR_REJECTED && r.finger == 1,
          "3 ticks held");
    out.flags[1] = 0u;
    CHECK(rtcore_gate_outputs(&gate, &out, &r) == RTCORE_GATE_OK, "a good reading ends the streak");
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
    static double rows[3 * 24];
    int64_t count = 0;
    rtcore_inputs in;
    rtcore_outputs out;
    double sent[RTCORE_MAX_FINGERS] = {7.0, 8.0};
    double truth[RTCORE_MAX_FINGERS] = {11.0, 12.5};
    clear_inputs(&in);
    memset(&out, 0, sizeof(out));
    in.angle_ref_deg[1] = 42.0;
    in.mode[1] = RTCORE_MODE_POSITION;
    out.flags[0] = RTCORE_FLAG_SATURATED;
    /* pressing backwards: the force_est_n column is the signed normal force, not |F| */
    out.force_normal_n[1] = -1.5;
    out.force_magnitude_n[1] = 1.5;
    in.force_ref_n[1] = -1.0;
    CHECK(rtcore_ring_push_tick(rows, &count, 3, 24, 2, &in, &out, sent, truth, 0.25, 4) == 1, "pushed");
    CHECK(rows[0] == 0.25 && rows[1] == 4.0, "head");
    CHECK(rows[2 + 1] == 42.0 && rows[2 + 2] == 7.0, "blocks");
    CHECK(rows[2 + 6 * 2 + 1] == -1.5 && rows[2 + 7 * 2 + 1] == -1.0, "signed force %g, ref %g",
          rows[2 + 6 * 2 + 1], rows[2 + 7 * 2 + 1]);
    CHECK(rows[2 + 8 * 2 + 1] == 2.0 && rows[2 + 9 * 2] == 1.0, "mode and flags");
    CHECK(rows[2 + 10 * 2] == 11.0 && rows[2 + 10 * 2 + 1] == 12.5, "true angle");
    CHECK(rtcore_ring_push_tick(rows, &count, 3, 22, 2, &in, &out, sent, truth, 0.0, 0) == -1, "bad width");
    CHECK(rtcore_ring_push_tick(rows, &count, 3, 24, 2, &in, &out, sent, 0, 0.5, 4) == 2, "no truth");
    CHECK(isnan(rows[24 + 2 + 10 * 2]) && isnan(rows[24 + 2 + 10 * 2 + 1]), "no truth: NaN");
    for (int k = 0; k < 4; ++k) {
        rtcore_ring_push_tick(rows, &count, 3, 24, 2, &in, &out, sent, truth, 0.01 * k, 4);
    }
    CHECK(count == 6 && rows[24 * (5 % 3)] == 0.03, "wraps: count %lld", (long long)count);
}

void run_supervisor_tests(void)
{
    test_gate();
    test_ring_tick();
}
