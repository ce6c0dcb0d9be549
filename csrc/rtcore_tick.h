/*
 * rtcore_tick: the supervisor's tick (csrc/rtcore_tick.c).
 * Everything a supervisor tick does between reading the sensors and sending the valve
 * commands, in one call on caller-owned structs: the gate's checks on the way in, the
 * references for the supervisor's state (a trajectory row, the API's targets, a hold or a
 * vent), the control step, the gate's checks on the way out, and the command to send.
 * The supervisor's state machine, the wording of a fault and the transports stay in
 * Python; each check's finding is in the struct for it to word.
 *
 * rtcore_tick_sim and rtcore_tick_sim_at run the tick on the simulated link
 * (rtcore_sim.h); rtcore_tick_sim_at also sleeps on the clock (rtcore_clock.h) and pushes
 * the ring row (rtcore_ring.h), which only its implementation needs.
 *
 * The block between the CDEF markers is read verbatim by rtcore/_build.py (with the
 * other headers' blocks, in the order listed there) and handed to cffi: keep it to
 * plain declarations and integer #defines.
 */
#ifndef RTCORE_TICK_H
#define RTCORE_TICK_H

#include <stdint.h>

#include "rtcore_gate.h"
#include "rtcore_sim.h"
#include "rtcore_step.h"

#ifdef __cplusplus
extern "C" {
#endif

/* BEGIN CDEF */
/* The references a tick feeds the step (the supervisor's state) */
#define RTCORE_REFS_VENT 0 /* every finger vents (INIT, DISARMED, ARMED, FAULT, ESTOP) */
#define RTCORE_REFS_HOLD 1 /* HOLD: every reference stays where it is, at rest */
#define RTCORE_REFS_RUN 2 /* RUNNING: the trajectory while it plays, else the targets */

/* What a tick found: bits of the return value */
#define RTCORE_TICK_OVERRUN 1
#define RTCORE_TICK_SAMPLE 2
#define RTCORE_TICK_FRAME 4
#define RTCORE_TICK_OUTPUT 8
#define RTCORE_TICK_LEAK 16
#define RTCORE_TICK_FAULTS 31
#define RTCORE_TICK_TRAJECTORY_END 32

/* A trajectory on the tick grid: n_ticks rows of n_fingers (the tick's), row-major, in
 * caller memory that outlives its use. driven[i] 0: finger i follows its target instead. */
typedef struct {
    const int32_t *mode;
    const double *angle_deg;
    const double *velocity_deg_per_s;
    const double *accel_deg_per_s2;
    const double *jerk_deg_per_s3;
    const double *force_n;
    int64_t n_ticks; /* 0: no trajectory */
    int32_t loop; /* from its start again at its end; else its last row becomes the targets */
    int32_t driven[RTCORE_MAX_FINGERS];
} rtcore_trajectory;

typedef struct {
    int32_t n_fingers;
    rtcore_hand *hand;
    rtcore_inputs *inputs;
    rtcore_outputs *outputs;
    rtcore_gate *gate;
    /* the API's targets, for the fingers no trajectory drives */
    int32_t target_mode[RTCORE_MAX_FINGERS];
    double target_angle_deg[RTCORE_MAX_FINGERS];
    double target_force_n[RTCORE_MAX_FINGERS];
    double target_pressure_kpa[RTCORE_MAX_FINGERS];
    rtcore_trajectory trajectory;
    int64_t trajectory_tick; /* the row the next RUNNING tick plays */
    int32_t trajectory_done; /* its end has been reached: the targets hold its last row */
    /* the command this tick sends: the step's, or 0 kPa when vented or at fault */
    double sent_kpa[RTCORE_MAX_FINGERS];
    /* the recording ring a tick that found nothing pushes its row into in
     * rtcore_tick_sim_at (rtcore_ring_push_tick); ring_rows 0: not recording */
    double *ring_rows;
    int64_t *ring_count;
    int32_t ring_capacity;
    int32_t ring_cols;
    /* what each check found this tick (cause RTCORE_GATE_OK: nothing) */
    rtcore_gate_result overrun;
    rtcore_gate_result sample;
    rtcore_gate_result frame;
    rtcore_gate_result output;
    rtcore_gate_result follow;
} rtcore_tick;

/* The tick up to the send. The caller has written a fresh sample into inputs->sensor_mv and
 * inputs->pressure_meas_kpa (fresh = 1, after lost_in_a_row lost ones) or left the last one.
 * Runs the overrun, sample and frame checks, the references for refs (RTCORE_REFS_*), the
 * step and the output checks, then sets sent_kpa: the step's command, or 0 kPa when refs
 * vents, vent is set (the caller found a fault of its own) or a check found one. Returns
 * RTCORE_TICK_* bits: the checks that found a fault, and RTCORE_TICK_TRAJECTORY_END when a
 * trajectory that does not loop ended (the targets now hold its last row: HOLD). */
int32_t rtcore_tick_control(rtcore_tick *tick, int32_t refs, int32_t vent, int32_t missed_last,
                            int32_t fresh, int64_t lost_in_a_row, int64_t woke_ns);
/* After the send: the leak-or-burst check on sent_kpa. RTCORE_TICK_LEAK or 0. */
int32_t rtcore_tick_follow(rtcore_tick *tick);

/* A whole tick on the simulated hand: on_tick, latest into the step's inputs, control,
 * send sent_kpa (its period left pending), follow. The RTCORE_TICK_* bits of both halves. */
int32_t rtcore_tick_sim(rtcore_tick *tick, rtcore_sim_link *link, int64_t tick_index, int32_t refs,
                        int32_t missed_last, int64_t woke_ns);
/* The scheduled tick on the simulated hand, with no Python between the wake-up and the
 * end: sleep to deadline_ns (rtcore_sleep_until_ns, spin_ns), rtcore_tick_sim, and when
 * it found nothing (the state did not change) the ring row of t_s and state. times_ns[0]
 * is the wake-up, times_ns[1] the end. Returns the RTCORE_TICK_* bits, the row left to
 * the caller when any is set; or -1 with nothing done when the sleep failed (times_ns[0]:
 * -EINTR, a signal woke it early, or another -errno). */
int32_t rtcore_tick_sim_at(rtcore_tick *tick, rtcore_sim_link *link, int64_t deadline_ns,
                           int64_t spin_ns, int64_t tick_index, int32_t refs, int32_t missed_last,
                           double t_s, int32_t state, int64_t *times_ns);
/* END CDEF */

/* The wake-up of a scheduled tick (rtcore_tick_sim_at, rtcore_can_tick_at): sleep to
 * deadline_ns (rtcore_sleep_until_ns, spin_ns), the time woken into times_ns[0] and [1].
 * Returns it, or a negative value with nothing else done when the sleep failed or
 * times_ns is null. */
int64_t rtcore_tick_wake(int64_t deadline_ns, int64_t spin_ns, int64_t *times_ns);

#ifdef __cplusplus
}
#endif

#endif /* RTCORE_TICK_H */
