/* The valve board's measuring side (board.c's loop calls it): the board's own faults, the
 * inner loop that measures every chamber and regulates it, and the sample it reports (with
 * a test image's sensor faults). */
#include <math.h>
#include <string.h>

#include "board.h"
#include "board_internal.h"
#include "hal.h"
#include "regulator.h"

#define OPEN_CIRCUIT_MV 65535.0f
#define DEFAULT_ERROR_FRAMES_PER_S 100u
#define US_PER_S 1000000u

/* -- faults of the board's own --------------------------------------------------------- */

static void enter_fault(struct board *b, uint8_t code)
{
    board_vent_valves(b);
    b->fault_code = code;
    b->fault_seen_us = b->now_us;
    board_set_state(b, BOARD_FAULT);
}

void board_own_faults(struct board *b)
{
#ifdef BOARD_TEST_IMAGE
    const int32_t injected = inject_value(&b->inject, INJECT_FIRMWARE_FAULT, BOARD_FAULT_VALVE_DRIVER);
    if (injected >= 0) {
        if (b->state != BOARD_FAULT) {
            enter_fault(b, (uint8_t)injected);
            b->fault_injected = 1u;
        }
        b->fault_seen_us = b->now_us;
        return;
    }
#endif
    /* an injected fault ends with its injection; a real one fault_clear_us after its cause */
    if (b->state == BOARD_FAULT && b->fault_code != BOARD_FAULT_INTERNAL
        && (b->fault_injected || board_reached(b->now_us, b->fault_seen_us + b->cfg.fault_clear_us))) {
        b->fault_injected = 0u;
        b->fault_code = BOARD_FAULT_NONE;
        memset(b->pressure_bad_ticks, 0, sizeof b->pressure_bad_ticks);
        board_set_state(b, BOARD_IDLE);
    }
}

/* -- the inner loop: measure every chamber, regulate it ------------------------------- */

static float pressure_from_adc(const struct board *b, uint16_t counts, int *valid)
{
    const float mv = (float)counts * b->cfg.adc_ref_mv / (float)b->cfg.adc_max_counts;
    *valid = mv >= b->cfg.pressure_valid_min_mv && mv <= b->cfg.pressure_valid_max_mv;
    return (mv - b->cfg.pressure_offset_mv) / b->cfg.pressure_sensitivity_mv_per_kpa;
}

void board_inner_tick(struct board *b)
{
    for (uint8_t i = 0; i < b->cfg.n_fingers; i++) {
        int valid;
        const float kpa = pressure_from_adc(b, hal_adc_read((uint8_t)(2u * i)), &valid);
        b->pressure_kpa[i] = valid ? kpa : NAN;
        if (valid) {
            b->pressure_sum_kpa[i] += kpa;
            b->pressure_ticks[i]++;
        }
        b->pressure_bad_ticks[i] = valid ? 0u : (uint16_t)(b->pressure_bad_ticks[i] + 1u);
        if (b->pressure_bad_ticks[i] >= b->cfg.pressure_fault_ticks) {
            if (b->state != BOARD_FAULT) {
                enter_fault(b, BOARD_FAULT_PRESSURE_SENSOR);
            }
            b->fault_seen_us = b->now_us;
        } else if (valid && kpa > b->cfg.pressure_limit_kpa) {
            if (b->state != BOARD_FAULT) {
                enter_fault(b, BOARD_FAULT_OVER_PRESSURE);
            }
            b->fault_seen_us = b->now_us;
        }
    }
    const int applying = b->state == BOARD_RUNNING;
    for (uint8_t i = 0; i < b->cfg.n_fingers; i++) {
        struct regulator *r = &b->regulators[i];
        if (applying) {
            regulator_step(r, &b->cfg.regulator, b->command_kpa[i], b->pressure_kpa[i]);
        } else {
            regulator_vent(r);
        }
        const int dead = board_breaks(b, INJECT_BROKEN_VALVES_DEAD)
                         || (board_breaks(b, INJECT_BROKEN_VALVE_STUCK) && i == INJECT_BROKEN_FINGER);
        hal_valve_pwm(i, HAL_VALVE_INLET, dead ? 0u : r->inlet_permille);
        hal_valve_pwm(i, HAL_VALVE_EXHAUST, dead ? 0u : r->exhaust_permille);
    }
}

/* -- sampling -------------------------------------------------------------------------- */

