/* The supervisor's tick between the sensors and the valves, in one call (rtcore_tick.h).
 *
 * In Python the same work was some twenty calls and a dozen small numpy copies. Each is
 * quick when warm, but a tick that wakes after the host has used the CPU runs them all
 * from cold caches, and that cold tick, not the warm one, sets the tick's p99. Here it is
 * a few loops over at most RTCORE_MAX_FINGERS fingers on structs the caller owns. */
#include <math.h>

#include "rtcore_clock.h"
#include "rtcore_gate.h"
#include "rtcore_ring.h"
#include "rtcore_sim.h"
#include "rtcore_step.h"
#include "rtcore_tick.h"

static int32_t tick_fingers(const rtcore_tick *tick)
{
    const int32_t n = tick->n_fingers;
    return n < 0 ? 0 : (n > RTCORE_MAX_FINGERS ? RTCORE_MAX_FINGERS : n);
}

static void target_references(rtcore_tick *tick, int32_t i)
{
    rtcore_inputs *in = tick->inputs;
    in->mode[i] = tick->target_mode[i];
    in->angle_ref_deg[i] = tick->target_angle_deg[i];
    in->velocity_ref_deg_per_s[i] = 0.0;
    in->accel_ref_deg_per_s2[i] = 0.0;
    in->jerk_ref_deg_per_s3[i] = 0.0;
    in->force_ref_n[i] = tick->target_force_n[i];
    in->pressure_ref_kpa[i] = tick->target_pressure_kpa[i];
}

static int playable(const rtcore_trajectory *traj)
{
    return traj->n_ticks > 0 && traj->mode != 0 && traj->angle_deg != 0 && traj->velocity_deg_per_s != 0
           && traj->accel_deg_per_s2 != 0 && traj->jerk_deg_per_s3 != 0 && traj->force_n != 0;
}

/* The end of a trajectory that does not loop: its last row becomes the targets of the
 * fingers it drove, so they hold where it left them. */
static void finish_trajectory(rtcore_tick *tick)
{
    const rtcore_trajectory *traj = &tick->trajectory;
    const int32_t n = tick_fingers(tick);
    const int64_t last = (traj->n_ticks - 1) * (int64_t)n;
    int32_t i;
    for (i = 0; i < n; ++i) {
        int32_t mode;
        if (!traj->driven[i]) {
            continue;
        }
        mode = traj->mode[last + i];
        tick->target_mode[i] = mode;
        if (mode == RTCORE_MODE_POSITION) {
            tick->target_angle_deg[i] = traj->angle_deg[last + i];
        } else if (mode == RTCORE_MODE_FORCE) {
            tick->target_force_n[i] = traj->force_n[last + i];
        }
    }
    tick->trajectory_done = 1;
}

/* RUNNING: row trajectory_tick of the trajectory for the fingers it drives, the targets
 * for the rest. Returns RTCORE_TICK_TRAJECTORY_END when it ended on this tick. */
static int32_t running_references(rtcore_tick *tick)
{
    const rtcore_trajectory *traj = &tick->trajectory;
    const int32_t n = tick_fingers(tick);
    rtcore_inputs *in = tick->inputs;
    int32_t events = 0;
    int64_t k;
    int32_t i;
    if (playable(traj) && !tick->trajectory_done && tick->trajectory_tick >= traj->n_ticks) {
        if (traj->loop) {
            tick->trajectory_tick %= traj->n_ticks;
        } else {
            finish_trajectory(tick);
            events = RTCORE_TICK_TRAJECTORY_END;
        }
    }
    if (!playable(traj) || tick->trajectory_done || tick->trajectory_tick < 0) {
        for (i = 0; i < n; ++i) {
            target_references(tick, i);
        }
        return events;
    }
    k = tick->trajectory_tick * (int64_t)n;
    for (i = 0; i < n; ++i) {
        if (!traj->driven[i]) {
            target_references(tick, i);
            continue;
        }
        in->mode[i] = traj->mode[k + i];
        in->angle_ref_deg[i] = traj->angle_deg[k + i];
        in->velocity_ref_deg_per_s[i] = traj->velocity_deg_per_s[k + i];
        in->accel_ref_deg_per_s2[i] = traj->accel_deg_per_s2[k + i];
        in->jerk_ref_deg_per_s3[i] = traj->jerk_deg_per_s3[k + i];
        in->force_ref_n[i] = traj->force_n[k + i];
        in->pressure_ref_kpa[i] = tick->target_pressure_kpa[i];
    }
    tick->trajectory_tick += 1;
    return events;
}

