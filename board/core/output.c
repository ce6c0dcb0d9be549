/* The bottom of the core, which every other part calls and which calls no part of it: a
 * frame out (through a test image's faults and broken rules) to the HAL, every chamber
 * vented, the wrapping clock's comparison, the uptime and the protocol the board announces. */

#include "board.h"
#include "board_internal.h"
#include "hal.h"
#include "regulator.h"

void board_vent_valves(struct board *b)
{
    for (uint8_t i = 0; i < BOARD_MAX_FINGERS; i++) {
        b->command_kpa[i] = 0.0f;
        regulator_vent(&b->regulators[i]);
        if (i < b->cfg.n_fingers) {
            hal_valve_pwm(i, HAL_VALVE_INLET, 0u);
            hal_valve_pwm(i, HAL_VALVE_EXHAUST, HAL_DUTY_FULL_PERMILLE);
        }
    }
}

int board_reached(uint32_t now_us, uint32_t when_us)
{
    return (int32_t)(now_us - when_us) >= 0;
}

uint32_t board_uptime_ms(const struct board *b)
{
    return b->uptime_ms;
}

uint16_t board_announced_protocol(const struct board *b)
{
    if (b->echo_protocol != 0u) {
        return b->echo_protocol;
    }
#ifdef BOARD_TEST_IMAGE
    const int32_t changed = inject_value(&b->inject, INJECT_PROTOCOL_CHANGE,
                                         (uint16_t)(b->cfg.protocol_version + 1u));
    if (changed >= 0) {
        return (uint16_t)changed;
    }
#endif
    return b->cfg.protocol_version;
}

/* INJECT_BROKEN_WRONG_CRC: the CAN frame's E2E byte inverted, the serial frame's CRC from 0 */
static void wrong_crc(const struct board *b, struct board_unit *unit)
{
    if (b->cfg.wire == BOARD_WIRE_CAN) {
        unit->data[0] ^= 0xFFu;
    } else if (unit->len >= SERIAL_V1_HEADER_BYTES + SERIAL_V1_CRC_BYTES) {
        const uint16_t body = (uint16_t)(unit->len - 2u - SERIAL_V1_CRC_BYTES);
        serial_v1_put_u16(unit->data + 2u + body, serial_v1_crc16_from(0u, unit->data + 2, body));
    }
}

void board_emit(struct board *b, struct board_unit *unit)
{
    if (b->state == BOARD_BOOTING) {
        return;
    }
    if (board_breaks(b, INJECT_BROKEN_WRONG_CRC)) {
        wrong_crc(b, unit);
    }
#ifdef BOARD_TEST_IMAGE
    if (!inject_outgoing(&b->inject, unit, b->now_us)) {
        return;
    }
#endif
    if (b->cfg.wire == BOARD_WIRE_CAN) {
        hal_can_write(unit->can_id, unit->data, unit->len);
    } else {
        hal_serial_write(unit->data, unit->len);
    }
}
