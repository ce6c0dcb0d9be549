/* The supervisor's safety gate, on the control step's own structs. */
#include <math.h>

#include "rtcore_gate.h"

static int32_t found(rtcore_gate_result *result, int32_t cause, int32_t finger, double value,
                     double limit)
{
    if (result != 0) {
        result->cause = cause;
        result->finger = finger;
        result->value = value;
        result->limit = limit;
    }
    return cause;
}

static int32_t fingers(const rtcore_gate *gate)
{
    const int32_t n = gate->config.n_fingers;
    return n < 0 ? 0 : (n > RTCORE_MAX_FINGERS ? RTCORE_MAX_FINGERS : n);
}

void rtcore_gate_reset(rtcore_gate *gate)
{
    int32_t i;
    if (gate == 0) {
        return;
    }
    for (i = 0; i < RTCORE_MAX_FINGERS; ++i) {
        gate->expected_kpa[i] = 0.0;
        gate->leak_ticks[i] = 0;
        gate->rejected_ticks[i] = 0;
    }
    gate->overruns = 0;
    gate->has_frame = 0;
    gate->last_frame_ns = 0;
}

int32_t rtcore_gate_overrun(rtcore_gate *gate, int32_t missed_last, rtcore_gate_result *result)
{
    if (gate == 0) {
        return found(result, RTCORE_GATE_NON_FINITE, -1, NAN, NAN);
    }
    gate->overruns = missed_last ? gate->overruns + 1 : 0;
    if (gate->overruns >= gate->config.overrun_streak) {
        return found(result, RTCORE_GATE_OVERRUN_STREAK, -1, (double)gate->overruns,
                     (double)gate->config.overrun_streak);
    }
    return found(result, RTCORE_GATE_OK, -1, 0.0, 0.0);
}

int32_t rtcore_gate_frame(rtcore_gate *gate, int32_t fresh, int64_t lost_in_a_row, int64_t now_ns,
                          rtcore_gate_result *result)
{
    int64_t silent_ns;
    if (gate == 0) {
        return found(result, RTCORE_GATE_NON_FINITE, -1, NAN, NAN);
    }
    if (fresh) {
        gate->last_frame_ns = now_ns;
        gate->has_frame = 1;
        if (lost_in_a_row >= gate->config.stale_sensor_ticks) {
            return found(result, RTCORE_GATE_STALE_SENSOR, -1, (double)lost_in_a_row,
                         (double)gate->config.stale_sensor_ticks);
        }
        return found(result, RTCORE_GATE_OK, -1, 0.0, 0.0);
    }
    if (!gate->has_frame) { /* silence counts from the first check */
        gate->last_frame_ns = now_ns;
        gate->has_frame = 1;
    }
    silent_ns = now_ns - gate->last_frame_ns;
    if (silent_ns >= gate->config.transport_timeout_ns) {
        return found(result, RTCORE_GATE_TRANSPORT_LOST, -1, (double)silent_ns,
                     (double)gate->config.transport_timeout_ns);
    }
    return found(result, RTCORE_GATE_OK, -1, 0.0, 0.0);
}

int32_t rtcore_gate_inputs(const rtcore_gate *gate, const rtcore_inputs *in, rtcore_gate_result *result)
{
    int32_t i;
    if (gate == 0 || in == 0) {
        return found(result, RTCORE_GATE_NON_FINITE, -1, NAN, NAN);
    }
    for (i = 0; i < fingers(gate); ++i) {
        if (!isfinite(in->sensor_mv[i])) {
            return found(result, RTCORE_GATE_NON_FINITE, i, in->sensor_mv[i], NAN);
        }
        if (isinf(in->pressure_meas_kpa[i])) {
            return found(result, RTCORE_GATE_NON_FINITE, i, in->pressure_meas_kpa[i], NAN);
        }
    }
    return found(result, RTCORE_GATE_OK, -1, 0.0, 0.0);
}

