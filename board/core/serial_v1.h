/* serial-v1 framing (the host's hand_service/wire/framing.py):
 *
 *   offset  size  field
 *   0       2     sync 0xA5 0x5A
 *   2       1     payload length L (0..64)
 *   3       1     frame sequence, per direction, wraps at 256
 *   4       1     message type
 *   5       L     payload (little-endian fields)
 *   5+L     2     CRC-16/CCITT-FALSE of bytes 2..4+L, little-endian
 *
 * The decoder is fed one byte at a time and hunts for the next sync after garbage or a bad
 * CRC, one byte further on, as the host's does: a good frame hidden in rubbish is found.
 */
#ifndef BOARD_SERIAL_V1_H
#define BOARD_SERIAL_V1_H

#include <stdint.h>

#define SERIAL_V1_SYNC0 0xA5u
#define SERIAL_V1_SYNC1 0x5Au
#define SERIAL_V1_HEADER_BYTES 5u
#define SERIAL_V1_CRC_BYTES 2u
#define SERIAL_V1_MAX_PAYLOAD 64u
#define SERIAL_V1_MAX_FRAME (SERIAL_V1_HEADER_BYTES + SERIAL_V1_MAX_PAYLOAD + SERIAL_V1_CRC_BYTES)

#define SERIAL_V1_SENSOR_REPORT 0x10u
#define SERIAL_V1_VALVE_COMMAND 0x20u
#define SERIAL_V1_STATUS 0x30u
#define SERIAL_V1_VERSION_INFO 0x40u
#define SERIAL_V1_VERSION_REQUEST 0x41u
#define SERIAL_V1_FAULT_REQUEST 0x7Eu

struct serial_v1_decoder {
    uint8_t buf[SERIAL_V1_MAX_FRAME];
    uint8_t frame[SERIAL_V1_MAX_PAYLOAD]; /* the newest good frame's payload */
    uint8_t len;
    uint32_t crc_errors;
    uint32_t garbage_bytes;
};

struct serial_v1_frame {
    uint8_t sequence;
    uint8_t type;
    uint8_t length;
    const uint8_t *payload; /* points into the decoder: valid until the next frame */
};

uint16_t serial_v1_crc16(const uint8_t *data, uint16_t len);
/* The same CRC from another initial value (0: CRC-16/XMODEM, a broken test image's). */
uint16_t serial_v1_crc16_from(uint16_t init, const uint8_t *data, uint16_t len);

/* The framed bytes into out (room for SERIAL_V1_MAX_FRAME); returns their count, 0 if the
 * payload is too long. */
uint16_t serial_v1_encode(uint8_t *out, uint8_t sequence, uint8_t type, const uint8_t *payload,
                          uint8_t length);

void serial_v1_decoder_init(struct serial_v1_decoder *d);

/* Feed one byte, then take every frame it completed:
 *     serial_v1_feed(d, byte);
 *     while (serial_v1_next(d, &frame)) { ... }
 * (after rubbish one byte may complete a frame and reveal the start of the next). */
void serial_v1_feed(struct serial_v1_decoder *d, uint8_t byte);
int serial_v1_next(struct serial_v1_decoder *d, struct serial_v1_frame *frame);

/* Little-endian field helpers (the wire's byte order, whatever the MCU's). */
void serial_v1_put_u16(uint8_t *p, uint16_t v);
void serial_v1_put_u32(uint8_t *p, uint32_t v);
void serial_v1_put_f32(uint8_t *p, float v);
uint16_t serial_v1_get_u16(const uint8_t *p);
float serial_v1_get_f32(const uint8_t *p);

#endif
