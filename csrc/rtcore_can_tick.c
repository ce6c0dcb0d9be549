/* The can-v1 tick (rtcore_can.h): the reader thread's batch of frames, taken without
 * waiting, decoded; the control half; the command frames encoded; the follow check. One C
 * call with the GIL released, each phase timed into rtcore_can_io.phase_ns. */
#define _POSIX_C_SOURCE 200809L /* sched_yield */
#include <sched.h>
#include <string.h>

#include "rtcore_can.h"
#include "rtcore_clock.h"
#include "rtcore_tick.h"

#define SEQUENCE_MODULO 256

static void rx_lock(rtcore_can_io *io)
{
    while (__atomic_exchange_n(&io->rx_lock, 1, __ATOMIC_ACQUIRE)) {
        sched_yield();
    }
}

/* The tick never waits on the reader: a batch being added to is left for the next tick. */
static int rx_trylock(rtcore_can_io *io)
{
    return !__atomic_exchange_n(&io->rx_lock, 1, __ATOMIC_ACQUIRE);
}

static void rx_unlock(rtcore_can_io *io)
{
    __atomic_store_n(&io->rx_lock, 0, __ATOMIC_RELEASE);
}

int32_t rtcore_can_rx_add(rtcore_can_io *io, int32_t id, const uint8_t *data, int32_t len, double received_s)
{
    int32_t k;
    int32_t added = 0;
    if (io == 0 || data == 0 || len < 0) {
        return 0;
    }
    rx_lock(io);
    k = io->n_rx < 0 ? 0 : io->n_rx;
    if (k < RTCORE_CAN_MAX_RX && len <= RTCORE_CAN_FRAME_BYTES) {
        io->rx_id[k] = id;
        io->rx_len[k] = len;
        io->rx_received_s[k] = received_s;
        memcpy(io->rx_data + k * RTCORE_CAN_FRAME_BYTES, data, (size_t)len);
        io->n_rx = k + 1;
        added = 1;
    } else {
        io->rx_dropped += 1;
    }
    rx_unlock(io);
    return added;
}

/* A complete sample is taken when its sequence is 1..127 ahead of the last one taken. */
static void take_sample(rtcore_can *can, rtcore_can_io *io, const rtcore_can_message *message)
{
    int64_t lost = 0;
    if (can->has_last_sample) {
        const int32_t delta = (message->sequence - can->last_sample_sequence + SEQUENCE_MODULO) % SEQUENCE_MODULO;
        if (delta == 0 || delta >= SEQUENCE_MODULO / 2) {
            return;
        }
        lost = delta - 1;
    }
    can->has_last_sample = 1;
    can->last_sample_sequence = message->sequence;
    io->sample = *message;
    io->samples += 1;
    if (lost > io->lost_in_a_row) {
        io->lost_in_a_row = lost;
    }
}

/* The end of one phase of the tick: its time (from the end of the one before) into
 * io->phase_ns; returns the clock read. */
static int64_t phase_end(rtcore_can_io *io, int32_t phase, int64_t begin_ns)
{
    const int64_t now = rtcore_clock_now_ns();
    io->phase_ns[phase] = now - begin_ns;
    return now;
}

static void decode_batch(rtcore_can *can, rtcore_can_io *io)
{
    const int32_t n_rx = io->n_rx < 0 ? 0 : (io->n_rx > RTCORE_CAN_MAX_RX ? RTCORE_CAN_MAX_RX : io->n_rx);
    rtcore_can_message message;
    int32_t k;
    io->samples = 0;
    io->lost_in_a_row = 0;
    for (k = 0; k < n_rx; ++k) {
        if (!rtcore_can_decode(can, io->rx_id[k], io->rx_data + k * RTCORE_CAN_FRAME_BYTES, io->rx_len[k],
                               &message)) {
            continue;
        }
        message.received_s = io->rx_received_s[k];
        if (message.kind == RTCORE_CAN_SENSOR) {
            take_sample(can, io, &message);
        }
    }
    io->n_rx = 0;
}

int32_t rtcore_can_tick(rtcore_tick *tick, rtcore_can *can, rtcore_can_io *io, int32_t refs,
                        int32_t vent, int32_t missed_last, int64_t woke_ns, int32_t command_sequence)
{
    rtcore_can_message command;
    int32_t events;
    int32_t fresh;
    int32_t i;
    int64_t start_ns;
    int64_t end_ns;
    if (tick == 0 || can == 0 || io == 0 || tick->inputs == 0) {
        return RTCORE_TICK_OUTPUT;
    }
    start_ns = rtcore_clock_now_ns();
    if (rx_trylock(io)) {
        decode_batch(can, io);
        rx_unlock(io);
    } else { /* the reader thread is adding a frame (it may be preempted): next tick */
        io->samples = 0;
        io->lost_in_a_row = 0;
        io->busy_ticks += 1;
    }
    fresh = io->samples > 0;
    if (fresh) {
        for (i = 0; i < can->n_fingers; ++i) {
            tick->inputs->sensor_mv[i] = io->sample.sensor_mv[i];
            tick->inputs->pressure_meas_kpa[i] = io->sample.pressure_meas_kpa[i];
        }
    }
    end_ns = phase_end(io, RTCORE_CAN_PHASE_DECODE, start_ns);
    events = rtcore_tick_control(tick, refs, vent, missed_last, fresh, io->lost_in_a_row, woke_ns);
    end_ns = phase_end(io, RTCORE_CAN_PHASE_CONTROL, end_ns);
    memset(&command, 0, sizeof command);
    command.kind = RTCORE_CAN_VALVE;
    command.sequence = command_sequence;
    command.n_fingers = can->n_fingers;
    for (i = 0; i < can->n_fingers; ++i) {
        command.pressure_cmd_kpa[i] = tick->sent_kpa[i];
    }
    io->n_tx = rtcore_can_encode(can, &command, io->tx_id, io->tx_len, io->tx_data, RTCORE_MAX_FINGERS);
    if (io->n_tx < 0) { /* the gate should have caught it: vent instead */
        for (i = 0; i < RTCORE_MAX_FINGERS; ++i) {
            tick->sent_kpa[i] = 0.0;
            command.pressure_cmd_kpa[i] = 0.0;
        }
        io->n_tx = rtcore_can_encode(can, &command, io->tx_id, io->tx_len, io->tx_data, RTCORE_MAX_FINGERS);
        events |= RTCORE_TICK_OUTPUT;
    }
    end_ns = phase_end(io, RTCORE_CAN_PHASE_ENCODE, end_ns);
    events |= rtcore_tick_follow(tick);
    (void)phase_end(io, RTCORE_CAN_PHASE_FOLLOW, end_ns);
    return events;
}

int32_t rtcore_can_tick_at(rtcore_tick *tick, rtcore_can *can, rtcore_can_io *io, int64_t deadline_ns,
                           int64_t spin_ns, int32_t refs, int32_t vent, int32_t missed_last,
                           int32_t command_sequence, int64_t *times_ns)
{
    const int64_t woke = rtcore_tick_wake(deadline_ns, spin_ns, times_ns);
    int32_t events;
    if (woke < 0) {
        return -1;
    }
    events = rtcore_can_tick(tick, can, io, refs, vent, missed_last, woke, command_sequence);
    times_ns[1] = rtcore_clock_now_ns();
    return events;
}
