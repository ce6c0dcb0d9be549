/* The supervisor's tick in C: the gate's timing checks, the references for each state,
 * a trajectory played, looped and ended, the vent on a fault, and the simulated hand as
 * a link whose period may be simulated later without changing what it reads. */
#include "check.h"

typedef struct {
    rtcore_hand hand;
    rtcore_inputs in;
    rtcore_outputs out;
    rtcore_gate gate;
    rtcore_tick tick;
} rig;

static void rig_init(rig *r)
{
    rtcore_hand_config config = one_finger();
    int i;
    memset(r, 0, sizeof(*r));
    config.n_fingers = 2;
    config.finger[1] = index_finger();
    CHECK(rtcore_hand_configure(&r->hand, &config) == RTCORE_OK, "two fingers");
    clear_inputs(&r->in);
    r->gate.config.n_fingers = 2;
    r->gate.config.angle_min_deg = -60.0;
    r->gate.config.angle_max_deg = 200.0;
    r->gate.config.leak_tolerance_kpa = 1e9;
    r->gate.config.leak_ticks = 5;
    r->gate.config.overrun_streak = 3;
    r->gate.config.stale_sensor_ticks = 4;
    r->gate.config.transport_timeout_ns = 50000000;
    for (i = 0; i < 2; ++i) {
        r->gate.config.pressure_max_kpa[i] = 200.0;
        r->gate.config.follow_alpha[i] = 1.0;
    }
    rtcore_gate_reset(&r->gate);
    r->tick.n_fingers = 2;
    r->tick.hand = &r->hand;
    r->tick.inputs = &r->in;
    r->tick.outputs = &r->out;
    r->tick.gate = &r->gate;
}

static int32_t run(rig *r, int32_t refs)
{
    return rtcore_tick_control(&r->tick, refs, 0, 0, 1, 0, 0);
}

static void test_gate_timing(void)
{
    rtcore_gate gate;
    rtcore_gate_result res;
    memset(&gate, 0, sizeof(gate));
    gate.config.overrun_streak = 3;
    gate.config.stale_sensor_ticks = 4;
    gate.config.transport_timeout_ns = 50000000;
    rtcore_gate_reset(&gate);
    CHECK(rtcore_gate_overrun(&gate, 1, &res) == RTCORE_GATE_OK, "one miss");
    CHECK(rtcore_gate_overrun(&gate, 1, &res) == RTCORE_GATE_OK, "two misses");
    CHECK(rtcore_gate_overrun(&gate, 1, &res) == RTCORE_GATE_OVERRUN_STREAK && res.value == 3.0,
          "three in a row");
    CHECK(rtcore_gate_overrun(&gate, 0, &res) == RTCORE_GATE_OK && gate.overruns == 0, "a met deadline");
    CHECK(rtcore_gate_frame(&gate, 1, 3, 0, &res) == RTCORE_GATE_OK, "3 lost");
    CHECK(rtcore_gate_frame(&gate, 1, 4, 0, &res) == RTCORE_GATE_STALE_SENSOR && res.value == 4.0,
          "4 lost in a row: stale");
    CHECK(rtcore_gate_frame(&gate, 0, 0, 49999999, &res) == RTCORE_GATE_OK, "silent under the timeout");
    CHECK(rtcore_gate_frame(&gate, 0, 0, 50000000, &res) == RTCORE_GATE_TRANSPORT_LOST
          && res.value == 5e7, "silent for the timeout: %g", res.value);
    CHECK(rtcore_gate_frame(&gate, 1, 0, 60000000, &res) == RTCORE_GATE_OK, "a frame again");
    rtcore_gate_reset(&gate);
    CHECK(rtcore_gate_frame(&gate, 0, 0, 900000000, &res) == RTCORE_GATE_OK,
          "after a reset, silence counts from the first check");
    CHECK(rtcore_gate_frame(&gate, 0, 0, 949999999, &res) == RTCORE_GATE_OK, "under the timeout");
    CHECK(rtcore_gate_overrun(0, 1, &res) == RTCORE_GATE_NON_FINITE, "null gate refused");
}

