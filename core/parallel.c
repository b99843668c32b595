/* parallel.c — sv_parallel_for (parallel.h): one pthread per extra chunk.
 *
 * A thread per call rather than a pool: the regions that pay (billboard-cloud
 * refinement and candidate scans, the dual-grid updates, k-planes
 * assignment) each run for tens of microseconds to milliseconds, against
 * ~20 µs to create and join a thread, and nothing stays alive between bakes
 * or across the zygote's fork (docs/design.md). Callers keep regions that
 * are too small to pay serial (threads = 1); that never changes a result.
 */
#include "parallel.h"

#include <pthread.h>
#include <stdbool.h>

/* A small stack: chunk functions keep their data on the heap, and under
 * RLIMIT_AS (sylvad's worker_memory) 8 MiB of reserved stack per thread is
 * address space a bake may need. 1 MiB leaves room for ASan's larger frames. */
#define CHUNK_STACK (1u << 20)

typedef struct chunk {
    sv_range_fn fn;
    void *ctx;
    uint32_t t, lo, hi;
} chunk;

static void *chunk_run(void *arg)
{
    const chunk *c = arg;
    c->fn(c->ctx, c->t, c->lo, c->hi);
    return NULL;
}

uint32_t sv_parallel_chunks(uint32_t n, uint32_t threads)
{
    uint32_t c = threads ? threads : 1;
    if (c > SV_PARALLEL_MAX) c = SV_PARALLEL_MAX;
    if (c > n) c = n;
    return c;
}

uint32_t sv_parallel_for(uint32_t n, uint32_t threads, sv_range_fn fn, void *ctx)
{
    uint32_t nc = sv_parallel_chunks(n, threads);
    if (nc == 0) return 1;
    chunk ch[SV_PARALLEL_MAX];
    pthread_t th[SV_PARALLEL_MAX];
    bool started[SV_PARALLEL_MAX];
    for (uint32_t t = 0; t < nc; t++) {
        ch[t] = (chunk){fn, ctx, t, (uint32_t)((uint64_t)n * t / nc),
                        (uint32_t)((uint64_t)n * (t + 1) / nc)};
        started[t] = false;
    }
    uint32_t running = 1;
    if (nc > 1) {
        pthread_attr_t attr;
        bool have_attr = pthread_attr_init(&attr) == 0;
        if (have_attr && pthread_attr_setstacksize(&attr, CHUNK_STACK) != 0) {
            pthread_attr_destroy(&attr);
            have_attr = false;
        }
        for (uint32_t t = 1; t < nc; t++) {
            started[t] = pthread_create(&th[t], have_attr ? &attr : NULL, chunk_run, &ch[t]) == 0;
            running += started[t];
        }
        if (have_attr) pthread_attr_destroy(&attr);
    }
    chunk_run(&ch[0]);
    for (uint32_t t = 1; t < nc; t++) {
        if (started[t]) pthread_join(th[t], NULL);
        else chunk_run(&ch[t]); /* no thread: the same call, here */
    }
    return running;
}
