/* A single-producer, single-consumer ring of fixed-width rows of doubles in shared
 * memory: the supervisor's tick pushes one row, a writer (another process or thread)
 * drains them. The count is published with release semantics after the row is copied
 * and read with acquire semantics, so a reader never sees a count ahead of its row, on
 * any CPU. */
#include <string.h>

#include "rtcore.h"

int64_t rtcore_ring_push(double *rows, int64_t *count, int32_t capacity, int32_t n_cols,
                         const double *row)
{
    int64_t n;
    if (rows == 0 || count == 0 || row == 0 || capacity <= 0 || n_cols <= 0) {
        return -1;
    }
    n = __atomic_load_n(count, __ATOMIC_RELAXED);
    memcpy(rows + (size_t)(n % capacity) * (size_t)n_cols, row, sizeof(double) * (size_t)n_cols);
    __atomic_store_n(count, n + 1, __ATOMIC_RELEASE);
    return n + 1;
}

int64_t rtcore_ring_count(const int64_t *count)
{
    if (count == 0) {
        return -1;
    }
    return __atomic_load_n(count, __ATOMIC_ACQUIRE);
}
