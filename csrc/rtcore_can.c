/* The host's can-v1 codec around the pack/unpack cantools generates (rtcore_can.h).
 *
 * Scaled values are turned into raw ones as cantools' Python encoder does, (value -
 * offset) / scale rounded half to even (nearbyint in the default rounding mode), with the
 * scale and offset read back from the generated decode functions, so that a frame encoded
 * here is byte for byte the frame hand_service/wire/can_codec.py encodes (the encoder:
 * rtcore_can_encode.c). The tick that uses it: rtcore_can_tick.c. */
#include <math.h>
#include <string.h>

#include "rtcore_can_v1.h"
#include "rtcore_can.h"

uint8_t rtcore_can_e2e_crc(const uint8_t *data, int32_t len, uint8_t data_id)
{
    uint8_t crc = 0xFFu;
    int32_t i;
    int bit;
    for (i = 1; i <= len; ++i) {
        crc ^= i < len ? data[i] : data_id;
        for (bit = 0; bit < 8; ++bit) {
            crc = (crc & 0x80u) ? (uint8_t)((crc << 1) ^ 0x2Fu) : (uint8_t)(crc << 1);
        }
    }
    return (uint8_t)(crc ^ 0xFFu);
}

static int32_t clamp_fingers(int32_t n)
{
    return n < 1 ? 1 : (n > RTCORE_MAX_FINGERS ? RTCORE_MAX_FINGERS : n);
}

void rtcore_can_init(rtcore_can *can, int32_t n_fingers, double flex_low_mv, double flex_high_mv,
                     double pressure_meas_low_kpa, double pressure_meas_high_kpa, double command_low_kpa,
                     double command_high_kpa)
{
    if (can == 0) {
        return;
    }
    memset(can, 0, sizeof *can);
    can->n_fingers = clamp_fingers(n_fingers);
    can->flex_low_mv = flex_low_mv;
    can->flex_high_mv = flex_high_mv;
    can->pressure_meas_low_kpa = pressure_meas_low_kpa;
    can->pressure_meas_high_kpa = pressure_meas_high_kpa;
    can->command_low_kpa = command_low_kpa;
    can->command_high_kpa = command_high_kpa;
}

void rtcore_can_reset(rtcore_can *can)
{
    if (can != 0) {
        can->sensor.active = 0;
        can->valve.active = 0;
        can->has_last_sample = 0;
    }
}

/* -- decoding ------------------------------------------------------------------------- */

static int32_t expected_length(int32_t id, int32_t *kind)
{
    switch (id) {
    case RTCORE_CAN_V1_SENSOR_FINGER_FRAME_ID: *kind = RTCORE_CAN_SENSOR; return RTCORE_CAN_V1_SENSOR_FINGER_LENGTH;
    case RTCORE_CAN_V1_VALVE_COMMAND_FRAME_ID: *kind = RTCORE_CAN_VALVE; return RTCORE_CAN_V1_VALVE_COMMAND_LENGTH;
    case RTCORE_CAN_V1_STATUS_FRAME_ID: *kind = RTCORE_CAN_STATUS; return RTCORE_CAN_V1_STATUS_LENGTH;
    case RTCORE_CAN_V1_FIRMWARE_VERSION_FRAME_ID: *kind = RTCORE_CAN_VERSION; return RTCORE_CAN_V1_FIRMWARE_VERSION_LENGTH;
    case RTCORE_CAN_V1_VERSION_REQUEST_FRAME_ID:
        *kind = RTCORE_CAN_VERSION_REQUEST;
        return RTCORE_CAN_V1_VERSION_REQUEST_LENGTH;
    case RTCORE_CAN_V1_FAULT_INJECT_FRAME_ID: *kind = RTCORE_CAN_FAULT_INJECT; return RTCORE_CAN_V1_FAULT_INJECT_LENGTH;
    default: *kind = RTCORE_CAN_NONE; return -1;
    }
}

static int32_t bad(rtcore_can *can, int32_t kind)
{
    can->decode_errors += 1;
    can->last_error = kind;
    return 0;
}

/* One finger's frame into its partial message; 1 (and *out) when every finger is in. */
static int32_t assemble(rtcore_can *can, rtcore_can_partial *p, int32_t kind, int32_t finger, int32_t sequence,
                        int32_t command_sequence, double first, double second, rtcore_can_message *out)
{
    const int32_t n = can->n_fingers;
    int32_t i;
    if (finger >= n) {
        return bad(can, kind);
    }
    if (!p->active || p->sequence != sequence) {
        if (p->active) {
            can->incomplete += 1;
        }
        p->active = 1;
        p->sequence = sequence;
        p->command_sequence = command_sequence;
        p->received_mask = 0u;
    }
    p->first[finger] = first;
    p->second[finger] = second;
    p->received_mask |= 1u << finger;
    if (p->received_mask != (1u << n) - 1u) {
        return 0;
    }
    p->active = 0;
    memset(out, 0, sizeof *out);
    out->kind = kind;
    out->sequence = p->sequence;
    out->n_fingers = n;
    if (kind == RTCORE_CAN_SENSOR) {
        out->command_sequence = p->command_sequence;
        for (i = 0; i < n; ++i) {
            out->sensor_mv[i] = p->first[i];
            out->pressure_meas_kpa[i] = p->second[i];
        }
    } else {
        for (i = 0; i < n; ++i) {
            out->pressure_cmd_kpa[i] = p->first[i];
        }
    }
    return 1;
}