int32_t rtcore_gate_outputs(rtcore_gate *gate, const rtcore_outputs *out, rtcore_gate_result *result)
{
    const rtcore_gate_config *c;
    int32_t cause = RTCORE_GATE_OK;
    int32_t i;
    if (gate == 0 || out == 0) {
        return found(result, RTCORE_GATE_NON_FINITE, -1, NAN, NAN);
    }
    c = &gate->config;
    for (i = 0; i < fingers(gate); ++i) { /* every finger's streak counts, every tick */
        if (out->flags[i] & (uint32_t)RTCORE_FLAG_SENSOR_REJECTED) {
            gate->rejected_ticks[i] += 1;
        } else {
            gate->rejected_ticks[i] = 0;
        }
        if (cause == RTCORE_GATE_OK && c->sensor_rejected_ticks > 0
            && gate->rejected_ticks[i] >= c->sensor_rejected_ticks) {
            cause = found(result, RTCORE_GATE_SENSOR_REJECTED, i, out->angle_deg[i],
                          (double)gate->rejected_ticks[i]);
        }
    }
    if (cause != RTCORE_GATE_OK) {
        return cause;
    }
    for (i = 0; i < fingers(gate); ++i) {
        const double angle = out->angle_deg[i];
        const double command = out->pressure_cmd_kpa[i];
        const double lowest_kpa = c->pressure_min_kpa[i] < 0.0 ? c->pressure_min_kpa[i] : 0.0;
        if (!isfinite(angle)) {
            return found(result, RTCORE_GATE_NON_FINITE, i, angle, NAN);
        }
        if (!isfinite(command)) {
            return found(result, RTCORE_GATE_NON_FINITE, i, command, NAN);
        }
        if (angle < c->angle_min_deg) {
            return found(result, RTCORE_GATE_ANGLE_OUT_OF_RANGE, i, angle, c->angle_min_deg);
        }
        if (angle > c->angle_max_deg) {
            return found(result, RTCORE_GATE_ANGLE_OUT_OF_RANGE, i, angle, c->angle_max_deg);
        }
        if (command > c->pressure_max_kpa[i]) {
            return found(result, RTCORE_GATE_PRESSURE_OVER_LIMIT, i, command, c->pressure_max_kpa[i]);
        }
        if (command < lowest_kpa) {
            return found(result, RTCORE_GATE_PRESSURE_OVER_LIMIT, i, command, lowest_kpa);
        }
    }
    return found(result, RTCORE_GATE_OK, -1, 0.0, 0.0);
}

int32_t rtcore_gate_follow(rtcore_gate *gate, const double *sent_kpa, const rtcore_inputs *in,
                           rtcore_gate_result *result)
{
    const rtcore_gate_config *c;
    int32_t worst = -1;
    int32_t i;
    if (gate == 0 || sent_kpa == 0 || in == 0) {
        return found(result, RTCORE_GATE_NON_FINITE, -1, NAN, NAN);
    }
    c = &gate->config;
    for (i = 0; i < fingers(gate); ++i) {
        /* NaN, not reported, compares false: never counted */
        if (fabs(in->pressure_meas_kpa[i] - gate->expected_kpa[i]) > c->leak_tolerance_kpa) {
            gate->leak_ticks[i] += 1;
        } else {
            gate->leak_ticks[i] = 0;
        }
        gate->expected_kpa[i] += c->follow_alpha[i] * (sent_kpa[i] - gate->expected_kpa[i]);
        if (gate->leak_ticks[i] >= c->leak_ticks && (worst < 0 || gate->leak_ticks[i] > gate->leak_ticks[worst])) {
            worst = i;
        }
    }
    if (worst >= 0) {
        return found(result, RTCORE_GATE_LEAK_OR_BURST, worst, in->pressure_meas_kpa[worst],
                     gate->expected_kpa[worst]);
    }
    return found(result, RTCORE_GATE_OK, -1, 0.0, 0.0);
}