static void test_references(void)
{
    static rig r;
    int32_t k;
    rig_init(&r);
    r.tick.target_mode[0] = RTCORE_MODE_POSITION;
    r.tick.target_angle_deg[0] = 30.0;
    r.tick.target_mode[1] = RTCORE_MODE_PRESSURE;
    r.tick.target_pressure_kpa[1] = 40.0;
    CHECK(run(&r, RTCORE_REFS_RUN) == 0, "targets");
    CHECK(r.in.mode[0] == RTCORE_MODE_POSITION && r.in.angle_ref_deg[0] == 30.0, "position target");
    CHECK(r.in.mode[1] == RTCORE_MODE_PRESSURE && r.in.pressure_ref_kpa[1] == 40.0, "pressure target");
    for (k = 0; k < 20; ++k) {
        run(&r, RTCORE_REFS_RUN);
    }
    CHECK(r.out.pressure_cmd_kpa[1] > 0.0 && r.tick.sent_kpa[1] == r.out.pressure_cmd_kpa[1],
          "sent the step's command: %g", r.tick.sent_kpa[1]);
    CHECK(r.tick.sent_kpa[2] == 0.0, "no command beyond the hand");
    CHECK(rtcore_tick_control(&r.tick, RTCORE_REFS_RUN, 1, 0, 1, 0, 0) == 0 && r.tick.sent_kpa[1] == 0.0
          && r.out.pressure_cmd_kpa[1] > 0.0, "the caller's vent: 0 kPa sent");
    r.in.velocity_ref_deg_per_s[0] = 5.0;
    CHECK(run(&r, RTCORE_REFS_HOLD) == 0 && r.in.velocity_ref_deg_per_s[0] == 0.0
          && r.in.angle_ref_deg[0] == 30.0 && r.tick.sent_kpa[1] > 0.0, "hold: at rest where it is");
    CHECK(run(&r, RTCORE_REFS_VENT) == 0 && r.in.mode[0] == RTCORE_MODE_VENT
          && r.in.mode[1] == RTCORE_MODE_VENT && r.tick.sent_kpa[1] == 0.0, "vent");
    r.tick.trajectory.n_ticks = 3; /* no rows behind it: not playable, the targets hold */
    CHECK(run(&r, RTCORE_REFS_RUN) == 0 && r.in.angle_ref_deg[0] == 30.0 && r.tick.trajectory_tick == 0,
          "null trajectory ignored");
}

static void test_trajectory(void)
{
    static rig r;
    /* three rows of two fingers; finger 1 is not driven */
    const int32_t mode[6] = {RTCORE_MODE_POSITION, -1, RTCORE_MODE_POSITION, -1, RTCORE_MODE_POSITION, -1};
    const double angle[6] = {10.0, NAN, 20.0, NAN, 25.0, NAN};
    const double velocity[6] = {1.0, NAN, 2.0, NAN, 3.0, NAN};
    const double zero[6] = {0.0, NAN, 0.0, NAN, 0.0, NAN};
    int32_t k;
    rig_init(&r);
    r.tick.target_mode[1] = RTCORE_MODE_POSITION;
    r.tick.target_angle_deg[1] = 15.0;
    r.tick.trajectory.mode = mode;
    r.tick.trajectory.angle_deg = angle;
    r.tick.trajectory.velocity_deg_per_s = velocity;
    r.tick.trajectory.accel_deg_per_s2 = zero;
    r.tick.trajectory.jerk_deg_per_s3 = zero;
    r.tick.trajectory.force_n = zero;
    r.tick.trajectory.n_ticks = 3;
    r.tick.trajectory.driven[0] = 1;
    for (k = 0; k < 3; ++k) {
        CHECK(run(&r, RTCORE_REFS_RUN) == 0, "row %d", k);
        CHECK(r.in.angle_ref_deg[0] == angle[2 * k] && r.in.velocity_ref_deg_per_s[0] == velocity[2 * k],
              "row %d played", k);
        CHECK(r.in.mode[1] == RTCORE_MODE_POSITION && r.in.angle_ref_deg[1] == 15.0, "finger 1 on its target");
        CHECK(r.tick.trajectory_tick == k + 1, "advanced to %lld", (long long)r.tick.trajectory_tick);
    }
    CHECK(run(&r, RTCORE_REFS_HOLD) == 0 && r.tick.trajectory_tick == 3, "hold does not advance");
    CHECK(run(&r, RTCORE_REFS_RUN) == RTCORE_TICK_TRAJECTORY_END && r.tick.trajectory_done,
          "the end, once");
    CHECK(r.tick.target_mode[0] == RTCORE_MODE_POSITION && r.tick.target_angle_deg[0] == 25.0
          && r.in.angle_ref_deg[0] == 25.0 && r.in.velocity_ref_deg_per_s[0] == 0.0,
          "the last row is the target, at rest");
    CHECK(run(&r, RTCORE_REFS_RUN) == 0 && r.in.angle_ref_deg[0] == 25.0, "held after the end");

    r.tick.trajectory_done = 0;
    r.tick.trajectory_tick = 0;
    r.tick.trajectory.loop = 1;
    for (k = 0; k < 4; ++k) {
        CHECK(run(&r, RTCORE_REFS_RUN) == 0, "looping tick %d", k);
    }
    CHECK(r.in.angle_ref_deg[0] == 10.0 && r.tick.trajectory_tick == 1 && !r.tick.trajectory_done,
          "a loop plays row 0 again");
}

