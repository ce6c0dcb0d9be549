/* The firmware core's C tests, against the fake HAL (fake_hal.h), built as a test image
 * (fault injection) under ASan and UBSan: make -C board test-core. The fixture and the
 * drivers: core_harness.c. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "board.h"
#include "board_internal.h"
#include "can_v1.h"
#include "core_harness.h"
#include "fake_hal.h"
#include "hal.h"

static void test_crcs(void)
{
    const uint8_t check[] = "123456789";
    CHECK(serial_v1_crc16(check, 9) == 0x29B1u); /* CRC-16/CCITT-FALSE check value */
    /* CRC-8/AUTOSAR check value 0xDF: our E2E CRC covers data[1..] and then the data id */
    uint8_t e2e[10] = {0, '1', '2', '3', '4', '5', '6', '7', '8'};
    CHECK(wire_can_e2e_crc(e2e, 9, '9') == 0xDFu);
}

static void test_decoder_hunts_through_garbage(void)
{
    struct serial_v1_decoder d;
    struct serial_v1_frame f;
    uint8_t stream[256];
    uint8_t payload[3] = {1, 2, 3};
    uint16_t n = 0;
    stream[n++] = 0x00;
    stream[n++] = 0xA5; /* a sync start in rubbish */
    stream[n++] = 0xA5;
    n = (uint16_t)(n + serial_v1_encode(stream + n, 7, 0x10, payload, 3));
    uint16_t bad = n;
    n = (uint16_t)(n + serial_v1_encode(stream + n, 8, 0x10, payload, 3));
    stream[bad + 6] ^= 0x01; /* a bad CRC */
    stream[n++] = 0xA5;
    stream[n++] = 0x5A;
    stream[n++] = 200; /* a length no frame has */
    n = (uint16_t)(n + serial_v1_encode(stream + n, 9, 0x30, payload, 2));
    serial_v1_decoder_init(&d);
    int got = 0;
    uint8_t sequences[4] = {0};
    for (uint16_t i = 0; i < n; i++) {
        serial_v1_feed(&d, stream[i]);
        while (serial_v1_next(&d, &f)) {
            if (got < 4) {
                sequences[got] = f.sequence;
            }
            got++;
        }
    }
    CHECK(got == 2);
    CHECK(sequences[0] == 7 && sequences[1] == 9);
    CHECK(d.crc_errors == 1);
}

static void test_boot_announces_version_then_status(void)
{
    boot(BOARD_WIRE_SERIAL);
    collect();
    CHECK(n_sent == 2);
    CHECK(sent[0].type == SERIAL_V1_VERSION_INFO && sent[1].type == SERIAL_V1_STATUS);
    CHECK(serial_v1_get_u16(sent[0].payload) == 1 && sent[0].payload[5] == 5);
    CHECK(sent[1].payload[0] == BOARD_IDLE);
    CHECK(fake.duty_permille[0][HAL_VALVE_EXHAUST] == 1000 && fake.duty_permille[0][HAL_VALVE_INLET] == 0);
    CHECK(fake.kicks > 0);
}

static uint32_t uptime_of(const struct sent *status)
{
    const uint8_t *p = status->payload + 3;
    return (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) | ((uint32_t)p[3] << 24);
}

static void test_samples_at_the_rate_while_idle(void)
{
    boot(BOARD_WIRE_SERIAL);
    run_for_us(1000000u);
    collect();
    const int samples = count_type(SERIAL_V1_SENSOR_REPORT);
    CHECK(samples >= 99 && samples <= 101);
    const int statuses = count_type(SERIAL_V1_STATUS);
    CHECK(statuses >= 10 && statuses <= 12);
    const struct sent *s = last_of(SERIAL_V1_SENSOR_REPORT);
    CHECK(s != NULL && s->length == 3 + 8 * 5);
    if (s != NULL) {
        CHECK(s->payload[0] == (uint8_t)(samples - 1)); /* the sequence from 0, one a sample */
        const float mv = serial_v1_get_f32(s->payload + 3);
        CHECK(fabsf(mv - 2000.0f * 5000.0f / 4095.0f) < 0.01f);
        CHECK(fabsf(serial_v1_get_f32(s->payload + 7)) < 0.5f);
    }
    const struct sent *st = last_of(SERIAL_V1_STATUS);
    CHECK(st != NULL && uptime_of(st) >= 990u);
}

