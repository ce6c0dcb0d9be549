/* The firmware core in a Python process (inprocess.h): its HAL's clock and link. */
#include "inprocess.h"

#include <string.h>

#include "board.h"
#include "hal.h"
#include "hal_plant.h"
#include "host.h"

#define RX_BYTES 16384u
#define TX_BYTES 65536u
#define CAN_QUEUE 512u
#define RAD_TO_DEG 57.29577951308232
/* A run normally follows what arrived at once (the caller wakes on input), so the board
 * receives it at the run's last step. A longer gap is this process held up (a busy machine),
 * not the board: what arrived came at unknown times within it, so the board receives it
 * spread evenly over the gap, living through the gap step by step as a board does; it would
 * otherwise vent for want of commands that were waiting. A gap beyond STALL_MAX_US is cut
 * to it (the board's clock jumps, as its sample timer does after that long). */
#define STALL_US 50000u
#define STALL_MAX_US 500000u

struct inprocess {
    struct board board;
    struct hal_plant plant;
    uint64_t t0_us;               /* the caller's clock at init: the HAL's clock counts from it */
    uint64_t now_us;              /* the HAL's clock, in the caller's time */
    uint32_t rx_budget;           /* how many frames (can) or bytes (serial) the link hands out now */
    uint8_t rx[RX_BYTES];
    uint32_t rx_head, rx_count;
    uint8_t tx[TX_BYTES];
    uint32_t tx_head, tx_count;
    struct inprocess_frame can_rx[CAN_QUEUE];
    uint32_t can_rx_head, can_rx_count;
    struct inprocess_frame can_tx[CAN_QUEUE];
    uint32_t can_tx_head, can_tx_count;
    uint32_t vent_count;
    uint64_t vent_at_us;
};

static struct inprocess *current; /* the instance being run: what the HAL acts on */

static void select_instance(struct inprocess *ip)
{
    current = ip;
    hal_plant_current = &ip->plant;
}

uint32_t hal_time_us(void)
{
    return (uint32_t)(current->now_us - current->t0_us);
}

uint16_t hal_serial_read(uint8_t *buf, uint16_t max_len)
{
    struct inprocess *ip = current;
    uint16_t n = 0u;
    while (ip->rx_budget > 0u && n < max_len && ip->rx_count > 0u) {
        ip->rx_budget--;
        buf[n++] = ip->rx[ip->rx_head];
        ip->rx_head = (ip->rx_head + 1u) % RX_BYTES;
        ip->rx_count--;
    }
    return n;
}

void hal_serial_write(const uint8_t *buf, uint16_t len)
{
    struct inprocess *ip = current;
    for (uint16_t i = 0; i < len && ip->tx_count < TX_BYTES; i++) {
        ip->tx[(ip->tx_head + ip->tx_count) % TX_BYTES] = buf[i];
        ip->tx_count++;
    }
}

static int queue_frame(struct inprocess_frame *queue, uint32_t head, uint32_t *count, const struct inprocess_frame *f)
{
    if (*count >= CAN_QUEUE) {
        return 0;
    }
    queue[(head + *count) % CAN_QUEUE] = *f;
    (*count)++;
    return 1;
}

uint8_t hal_can_read(uint16_t *id, uint8_t *data, uint8_t *len)
{
    struct inprocess *ip = current;
    if (ip->rx_budget == 0u || ip->can_rx_count == 0u) {
        return 0u;
    }
    ip->rx_budget--;
    const struct inprocess_frame *f = &ip->can_rx[ip->can_rx_head];
    *id = f->id;
    *len = f->len;
    memcpy(data, f->data, f->len);
    ip->can_rx_head = (ip->can_rx_head + 1u) % CAN_QUEUE;
    ip->can_rx_count--;
    return 1u;
}

void hal_can_write(uint16_t id, const uint8_t *data, uint8_t len)
{
    struct inprocess_frame f;
    memset(&f, 0, sizeof f);
    f.kind = INPROCESS_DATA;
    f.id = id;
    f.len = len > 8u ? 8u : len;
    memcpy(f.data, data, f.len);
    (void)queue_frame(current->can_tx, current->can_tx_head, &current->can_tx_count, &f);
}

void hal_can_error(uint8_t bus_off)
{
    struct inprocess_frame f;
    memset(&f, 0, sizeof f);
    f.kind = bus_off ? INPROCESS_BUS_OFF : INPROCESS_BUS_ERROR;
    (void)queue_frame(current->can_tx, current->can_tx_head, &current->can_tx_count, &f);
}

void hal_watchdog_kick(void)
{
    /* no hardware watchdog in a Python process: a stuck board is ended by its tests */
}

size_t inprocess_size(void)
{
    return sizeof(struct inprocess);
}

int inprocess_init(struct inprocess *ip, const struct inprocess_config *cfg, uint64_t now_us)
{
    memset(ip, 0, sizeof *ip);
    ip->t0_us = now_us;
    ip->now_us = now_us;
    select_instance(ip);
    struct board_config c = board_config_defaults();
    c.wire = cfg->can ? BOARD_WIRE_CAN : BOARD_WIRE_SERIAL;
    c.n_fingers = cfg->n_fingers;
    c.protocol_version = cfg->protocol_version;
    memcpy(c.firmware_version, cfg->firmware_version, sizeof c.firmware_version);
    c.sample_period_us = cfg->sample_period_us;
    c.watchdog_us = cfg->watchdog_us;
    c.can_error_frames = cfg->can_error_frames;
    c.broken = cfg->broken < INJECT_BROKEN_RULES ? cfg->broken : INJECT_BROKEN_NONE;
    const int n = cfg->n_fingers >= 1u && cfg->n_fingers <= HOST_DEFAULT_FINGERS ? cfg->n_fingers : 1;
    const int plant_status = hal_plant_init(&ip->plant, c.regulator.pwm_period_us, host_default_hand, n, cfg->seed, 0u);
    if (plant_status != 0 || cfg->n_fingers < 1u || cfg->n_fingers > HOST_DEFAULT_FINGERS) {
        return -1;
    }
    return board_init(&ip->board, &c);
}