static void test_faults_vent(void)
{
    static rig r;
    int32_t k;
    rig_init(&r);
    r.tick.target_mode[0] = RTCORE_MODE_PRESSURE;
    r.tick.target_pressure_kpa[0] = 80.0;
    for (k = 0; k < 20; ++k) {
        CHECK(run(&r, RTCORE_REFS_RUN) == 0, "clean tick %d", k);
    }
    r.gate.config.pressure_max_kpa[0] = 50.0; /* the core's limit is wrong: 200 kPa */
    CHECK(run(&r, RTCORE_REFS_RUN) == RTCORE_TICK_OUTPUT && r.tick.output.cause == RTCORE_GATE_PRESSURE_OVER_LIMIT
          && r.tick.sent_kpa[0] == 0.0 && r.out.pressure_cmd_kpa[0] > 50.0, "over the gate's limit: vented");
    r.gate.config.pressure_max_kpa[0] = 200.0;
    r.in.sensor_mv[1] = NAN;
    CHECK(rtcore_tick_control(&r.tick, RTCORE_REFS_RUN, 0, 0, 0, 0, 0) == 0, "not fresh: not checked");
    CHECK(run(&r, RTCORE_REFS_RUN) == RTCORE_TICK_SAMPLE && r.tick.sample.finger == 1 && r.tick.sent_kpa[0] == 0.0,
          "a NaN sample: vented");
    r.in.sensor_mv[1] = 50.0;
    CHECK(rtcore_tick_control(&r.tick, RTCORE_REFS_RUN, 0, 1, 1, 0, 0) == 0, "a miss");
    CHECK(rtcore_tick_control(&r.tick, RTCORE_REFS_RUN, 0, 1, 1, 0, 0) == 0, "two");
    CHECK(rtcore_tick_control(&r.tick, RTCORE_REFS_RUN, 0, 1, 1, 5, 0) == (RTCORE_TICK_OVERRUN | RTCORE_TICK_FRAME)
          && r.tick.frame.cause == RTCORE_GATE_STALE_SENSOR, "three misses and five lost samples");
    CHECK(run(&r, RTCORE_REFS_RUN) == 0 && r.tick.sent_kpa[0] > 0.0, "clean again");
    r.gate.config.leak_tolerance_kpa = 1.0; /* the measured pressure is NaN: never a leak */
    for (k = 0; k < 10; ++k) {
        CHECK(rtcore_tick_follow(&r.tick) == 0, "NaN is not reported (tick %d)", k);
    }
    r.in.pressure_meas_kpa[0] = r.tick.sent_kpa[0] + 30.0; /* the chamber stuck high */
    for (k = 0; k < 4; ++k) {
        CHECK(rtcore_tick_follow(&r.tick) == 0, "off by 30 kPa for %d ticks", k + 1);
    }
    CHECK(rtcore_tick_follow(&r.tick) == RTCORE_TICK_LEAK && r.tick.follow.finger == 0, "the 5th tick off: a leak");
    CHECK(rtcore_tick_control(0, RTCORE_REFS_RUN, 0, 0, 1, 0, 0) == RTCORE_TICK_OUTPUT, "null tick refused");
    r.tick.gate = 0;
    CHECK(rtcore_tick_follow(&r.tick) == RTCORE_TICK_LEAK, "a tick without its gate refused");
}

static rtcore_sim_config sim_config(void)
{
    rtcore_sim_config c;
    rtcore_finger_config f = index_finger();
    memset(&c, 0, sizeof(c));
    c.n_fingers = 2;
    c.sample_rate_hz = 100.0;
    c.substeps = 10;
    c.seed = 7;
    for (int i = 0; i < 2; ++i) {
        c.finger[i].prbm = f.prbm; /* the controller's PRBM is the truth */
        c.finger[i].prbm.effects.valve_lag_tau_s = 0.02;
        c.finger[i].supply_max_kpa = 300.0;
        c.finger[i].sensor_gain_deg_per_mv = f.sensor_gain_deg_per_mv;
        c.finger[i].sensor_offset_deg = f.sensor_offset_deg;
        c.finger[i].sensor_noise_deg = 0.2;
        c.finger[i].pressure_noise_kpa = 0.5;
    }
    return c;
}

