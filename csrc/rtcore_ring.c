/* A single-producer, single-consumer ring of fixed-width rows of doubles in shared
 * memory: the supervisor's tick pushes one row, a writer (another process or thread)
 * drains them. The count is published with release semantics after the row is copied
 * and read with acquire semantics, so a reader never sees a count ahead of its row. The
 * row is written in place before the count moves: while the count reads n, the slot of
 * row n - capacity may be half overwritten, so a reader trusts only the last
 * capacity - 1 rows below the count (rtcore/ring.py, Ring.read), and checks the count
 * again after its copy, as a seqlock reader does. Two fences make that check hold on a
 * weakly ordered CPU (ARM, POWER) as well as on x86, where both cost nothing: the
 * producer's count store is ordered before its next row's stores, and the reader's row
 * loads before its second count load (H.-J. Boehm, "Can seqlocks get along with
 * programming language memory models?", MSPC 2012). */
#include <math.h>
#include <string.h>

#include "rtcore_ring.h"

int64_t rtcore_ring_count(const int64_t *count)
{
    if (count == 0) {
        return -1;
    }
    /* the caller's loads so far (a copy of rows) complete before the count is read */
    __atomic_thread_fence(__ATOMIC_ACQUIRE);
    return __atomic_load_n(count, __ATOMIC_ACQUIRE);
}

int64_t rtcore_ring_push_tick(double *rows, int64_t *count, int32_t capacity, int32_t n_cols,
                              int32_t n_fingers, const rtcore_inputs *in, const rtcore_outputs *out,
                              const double *sent_kpa, const double *angle_true_deg, double t_s,
                              int32_t state)
{
    const double *blocks[8];
    double *row;
    int64_t n;
    int32_t b;
    int32_t i;

    if (rows == 0 || count == 0 || in == 0 || out == 0 || sent_kpa == 0 || capacity <= 0
        || n_fingers < 1 || n_fingers > RTCORE_MAX_FINGERS || n_cols != 2 + RTCORE_RING_QUANTITIES * n_fingers) {
        return -1;
    }
    n = __atomic_load_n(count, __ATOMIC_RELAXED);
    /* the count published by the last push is ordered before this row's stores: a reader
     * that still sees an older count has not seen this slot change under it */
    __atomic_thread_fence(__ATOMIC_RELEASE);
    row = rows + (size_t)(n % capacity) * (size_t)n_cols;
    row[0] = t_s;
    row[1] = (double)state;
    blocks[0] = in->angle_ref_deg;
    blocks[1] = sent_kpa;
    blocks[2] = in->pressure_meas_kpa;
    blocks[3] = out->angle_deg;
    blocks[4] = out->angle_filt_deg;
    blocks[5] = out->velocity_deg_per_s;
    blocks[6] = out->force_normal_n; /* the force_est_n column: signed, as force_ref_n */
    blocks[7] = in->force_ref_n;
    for (b = 0; b < 8; ++b) {
        memcpy(row + 2 + b * n_fingers, blocks[b], sizeof(double) * (size_t)n_fingers);
    }
    for (i = 0; i < n_fingers; ++i) {
        row[2 + 8 * n_fingers + i] = (double)in->mode[i];
        row[2 + 9 * n_fingers + i] = (double)out->flags[i];
        /* the truth a simulator knows; none (NaN) from a board */
        row[2 + 10 * n_fingers + i] = angle_true_deg != 0 ? angle_true_deg[i] : (double)NAN;
    }
    __atomic_store_n(count, n + 1, __ATOMIC_RELEASE);
    return n + 1;
}
