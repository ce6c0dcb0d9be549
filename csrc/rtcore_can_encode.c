/* The host's can-v1 encoder (rtcore_can.h): a message into the frames the DBC lays out,
 * each value made raw as cantools' Python encoder makes it, so that the frames are byte for
 * byte those hand_service/wire/can_codec.py encodes. The decoder: rtcore_can.c. */
#include <math.h>
#include <string.h>

#include "rtcore_can_v1.h"
#include "rtcore_can.h"

#define SEQUENCE_MODULO 256
#define UPTIME_MODULO 4294967296.0

/* cantools' raw value of a scaled one: (value - offset) / scale, rounded half to even;
 * scale and offset from the generated decode (raw 1 and raw 0). */
static double raw_of(double value, double decoded_0, double decoded_1)
{
    return nearbyint((value - decoded_0) / (decoded_1 - decoded_0));
}

static double clamp(double v, double low, double high)
{
    return v < low ? low : (v > high ? high : v);
}

static int32_t wrap(int64_t value, int64_t modulo)
{
    return (int32_t)(((value % modulo) + modulo) % modulo);
}

static int in_range(int64_t value, int64_t low, int64_t high)
{
    return value >= low && value <= high;
}

static void finish_frame(int32_t id, int32_t len, int32_t *ids, int32_t *lens, uint8_t *data)
{
    *ids = id;
    *lens = len;
    data[0] = rtcore_can_e2e_crc(data, len, (uint8_t)(id & 0xFF));
}

static int32_t encode_sensor(const rtcore_can *can, const rtcore_can_message *m, int32_t *ids, int32_t *lens,
                             uint8_t *data)
{
    const int32_t n = m->n_fingers;
    const double flex_0 = rtcore_can_v1_sensor_finger_flex_mv_decode(0);
    const double flex_1 = rtcore_can_v1_sensor_finger_flex_mv_decode(1);
    const double kpa_0 = rtcore_can_v1_sensor_finger_pressure_meas_kpa_decode(0);
    const double kpa_1 = rtcore_can_v1_sensor_finger_pressure_meas_kpa_decode(1);
    int32_t i;
    for (i = 0; i < n; ++i) {
        if (isnan(m->sensor_mv[i])) { /* flex_mv has no not_reported value */
            return -1;
        }
    }
    for (i = 0; i < n; ++i) {
        struct rtcore_can_v1_sensor_finger_t f;
        const double kpa = m->pressure_meas_kpa[i];
        uint8_t *d = data + i * RTCORE_CAN_FRAME_BYTES;
        rtcore_can_v1_sensor_finger_init(&f);
        f.finger_index = (uint8_t)i;
        f.sequence = (uint8_t)wrap(m->sequence, SEQUENCE_MODULO);
        f.command_sequence = (uint8_t)wrap(m->command_sequence, SEQUENCE_MODULO);
        f.flex_mv = (uint16_t)raw_of(clamp(m->sensor_mv[i], can->flex_low_mv, can->flex_high_mv), flex_0, flex_1);
        f.pressure_meas_kpa = isnan(kpa) ? (int16_t)RTCORE_CAN_V1_SENSOR_FINGER_PRESSURE_MEAS_KPA_NOT_REPORTED_CHOICE
                                         : (int16_t)raw_of(clamp(kpa, can->pressure_meas_low_kpa,
                                                                 can->pressure_meas_high_kpa), kpa_0, kpa_1);
        memset(d, 0, RTCORE_CAN_FRAME_BYTES);
        (void)rtcore_can_v1_sensor_finger_pack(d, &f, RTCORE_CAN_FRAME_BYTES);
        finish_frame(RTCORE_CAN_V1_SENSOR_FINGER_FRAME_ID, RTCORE_CAN_V1_SENSOR_FINGER_LENGTH, ids + i, lens + i, d);
    }
    return n;
}

static int32_t encode_valve(const rtcore_can *can, const rtcore_can_message *m, int32_t *ids, int32_t *lens,
                            uint8_t *data)
{
    const int32_t n = m->n_fingers;
    const double kpa_0 = rtcore_can_v1_valve_command_pressure_cmd_kpa_decode(0);
    const double kpa_1 = rtcore_can_v1_valve_command_pressure_cmd_kpa_decode(1);
    int32_t i;
    for (i = 0; i < n; ++i) {
        const double kpa = m->pressure_cmd_kpa[i];
        if (!(kpa >= can->command_low_kpa && kpa <= can->command_high_kpa)) { /* NaN too */
            return -1;
        }
    }
    for (i = 0; i < n; ++i) {
        struct rtcore_can_v1_valve_command_t f;
        uint8_t *d = data + i * RTCORE_CAN_FRAME_BYTES;
        rtcore_can_v1_valve_command_init(&f);
        f.finger_index = (uint8_t)i;
        f.sequence = (uint8_t)wrap(m->sequence, SEQUENCE_MODULO);
        f.pressure_cmd_kpa = (int16_t)raw_of(m->pressure_cmd_kpa[i], kpa_0, kpa_1);
        memset(d, 0, RTCORE_CAN_FRAME_BYTES);
        (void)rtcore_can_v1_valve_command_pack(d, &f, RTCORE_CAN_FRAME_BYTES);
        finish_frame(RTCORE_CAN_V1_VALVE_COMMAND_FRAME_ID, RTCORE_CAN_V1_VALVE_COMMAND_LENGTH, ids + i, lens + i, d);
    }
    return n;
}