static void test_command_runs_then_watchdog_vents(void)
{
    boot(BOARD_WIRE_SERIAL);
    send_command(42, 60.0f, 5);
    run_for_us(2000u);
    CHECK(b.state == BOARD_RUNNING);
    CHECK(b.command_sequence == 42);
    CHECK(fake.duty_permille[0][HAL_VALVE_INLET] == 1000 && fake.duty_permille[0][HAL_VALVE_EXHAUST] == 0);
    set_pressure(0, 59.6f); /* inside the deadband: hold */
    run_for_us(2000u);
    CHECK(fake.duty_permille[0][HAL_VALVE_INLET] == 0 && fake.duty_permille[0][HAL_VALVE_EXHAUST] == 0);
    set_pressure(0, 58.0f); /* a small error: at least the minimum pulse */
    run_for_us(2000u);
    CHECK(fake.duty_permille[0][HAL_VALVE_INLET] == 300);
    set_pressure(0, 70.0f); /* above: exhaust */
    run_for_us(2000u);
    CHECK(fake.duty_permille[0][HAL_VALVE_INLET] == 0 && fake.duty_permille[0][HAL_VALVE_EXHAUST] >= 580
          && fake.duty_permille[0][HAL_VALVE_EXHAUST] <= 620);
    /* the host goes quiet: vented after the watchdog time, not before */
    run_for_us(80000u);
    CHECK(b.state == BOARD_RUNNING);
    run_for_us(30000u);
    CHECK(b.state == BOARD_WATCHDOG_VENTED);
    CHECK(b.vent_count == 1);
    for (uint8_t i = 0; i < 5; i++) {
        CHECK(fake.duty_permille[i][HAL_VALVE_EXHAUST] == 1000 && fake.duty_permille[i][HAL_VALVE_INLET] == 0);
    }
    /* the next valid command runs again */
    send_command(43, 10.0f, 5);
    run_for_us(2000u);
    CHECK(b.state == BOARD_RUNNING);
}

static void test_invalid_commands_are_counted_and_ignored(void)
{
    boot(BOARD_WIRE_SERIAL);
    send_command(1, 30.0f, 4); /* the wrong finger count */
    send_command(2, NAN, 5);
    send_command(3, INFINITY, 5);
    uint8_t frame[SERIAL_V1_MAX_FRAME];
    uint8_t payload[22] = {4, 5};
    const uint16_t len = serial_v1_encode(frame, 0, SERIAL_V1_VALVE_COMMAND, payload, 22);
    frame[7] ^= 0x10; /* a bad CRC */
    fake_input(frame, len);
    run_for_us(5000u);
    CHECK(b.state == BOARD_IDLE);
    CHECK(b.rx_errors == 4);
    send_command(5, -20.0f, 5); /* a negative setpoint is a vent, valid */
    run_for_us(2000u);
    CHECK(b.state == BOARD_RUNNING && b.command_kpa[0] == 0.0f);
    send_command(6, 1000.0f, 5); /* above the board's limit: clamped to it */
    run_for_us(2000u);
    CHECK(b.command_kpa[0] == 300.0f);
}

