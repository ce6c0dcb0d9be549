/* The valve-board firmware core (board.h): the state machine, sampling on the board's own
 * clock, the pressure loops, the watchdog and the board's own faults. Its decisions:
 *
 * - boot: valves vented; VersionInfo, then Status; counters (sample and frame sequence,
 *   rx_errors, uptime) from zero; IDLE until the first valid command.
 * - a valid command: a complete ValveCommand with this hand's finger count and finite
 *   setpoints. It is applied (clamped to 0 .. pressure_limit_kpa: a chamber cannot be
 *   driven below the atmosphere) and feeds the watchdog; the first one makes the board
 *   RUNNING. A vent is a command of 0 kPa for every finger.
 * - the handshake: a VersionRequest is answered with Status, then VersionInfo. A request
 *   for a protocol this board does not speak is refused: it answers all the same (so the
 *   host can name both versions), stays vented and ignores valve commands until a request
 *   for its own protocol.
 * - samples at the profile's rate, on the board's clock, while not BOOTING: every state
 *   reports (idle and vented too); Status every status_every_samples samples and at once
 *   on a change of state.
 * - the watchdog: RUNNING with no valid command for watchdog_us -> every chamber vented,
 *   WATCHDOG_VENTED, until the next valid command.
 * - the board's own faults: a pressure above pressure_limit_kpa (OVER_PRESSURE), a
 *   pressure sensor outside its valid output (PRESSURE_SENSOR): vent, FAULT, commands
 *   ignored; it clears fault_clear_us after the condition ends (to IDLE: vented until the
 *   next valid command).
 */
#include "board.h"

#include <math.h>
#include <string.h>

#include "board_internal.h"
#include "hal.h"

#define CATCH_UP_SAMPLES 25u
#define DEFAULT_BOOT_MS 200u
#define DEFAULT_DRIFT_PPM 20000u

struct board_config board_config_defaults(void)
{
    struct board_config c;
    memset(&c, 0, sizeof c);
    c.wire = BOARD_WIRE_SERIAL;
    c.n_fingers = 5u;
    c.protocol_version = 1u;
    c.firmware_version[0] = 1u;
    c.sample_period_us = 10000u;       /* 100 Hz: the shipped profiles' control.rate_hz */
    c.watchdog_us = 100000u;           /* the shipped profiles' firmware_watchdog_ms */
    c.inner_period_us = 1000u;         /* 1 kHz pressure loops */
    c.status_every_samples = 10u;      /* 10 Hz heartbeat at 100 Hz */
    c.adc_max_counts = 4095u;          /* 12-bit ADC over 5 V: 1.22 mV a count */
    c.adc_ref_mv = 5000.0f;
    /* an MPX5700-class sensor: 0.2 V at 0 kPa gauge, 6.4 mV/kPa, 4.7 V at 700 kPa */
    c.pressure_offset_mv = 200.0f;
    c.pressure_sensitivity_mv_per_kpa = 6.4f;
    c.pressure_valid_min_mv = 100.0f;  /* below: open wire (the output never goes under 0.2 V - noise) */
    c.pressure_valid_max_mv = 4900.0f; /* above: shorted to the supply */
    c.pressure_fault_ticks = 5u;
    c.pressure_limit_kpa = 300.0f;     /* above every shipped finger's pressure_max_kpa (250) */
    c.fault_clear_us = 1000000u;
    c.regulator.deadband_kpa = 1.0f;
    c.regulator.gain_permille_per_kpa = 60.0f; /* full duty from about 17 kPa of error */
    c.regulator.pwm_period_us = 10000u;        /* 100 Hz PWM */
    c.regulator.min_pulse_us = 3000u;          /* longer than the valves' opening delay */
    c.regulator.vent_below_kpa = 0.5f;
    return c;
}

static int config_ok(const struct board_config *c)
{
    return c->n_fingers >= 1u && c->n_fingers <= BOARD_MAX_FINGERS && c->sample_period_us > 0u
        && c->watchdog_us > 0u && c->inner_period_us > 0u && c->inner_period_us <= 2000u
        && c->status_every_samples > 0u && c->adc_max_counts > 0u && c->adc_ref_mv > 0.0f
        && c->pressure_sensitivity_mv_per_kpa > 0.0f && c->pressure_limit_kpa > 0.0f
        && c->regulator.pwm_period_us > 0u && c->regulator.min_pulse_us <= c->regulator.pwm_period_us
        && (c->wire == BOARD_WIRE_SERIAL || c->wire == BOARD_WIRE_CAN);
}

static void announce(struct board *b)
{
    b->state = BOARD_IDLE;
    b->uptime_ms = 0u;
    b->uptime_rem_us = 0u;
    b->sequence = 0u;
    b->command_sequence = 0u;
    b->tx_frame_sequence = 0u;
    b->samples_since_status = 0u;
    b->rx_errors = 0u;
    b->refused = 0u;
    b->next_sample_us = b->now_us + b->cfg.sample_period_us;
    if (!board_breaks(b, INJECT_BROKEN_SILENT_REBOOT)) {
        board_send_version(b);
    }
    board_send_status(b);
}