static int32_t decode_sensor(rtcore_can *can, const uint8_t *data, int32_t len, rtcore_can_message *out)
{
    struct rtcore_can_v1_sensor_finger_t m;
    double pressure_kpa;
    (void)rtcore_can_v1_sensor_finger_unpack(&m, data, (size_t)len);
    pressure_kpa = m.pressure_meas_kpa == RTCORE_CAN_V1_SENSOR_FINGER_PRESSURE_MEAS_KPA_NOT_REPORTED_CHOICE
                       ? NAN
                       : rtcore_can_v1_sensor_finger_pressure_meas_kpa_decode(m.pressure_meas_kpa);
    return assemble(can, &can->sensor, RTCORE_CAN_SENSOR, m.finger_index, m.sequence, m.command_sequence,
                    rtcore_can_v1_sensor_finger_flex_mv_decode(m.flex_mv), pressure_kpa, out);
}

static int32_t decode_valve(rtcore_can *can, const uint8_t *data, int32_t len, rtcore_can_message *out)
{
    struct rtcore_can_v1_valve_command_t m;
    (void)rtcore_can_v1_valve_command_unpack(&m, data, (size_t)len);
    return assemble(can, &can->valve, RTCORE_CAN_VALVE, m.finger_index, m.sequence, 0,
                    rtcore_can_v1_valve_command_pressure_cmd_kpa_decode(m.pressure_cmd_kpa), 0.0, out);
}

/* The single-frame messages. A state or a fault kind the DBC's value table does not name
 * is a frame this host cannot read (as FirmwareState(x) and FaultKind(x) refuse it). */
static int32_t decode_single(rtcore_can *can, int32_t kind, const uint8_t *data, int32_t len,
                             rtcore_can_message *out)
{
    memset(out, 0, sizeof *out);
    out->kind = kind;
    if (kind == RTCORE_CAN_STATUS) {
        struct rtcore_can_v1_status_t m;
        (void)rtcore_can_v1_status_unpack(&m, data, (size_t)len);
        if (m.state > RTCORE_CAN_V1_STATUS_STATE_FAULT_CHOICE || m.fault_active > RTCORE_CAN_V1_STATUS_FAULT_ACTIVE_SENSOR_DRIFT_CHOICE) {
            return bad(can, kind);
        }
        out->state = m.state;
        out->fault_active = m.fault_active;
        out->rx_errors = m.rx_errors;
        out->fault_code = m.fault_code;
        out->uptime_ms = (int64_t)m.uptime_ms;
    } else if (kind == RTCORE_CAN_VERSION) {
        struct rtcore_can_v1_firmware_version_t m;
        (void)rtcore_can_v1_firmware_version_unpack(&m, data, (size_t)len);
        out->protocol_version = m.protocol_version;
        out->firmware_major = m.firmware_major;
        out->firmware_minor = m.firmware_minor;
        out->firmware_patch = m.firmware_patch;
        out->finger_count = m.finger_count;
    } else if (kind == RTCORE_CAN_VERSION_REQUEST) {
        struct rtcore_can_v1_version_request_t m;
        (void)rtcore_can_v1_version_request_unpack(&m, data, (size_t)len);
        out->protocol_version = m.protocol_version;
    } else {
        struct rtcore_can_v1_fault_inject_t m;
        (void)rtcore_can_v1_fault_inject_unpack(&m, data, (size_t)len);
        if (m.fault > RTCORE_CAN_V1_FAULT_INJECT_FAULT_SENSOR_DRIFT_CHOICE) {
            return bad(can, kind);
        }
        out->fault = m.fault;
        out->finger_index = m.finger_index;
        out->duration_ms = m.duration_ms;
        out->value = m.value;
    }
    return 1;
}

int32_t rtcore_can_decode(rtcore_can *can, int32_t id, const uint8_t *data, int32_t len,
                          rtcore_can_message *out)
{
    int32_t kind;
    int32_t expected;
    if (can == 0 || out == 0) {
        return 0;
    }
    expected = id == RTCORE_CAN_NO_FRAME ? -1 : expected_length(id, &kind);
    if (expected < 0 || data == 0) {
        can->ignored += 1;
        return 0;
    }
    if (len != expected) {
        return bad(can, kind);
    }
    if (data[0] != rtcore_can_e2e_crc(data, len, (uint8_t)(id & 0xFF))) {
        can->crc_errors += 1;
        can->last_error = kind;
        return 0;
    }
    can->frames += 1;
    if (kind == RTCORE_CAN_SENSOR) {
        return decode_sensor(can, data, len, out);
    }
    if (kind == RTCORE_CAN_VALVE) {
        return decode_valve(can, data, len, out);
    }
    return decode_single(can, kind, data, len, out);
}
