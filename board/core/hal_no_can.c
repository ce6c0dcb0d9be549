/* The CAN half of the HAL for a port without a CAN controller (the AVR board, its Arduino
 * sketch, the Cortex-M image under QEMU): such a port speaks serial-v1 only, its
 * configuration's wire, so the core never reaches these; they exist so that it links.
 * docs/board.md says why the Nano has no MCP2515. */
#include "hal.h"

uint8_t hal_can_read(uint16_t *id, uint8_t *data, uint8_t *len)
{
    (void)id;
    (void)data;
    (void)len;
    return 0u;
}

void hal_can_error(uint8_t bus_off)
{
    (void)bus_off;
}

void hal_can_write(uint16_t id, const uint8_t *data, uint8_t len)
{
    (void)id;
    (void)data;
    (void)len;
}
