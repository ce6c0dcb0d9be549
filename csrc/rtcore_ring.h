/*
 * rtcore_ring: the recording ring (csrc/rtcore_ring.c).
 * One producer (the tick) and one consumer (the writer), rows of n_cols doubles in
 * caller-provided (shared) memory. A push writes its row into slot count % capacity, then
 * publishes count + 1 with release semantics, so while the count reads n the slot of row
 * n - capacity may be half overwritten: a reader trusts the last capacity - 1 rows only.
 * ring_count reads the count with acquire semantics, after a fence that completes the
 * caller's earlier loads (the seqlock check after a copy; csrc/rtcore_ring.c).
 *
 * The block between the CDEF markers is read verbatim by rtcore/_build.py (with the
 * other headers' blocks, in the order listed there) and handed to cffi: keep it to
 * plain declarations and integer #defines.
 */
#ifndef RTCORE_RING_H
#define RTCORE_RING_H

#include <stdint.h>

#include "rtcore_step.h"

#ifdef __cplusplus
extern "C" {
#endif

/* BEGIN CDEF */
int64_t rtcore_ring_count(const int64_t *count);
/* The ring row's width: t_s, state, then RTCORE_RING_QUANTITIES blocks of n_fingers */
#define RTCORE_RING_QUANTITIES 11
/* One supervisor tick as one ring row, written straight into the ring: t_s, state, then
 * blocks of n_fingers in the order angle_ref_deg, pressure_kpa (sent_kpa), pressure_meas_kpa,
 * angle_deg, angle_filt_deg, velocity_deg_per_s, force_est_n (out->force_normal_n, the signed
 * normal force that force control tracks, not the magnitude out->force_magnitude_n), force_ref_n,
 * mode, flags, angle_true_deg (hand_service/service/recorder_writer.py QUANTITIES).
 * angle_true_deg: the simulated hand's true angle at the sample the tick read (the simulator's
 * output, before sensor noise), or NULL where there is no such truth (a board): NaN. Returns
 * the new count, or -1 when n_cols is not 2 + RTCORE_RING_QUANTITIES * n_fingers. */
int64_t rtcore_ring_push_tick(double *rows, int64_t *count, int32_t capacity, int32_t n_cols,
                              int32_t n_fingers, const rtcore_inputs *in, const rtcore_outputs *out,
                              const double *sent_kpa, const double *angle_true_deg, double t_s,
                              int32_t state);
/* END CDEF */

#ifdef __cplusplus
}
#endif

#endif /* RTCORE_RING_H */