int board_init(struct board *b, const struct board_config *cfg)
{
    memset(b, 0, sizeof *b);
    b->cfg = *cfg;
    if (!config_ok(cfg)) {
        b->cfg = board_config_defaults();
        b->cfg.n_fingers = cfg->n_fingers >= 1u && cfg->n_fingers <= BOARD_MAX_FINGERS ? cfg->n_fingers : 1u;
        b->state = BOARD_FAULT;
        b->fault_code = BOARD_FAULT_INTERNAL;
        board_vent_valves(b);
        return -1;
    }
    serial_v1_decoder_init(&b->decoder);
#ifdef BOARD_TEST_IMAGE
    inject_init(&b->inject, 0x5EEDu);
#endif
    b->now_us = hal_time_us();
    b->hal_last_us = b->now_us;
    b->last_poll_us = b->now_us;
    b->state = BOARD_BOOTING;
    b->boot_end_us = b->now_us;
    b->next_inner_us = b->now_us;
    board_vent_valves(b);
    return 0;
}

/* -- decoded messages ------------------------------------------------------------------ */

static void board_on_bad_frame(struct board *b)
{
    if (b->state != BOARD_BOOTING) {
        b->rx_errors++;
    }
}

static int all_zero(const float *pressure_kpa, uint8_t n)
{
    for (uint8_t i = 0; i < n; i++) {
        if (pressure_kpa[i] != 0.0f) {
            return 0;
        }
    }
    return 1;
}

static void board_on_valve_command(struct board *b, uint8_t sequence, const float *pressure_kpa, uint8_t n)
{
    if (b->state == BOARD_BOOTING || b->state == BOARD_FAULT || b->refused || n != b->cfg.n_fingers) {
        return; /* a board at fault keeps its valves vented whatever it is told */
    }
    if (board_breaks(b, INJECT_BROKEN_ZERO_VENTS) && all_zero(pressure_kpa, n)
        && (b->state == BOARD_RUNNING || b->state == BOARD_WATCHDOG_VENTED)) {
        board_vent_valves(b); /* acknowledged and vented, but no longer running */
        b->command_sequence = sequence;
        b->last_command_us = b->now_us;
        board_set_state(b, BOARD_WATCHDOG_VENTED);
        return;
    }
#ifdef BOARD_TEST_IMAGE
    const int ignored = inject_active(&b->inject, INJECT_VALVES_IGNORED) != 0;
#else
    const int ignored = 0;
#endif
    if (!ignored) { /* else it acknowledges and holds (the test image's VALVES_IGNORED) */
        for (uint8_t i = 0; i < n; i++) {
            const float kpa = pressure_kpa[i];
            b->command_kpa[i] = kpa < 0.0f ? 0.0f : (kpa > b->cfg.pressure_limit_kpa ? b->cfg.pressure_limit_kpa : kpa);
        }
    }
    b->command_sequence = sequence;
    b->last_command_us = b->now_us;
    board_set_state(b, BOARD_RUNNING);
}

static void board_on_version_request(struct board *b, uint16_t protocol_version)
{
    if (b->state == BOARD_BOOTING) {
        return;
    }
    if (board_breaks(b, INJECT_BROKEN_ECHO_VERSION)) { /* says it speaks whatever it is asked */
        board_send_status(b);
        b->echo_protocol = protocol_version;
        board_send_version(b);
        b->echo_protocol = 0u;
        return;
    }
    b->refused = protocol_version != b->cfg.protocol_version;
    if (b->refused && b->state == BOARD_RUNNING) {
        board_vent_valves(b);
        b->state = BOARD_IDLE;
    }
    board_send_status(b);
    board_send_version(b);
}

static void board_on_fault_request(struct board *b, uint8_t kind, uint8_t finger, uint16_t duration_ms,
                            uint16_t value)
{
#ifdef BOARD_TEST_IMAGE
    if (b->state == BOARD_BOOTING) {
        return;
    }
    if (kind == INJECT_REBOOT) { /* reset now: vent, go silent for `value` ms, announce again */
        board_vent_valves(b);
        inject_clear(&b->inject);
        b->fault_code = BOARD_FAULT_NONE;
        b->fault_injected = 0u;
        b->state = BOARD_BOOTING;
        b->boot_end_us = b->now_us + (uint32_t)(value ? value : DEFAULT_BOOT_MS) * 1000u;
        serial_v1_decoder_init(&b->decoder);
        memset(&b->partial, 0, sizeof b->partial);
        return;
    }
    if (kind >= INJECT_KINDS
        || (kind == INJECT_CAN_ERROR_FRAMES && (b->cfg.wire != BOARD_WIRE_CAN || !b->cfg.can_error_frames))
        || (kind == INJECT_BUS_OFF && b->cfg.wire != BOARD_WIRE_CAN)
        || (kind == INJECT_SENSOR_NAN && b->cfg.wire == BOARD_WIRE_CAN)) {
        return; /* not on this link or this board (as the mock ignores what its link cannot carry) */
    }
    inject_request(&b->inject, kind, finger, duration_ms, value, b->now_us);
    if (kind == INJECT_BUS_OFF) {
        hal_can_error(1u); /* the driver says so, then nothing crosses */
    }
    board_send_status(b);
    if (kind == INJECT_PROTOCOL_CHANGE) {
        board_send_version(b);
    }
#else
    (void)kind;
    (void)finger;
    (void)duration_ms;
    (void)value;
    board_on_bad_frame(b);
#endif
}

