/* The parts of the core and what each calls of the parts below it; not part of the core's
 * public interface (board.h). Each part calls down only:
 *
 *     board.c     init, the loop, the decoded messages' handlers
 *     measure.c   the board's own faults, the inner pressure loop, the sample
 *     report.c    Status, VersionInfo, a sample, a change of state: on the board's wire
 *     wire_serial.c, wire_can.c   each protocol's messages; what they receive goes up
 *                 through struct board_rx, which board.c fills
 *     output.c    a frame out to the HAL, the vent, the clock comparison
 *     serial_v1.c, inject.c, regulator.c, hal.h
 */
#ifndef BOARD_INTERNAL_H
#define BOARD_INTERNAL_H

#include <stdint.h>

#include "board.h"

/* Does this image break `rule` (enum inject_broken) on purpose? Never in a release image. */
static inline int board_breaks(const struct board *b, uint8_t rule)
{
#ifdef BOARD_TEST_IMAGE
    return b->cfg.broken == rule;
#else
    (void)b;
    (void)rule;
    return 0;
#endif
}

/* -- measure.c: the board's own faults (vent, FAULT, cleared fault_clear_us after the
 * cause); the inner loop (measure every chamber, regulate it); one sample (the sensors,
 * reported) */
void board_own_faults(struct board *b);
void board_inner_tick(struct board *b);
void board_sample(struct board *b);

/* -- report.c: on the board's wire; a change of state sends Status at once */
void board_send_status(struct board *b);
void board_send_version(struct board *b);
void board_send_sample(struct board *b, const float *flex_mv, const float *pressure_kpa);
void board_set_state(struct board *b, uint8_t state);

/* -- wire_serial.c, wire_can.c: the encoders, and the receive side, which hands every
 * decoded message to the handlers board.c gives it */
struct board_rx {
    void (*valve_command)(struct board *b, uint8_t sequence, const float *pressure_kpa, uint8_t n);
    void (*version_request)(struct board *b, uint16_t protocol_version);
    void (*fault_request)(struct board *b, uint8_t kind, uint8_t finger, uint16_t duration_ms, uint16_t value);
    void (*bad_frame)(struct board *b);
};

void wire_serial_receive(struct board *b, const struct board_rx *rx);
void wire_serial_sensor(struct board *b, const float *flex_mv, const float *pressure_kpa);
void wire_serial_status(struct board *b);
void wire_serial_version(struct board *b);

void wire_can_receive(struct board *b, int bus_off, const struct board_rx *rx);
void wire_can_sensor(struct board *b, const float *flex_mv, const float *pressure_kpa);
void wire_can_status(struct board *b);
void wire_can_version(struct board *b);

/* AUTOSAR E2E profile-2 CRC-8 (poly 0x2F, init 0xFF, xor-out 0xFF) over data[1..len) and the
 * data id (the frame id's low byte), as the host's cantools.autosar computes it. */
uint8_t wire_can_e2e_crc(const uint8_t *data, uint8_t len, uint8_t data_id);

/* -- output.c: one outgoing frame, through the test image's faults, to the HAL; vent every
 * chamber; whether now_us has reached when_us on the wrapping microsecond clock; the
 * protocol version the board announces (a test image's PROTOCOL_CHANGE changes it) */
void board_emit(struct board *b, struct board_unit *unit);
void board_vent_valves(struct board *b);
int board_reached(uint32_t now_us, uint32_t when_us);
uint16_t board_announced_protocol(const struct board *b);

#endif