static void step(struct inprocess *ip, uint64_t at_us)
{
    ip->now_us = at_us;
    hal_plant_advance(&ip->plant, at_us - ip->t0_us);
    board_poll(&ip->board);
    if (ip->board.vent_count != ip->vent_count) {
        ip->vent_count = ip->board.vent_count;
        ip->vent_at_us = at_us;
    }
}

static uint32_t waiting(const struct inprocess *ip)
{
    return ip->board.cfg.wire == BOARD_WIRE_CAN ? ip->can_rx_count : ip->rx_count;
}

void inprocess_run(struct inprocess *ip, uint64_t now_us)
{
    select_instance(ip);
    const uint64_t inner_us = ip->board.cfg.inner_period_us;
    if (now_us > ip->now_us + STALL_MAX_US) {
        ip->now_us = now_us - STALL_MAX_US;
    }
    const uint64_t start_us = ip->now_us;
    const uint64_t gap_us = now_us > start_us ? now_us - start_us : 0u;
    const uint32_t arrived = waiting(ip);
    while (ip->now_us + inner_us < now_us) {
        const uint64_t at_us = ip->now_us + inner_us;
        ip->rx_budget = 0u;
        if (gap_us > STALL_US) { /* what should have arrived by at_us, of what is waiting */
            const uint32_t later = (uint32_t)((uint64_t)arrived * (now_us - at_us) / gap_us);
            ip->rx_budget = waiting(ip) > later ? waiting(ip) - later : 0u;
        }
        step(ip, at_us);
    }
    ip->rx_budget = UINT32_MAX;
    step(ip, now_us > ip->now_us ? now_us : ip->now_us);
    ip->rx_budget = 0u;
}

/* The time from now_us to when_us on the wrapping clock; 0 once it has passed. */
static uint32_t time_left_us(uint32_t now_us, uint32_t when_us)
{
    const int32_t left_us = (int32_t)(when_us - now_us);
    return left_us > 0 ? (uint32_t)left_us : 0u;
}

static uint32_t smaller(uint32_t a, uint32_t b)
{
    return a < b ? a : b;
}

uint64_t inprocess_next_event_us(const struct inprocess *ip)
{
    const struct board *b = &ip->board;
    uint32_t left_us = time_left_us(b->now_us, b->next_sample_us);
    if (b->state == BOARD_RUNNING) {
        left_us = smaller(left_us, time_left_us(b->now_us, b->last_command_us + b->cfg.watchdog_us));
    }
    if (b->state == BOARD_BOOTING) {
        left_us = smaller(left_us, time_left_us(b->now_us, b->boot_end_us));
    }
#ifdef BOARD_TEST_IMAGE
    if (b->inject.count > 0u) {
        left_us = smaller(left_us, time_left_us(b->now_us, b->inject.due_us[b->inject.head]));
    }
#endif
    return ip->now_us + left_us;
}

int inprocess_can_push(struct inprocess *ip, uint16_t id, const uint8_t *data, uint8_t len)
{
    struct inprocess_frame f;
    memset(&f, 0, sizeof f);
    f.id = id;
    f.len = len > 8u ? 8u : len;
    memcpy(f.data, data, f.len);
    return queue_frame(ip->can_rx, ip->can_rx_head, &ip->can_rx_count, &f);
}

uint32_t inprocess_serial_push(struct inprocess *ip, const uint8_t *data, uint32_t len)
{
    uint32_t n = 0u;
    for (; n < len && ip->rx_count < RX_BYTES; n++) {
        ip->rx[(ip->rx_head + ip->rx_count) % RX_BYTES] = data[n];
        ip->rx_count++;
    }
    return n;
}

int inprocess_can_pop(struct inprocess *ip, struct inprocess_frame *frame)
{
    if (ip->can_tx_count == 0u) {
        return 0;
    }
    *frame = ip->can_tx[ip->can_tx_head];
    ip->can_tx_head = (ip->can_tx_head + 1u) % CAN_QUEUE;
    ip->can_tx_count--;
    return 1;
}

uint32_t inprocess_serial_pop(struct inprocess *ip, uint8_t *out, uint32_t max_len)
{
    uint32_t n = 0u;
    for (; n < max_len && ip->tx_count > 0u; n++) {
        out[n] = ip->tx[ip->tx_head];
        ip->tx_head = (ip->tx_head + 1u) % TX_BYTES;
        ip->tx_count--;
    }
    return n;
}

void inprocess_view(const struct inprocess *ip, struct inprocess_view *view)
{
    memset(view, 0, sizeof *view);
    view->state = ip->board.state;
    view->fault_code = ip->board.fault_code;
    view->vent_count = ip->vent_count;
    view->vent_at_us = ip->vent_at_us;
    for (int i = 0; i < ip->plant.plant.n_fingers && i < 8; i++) {
        view->command_kpa[i] = ip->board.command_kpa[i];
        view->angle_deg[i] = ip->plant.plant.motion[i].angle_rad * RAD_TO_DEG;
    }
}