/* The single-frame messages: an integer field beyond its signal's declared range is refused
 * (cantools' strict encoding); the counters wrap and rx_errors saturates as the Python
 * codec sends them. */
static int32_t encode_single(const rtcore_can_message *m, int32_t *ids, int32_t *lens, uint8_t *d)
{
    memset(d, 0, RTCORE_CAN_FRAME_BYTES);
    if (m->kind == RTCORE_CAN_STATUS) {
        struct rtcore_can_v1_status_t f;
        const int32_t rx_errors = m->rx_errors < 255 ? m->rx_errors : 255;
        if (!in_range(m->state, 0, 7) || !in_range(m->fault_active, 0, 31) || !in_range(rx_errors, 0, 255)
            || !in_range(m->fault_code, 0, 255)) {
            return -1;
        }
        rtcore_can_v1_status_init(&f);
        f.state = (uint8_t)m->state;
        f.fault_active = (uint8_t)m->fault_active;
        f.rx_errors = (uint8_t)rx_errors;
        f.fault_code = (uint8_t)m->fault_code;
        f.uptime_ms = (uint32_t)fmod(fmod((double)m->uptime_ms, UPTIME_MODULO) + UPTIME_MODULO, UPTIME_MODULO);
        (void)rtcore_can_v1_status_pack(d, &f, RTCORE_CAN_FRAME_BYTES);
        finish_frame(RTCORE_CAN_V1_STATUS_FRAME_ID, RTCORE_CAN_V1_STATUS_LENGTH, ids, lens, d);
    } else if (m->kind == RTCORE_CAN_VERSION) {
        struct rtcore_can_v1_firmware_version_t f;
        if (!in_range(m->protocol_version, 0, 65535) || !in_range(m->firmware_major, 0, 255)
            || !in_range(m->firmware_minor, 0, 255) || !in_range(m->firmware_patch, 0, 255)
            || !in_range(m->finger_count, 0, 8)) {
            return -1;
        }
        rtcore_can_v1_firmware_version_init(&f);
        f.protocol_version = (uint16_t)m->protocol_version;
        f.firmware_major = (uint8_t)m->firmware_major;
        f.firmware_minor = (uint8_t)m->firmware_minor;
        f.firmware_patch = (uint8_t)m->firmware_patch;
        f.finger_count = (uint8_t)m->finger_count;
        (void)rtcore_can_v1_firmware_version_pack(d, &f, RTCORE_CAN_FRAME_BYTES);
        finish_frame(RTCORE_CAN_V1_FIRMWARE_VERSION_FRAME_ID, RTCORE_CAN_V1_FIRMWARE_VERSION_LENGTH, ids, lens, d);
    } else if (m->kind == RTCORE_CAN_VERSION_REQUEST) {
        struct rtcore_can_v1_version_request_t f;
        if (!in_range(m->protocol_version, 0, 65535)) {
            return -1;
        }
        rtcore_can_v1_version_request_init(&f);
        f.protocol_version = (uint16_t)m->protocol_version;
        (void)rtcore_can_v1_version_request_pack(d, &f, RTCORE_CAN_FRAME_BYTES);
        finish_frame(RTCORE_CAN_V1_VERSION_REQUEST_FRAME_ID, RTCORE_CAN_V1_VERSION_REQUEST_LENGTH, ids, lens, d);
    } else if (m->kind == RTCORE_CAN_FAULT_INJECT) {
        struct rtcore_can_v1_fault_inject_t f;
        if (!in_range(m->fault, 0, 31) || !in_range(m->finger_index, 0, 255) || !in_range(m->duration_ms, 0, 65535)
            || !in_range(m->value, 0, 65535)) {
            return -1;
        }
        rtcore_can_v1_fault_inject_init(&f);
        f.fault = (uint8_t)m->fault;
        f.finger_index = (uint8_t)m->finger_index;
        f.duration_ms = (uint16_t)m->duration_ms;
        f.value = (uint16_t)m->value;
        (void)rtcore_can_v1_fault_inject_pack(d, &f, RTCORE_CAN_FRAME_BYTES);
        finish_frame(RTCORE_CAN_V1_FAULT_INJECT_FRAME_ID, RTCORE_CAN_V1_FAULT_INJECT_LENGTH, ids, lens, d);
    } else {
        return -1;
    }
    return 1;
}

int32_t rtcore_can_encode(const rtcore_can *can, const rtcore_can_message *message, int32_t *ids,
                          int32_t *lens, uint8_t *data, int32_t capacity)
{
    int32_t needed;
    if (can == 0 || message == 0 || ids == 0 || lens == 0 || data == 0) {
        return -1;
    }
    if (message->kind == RTCORE_CAN_SENSOR || message->kind == RTCORE_CAN_VALVE) {
        if (message->n_fingers < 0 || message->n_fingers > RTCORE_MAX_FINGERS) {
            return -1;
        }
        needed = message->n_fingers;
    } else {
        needed = 1;
    }
    if (needed > capacity) {
        return -2;
    }
    if (message->kind == RTCORE_CAN_SENSOR) {
        return encode_sensor(can, message, ids, lens, data);
    }
    if (message->kind == RTCORE_CAN_VALVE) {
        return encode_valve(can, message, ids, lens, data);
    }
    return encode_single(message, ids, lens, data);
}