typedef struct {
    rtcore_sim sim;
    rtcore_sim_outputs out;
    double command_kpa[RTCORE_MAX_FINGERS];
    rtcore_sim_link link;
} sim_rig;

static void sim_init(sim_rig *s)
{
    rtcore_sim_config c = sim_config();
    memset(s, 0, sizeof(*s));
    CHECK(rtcore_sim_configure(&s->sim, &c) == RTCORE_OK, "sim configured");
    rtcore_sim_sample(&s->sim, &s->out);
    s->link.sim = &s->sim;
    s->link.out = &s->out;
    s->link.command_kpa = s->command_kpa;
    s->link.open = 1;
    s->link.fresh = 1;
}

static void test_sim_link(void)
{
    static sim_rig eager;
    static sim_rig lazy;
    double mv_a[RTCORE_MAX_FINGERS];
    double kpa_a[RTCORE_MAX_FINGERS];
    double mv_b[RTCORE_MAX_FINGERS];
    double kpa_b[RTCORE_MAX_FINGERS];
    double cmd[RTCORE_MAX_FINGERS] = {0.0};
    int32_t k;
    int same = 1;
    sim_init(&eager);
    sim_init(&lazy);
    CHECK(rtcore_sim_link_latest(&lazy.link, mv_b, kpa_b) == 1, "the reading before the first command");
    CHECK(rtcore_sim_link_latest(&lazy.link, mv_b, kpa_b) == 0, "taken once");
    rtcore_sim_link_latest(&eager.link, mv_a, kpa_a);
    for (k = 0; k < 50; ++k) {
        cmd[0] = 2.0 * k;
        cmd[1] = 100.0 - k;
        /* one side simulates each period at once, the other when the next sample needs it */
        rtcore_sim_link_on_tick(&eager.link, k);
        rtcore_sim_link_send(&eager.link, cmd);
        rtcore_sim_link_advance(&eager.link);
        rtcore_sim_link_on_tick(&lazy.link, k);
        rtcore_sim_link_send(&lazy.link, cmd);
        if (k == 10) {
            CHECK(lazy.link.pending && lazy.sim.time_s < eager.sim.time_s, "the period is pending");
        }
        same &= rtcore_sim_link_latest(&eager.link, mv_a, kpa_a) == 1;
        same &= rtcore_sim_link_latest(&lazy.link, mv_b, kpa_b) == 1;
        same &= memcmp(mv_a, mv_b, 2 * sizeof(double)) == 0 && memcmp(kpa_a, kpa_b, 2 * sizeof(double)) == 0;
    }
    CHECK(same, "the same samples, bit for bit, whenever the period is simulated");
    CHECK(eager.link.frames_out == 50 && eager.link.frames_in == 51 && eager.link.sequence == 51,
          "counters: %lld out, %lld in", (long long)eager.link.frames_out, (long long)eager.link.frames_in);
    rtcore_sim_link_send(&lazy.link, cmd);
    rtcore_sim_link_on_tick(&lazy.link, 53); /* the pending period, then 50, 51 and 52 skipped */
    CHECK(fabs(lazy.sim.time_s - 54 * 0.01) < 1e-9, "skipped deadlines pass: t = %g", lazy.sim.time_s);
    lazy.link.open = 0;
    rtcore_sim_link_send(&lazy.link, cmd);
    CHECK(!lazy.link.pending && rtcore_sim_link_latest(&lazy.link, mv_b, kpa_b) == 0, "closed: nothing");
}