/* what the wires hand up */
static const struct board_rx RX = {board_on_valve_command, board_on_version_request, board_on_fault_request,
                                   board_on_bad_frame};

/* -- the main loop --------------------------------------------------------------------- */

static void receive(struct board *b)
{
    if (b->cfg.wire == BOARD_WIRE_CAN) {
#ifdef BOARD_TEST_IMAGE
        wire_can_receive(b, inject_active(&b->inject, INJECT_BUS_OFF) != 0, &RX);
#else
        wire_can_receive(b, 0, &RX);
#endif
    } else {
        wire_serial_receive(b, &RX);
    }
}

/* The board's clock: the HAL's, or (a test image's CLOCK_DRIFT) one running fast or slow
 * by `value` ppm (signed 16-bit: above 32767 is slow), as a board's oscillator would; every
 * time the board keeps (samples, watchdog, uptime, fault durations) moves with it. */
static uint32_t board_clock(struct board *b)
{
    const uint32_t hal_us = hal_time_us();
    const uint32_t delta_us = hal_us - b->hal_last_us;
    b->hal_last_us = hal_us;
    uint32_t now_us = b->now_us + delta_us;
#ifdef BOARD_TEST_IMAGE
    const int32_t value = inject_value(&b->inject, INJECT_CLOCK_DRIFT, DEFAULT_DRIFT_PPM);
    if (value >= 0) {
        const int32_t ppm = value >= 32768 ? value - 65536 : value;
        const uint32_t step_us = delta_us > 1000000u ? 1000000u : delta_us; /* no overflow below */
        const int64_t scaled = (int64_t)step_us * ppm + b->drift_remainder; /* us * ppm */
        const int32_t extra_us = (int32_t)(scaled / 1000000);
        b->drift_remainder = (int32_t)(scaled - (int64_t)extra_us * 1000000);
        now_us += (uint32_t)extra_us; /* modular: a negative extra slows the clock */
    }
#endif
    return now_us;
}

void board_poll(struct board *b)
{
    b->now_us = board_clock(b);
    b->uptime_rem_us += b->now_us - b->last_poll_us;
    b->last_poll_us = b->now_us;
    b->uptime_ms += b->uptime_rem_us / 1000u;
    b->uptime_rem_us %= 1000u;
    hal_watchdog_kick();
    if (b->state == BOARD_FAULT && b->fault_code == BOARD_FAULT_INTERNAL) {
        board_vent_valves(b); /* a configuration it cannot run: vented for good */
        return;
    }
    receive(b);
#ifdef BOARD_TEST_IMAGE
    if (inject_expire(&b->inject, b->now_us) > 0u && b->state != BOARD_BOOTING) {
        board_send_status(b); /* the status says the fault is over */
    }
#endif
    if (b->state == BOARD_BOOTING) {
        if (!board_reached(b->now_us, b->boot_end_us)) {
            return;
        }
        announce(b);
    }
    board_own_faults(b);
    if (b->state == BOARD_RUNNING && !board_reached(b->last_command_us + b->cfg.watchdog_us, b->now_us)
        && !board_breaks(b, INJECT_BROKEN_NO_WATCHDOG)) {
        board_vent_valves(b);
        b->vent_count++;
        b->vent_us = b->now_us;
        board_set_state(b, BOARD_WATCHDOG_VENTED);
    }
    if (board_reached(b->now_us, b->next_inner_us)) {
        board_inner_tick(b);
        b->next_inner_us += b->cfg.inner_period_us;
        if (board_reached(b->now_us, b->next_inner_us)) { /* behind: no burst, the next tick from now */
            b->next_inner_us = b->now_us + b->cfg.inner_period_us;
        }
    }
    /* the sample timer keeps its phase: samples missed while the loop was held up are
     * taken now, in a short burst, as a timer interrupt would have queued them */
    uint8_t taken = 0u;
    while (board_reached(b->now_us, b->next_sample_us) && taken < CATCH_UP_SAMPLES) {
        board_sample(b);
        b->next_sample_us += b->cfg.sample_period_us;
        taken++;
    }
    if (board_reached(b->now_us, b->next_sample_us)) {
        b->next_sample_us = b->now_us + b->cfg.sample_period_us;
    }
#ifdef BOARD_TEST_IMAGE
    struct board_unit unit;
    while (inject_release(&b->inject, b->now_us, &unit)) {
        if (b->cfg.wire == BOARD_WIRE_CAN) {
            hal_can_write(unit.can_id, unit.data, unit.len);
        } else {
            hal_serial_write(unit.data, unit.len);
        }
    }
#endif
}
