/* What the core's C tests share (test_core.c): the board under test, a CHECK that counts
 * failures, the frames the board sent decoded with the core's own decoder, and the inputs
 * a test drives it with (sensor readings, time, serial frames), on the fake HAL. */
#ifndef BOARD_CORE_HARNESS_H
#define BOARD_CORE_HARNESS_H

#include <stdint.h>
#include <stdio.h>

#include "board.h"

extern int failures;

#define CHECK(cond)                                                                          \
    do {                                                                                     \
        if (!(cond)) {                                                                       \
            fprintf(stderr, "%s:%d: %s: check failed: %s\n", __FILE__, __LINE__, __func__, #cond); \
            failures++;                                                                      \
        }                                                                                    \
    } while (0)

extern struct board b;

/* the frames the board sent, decoded with the core's own decoder (collect) */
struct sent {
    uint8_t type;
    uint8_t length;
    uint8_t payload[64];
};
#define SENT_FRAMES 2048
extern struct sent sent[SENT_FRAMES];
extern int n_sent;

void collect(void);
int count_type(uint8_t type);
const struct sent *last_of(uint8_t type);
/* chamber i reads `kpa` on its sensor (the default MPX5700-class scaling) */
void set_pressure(uint8_t i, float kpa);
void run_for_us(uint32_t us);
/* a fresh fake HAL, the clock just before it wraps, and the board booted on `wire` */
void boot(uint8_t wire);
void boot_with(const struct board_config *cfg);
void send_command(uint8_t sequence, float kpa, uint8_t n);
void send_simple(uint8_t type, const uint8_t *payload, uint8_t length);

#endif