static int32_t references(rtcore_tick *tick, int32_t refs)
{
    const int32_t n = tick_fingers(tick);
    rtcore_inputs *in = tick->inputs;
    int32_t i;
    if (refs == RTCORE_REFS_RUN) {
        return running_references(tick);
    }
    for (i = 0; i < n; ++i) {
        if (refs == RTCORE_REFS_HOLD) { /* where it is, at rest */
            in->velocity_ref_deg_per_s[i] = 0.0;
            in->accel_ref_deg_per_s2[i] = 0.0;
            in->jerk_ref_deg_per_s3[i] = 0.0;
        } else {
            in->mode[i] = RTCORE_MODE_VENT;
        }
    }
    return 0;
}

static int ready(const rtcore_tick *tick)
{
    return tick != 0 && tick->hand != 0 && tick->inputs != 0 && tick->outputs != 0 && tick->gate != 0;
}

int32_t rtcore_tick_control(rtcore_tick *tick, int32_t refs, int32_t vent, int32_t missed_last,
                            int32_t fresh, int64_t lost_in_a_row, int64_t woke_ns)
{
    int32_t events = 0;
    int32_t i;
    if (!ready(tick)) {
        return RTCORE_TICK_OUTPUT;
    }
    if (rtcore_gate_overrun(tick->gate, missed_last, &tick->overrun) != RTCORE_GATE_OK) {
        events |= RTCORE_TICK_OVERRUN;
    }
    tick->sample.cause = RTCORE_GATE_OK;
    if (fresh && rtcore_gate_inputs(tick->gate, tick->inputs, &tick->sample) != RTCORE_GATE_OK) {
        events |= RTCORE_TICK_SAMPLE;
    }
    if (rtcore_gate_frame(tick->gate, fresh, lost_in_a_row, woke_ns, &tick->frame) != RTCORE_GATE_OK) {
        events |= RTCORE_TICK_FRAME;
    }
    events |= references(tick, refs);
    rtcore_hand_step(tick->hand, tick->inputs, tick->outputs);
    if (rtcore_gate_outputs(tick->gate, tick->outputs, &tick->output) != RTCORE_GATE_OK) {
        events |= RTCORE_TICK_OUTPUT;
    }
    vent = vent || refs == RTCORE_REFS_VENT || (events & RTCORE_TICK_FAULTS) != 0;
    for (i = 0; i < RTCORE_MAX_FINGERS; ++i) {
        tick->sent_kpa[i] = (vent || i >= tick_fingers(tick)) ? 0.0 : tick->outputs->pressure_cmd_kpa[i];
    }
    tick->follow.cause = RTCORE_GATE_OK;
    return events;
}

int32_t rtcore_tick_follow(rtcore_tick *tick)
{
    if (!ready(tick)) {
        return RTCORE_TICK_LEAK;
    }
    if (rtcore_gate_follow(tick->gate, tick->sent_kpa, tick->inputs, &tick->follow) != RTCORE_GATE_OK) {
        return RTCORE_TICK_LEAK;
    }
    return 0;
}

int32_t rtcore_tick_sim(rtcore_tick *tick, rtcore_sim_link *link, int64_t tick_index, int32_t refs,
                        int32_t missed_last, int64_t woke_ns)
{
    int32_t events;
    int32_t fresh;
    if (!ready(tick) || link == 0) {
        return RTCORE_TICK_OUTPUT;
    }
    rtcore_sim_link_on_tick(link, tick_index);
    fresh = rtcore_sim_link_latest(link, tick->inputs->sensor_mv, tick->inputs->pressure_meas_kpa);
    events = rtcore_tick_control(tick, refs, 0, missed_last, fresh, 0, woke_ns);
    rtcore_sim_link_send(link, tick->sent_kpa);
    return events | rtcore_tick_follow(tick);
}

int64_t rtcore_tick_wake(int64_t deadline_ns, int64_t spin_ns, int64_t *times_ns)
{
    int64_t woke;
    if (times_ns == 0) {
        return -1;
    }
    woke = rtcore_sleep_until_ns(deadline_ns, spin_ns);
    times_ns[0] = woke;
    times_ns[1] = woke;
    return woke;
}

int32_t rtcore_tick_sim_at(rtcore_tick *tick, rtcore_sim_link *link, int64_t deadline_ns,
                           int64_t spin_ns, int64_t tick_index, int32_t refs, int32_t missed_last,
                           double t_s, int32_t state, int64_t *times_ns)
{
    const int64_t woke = rtcore_tick_wake(deadline_ns, spin_ns, times_ns);
    int32_t events;
    if (woke < 0) {
        return -1;
    }
    events = rtcore_tick_sim(tick, link, tick_index, refs, missed_last, woke);
    if (events == 0 && tick->ring_rows != 0) {
        /* link->out: the sample this tick read (the link advances in the slack, after) */
        rtcore_ring_push_tick(tick->ring_rows, tick->ring_count, tick->ring_capacity, tick->ring_cols,
                              tick->n_fingers, tick->inputs, tick->outputs, tick->sent_kpa,
                              link->out != 0 ? link->out->angle_deg : 0, t_s, state);
    }
    times_ns[1] = rtcore_clock_now_ns();
    return events;
}
