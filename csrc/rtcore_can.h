/*
 * rtcore_can: the host's can-v1 codec in C (csrc/rtcore_can.c) and the tick around it
 * (csrc/rtcore_can_tick.c).
 *
 * The pack and unpack of every frame are the C source cantools generates from
 * firmware_profiles/can-v1.dbc at build time (rtcore/_build.py writes rtcore_can_v1.[ch] into the
 * build directory; they are never committed), so the DBC stays the one truth. Around them,
 * what hand_service/wire/can_codec.py does in Python, frame for frame: byte 0 of every
 * frame is the AUTOSAR E2E profile-2 CRC-8 over the rest of the frame and the frame id's
 * low byte; sensor and valve messages travel as one frame per finger and are reassembled
 * here (a new sequence abandons an incomplete one); a pressure reading the board does not
 * have (NaN) crosses as the raw value the DBC's value table names not_reported; a reading
 * beyond its range is sent at the range's end; a command or an integer field the wire
 * cannot carry is refused (-1), never clipped.
 *
 * rtcore_can_tick is a supervisor tick over can-v1 in one call: a batch of received frames
 * decoded (the newest complete sample into the step's inputs), rtcore_tick_control, the
 * command encoded into the frames to send, rtcore_tick_follow. The bus I/O stays with the
 * caller (python-can): its reader thread fills the batch, its writer thread sends the
 * frames. A sample counts as fresh as the host's SampleMonitor counts it: its sequence
 * ahead of the last one taken by 1..127 (0 or 128 and more: a duplicate or an old one).
 *
 * The block between the CDEF markers is read verbatim by rtcore/_build.py.
 */
#ifndef RTCORE_CAN_H
#define RTCORE_CAN_H

#include <stdint.h>

#include "rtcore_step.h"
#include "rtcore_tick.h"