static void test_version_request_and_refusal(void)
{
    boot(BOARD_WIRE_SERIAL);
    fake.out_len = 0;
    uint8_t request[2] = {2, 0}; /* protocol 2: not ours */
    send_simple(SERIAL_V1_VERSION_REQUEST, request, 2);
    run_for_us(200u);
    collect();
    CHECK(n_sent >= 2 && sent[0].type == SERIAL_V1_STATUS && sent[1].type == SERIAL_V1_VERSION_INFO);
    send_command(1, 30.0f, 5);
    run_for_us(2000u);
    CHECK(b.state == BOARD_IDLE); /* refused: commands ignored */
    request[0] = 1;
    send_simple(SERIAL_V1_VERSION_REQUEST, request, 2);
    send_command(2, 30.0f, 5);
    run_for_us(2000u);
    CHECK(b.state == BOARD_RUNNING);
}

static void test_over_pressure_and_sensor_faults(void)
{
    boot(BOARD_WIRE_SERIAL);
    send_command(1, 100.0f, 5);
    run_for_us(2000u);
    set_pressure(2, 320.0f);
    run_for_us(2000u);
    CHECK(b.state == BOARD_FAULT && b.fault_code == BOARD_FAULT_OVER_PRESSURE);
    CHECK(fake.duty_permille[0][HAL_VALVE_EXHAUST] == 1000);
    send_command(2, 100.0f, 5);
    run_for_us(2000u);
    CHECK(b.state == BOARD_FAULT); /* commands ignored */
    set_pressure(2, 0.0f);
    run_for_us(500000u);
    CHECK(b.state == BOARD_FAULT);
    run_for_us(600000u);
    CHECK(b.state == BOARD_IDLE && b.fault_code == 0);
    fake.adc_counts[4] = 0; /* chamber 2's sensor: open wire */
    run_for_us(3000u);
    CHECK(b.state == BOARD_IDLE); /* not before pressure_fault_ticks */
    run_for_us(5000u);
    CHECK(b.state == BOARD_FAULT && b.fault_code == BOARD_FAULT_PRESSURE_SENSOR);
    CHECK(isnan(b.pressure_kpa[2]));
}

static void test_injected_faults(void)
{
    boot(BOARD_WIRE_SERIAL);
    uint8_t drop[6] = {INJECT_DROP, 255, 0x2C, 0x01, 100, 0}; /* 300 ms, 100 % */
    send_simple(SERIAL_V1_FAULT_REQUEST, drop, 6);
    run_for_us(1000u);
    fake.out_len = 0;
    run_for_us(250000u);
    CHECK(fake.out_len == 0);
    run_for_us(100000u);
    CHECK(fake.out_len > 0); /* over after 300 ms */
    uint8_t reboot[6] = {INJECT_REBOOT, 255, 0, 0, 50, 0};
    send_command(9, 30.0f, 5);
    send_simple(SERIAL_V1_FAULT_REQUEST, reboot, 6);
    run_for_us(1000u);
    CHECK(b.state == BOARD_BOOTING);
    fake.out_len = 0;
    run_for_us(40000u);
    CHECK(fake.out_len == 0);
    run_for_us(20000u);
    collect();
    CHECK(n_sent >= 2 && sent[0].type == SERIAL_V1_VERSION_INFO && b.sequence < 3 && b.state == BOARD_IDLE);
    uint8_t fault[6] = {INJECT_FIRMWARE_FAULT, 255, 100, 0, 0, 0};
    send_simple(SERIAL_V1_FAULT_REQUEST, fault, 6);
    run_for_us(1000u);
    CHECK(b.state == BOARD_FAULT && b.fault_code == BOARD_FAULT_VALVE_DRIVER);
    run_for_us(110000u);
    CHECK(b.state == BOARD_IDLE);
    uint8_t wild[6] = {INJECT_SENSOR_OUT_OF_RANGE, 1, 0, 0, 0, 0};
    send_simple(SERIAL_V1_FAULT_REQUEST, wild, 6);
    fake.out_len = 0;
    run_for_us(20000u);
    collect();
    const struct sent *s = last_of(SERIAL_V1_SENSOR_REPORT);
    CHECK(s != NULL && serial_v1_get_f32(s->payload + 3 + 8) == 65535.0f);
    const struct sent *st = last_of(SERIAL_V1_STATUS);
    CHECK(st != NULL && st->payload[1] == INJECT_SENSOR_OUT_OF_RANGE);
}

