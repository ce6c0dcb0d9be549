/* serial-v1 framing (serial_v1.h). */
#include "serial_v1.h"

#include <string.h>

uint16_t serial_v1_crc16(const uint8_t *data, uint16_t len)
{
    return serial_v1_crc16_from(0xFFFFu, data, len); /* CRC-16/CCITT-FALSE: init 0xFFFF */
}

uint16_t serial_v1_crc16_from(uint16_t init, const uint8_t *data, uint16_t len)
{
    uint16_t crc = init; /* poly 0x1021, no reflection */
    for (uint16_t i = 0; i < len; i++) {
        crc ^= (uint16_t)((uint16_t)data[i] << 8);
        for (uint8_t bit = 0; bit < 8u; bit++) {
            crc = (crc & 0x8000u) ? (uint16_t)((crc << 1) ^ 0x1021u) : (uint16_t)(crc << 1);
        }
    }
    return crc;
}

void serial_v1_put_u16(uint8_t *p, uint16_t v)
{
    p[0] = (uint8_t)(v & 0xFFu);
    p[1] = (uint8_t)(v >> 8);
}

void serial_v1_put_u32(uint8_t *p, uint32_t v)
{
    for (uint8_t i = 0; i < 4u; i++) {
        p[i] = (uint8_t)((v >> (8u * i)) & 0xFFu);
    }
}

void serial_v1_put_f32(uint8_t *p, float v)
{
    uint32_t bits;
    memcpy(&bits, &v, sizeof bits); /* IEEE 754 single on every supported target */
    serial_v1_put_u32(p, bits);
}

uint16_t serial_v1_get_u16(const uint8_t *p)
{
    return (uint16_t)(p[0] | ((uint16_t)p[1] << 8));
}

float serial_v1_get_f32(const uint8_t *p)
{
    uint32_t bits = 0;
    for (uint8_t i = 0; i < 4u; i++) {
        bits |= (uint32_t)p[i] << (8u * i);
    }
    float v;
    memcpy(&v, &bits, sizeof v);
    return v;
}

uint16_t serial_v1_encode(uint8_t *out, uint8_t sequence, uint8_t type, const uint8_t *payload,
                          uint8_t length)
{
    if (length > SERIAL_V1_MAX_PAYLOAD) {
        return 0u;
    }
    out[0] = SERIAL_V1_SYNC0;
    out[1] = SERIAL_V1_SYNC1;
    out[2] = length;
    out[3] = sequence;
    out[4] = type;
    if (length > 0u) {
        memcpy(out + SERIAL_V1_HEADER_BYTES, payload, length);
    }
    const uint16_t crc = serial_v1_crc16(out + 2, (uint16_t)(3u + length));
    serial_v1_put_u16(out + SERIAL_V1_HEADER_BYTES + length, crc);
    return (uint16_t)(SERIAL_V1_HEADER_BYTES + length + SERIAL_V1_CRC_BYTES);
}

void serial_v1_decoder_init(struct serial_v1_decoder *d)
{
    memset(d, 0, sizeof *d);
}

/* Drop the first byte and rescan what is buffered for the next sync (the hunt). */
static void resync(struct serial_v1_decoder *d)
{
    uint8_t start = 1u;
    while (start < d->len) {
        if (d->buf[start] == SERIAL_V1_SYNC0
            && (start + 1u >= d->len || d->buf[start + 1u] == SERIAL_V1_SYNC1)) {
            break;
        }
        start++;
    }
    d->garbage_bytes += start;
    memmove(d->buf, d->buf + start, (size_t)(d->len - start));
    d->len = (uint8_t)(d->len - start);
}

/* The buffer holds a possible frame start: is it complete and good? 1: a frame, 0: wait for
 * more, -1: not a frame here (resync). */
static int check(struct serial_v1_decoder *d, struct serial_v1_frame *frame)
{
    if (d->len >= 1u && d->buf[0] != SERIAL_V1_SYNC0) {
        return -1;
    }
    if (d->len >= 2u && d->buf[1] != SERIAL_V1_SYNC1) {
        return -1;
    }
    if (d->len < SERIAL_V1_HEADER_BYTES) {
        return 0;
    }
    const uint8_t length = d->buf[2];
    if (length > SERIAL_V1_MAX_PAYLOAD) {
        return -1;
    }
    const uint8_t end = (uint8_t)(SERIAL_V1_HEADER_BYTES + length + SERIAL_V1_CRC_BYTES);
    if (d->len < end) {
        return 0;
    }
    const uint16_t crc = serial_v1_crc16(d->buf + 2, (uint16_t)(3u + length));
    if (serial_v1_get_u16(d->buf + end - SERIAL_V1_CRC_BYTES) != crc) {
        d->crc_errors++;
        return -1;
    }
    frame->sequence = d->buf[3];
    frame->type = d->buf[4];
    frame->length = length;
    memcpy(d->frame, d->buf + SERIAL_V1_HEADER_BYTES, length);
    frame->payload = d->frame;
    memmove(d->buf, d->buf + end, (size_t)(d->len - end));
    d->len = (uint8_t)(d->len - end);
    return 1;
}

void serial_v1_feed(struct serial_v1_decoder *d, uint8_t byte)
{
    if (d->len == 0u && byte != SERIAL_V1_SYNC0) {
        d->garbage_bytes++;
        return;
    }
    if (d->len >= SERIAL_V1_MAX_FRAME) { /* unreachable while every feed is followed by next() */
        resync(d);
    }
    d->buf[d->len++] = byte;
}

int serial_v1_next(struct serial_v1_decoder *d, struct serial_v1_frame *frame)
{
    while (d->len > 0u) {
        const int result = check(d, frame);
        if (result != -1) {
            return result;
        }
        resync(d);
    }
    return 0;
}
