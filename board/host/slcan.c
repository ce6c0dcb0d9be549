/* An SLCAN (Lawicel) USB-CAN adapter on the pty, with the can-v1 firmware behind it: the
 * host's python-can `slcan` interface talks to it unchanged, as it does to the Python mock's
 * SlcanAdapterPort (hand_service/firmware/ports.py), whose answers this follows. */
#include <stdio.h>
#include <string.h>

#include "host.h"

static const uint8_t OK[] = "\r";
static const uint8_t ERROR[] = "\a";

static int hex_value(char c)
{
    if (c >= '0' && c <= '9') {
        return c - '0';
    }
    if (c >= 'A' && c <= 'F') {
        return c - 'A' + 10;
    }
    if (c >= 'a' && c <= 'f') {
        return c - 'a' + 10;
    }
    return -1;
}

static long hex_field(const char *s, int digits)
{
    long v = 0;
    for (int i = 0; i < digits; i++) {
        const int h = hex_value(s[i]);
        if (h < 0) {
            return -1;
        }
        v = v * 16 + h;
    }
    return v;
}

static void reply(const uint8_t *text)
{
    host_pty_write(host.fd, text, (uint32_t)strlen((const char *)text));
}

static int frame(const char *line, int extended)
{
    const int id_digits = extended ? 8 : 3;
    const size_t len = strlen(line);
    if (len < (size_t)(2 + id_digits)) {
        return -1;
    }
    const long id = hex_field(line + 1, id_digits);
    const int dlc = hex_value(line[1 + id_digits]);
    if (id < 0 || dlc < 0 || dlc > 8 || len != (size_t)(2 + id_digits + 2 * dlc)) {
        return -1;
    }
    struct host_can_frame f;
    f.len = (uint8_t)dlc;
    for (int i = 0; i < dlc; i++) {
        const long byte = hex_field(line + 2 + id_digits + 2 * i, 2);
        if (byte < 0) {
            return -1;
        }
        f.data[i] = (uint8_t)byte;
    }
    reply(extended ? (const uint8_t *)"Z\r" : (const uint8_t *)"z\r"); /* Lawicel: sent */
    if (extended) {
        return 0; /* can-v1 uses standard ids only: another node's frame */
    }
    f.id = (uint16_t)id;
    if (host.can_count < HOST_CAN_QUEUE) {
        host.can_rx[(host.can_head + host.can_count) % HOST_CAN_QUEUE] = f;
        host.can_count++;
    }
    return 0;
}

void host_slcan_line(const char *line)
{
    const char code = line[0];
    if (code == 't' || code == 'T') {
        if (frame(line, code == 'T') != 0) {
            reply(ERROR);
        }
        return;
    }
    if (code == 'O' || code == 'L') {
        host.slcan_open = 1;
    } else if (code == 'C') {
        host.slcan_open = 0;
    } else if (code == 'V') {
        reply((const uint8_t *)"V1013\r");
        return;
    } else if (code != '\0' && strchr("SsYZFN", code) == NULL) {
        reply(ERROR);
        return;
    }
    reply(OK);
}

void host_slcan_send(uint16_t id, const uint8_t *data, uint8_t len)
{
    if (!host.slcan_open || len > 8u) {
        return; /* a closed channel forwards nothing, as on a real adapter */
    }
    char text[32];
    int n = snprintf(text, sizeof text, "t%03X%u", (unsigned)(id & 0x7FFu), (unsigned)len);
    for (uint8_t i = 0; i < len; i++) {
        n += snprintf(text + n, sizeof text - (size_t)n, "%02X", data[i]);
    }
    text[n++] = '\r';
    host_pty_write(host.fd, (const uint8_t *)text, (uint32_t)n);
}