static void can_command(uint8_t sequence, uint8_t finger, float kpa)
{
    struct can_v1_valve_command_t msg;
    uint8_t data[8];
    can_v1_valve_command_init(&msg);
    msg.finger_index = finger;
    msg.sequence = sequence;
    msg.pressure_cmd_kpa = can_v1_valve_command_pressure_cmd_kpa_encode(kpa);
    const int len = can_v1_valve_command_pack(data, &msg, sizeof data);
    data[0] = wire_can_e2e_crc(data, (uint8_t)len, (uint8_t)(CAN_V1_VALVE_COMMAND_FRAME_ID & 0xFFu));
    fake_can_input(CAN_V1_VALVE_COMMAND_FRAME_ID, data, (uint8_t)len);
}

static void test_can_wire(void)
{
    boot(BOARD_WIRE_CAN);
    CHECK(fake.can_out_len == 2 && fake.can_out[0].id == CAN_V1_FIRMWARE_VERSION_FRAME_ID);
    run_for_us(10000u);
    int sensor_frames = 0;
    for (uint32_t i = 0; i < fake.can_out_len; i++) {
        const struct fake_frame *f = &fake.can_out[i];
        CHECK(f->data[0] == wire_can_e2e_crc(f->data, f->len, (uint8_t)(f->id & 0xFFu)));
        sensor_frames += f->id == CAN_V1_SENSOR_FINGER_FRAME_ID;
    }
    CHECK(sensor_frames == 5);
    for (uint8_t i = 0; i < 4; i++) { /* four of five fingers: not yet a command */
        can_command(7, i, 40.0f);
    }
    run_for_us(1000u);
    CHECK(b.state == BOARD_IDLE);
    can_command(8, 0, 40.0f); /* a new sequence abandons the incomplete one */
    for (uint8_t i = 1; i < 5; i++) {
        can_command(8, i, 40.0f);
    }
    run_for_us(1000u);
    CHECK(b.state == BOARD_RUNNING && b.command_sequence == 8 && fabsf(b.command_kpa[4] - 40.0f) < 0.02f);
    uint8_t bad[6] = {0};
    fake_can_input(CAN_V1_VALVE_COMMAND_FRAME_ID, bad, 6);
    fake_can_input(0x555, bad, 6); /* another node's frame: not an error */
    run_for_us(1000u);
    CHECK(b.rx_errors == 1);
}

static void test_sample_reports_the_periods_mean_pressure(void)
{
    boot(BOARD_WIRE_SERIAL);
    for (int ms = 0; ms < 40; ms++) { /* a chamber that swings 20 <-> 40 kPa every tick (PWM ripple) */
        set_pressure(0, ms % 2 ? 40.0f : 20.0f);
        run_for_us(1000u);
    }
    collect();
    const struct sent *s = last_of(SERIAL_V1_SENSOR_REPORT);
    CHECK(s != NULL && fabsf(serial_v1_get_f32(s->payload + 7) - 30.0f) < 2.5f);
}

static void can_fault(uint8_t kind, uint16_t value)
{
    struct can_v1_fault_inject_t msg;
    uint8_t data[8];
    can_v1_fault_inject_init(&msg);
    msg.fault = kind;
    msg.finger_index = INJECT_ALL_FINGERS;
    msg.value = value;
    const int len = can_v1_fault_inject_pack(data, &msg, sizeof data);
    data[0] = wire_can_e2e_crc(data, (uint8_t)len, (uint8_t)(CAN_V1_FAULT_INJECT_FRAME_ID & 0xFFu));
    fake_can_input(CAN_V1_FAULT_INJECT_FRAME_ID, data, (uint8_t)len);
}

