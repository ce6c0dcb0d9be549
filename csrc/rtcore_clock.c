/* The supervisor's clock: an absolute-deadline schedule on CLOCK_MONOTONIC that never
 * drifts, an optional spin before each deadline, memory locking, and the bare loop that
 * measures the machine's own wake-up floor on the same schedule. */
#define _POSIX_C_SOURCE 200809L

#include <errno.h>
#include <sys/mman.h>
#include <time.h>

#include "rtcore_clock.h"

#define NS_PER_S 1000000000LL

int64_t rtcore_clock_now_ns(void)
{
    struct timespec ts;
    if (clock_gettime(CLOCK_MONOTONIC, &ts) != 0) {
        return -1;
    }
    return (int64_t)ts.tv_sec * NS_PER_S + (int64_t)ts.tv_nsec;
}

static int32_t sleep_abs(int64_t deadline_ns)
{
    struct timespec ts;
    int rc;
    if (deadline_ns <= 0) {
        return 0;
    }
    ts.tv_sec = (time_t)(deadline_ns / NS_PER_S);
    ts.tv_nsec = (long)(deadline_ns % NS_PER_S);
    rc = clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, 0);
    return (int32_t)rc;
}

int64_t rtcore_sleep_until_ns(int64_t deadline_ns, int64_t spin_ns)
{
    int64_t now;
    int32_t rc;
    if (spin_ns < 0) {
        spin_ns = 0;
    }
    rc = sleep_abs(deadline_ns - spin_ns);
    if (rc == EINTR && rtcore_clock_now_ns() < deadline_ns - spin_ns) {
        return -(int64_t)EINTR; /* woken early by a signal: the caller handles it, sleeps again */
    }
    if (rc != 0 && rc != EINTR) {
        return -(int64_t)rc;
    }
    do {
        now = rtcore_clock_now_ns();
    } while (now < deadline_ns);
    return now;
}

int64_t rtcore_next_deadline_ns(int64_t start_ns, int64_t period_ns, int64_t after_ns,
                                int64_t *index)
{
    int64_t k;
    if (period_ns <= 0 || index == 0) {
        return -1;
    }
    k = *index + 1;
    if (start_ns + k * period_ns <= after_ns) {
        k = (after_ns - start_ns) / period_ns + 1;
    }
    *index = k;
    return start_ns + k * period_ns;
}

int64_t rtcore_floor_loop(int64_t start_ns, int64_t period_ns, int64_t first_index,
                          int32_t n_ticks, int64_t spin_ns, int64_t *wake_late_ns,
                          int64_t *index_out, int32_t *misses)
{
    int64_t k = first_index;
    int32_t i;
    int32_t missed = 0;
    if (period_ns <= 0 || n_ticks < 0 || wake_late_ns == 0 || index_out == 0 || misses == 0) {
        return -1;
    }
    for (i = 0; i < n_ticks; ++i) {
        const int64_t deadline = start_ns + k * period_ns;
        int64_t woke = rtcore_sleep_until_ns(deadline, spin_ns);
        while (woke < 0) { /* a signal: sleep again to the same deadline */
            woke = rtcore_sleep_until_ns(deadline, spin_ns);
        }
        wake_late_ns[i] = woke - deadline;
        index_out[i] = k;
        /* the bare loop's tick ends when it wakes: a miss is a wake past the period */
        if (woke > deadline + period_ns) {
            ++missed;
        }
        rtcore_next_deadline_ns(start_ns, period_ns, woke, &k);
    }
    *misses = missed;
    return k;
}

int32_t rtcore_lock_memory(void)
{
    if (mlockall(MCL_CURRENT | MCL_FUTURE) != 0) {
        return (int32_t)errno;
    }
    return 0;
}

int32_t rtcore_unlock_memory(void)
{
    if (munlockall() != 0) {
        return (int32_t)errno;
    }
    return 0;
}