void board_sample(struct board *b)
{
    float flex_mv[BOARD_MAX_FINGERS];
    float pressure_kpa[BOARD_MAX_FINGERS];
    for (uint8_t i = 0; i < b->cfg.n_fingers; i++) {
        flex_mv[i] = (float)hal_adc_read((uint8_t)(2u * i + 1u)) * b->cfg.adc_ref_mv / (float)b->cfg.adc_max_counts;
        /* the mean over the sample period, not the newest tick: the valves' PWM ripples the
         * chamber pressure at the sample rate, and one tick of it would read the ripple's
         * phase as a pressure the finger never felt */
        pressure_kpa[i] = isnan(b->pressure_kpa[i]) || b->pressure_ticks[i] == 0u
                              ? b->pressure_kpa[i]
                              : b->pressure_sum_kpa[i] / (float)b->pressure_ticks[i];
        b->pressure_sum_kpa[i] = 0.0f;
        b->pressure_ticks[i] = 0u;
    }
#ifdef BOARD_TEST_IMAGE
    struct inject *in = &b->inject;
    struct inject_fault *stuck = &in->faults[INJECT_STUCK_SENSOR];
    struct inject_fault *frozen = &in->faults[INJECT_PRESSURE_STUCK];
    for (uint8_t k = 0; k < 2u; k++) {
        struct inject_fault *f = k == 0u ? stuck : frozen;
        float *values = k == 0u ? flex_mv : pressure_kpa;
        if (!f->active) {
            continue;
        }
        if (!f->held_valid) {
            memcpy(f->held, values, sizeof f->held);
            f->held_valid = 1u;
        }
        for (uint8_t i = 0; i < b->cfg.n_fingers; i++) {
            values[i] = inject_hits(f, i) ? f->held[i] : values[i];
        }
    }
    const struct inject_fault *wild = inject_active(in, INJECT_SENSOR_OUT_OF_RANGE);
    const struct inject_fault *flex_nan = inject_active(in, INJECT_SENSOR_NAN);
    const struct inject_fault *pressure_nan = inject_active(in, INJECT_PRESSURE_NAN);
    const struct inject_fault *drift = inject_active(in, INJECT_SENSOR_DRIFT);
    for (uint8_t i = 0; i < b->cfg.n_fingers; i++) {
        if (inject_hits(drift, i)) { /* `value` mV/s, signed 16-bit, from the request on */
            flex_mv[i] += (float)(int16_t)drift->value * (float)(uint32_t)(b->now_us - drift->since_us) * 1e-6f;
        }
        if (inject_hits(wild, i)) {
            flex_mv[i] = wild->value ? (float)wild->value : OPEN_CIRCUIT_MV;
        }
        if (inject_hits(flex_nan, i)) {
            flex_mv[i] = NAN;
        }
        if (inject_hits(pressure_nan, i)) {
            pressure_kpa[i] = NAN;
        }
    }
    for (uint8_t i = 0; i < b->cfg.n_fingers; i++) { /* the sensors a broken image misreports */
        if (board_breaks(b, INJECT_BROKEN_PRESSURE_NAN)) {
            pressure_kpa[i] = NAN;
        } else if (board_breaks(b, INJECT_BROKEN_PRESSURE_X2)) {
            pressure_kpa[i] *= 2.0f;
        }
    }
    if (b->cfg.n_fingers > INJECT_BROKEN_FINGER) {
        if (board_breaks(b, INJECT_BROKEN_FLEX_STUCK)) {
            if (!b->broken_flex_held) {
                b->broken_flex_mv = flex_mv[INJECT_BROKEN_FINGER];
                b->broken_flex_held = 1u;
            }
            flex_mv[INJECT_BROKEN_FINGER] = b->broken_flex_mv;
        } else if (board_breaks(b, INJECT_BROKEN_FLEX_X2)) {
            flex_mv[INJECT_BROKEN_FINGER] *= 2.0f;
        }
    }
#endif
    if (b->state == BOARD_RUNNING || !board_breaks(b, INJECT_BROKEN_QUIET_IDLE)) {
        board_send_sample(b, flex_mv, pressure_kpa);
    }
#ifdef BOARD_TEST_IMAGE
    if (!inject_active(in, INJECT_SEQUENCE_STUCK) && !board_breaks(b, INJECT_BROKEN_STUCK_SEQUENCE))
#endif
    {
        b->sequence++;
    }
    if (++b->samples_since_status >= b->cfg.status_every_samples) {
        b->samples_since_status = 0u;
        board_send_status(b);
    }
#ifdef BOARD_TEST_IMAGE
    /* CAN_ERROR_FRAMES: `value` error frames a second, as the host's driver reports errors on
     * a noisy bus (they do not pass through the link faults) */
    const int32_t per_s = inject_value(in, INJECT_CAN_ERROR_FRAMES, DEFAULT_ERROR_FRAMES_PER_S);
    if (per_s < 0) {
        in->error_credit = 0u;
        return;
    }
    in->error_credit += (uint64_t)per_s * b->cfg.sample_period_us;
    for (; in->error_credit >= US_PER_S; in->error_credit -= US_PER_S) {
        hal_can_error(0u);
    }
#endif
}
