/* What the board reports, on its wire (wire_serial.c, wire_can.c): Status, VersionInfo, a
 * sample; and a change of state, which sends Status at once. */
#include "board.h"
#include "board_internal.h"

void board_send_status(struct board *b)
{
    if (b->cfg.wire == BOARD_WIRE_CAN) {
        wire_can_status(b);
    } else {
        wire_serial_status(b);
    }
}

void board_send_version(struct board *b)
{
    if (b->cfg.wire == BOARD_WIRE_CAN) {
        wire_can_version(b);
    } else {
        wire_serial_version(b);
    }
}

void board_set_state(struct board *b, uint8_t state)
{
    if (b->state != state) {
        b->state = state;
        board_send_status(b);
    }
}

void board_send_sample(struct board *b, const float *flex_mv, const float *pressure_kpa)
{
    if (b->cfg.wire == BOARD_WIRE_CAN) {
        wire_can_sensor(b, flex_mv, pressure_kpa);
    } else {
        wire_serial_sensor(b, flex_mv, pressure_kpa);
    }
}
