/*
 * rtcore_clock: the supervisor's clock (csrc/rtcore_clock.c).
 * CLOCK_MONOTONIC in ns, and an absolute-deadline schedule: deadline k is
 * start_ns + k*period_ns, so the schedule never drifts whatever a tick costs.
 *
 * The block between the CDEF markers is read verbatim by rtcore/_build.py (with the
 * other headers' blocks, in the order listed there) and handed to cffi: keep it to
 * plain declarations and integer #defines.
 */
#ifndef RTCORE_CLOCK_H
#define RTCORE_CLOCK_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* BEGIN CDEF */
int64_t rtcore_clock_now_ns(void);
/* Sleep (clock_nanosleep, TIMER_ABSTIME) until deadline_ns - spin_ns, then spin on the
 * clock until deadline_ns. Returns the wake-up time in ns, or a negative errno:
 * -EINTR (4) when a signal woke it early, so the caller can handle it and sleep again. */
int64_t rtcore_sleep_until_ns(int64_t deadline_ns, int64_t spin_ns);
/* The deadline after tick *index that ends at after_ns: index+1, or when that deadline
 * has passed already (a deadline miss), the first one still ahead; *index is updated. */
int64_t rtcore_next_deadline_ns(int64_t start_ns, int64_t period_ns, int64_t after_ns,
                                int64_t *index);
/* The machine's floor: a bare loop of n_ticks on the same schedule, from first_index.
 * wake_late_ns[i] is how late tick i woke, index_out[i] its schedule index, *misses the
 * ticks that woke after their period had ended. Returns the next index, or -1. */
int64_t rtcore_floor_loop(int64_t start_ns, int64_t period_ns, int64_t first_index,
                          int32_t n_ticks, int64_t spin_ns, int64_t *wake_late_ns,
                          int64_t *index_out, int32_t *misses);
/* mlockall(MCL_CURRENT | MCL_FUTURE) and munlockall(): 0 or the errno. */
int32_t rtcore_lock_memory(void);
int32_t rtcore_unlock_memory(void);
/* END CDEF */

#ifdef __cplusplus
}
#endif

#endif /* RTCORE_CLOCK_H */
