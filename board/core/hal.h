/* The hardware abstraction layer: the only functions the firmware core calls that a port
 * to another board or MCU must write (docs/board.md, "Porting to another MCU").
 *
 * Every function is called from the one main loop (board_poll), never from an interrupt,
 * and none may block: a port that receives bytes or frames in an interrupt queues them and
 * hands them out here. The core keeps all its state in the caller's struct board; a port
 * keeps its own (UART ring buffers, timer handles) where it likes.
 */
#ifndef BOARD_HAL_H
#define BOARD_HAL_H

#include <stdint.h>

#define HAL_VALVE_INLET 0u   /* supply -> chamber */
#define HAL_VALVE_EXHAUST 1u /* chamber -> atmosphere */
#define HAL_DUTY_FULL_PERMILLE 1000u

/* Microseconds on a free-running clock that wraps at 2^32 (about 71.6 minutes); the core
 * only ever takes differences, so the wrap is harmless. */
uint32_t hal_time_us(void);

/* One conversion of ADC channel `channel`, in counts (0..BOARD_ADC_MAX_COUNTS of the
 * board's configuration). Channel 2*i is chamber i's pressure sensor, 2*i+1 finger i's
 * flex sensor. May take a few tens of microseconds. */
uint16_t hal_adc_read(uint8_t channel);

/* The PWM duty of one valve of chamber `chamber` (HAL_VALVE_INLET or HAL_VALVE_EXHAUST),
 * 0..1000 per mille of the board's PWM period. A port with hardware PWM loads it into the
 * timer's shadow register (it takes effect at the next period); 0 and 1000 are a valve
 * held shut and held open. */
void hal_valve_pwm(uint8_t chamber, uint8_t valve, uint16_t duty_permille);

/* Serial link (serial-v1): up to `max_len` received bytes into buf; returns how many (0:
 * none waiting). Never waits. */
uint16_t hal_serial_read(uint8_t *buf, uint16_t max_len);

/* Serial link: queue `len` bytes for sending. Never waits: what does not fit the port's
 * transmit buffer is dropped, as a UART with no one listening drops it. */
void hal_serial_write(const uint8_t *buf, uint16_t len);

/* CAN link (can-v1): one received standard-id data frame; returns 1 and fills id, data
 * (up to 8 bytes) and len, or returns 0 when none is waiting. */
uint8_t hal_can_read(uint16_t *id, uint8_t *data, uint8_t *len);

/* CAN link: queue one standard-id data frame for sending (dropped when the queue is full). */
void hal_can_write(uint16_t id, const uint8_t *data, uint8_t len);

/* CAN link: the controller reports an error on the bus to the host's CAN driver (bus_off 0:
 * a bus error, 1: the controller went bus-off), which hands it to the host as an error frame
 * (SocketCAN's, python-can's). Only called when the configuration says the link carries
 * error frames (board_config.can_error_frames) or for a bus-off; a port whose link has none
 * (SLCAN, serial) does nothing. */
void hal_can_error(uint8_t bus_off);

/* Kick the hardware watchdog (a stuck main loop resets the MCU, which boots vented). */
void hal_watchdog_kick(void);

#endif