static void test_can_error_frames_and_bus_off(void)
{
    boot(BOARD_WIRE_CAN); /* a link without error frames (SLCAN): the request is ignored */
    can_fault(INJECT_CAN_ERROR_FRAMES, 200u);
    run_for_us(100000u);
    CHECK(fake.can_errors[0] == 0u && inject_current(&b.inject) == 0u);
    struct board_config cfg = board_config_defaults();
    cfg.wire = BOARD_WIRE_CAN;
    cfg.can_error_frames = 1u;
    boot_with(&cfg);
    can_fault(INJECT_CAN_ERROR_FRAMES, 200u);
    run_for_us(1000000u);
    CHECK(fake.can_errors[0] >= 198u && fake.can_errors[0] <= 202u);
    can_fault(INJECT_CLEAR, 0u);
    run_for_us(1000u);
    const uint32_t errors = fake.can_errors[0];
    can_fault(INJECT_BUS_OFF, 0u);
    run_for_us(1000u);
    CHECK(fake.can_errors[0] == errors && fake.can_errors[1] == 1u);
    fake.can_out_len = 0;
    run_for_us(50000u);
    CHECK(fake.can_out_len == 0u); /* bus-off: nothing crosses */
}

static void test_clock_drift_moves_every_time_the_board_keeps(void)
{
    boot(BOARD_WIRE_SERIAL);
    uint8_t fast[6] = {INJECT_CLOCK_DRIFT, 255, 0, 0, 0x20, 0x4E}; /* +20000 ppm */
    send_simple(SERIAL_V1_FAULT_REQUEST, fast, 6);
    run_for_us(100u);
    const uint32_t up0 = board_uptime_ms(&b);
    const uint8_t seq0 = b.sequence;
    run_for_us(1000000u);
    const uint32_t fast_ms = board_uptime_ms(&b) - up0;
    CHECK(fast_ms >= 1018u && fast_ms <= 1022u);
    CHECK((uint8_t)(b.sequence - seq0) >= 101u && (uint8_t)(b.sequence - seq0) <= 103u);
    uint8_t slow[6] = {INJECT_CLOCK_DRIFT, 255, 0, 0, 0xE0, 0xB1}; /* -20000 ppm (signed 16-bit) */
    send_simple(SERIAL_V1_FAULT_REQUEST, slow, 6);
    run_for_us(100u);
    const uint32_t up1 = board_uptime_ms(&b);
    run_for_us(1000000u);
    const uint32_t slow_ms = board_uptime_ms(&b) - up1;
    CHECK(slow_ms >= 978u && slow_ms <= 982u);
}

static void test_bad_config_stays_vented(void)
{
    fake_reset();
    struct board_config cfg = board_config_defaults();
    cfg.inner_period_us = 5000u; /* below 500 Hz */
    CHECK(board_init(&b, &cfg) == -1);
    run_for_us(50000u);
    CHECK(b.state == BOARD_FAULT && b.fault_code == BOARD_FAULT_INTERNAL);
    CHECK(fake.duty_permille[0][HAL_VALVE_EXHAUST] == 1000 && fake.out_len == 0);
}

int main(void)
{
    test_crcs();
    test_decoder_hunts_through_garbage();
    test_boot_announces_version_then_status();
    test_samples_at_the_rate_while_idle();
    test_command_runs_then_watchdog_vents();
    test_invalid_commands_are_counted_and_ignored();
    test_version_request_and_refusal();
    test_over_pressure_and_sensor_faults();
    test_injected_faults();
    test_sample_reports_the_periods_mean_pressure();
    test_can_wire();
    test_can_error_frames_and_bus_off();
    test_clock_drift_moves_every_time_the_board_keeps();
    test_bad_config_stays_vented();
    if (failures) {
        fprintf(stderr, "test-core: %d check(s) failed\n", failures);
        return EXIT_FAILURE;
    }
    printf("test-core: all passed\n");
    return EXIT_SUCCESS;
}