static void test_tick_sim(void)
{
    static rig r;
    static sim_rig s;
    int32_t k;
    int32_t events = 0;
    rig_init(&r);
    sim_init(&s);
    r.tick.target_mode[0] = RTCORE_MODE_POSITION;
    r.tick.target_angle_deg[0] = 40.0;
    r.tick.target_mode[1] = RTCORE_MODE_POSITION;
    r.tick.target_angle_deg[1] = 20.0;
    for (k = 0; k < 300; ++k) {
        events |= rtcore_tick_sim(&r.tick, &s.link, k, RTCORE_REFS_RUN, 0, (int64_t)k * 10000000);
    }
    CHECK(events == 0, "300 clean ticks: %d", events);
    CHECK(fabs(r.out.angle_filt_deg[0] - 40.0) < 1.0 && fabs(r.out.angle_filt_deg[1] - 20.0) < 1.0,
          "tracks its targets: %g, %g", r.out.angle_filt_deg[0], r.out.angle_filt_deg[1]);
    CHECK(s.link.pending && s.link.frames_out == 300, "the last period is left to the slack");
    s.link.open = 0;
    for (k = 300; k < 306; ++k) {
        events = rtcore_tick_sim(&r.tick, &s.link, k, RTCORE_REFS_RUN, 0, (int64_t)k * 10000000);
    }
    CHECK(events == RTCORE_TICK_FRAME && r.tick.frame.cause == RTCORE_GATE_TRANSPORT_LOST
          && r.tick.sent_kpa[0] == 0.0, "a closed link falls silent: lost, vented (%d)", events);
    CHECK(rtcore_tick_sim(&r.tick, 0, 0, RTCORE_REFS_RUN, 0, 0) == RTCORE_TICK_OUTPUT, "null link refused");
}

static void test_tick_sim_at(void)
{
    static rig r;
    static sim_rig s;
    static double rows[4 * 24]; /* 2 fingers: 2 + 11 * 2 columns */
    int64_t count = 0;
    int64_t times[2];
    int32_t k;
    rig_init(&r);
    sim_init(&s);
    r.tick.ring_rows = rows;
    r.tick.ring_count = &count;
    r.tick.ring_capacity = 4;
    r.tick.ring_cols = 24;
    r.tick.target_mode[0] = RTCORE_MODE_PRESSURE;
    r.tick.target_pressure_kpa[0] = 60.0;
    for (k = 0; k < 3; ++k) { /* deadlines already passed: no sleep */
        CHECK(rtcore_tick_sim_at(&r.tick, &s.link, rtcore_clock_now_ns(), 0, k, RTCORE_REFS_RUN, 0, 0.01 * k,
                                 3, times) == 0, "clean tick %d", k);
    }
    CHECK(count == 3 && rows[2 * 24] == 0.02 && rows[2 * 24 + 1] == 3.0, "each clean tick its row");
    /* the true angle: the simulator's, at the sample the tick read (the link has not advanced) */
    CHECK(rows[2 * 24 + 2 + 10 * 2] == s.out.angle_deg[0] && rows[2 * 24 + 2 + 10 * 2 + 1] == s.out.angle_deg[1]
          && s.out.angle_deg[0] != 0.0, "the true angle %g, the simulator's %g", rows[2 * 24 + 2 + 10 * 2],
          s.out.angle_deg[0]);
    CHECK(times[0] > 0 && times[1] > times[0], "wake-up %lld, end %lld", (long long)times[0],
          (long long)times[1]);
    {
        const int64_t deadline_ns = rtcore_clock_now_ns() + 2000000;
        CHECK(rtcore_tick_sim_at(&r.tick, &s.link, deadline_ns, 0, 3, RTCORE_REFS_RUN, 0, 0.03, 3, times) == 0
              && times[0] >= deadline_ns && count == 4, "slept to its deadline, then ticked");
    }
    r.gate.config.pressure_max_kpa[0] = 1.0;
    CHECK(rtcore_tick_sim_at(&r.tick, &s.link, rtcore_clock_now_ns(), 0, 4, RTCORE_REFS_RUN, 0, 0.04, 3,
                             times) == RTCORE_TICK_OUTPUT && count == 4, "a fault: the row is the caller's");
    r.tick.ring_rows = 0;
    r.gate.config.pressure_max_kpa[0] = 200.0;
    CHECK(rtcore_tick_sim_at(&r.tick, &s.link, rtcore_clock_now_ns(), 0, 5, RTCORE_REFS_RUN, 0, 0.05, 3,
                             times) == 0 && count == 4, "not recording: no row");
    CHECK(rtcore_tick_sim_at(&r.tick, &s.link, 0, 0, 6, RTCORE_REFS_RUN, 0, 0.06, 3, 0) == -1,
          "no times: refused");
}

void run_tick_tests(void)
{
    test_gate_timing();
    test_references();
    test_trajectory();
    test_faults_vent();
    test_sim_link();
    test_tick_sim();
    test_tick_sim_at();
}
