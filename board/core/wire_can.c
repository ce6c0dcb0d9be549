/* can-v1 messages, packed and unpacked by the code cantools generates from
 * firmware_profiles/can-v1.dbc at build time (can_v1.h, can_v1.c in the build directory), so
 * the DBC stays the one truth. Byte 0 of every frame is the AUTOSAR E2E profile-2 CRC-8 over
 * the rest of the frame and the frame id's low byte. Sensor and valve messages travel as one
 * frame per finger; a valve command is complete, and valid, when every finger of one
 * sequence has arrived (a new sequence abandons an incomplete one).
 */
#include <math.h>
#include <string.h>

#include "board_internal.h"
#include "can_v1.h"
#include "hal.h"

#define NOT_REPORTED_RAW (-32768) /* the DBC's value table: pressure_meas_kpa not_reported */

uint8_t wire_can_e2e_crc(const uint8_t *data, uint8_t len, uint8_t data_id)
{
    uint8_t crc = 0xFFu;
    for (uint8_t i = 1; i <= len; i++) {
        crc ^= i < len ? data[i] : data_id;
        for (uint8_t bit = 0; bit < 8u; bit++) {
            crc = (crc & 0x80u) ? (uint8_t)((crc << 1) ^ 0x2Fu) : (uint8_t)(crc << 1);
        }
    }
    return (uint8_t)(crc ^ 0xFFu);
}

static void send(struct board *b, uint16_t id, struct board_unit *unit)
{
    unit->can_id = id;
    unit->data[0] = wire_can_e2e_crc(unit->data, unit->len, (uint8_t)(id & 0xFFu));
    board_emit(b, unit);
}

static float clamp(float v, float low, float high)
{
    return v < low ? low : (v > high ? high : v);
}

void wire_can_sensor(struct board *b, const float *flex_mv, const float *pressure_kpa)
{
    for (uint8_t i = 0; i < b->cfg.n_fingers; i++) {
        struct can_v1_sensor_finger_t msg;
        struct board_unit unit;
        can_v1_sensor_finger_init(&msg);
        msg.finger_index = i;
        msg.sequence = b->sequence;
        msg.command_sequence = b->command_sequence;
        /* flex_mv has no "not reported" value: a NaN reading is sent at the scale's end */
        const float mv = isnan(flex_mv[i]) ? 6553.5f : clamp(flex_mv[i], 0.0f, 6553.5f);
        msg.flex_mv = can_v1_sensor_finger_flex_mv_encode(mv);
        msg.pressure_meas_kpa = isnan(pressure_kpa[i])
            ? (int16_t)NOT_REPORTED_RAW
            : can_v1_sensor_finger_pressure_meas_kpa_encode(clamp(pressure_kpa[i], -655.34f, 655.34f));
        unit.len = (uint8_t)can_v1_sensor_finger_pack(unit.data, &msg, sizeof unit.data);
        send(b, CAN_V1_SENSOR_FINGER_FRAME_ID, &unit);
    }
}

void wire_can_status(struct board *b)
{
    struct can_v1_status_t msg;
    struct board_unit unit;
    can_v1_status_init(&msg);
    msg.state = b->state;
#ifdef BOARD_TEST_IMAGE
    msg.fault_active = inject_current(&b->inject);
#endif
    msg.rx_errors = (uint8_t)(b->rx_errors > 255u ? 255u : b->rx_errors);
    msg.fault_code = b->fault_code;
    msg.uptime_ms = board_uptime_ms(b);
    unit.len = (uint8_t)can_v1_status_pack(unit.data, &msg, sizeof unit.data);
    send(b, CAN_V1_STATUS_FRAME_ID, &unit);
}

void wire_can_version(struct board *b)
{
    struct can_v1_firmware_version_t msg;
    struct board_unit unit;
    can_v1_firmware_version_init(&msg);
    msg.protocol_version = board_announced_protocol(b);
    msg.firmware_major = b->cfg.firmware_version[0];
    msg.firmware_minor = b->cfg.firmware_version[1];
    msg.firmware_patch = b->cfg.firmware_version[2];
    msg.finger_count = b->cfg.n_fingers;
    unit.len = (uint8_t)can_v1_firmware_version_pack(unit.data, &msg, sizeof unit.data);
    send(b, CAN_V1_FIRMWARE_VERSION_FRAME_ID, &unit);
}

static void valve_frame(struct board *b, const uint8_t *data, uint8_t len, const struct board_rx *rx)
{
    struct can_v1_valve_command_t msg;
    if (can_v1_valve_command_unpack(&msg, data, len) != 0 || msg.finger_index >= b->cfg.n_fingers) {
        rx->bad_frame(b);
        return;
    }
    struct board_partial_command *p = &b->partial;
    if (!p->active || p->sequence != msg.sequence) {
        p->active = 1u;
        p->sequence = msg.sequence;
        p->received_mask = 0u;
    }
    p->pressure_kpa[msg.finger_index] = can_v1_valve_command_pressure_cmd_kpa_decode(msg.pressure_cmd_kpa);
    p->received_mask = (uint8_t)(p->received_mask | (1u << msg.finger_index));
    if (p->received_mask == (uint8_t)((1u << b->cfg.n_fingers) - 1u)) {
        p->active = 0u;
        rx->valve_command(b, p->sequence, p->pressure_kpa, b->cfg.n_fingers);
    }
}

static void frame(struct board *b, uint16_t id, const uint8_t *data, uint8_t len, const struct board_rx *rx)
{
    uint8_t expected;
    switch (id) {
    case CAN_V1_VALVE_COMMAND_FRAME_ID: expected = CAN_V1_VALVE_COMMAND_LENGTH; break;
    case CAN_V1_VERSION_REQUEST_FRAME_ID: expected = CAN_V1_VERSION_REQUEST_LENGTH; break;
#ifdef BOARD_TEST_IMAGE
    case CAN_V1_FAULT_INJECT_FRAME_ID: expected = CAN_V1_FAULT_INJECT_LENGTH; break;
#endif
    default: /* a frame for another node: a CAN bus is shared */
        if (board_breaks(b, INJECT_BROKEN_COUNTS_RUBBISH)) {
            rx->bad_frame(b);
        }
        return;
    }
    if (len != expected || data[0] != wire_can_e2e_crc(data, len, (uint8_t)(id & 0xFFu))) {
        rx->bad_frame(b);
        return;
    }
    if (id == CAN_V1_VALVE_COMMAND_FRAME_ID) {
        valve_frame(b, data, len, rx);
    } else if (id == CAN_V1_VERSION_REQUEST_FRAME_ID) {
        struct can_v1_version_request_t msg;
        (void)can_v1_version_request_unpack(&msg, data, len);
        rx->version_request(b, msg.protocol_version);
    }
#ifdef BOARD_TEST_IMAGE
    else {
        struct can_v1_fault_inject_t msg;
        (void)can_v1_fault_inject_unpack(&msg, data, len);
        rx->fault_request(b, msg.fault, msg.finger_index, msg.duration_ms, msg.value);
    }
#endif
}

void wire_can_receive(struct board *b, int bus_off, const struct board_rx *rx)
{
    uint16_t id;
    uint8_t data[8];
    uint8_t len;
    while (hal_can_read(&id, data, &len)) {
        /* bus-off (a test image's BUS_OFF): nothing arrives but the debug port, which is
         * not on the bus */
        if (!bus_off || id == CAN_V1_FAULT_INJECT_FRAME_ID) {
            frame(b, id, data, len, rx);
        }
    }
}