#ifdef __cplusplus
extern "C" {
#endif

/* BEGIN CDEF */
/* The messages of can-v1 (rtcore_can_message.kind) */
#define RTCORE_CAN_NONE 0
#define RTCORE_CAN_SENSOR 1 /* SensorFinger, one frame per finger */
#define RTCORE_CAN_VALVE 2 /* ValveCommand, one frame per finger */
#define RTCORE_CAN_STATUS 3
#define RTCORE_CAN_VERSION 4 /* FirmwareVersion */
#define RTCORE_CAN_VERSION_REQUEST 5
#define RTCORE_CAN_FAULT_INJECT 6

#define RTCORE_CAN_NO_FRAME -1 /* rx id of an error or remote frame: counted as ignored */
#define RTCORE_CAN_FRAME_BYTES 8
#define RTCORE_CAN_MAX_RX 256 /* frames one rtcore_can_tick decodes */
/* The phases of one rtcore_can_tick, in order (rtcore_can_io.phase_ns) */
#define RTCORE_CAN_PHASE_DECODE 0 /* the batch decoded, the newest sample into the inputs */
#define RTCORE_CAN_PHASE_CONTROL 1 /* rtcore_tick_control */
#define RTCORE_CAN_PHASE_ENCODE 2 /* the command frames encoded */
#define RTCORE_CAN_PHASE_FOLLOW 3 /* rtcore_tick_follow */
#define RTCORE_CAN_PHASES 4

/* One protocol message, the fields of its kind set (wire.messages in Python). */
typedef struct {
    int32_t kind;
    int32_t sequence; /* SENSOR, VALVE */
    int32_t command_sequence; /* SENSOR */
    double sensor_mv[RTCORE_MAX_FINGERS]; /* SENSOR */
    double pressure_meas_kpa[RTCORE_MAX_FINGERS]; /* SENSOR; NaN: not reported */
    double pressure_cmd_kpa[RTCORE_MAX_FINGERS]; /* VALVE */
    int32_t n_fingers; /* SENSOR, VALVE: the values set (the codec's fingers on decode) */
    int32_t state; /* STATUS */
    int32_t fault_active;
    int32_t rx_errors;
    int32_t fault_code;
    int64_t uptime_ms;
    int32_t protocol_version; /* VERSION, VERSION_REQUEST */
    int32_t firmware_major; /* VERSION */
    int32_t firmware_minor;
    int32_t firmware_patch;
    int32_t finger_count;
    int32_t fault; /* FAULT_INJECT */
    int32_t finger_index;
    int32_t duration_ms;
    int32_t value;
    double received_s; /* rtcore_can_tick: when its last frame arrived (the caller's clock) */
} rtcore_can_message;

/* A multi-frame message being reassembled: one slot per finger. */
typedef struct {
    int32_t active;
    int32_t sequence;
    int32_t command_sequence;
    uint32_t received_mask;
    double first[RTCORE_MAX_FINGERS]; /* sensor_mv or pressure_cmd_kpa */
    double second[RTCORE_MAX_FINGERS]; /* pressure_meas_kpa */
} rtcore_can_partial;

typedef struct {
    int32_t n_fingers; /* 1..RTCORE_MAX_FINGERS */
    /* the ranges the DBC's signals carry (CanCodec.signal_range): set by rtcore_can_init */
    double flex_low_mv;
    double flex_high_mv;
    double pressure_meas_low_kpa;
    double pressure_meas_high_kpa;
    double command_low_kpa;
    double command_high_kpa;
    rtcore_can_partial sensor;
    rtcore_can_partial valve;
    /* wire.messages.DecodeStats: they only grow */
    int64_t frames;
    int64_t crc_errors;
    int64_t decode_errors;
    int64_t ignored;
    int64_t incomplete;
    int32_t last_error; /* RTCORE_CAN_* kind of the newest bad frame (0: id unknown) */
    /* rtcore_can_tick: the sequence of the last sample it took (has_last 0: none yet) */
    int32_t has_last_sample;
    int32_t last_sample_sequence;
} rtcore_can;

/* Frames in and out of one rtcore_can_tick, in caller memory. The received frames are
 * added by another thread (rtcore_can_rx_add) than the one that ticks: rx_lock, a spin
 * lock held for a copy or a decode of the batch, keeps them apart. The tick never waits
 * on it: a batch locked by the adding thread is decoded on the next tick (busy_ticks). */
typedef struct {
    int32_t rx_lock;
    int32_t n_rx; /* received frames to decode, at most RTCORE_CAN_MAX_RX */
    int32_t rx_id[RTCORE_CAN_MAX_RX]; /* RTCORE_CAN_NO_FRAME: an error or remote frame */
    int32_t rx_len[RTCORE_CAN_MAX_RX];
    uint8_t rx_data[RTCORE_CAN_MAX_RX * RTCORE_CAN_FRAME_BYTES];
    double rx_received_s[RTCORE_CAN_MAX_RX]; /* when each arrived */
    int32_t rx_dropped; /* frames that found the batch full (the caller counts them) */
    int64_t busy_ticks; /* ticks that found the batch being added to, and left it */
    /* the samples taken (fresh), the newest of them, and the longest run of samples lost
     * between two taken ones (SensorSample.lost_in_a_row) */
    int32_t samples;
    int64_t lost_in_a_row;
    rtcore_can_message sample;
    /* the command frames to send */
    int32_t n_tx;
    int32_t tx_id[RTCORE_MAX_FINGERS];
    int32_t tx_len[RTCORE_MAX_FINGERS];
    uint8_t tx_data[RTCORE_MAX_FINGERS * RTCORE_CAN_FRAME_BYTES];
    /* how long each phase of the last rtcore_can_tick ran (ns, RTCORE_CAN_PHASE_*), from the
     * monotonic clock read at its start and at the end of each phase: they add up to the
     * tick's time from its start to the end of the follow check */
    int64_t phase_ns[RTCORE_CAN_PHASES];
} rtcore_can_io;

/* AUTOSAR E2E profile-2 CRC-8 (polynomial 0x2F) over data[1..len-1] and data_id. */
uint8_t rtcore_can_e2e_crc(const uint8_t *data, int32_t len, uint8_t data_id);
/* Zero the codec for n_fingers (clamped to 1..RTCORE_MAX_FINGERS) and the DBC's ranges. */
void rtcore_can_init(rtcore_can *can, int32_t n_fingers, double flex_low_mv, double flex_high_mv,
                     double pressure_meas_low_kpa, double pressure_meas_high_kpa, double command_low_kpa,
                     double command_high_kpa);
/* Forget the messages being reassembled and the last sample taken (a reconnect, a
 * reboot); the counters stay. */
void rtcore_can_reset(rtcore_can *can);
/* Decode one frame: 1 when it completed a message (written to *out), else 0 (a frame of a
 * message still incomplete, or a bad frame: counted). */
int32_t rtcore_can_decode(rtcore_can *can, int32_t id, const uint8_t *data, int32_t len,
                          rtcore_can_message *out);
/* Encode a message into frames (ids, lens, RTCORE_CAN_FRAME_BYTES bytes each): the number of
 * frames, or -1 for a message the wire cannot carry (nothing written then), or -2 when
 * capacity is too small. */
int32_t rtcore_can_encode(const rtcore_can *can, const rtcore_can_message *message, int32_t *ids,
                          int32_t *lens, uint8_t *data, int32_t capacity);

/* A received frame into io's batch for the next rtcore_can_tick (any thread): 1, or 0 when
 * the batch is full (counted in rx_dropped) or len is beyond a frame. */
int32_t rtcore_can_rx_add(rtcore_can_io *io, int32_t id, const uint8_t *data, int32_t len, double received_s);
/* A tick over can-v1: decode io's n_rx received frames (then n_rx = 0); the newest sample
 * taken, if any, into the step's inputs (fresh, after io->lost_in_a_row lost ones);
 * rtcore_tick_control(refs, vent, missed_last, woke_ns); the command sent_kpa encoded with
 * command_sequence into io's tx frames (0 kPa when vented);
 * rtcore_tick_follow; the time of each of these phases into io->phase_ns. Returns the
 * RTCORE_TICK_* bits of both halves. A command the wire cannot carry sends a vent instead
 * and returns RTCORE_TICK_OUTPUT. The other messages in the batch (status, version) are
 * not the tick's: the caller's reader thread decodes them as they arrive. */
int32_t rtcore_can_tick(rtcore_tick *tick, rtcore_can *can, rtcore_can_io *io, int32_t refs,
                        int32_t vent, int32_t missed_last, int64_t woke_ns, int32_t command_sequence);
/* The scheduled tick over can-v1, with no Python between the wake-up and the end: sleep to
 * deadline_ns (rtcore_sleep_until_ns, spin_ns), then rtcore_can_tick. times_ns[0] is the
 * wake-up, times_ns[1] the end. Returns the RTCORE_TICK_* bits, or -1 with nothing done
 * when the sleep failed (times_ns[0]: -EINTR, a signal woke it early, or another -errno). */
int32_t rtcore_can_tick_at(rtcore_tick *tick, rtcore_can *can, rtcore_can_io *io, int64_t deadline_ns,
                           int64_t spin_ns, int32_t refs, int32_t vent, int32_t missed_last,
                           int32_t command_sequence, int64_t *times_ns);
/* END CDEF */

#ifdef __cplusplus
}
#endif

#endif /* RTCORE_CAN_H */
