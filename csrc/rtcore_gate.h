/*
 * rtcore_gate: the safety gate (csrc/rtcore_gate.c).
 * The supervisor's checks on every tick, on the control step's own input and output
 * structs, in code apart from the step's: a fault here must vent even if the step is
 * wrong. Each check returns RTCORE_GATE_OK or a cause and fills *result with the first
 * finger at fault, the offending value and the limit or expectation it broke.
 *
 * The block between the CDEF markers is read verbatim by rtcore/_build.py (with the
 * other headers' blocks, in the order listed there) and handed to cffi: keep it to
 * plain declarations and integer #defines.
 */
#ifndef RTCORE_GATE_H
#define RTCORE_GATE_H

#include <stdint.h>

#include "rtcore_step.h"

#ifdef __cplusplus
extern "C" {
#endif

/* BEGIN CDEF */
#define RTCORE_GATE_OK 0
#define RTCORE_GATE_NON_FINITE 1
#define RTCORE_GATE_ANGLE_OUT_OF_RANGE 2
#define RTCORE_GATE_PRESSURE_OVER_LIMIT 3
#define RTCORE_GATE_LEAK_OR_BURST 4
#define RTCORE_GATE_SENSOR_REJECTED 5
#define RTCORE_GATE_OVERRUN_STREAK 6
#define RTCORE_GATE_STALE_SENSOR 7
#define RTCORE_GATE_TRANSPORT_LOST 8

typedef struct {
    int32_t n_fingers;
    double angle_min_deg;
    double angle_max_deg;
    double pressure_min_kpa[RTCORE_MAX_FINGERS];
    double pressure_max_kpa[RTCORE_MAX_FINGERS];
    double leak_tolerance_kpa;
    int32_t leak_ticks;
    /* the measured chamber pressure is expected to follow the sent command through a
     * first-order lag: expected += follow_alpha * (sent - expected) every tick */
    double follow_alpha[RTCORE_MAX_FINGERS];
    /* ticks in a row the step may hold a rejected sensor reading before it is a fault */
    int32_t sensor_rejected_ticks;
    /* deadline misses in a row that are a fault */
    int32_t overrun_streak;
    /* the firmware's samples in a row that never reached the host: a stale sensor */
    int32_t stale_sensor_ticks;
    /* no sample at all for this long, on the host's clock: the transport is lost */
    int64_t transport_timeout_ns;
} rtcore_gate_config;

typedef struct {
    rtcore_gate_config config;
    double expected_kpa[RTCORE_MAX_FINGERS];
    int32_t leak_ticks[RTCORE_MAX_FINGERS];
    int32_t rejected_ticks[RTCORE_MAX_FINGERS];
    int32_t overruns; /* deadline misses in a row */
    int32_t has_frame; /* last_frame_ns holds a time */
    int64_t last_frame_ns; /* the wake-up of the tick with the newest sample, or of the first check */
} rtcore_gate;

typedef struct {
    int32_t cause;
    int32_t finger;
    double value;
    double limit;
} rtcore_gate_result;

void rtcore_gate_reset(rtcore_gate *gate);
/* Sensor mV finite; a measured pressure finite, or NaN (not reported), never infinite. */
int32_t rtcore_gate_inputs(const rtcore_gate *gate, const rtcore_inputs *in,
                           rtcore_gate_result *result);
/* Angle and command finite; angle within [min, max]; command at most the finger's
 * maximum and not below min(pressure_min_kpa, 0) (between 0 and a positive minimum is
 * the ramp out of a vent); a sensor reading the step has held (rejected) for
 * sensor_rejected_ticks ticks in a row. */
int32_t rtcore_gate_outputs(rtcore_gate *gate, const rtcore_outputs *out,
                            rtcore_gate_result *result);
/* Leak or burst: the measured pressure stays more than leak_tolerance_kpa away from the
 * expectation for leak_ticks ticks. Then the expectation moves toward sent_kpa. */
int32_t rtcore_gate_follow(rtcore_gate *gate, const double *sent_kpa, const rtcore_inputs *in,
                           rtcore_gate_result *result);
/* A streak of deadline misses: missed_last (the tick before missed its deadline) adds one,
 * a met deadline starts again; overrun_streak in a row is a fault (value: the streak). */
int32_t rtcore_gate_overrun(rtcore_gate *gate, int32_t missed_last, rtcore_gate_result *result);
/* The link at now_ns. fresh: a new sample this tick, after lost_in_a_row of the firmware's
 * samples that never arrived (stale_sensor_ticks of them is a stale sensor; value: that
 * count). Without one, silence since the last sample (or since the first check) of
 * transport_timeout_ns is a lost transport (value: the silence in ns). */
int32_t rtcore_gate_frame(rtcore_gate *gate, int32_t fresh, int64_t lost_in_a_row, int64_t now_ns,
                          rtcore_gate_result *result);
/* END CDEF */

#ifdef __cplusplus
}
#endif

#endif /* RTCORE_GATE_H */
