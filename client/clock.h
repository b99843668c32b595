/* clock.h — the client's two clock helpers, shared by libsylva
 * (client/libsylva.c: retries, waits) and the `sylva` command
 * (client/sylva.c). Header-only (static): the command links libsylva's
 * public API only. */
#ifndef SYLVA_CLOCK_H
#define SYLVA_CLOCK_H

#include <errno.h>
#include <time.h>

/* Sleeps ms milliseconds (nothing when ms <= 0), resuming after signals. */
static inline void sylva_sleep_ms(long ms)
{
    if (ms <= 0) return;
    struct timespec ts = {ms / 1000, (ms % 1000) * 1000000L};
    while (nanosleep(&ts, &ts) != 0 && errno == EINTR) {}
}

/* Seconds on the monotonic clock (for intervals, not dates). */
static inline double sylva_now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

#endif
