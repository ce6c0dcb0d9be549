/* A release image (no BOARD_TEST_IMAGE) has no debug port: a FaultRequest is an unknown
 * message, counted in rx_errors, and changes nothing. */
#include <stdio.h>
#include <stdlib.h>

#include "board.h"
#include "fake_hal.h"

int main(void)
{
    static struct board b;
    fake_reset();
    for (int i = 0; i < 5; i++) {
        fake.adc_counts[2 * i] = 164; /* 0 kPa: 200 mV on the pressure sensors */
    }
    struct board_config cfg = board_config_defaults();
    if (board_init(&b, &cfg) != 0) {
        return EXIT_FAILURE;
    }
    board_poll(&b);
    const uint8_t reboot[6] = {7, 255, 0, 0, 50, 0}; /* REBOOT */
    uint8_t frame[SERIAL_V1_MAX_FRAME];
    const uint16_t len = serial_v1_encode(frame, 0, SERIAL_V1_FAULT_REQUEST, reboot, 6);
    fake_input(frame, len);
    for (int i = 0; i < 100; i++) {
        fake.time_us += 100u;
        board_poll(&b);
    }
    if (b.state != BOARD_IDLE || b.rx_errors != 1) {
        fprintf(stderr, "test-release: state %u, rx_errors %u: the fault request was not refused\n",
                (unsigned)b.state, (unsigned)b.rx_errors);
        return EXIT_FAILURE;
    }
    printf("test-release: all passed\n");
    return EXIT_SUCCESS;
}
