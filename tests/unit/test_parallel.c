/* test_parallel.c — sv_parallel_for (core/parallel.c): the fixed split, the
 * per-chunk ownership its callers rely on for identical bytes, and the
 * serial fallback when no thread can be created. */
#include <pthread.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmocka.h>

#include "parallel.h"

#define N_MAX 1000

typedef struct rec {
    uint32_t chunk_of[N_MAX]; /* per index: the chunk that wrote it, + 1 */
    double value[N_MAX];
    uint32_t lo[SV_PARALLEL_MAX], hi[SV_PARALLEL_MAX];
    uint32_t calls[SV_PARALLEL_MAX];
    pthread_t who[SV_PARALLEL_MAX];
} rec;

/* Per-index work that rounds (the kind the callers do): a short series. */
static double work(uint32_t i)
{
    double x = 0;
    for (uint32_t k = 1; k <= 50; k++) x += 1.0 / (k + i * 0.37);
    return x;
}

static void fill(void *ctx, uint32_t t, uint32_t lo, uint32_t hi)
{
    rec *r = ctx;
    r->lo[t] = lo;
    r->hi[t] = hi;
    r->calls[t]++;
    r->who[t] = pthread_self();
    for (uint32_t i = lo; i < hi; i++) {
        r->chunk_of[i] = t + 1;
        r->value[i] = work(i);
    }
}

static void chunks_are_fixed_contiguous_and_cover_every_index_once(void **state)
{
    (void)state;
    static rec r;
    const uint32_t ns[] = {1, 2, 3, 7, 16, 17, 999, 1000};
    const uint32_t ts[] = {0, 1, 2, 3, 16, 40};
    for (size_t a = 0; a < sizeof ns / sizeof ns[0]; a++)
        for (size_t b = 0; b < sizeof ts / sizeof ts[0]; b++) {
            uint32_t n = ns[a], th = ts[b];
            memset(&r, 0, sizeof r);
            uint32_t nc = sv_parallel_chunks(n, th);
            uint32_t want = th ? th : 1;
            if (want > SV_PARALLEL_MAX) want = SV_PARALLEL_MAX;
            if (want > n) want = n;
            assert_int_equal(nc, want);
            uint32_t ran = sv_parallel_for(n, th, fill, &r);
            assert_true(ran >= 1 && ran <= nc);
            for (uint32_t t = 0; t < nc; t++) {
                assert_int_equal(r.calls[t], 1);
                assert_int_equal(r.lo[t], (uint32_t)((uint64_t)n * t / nc));
                assert_int_equal(r.hi[t], (uint32_t)((uint64_t)n * (t + 1) / nc));
                for (uint32_t i = r.lo[t]; i < r.hi[t]; i++) assert_int_equal(r.chunk_of[i], t + 1);
            }
            for (uint32_t t = nc; t < SV_PARALLEL_MAX; t++) assert_int_equal(r.calls[t], 0);
        }
}

static void chunk_zero_runs_on_the_caller(void **state)
{
    (void)state;
    static rec r;
    memset(&r, 0, sizeof r);
    sv_parallel_for(100, 2, fill, &r);
    assert_true(pthread_equal(r.who[0], pthread_self()));
}

static void nothing_to_do_calls_nothing(void **state)
{
    (void)state;
    static rec r;
    memset(&r, 0, sizeof r);
    assert_int_equal(sv_parallel_chunks(0, 2), 0);
    assert_int_equal(sv_parallel_for(0, 2, fill, &r), 1);
    for (uint32_t t = 0; t < SV_PARALLEL_MAX; t++) assert_int_equal(r.calls[t], 0);
}

static void per_index_results_are_the_same_bytes_for_any_thread_count(void **state)
{
    (void)state;
    static rec a, b;
    memset(&a, 0, sizeof a);
    sv_parallel_for(N_MAX, 1, fill, &a);
    for (uint32_t th = 2; th <= SV_PARALLEL_MAX; th++) {
        memset(&b, 0, sizeof b);
        sv_parallel_for(N_MAX, th, fill, &b);
        assert_memory_equal(a.value, b.value, sizeof a.value);
    }
}

/* When no thread can be created, every chunk still runs, on the caller, with
 * the same bounds: the same bytes. Thread stacks are made impossible with an
 * address-space limit just above what the child already maps (in a child, so
 * the limit stays there). Runs first: glibc reuses the stacks of finished
 * threads, which would need no new mapping. */
#if !defined(__SANITIZE_ADDRESS__) /* ASan's own thread bookkeeping does not survive a
                                    * tight RLIMIT_AS: this case runs in the plain build */
static void chunks_run_serially_when_no_thread_can_start(void **state)
{
    (void)state;
    static rec want;
    memset(&want, 0, sizeof want);
    for (uint32_t i = 0; i < N_MAX; i++) want.value[i] = work(i);
    fflush(NULL);
    pid_t pid = fork();
    assert_true(pid >= 0);
    if (pid == 0) {
        static rec r;
        memset(&r, 0, sizeof r);
        unsigned long pages = 0;
        FILE *f = fopen("/proc/self/statm", "r");
        if (!f || fscanf(f, "%lu", &pages) != 1) _exit(3);
        fclose(f);
        rlim_t now = (rlim_t)pages * (rlim_t)sysconf(_SC_PAGESIZE);
        struct rlimit lim = {now + (256u << 10), now + (256u << 10)};
        if (setrlimit(RLIMIT_AS, &lim) != 0) _exit(3);
        uint32_t ran = sv_parallel_for(N_MAX, 4, fill, &r);
        if (ran != 1) _exit(4);
        for (uint32_t t = 0; t < 4; t++)
            if (r.calls[t] != 1 || !pthread_equal(r.who[t], pthread_self())) _exit(5);
        _exit(memcmp(r.value, want.value, sizeof r.value) ? 6 : 0);
    }
    int status = 0;
    assert_int_equal(waitpid(pid, &status, 0), pid);
    assert_true(WIFEXITED(status));
    assert_int_equal(WEXITSTATUS(status), 0);
}
#endif

int main(void)
{
    const struct CMUnitTest tests[] = {
#if !defined(__SANITIZE_ADDRESS__)
        cmocka_unit_test(chunks_run_serially_when_no_thread_can_start),
#endif
        cmocka_unit_test(chunks_are_fixed_contiguous_and_cover_every_index_once),
        cmocka_unit_test(chunk_zero_runs_on_the_caller),
        cmocka_unit_test(nothing_to_do_calls_nothing),
        cmocka_unit_test(per_index_results_are_the_same_bytes_for_any_thread_count),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
