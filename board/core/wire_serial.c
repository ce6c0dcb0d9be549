/* serial-v1 messages (payload layouts of hand_service/wire/serial_codec.py, little-endian):
 *
 *   0x10 SensorReport  board->host  u8 sequence, u8 command_sequence, u8 n; n x (f32 flex mV, f32 kPa)
 *   0x20 ValveCommand  host->board  u8 sequence, u8 n; n x f32 setpoint kPa
 *   0x30 Status        board->host  u8 state, u8 fault_active, u8 rx_errors, u32 uptime_ms, u8 fault_code
 *   0x40 VersionInfo   board->host  u16 protocol, u8 major, u8 minor, u8 patch, u8 fingers
 *   0x41 VersionRequest host->board u16 protocol the host speaks
 *   0x7E FaultRequest  host->board  u8 kind, u8 finger, u16 duration_ms, u16 value (test images)
 */
#include <math.h>

#include "board_internal.h"
#include "hal.h"

#define READ_CHUNK 64u

static void send_frame(struct board *b, uint8_t type, const uint8_t *payload, uint8_t length)
{
    struct board_unit unit;
    unit.can_id = 0u;
    unit.len = (uint8_t)serial_v1_encode(unit.data, b->tx_frame_sequence, type, payload, length);
    if (unit.len == 0u) {
        return;
    }
    b->tx_frame_sequence++;
    board_emit(b, &unit);
}

void wire_serial_sensor(struct board *b, const float *flex_mv, const float *pressure_kpa)
{
    uint8_t payload[SERIAL_V1_MAX_PAYLOAD];
    const uint8_t n = b->cfg.n_fingers;
    payload[0] = b->sequence;
    payload[1] = b->command_sequence;
    payload[2] = n;
    for (uint8_t i = 0; i < n; i++) {
        serial_v1_put_f32(payload + 3 + 8 * i, flex_mv[i]);
        serial_v1_put_f32(payload + 7 + 8 * i, pressure_kpa[i]);
    }
    send_frame(b, SERIAL_V1_SENSOR_REPORT, payload, (uint8_t)(3u + 8u * n));
}

void wire_serial_status(struct board *b)
{
    uint8_t payload[8];
    payload[0] = b->state;
#ifdef BOARD_TEST_IMAGE
    payload[1] = inject_current(&b->inject);
#else
    payload[1] = 0u;
#endif
    payload[2] = (uint8_t)(b->rx_errors > 255u ? 255u : b->rx_errors);
    serial_v1_put_u32(payload + 3, board_uptime_ms(b));
    payload[7] = b->fault_code;
    send_frame(b, SERIAL_V1_STATUS, payload, 8u);
}

void wire_serial_version(struct board *b)
{
    uint8_t payload[6];
    serial_v1_put_u16(payload, board_announced_protocol(b));
    payload[2] = b->cfg.firmware_version[0];
    payload[3] = b->cfg.firmware_version[1];
    payload[4] = b->cfg.firmware_version[2];
    payload[5] = b->cfg.n_fingers;
    send_frame(b, SERIAL_V1_VERSION_INFO, payload, 6u);
}

static void handle(struct board *b, const struct serial_v1_frame *f, const struct board_rx *rx)
{
    const uint8_t *p = f->payload;
    if (f->type == SERIAL_V1_VALVE_COMMAND) {
        /* a valid command: every finger of this hand, each a finite f32 */
        if (f->length < 2u || p[1] != b->cfg.n_fingers || f->length != 2u + 4u * p[1]) {
            rx->bad_frame(b);
            return;
        }
        float pressure_kpa[BOARD_MAX_FINGERS];
        for (uint8_t i = 0; i < p[1]; i++) {
            pressure_kpa[i] = serial_v1_get_f32(p + 2 + 4 * i);
            if (!isfinite(pressure_kpa[i])) {
                rx->bad_frame(b);
                return;
            }
        }
        rx->valve_command(b, p[0], pressure_kpa, p[1]);
    } else if (f->type == SERIAL_V1_VERSION_REQUEST && f->length == 2u) {
        rx->version_request(b, serial_v1_get_u16(p));
#ifdef BOARD_TEST_IMAGE
    } else if (f->type == SERIAL_V1_FAULT_REQUEST && f->length == 6u) {
        rx->fault_request(b, p[0], p[1], serial_v1_get_u16(p + 2), serial_v1_get_u16(p + 4));
#endif
    } else {
        rx->bad_frame(b); /* an unknown type, or a known one of the wrong length */
    }
}

void wire_serial_receive(struct board *b, const struct board_rx *rx)
{
    uint8_t chunk[READ_CHUNK];
    uint16_t got;
    while ((got = hal_serial_read(chunk, READ_CHUNK)) > 0u) {
        for (uint16_t i = 0; i < got; i++) {
            const uint32_t crc_errors = b->decoder.crc_errors;
            const uint32_t garbage_bytes = b->decoder.garbage_bytes;
            struct serial_v1_frame frame;
            serial_v1_feed(&b->decoder, chunk[i]);
            while (serial_v1_next(&b->decoder, &frame)) {
                handle(b, &frame, rx);
            }
            b->rx_errors += b->decoder.crc_errors - crc_errors;
            if (board_breaks(b, INJECT_BROKEN_COUNTS_RUBBISH)) {
                b->rx_errors += b->decoder.garbage_bytes - garbage_bytes;
            }
        }
    }
}
