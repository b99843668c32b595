/* Skips that are not passes, for the cmocka unit tests (include after cmocka.h).
 *
 * A test that cannot run here (no $SYLVA_DATA, no OSMesa context) calls
 * SV_SKIP("why", ...): it prints "skipped: why", marks the binary as having
 * skipped and leaves the test through cmocka's skip(). main() ends with
 *     return sv_test_exit(cmocka_run_group_tests(tests, NULL, NULL));
 * which is 1 on any failure, else 77 if anything skipped, else 0: tests/run.sh
 * reports 77 as SKIP, which fails the run unless expected (never with CI=true).
 * cmocka alone would count a skipped test as passed. */
#ifndef SV_TEST_SKIP_H
#define SV_TEST_SKIP_H

#include <stdio.h>
#include <stdlib.h>
#include <sys/stat.h>

static int sv_test_skipped;

#define SV_SKIP(...)                     \
    do {                                 \
        printf("skipped: " __VA_ARGS__); \
        printf("\n");                    \
        fflush(stdout);                  \
        sv_test_skipped = 1;             \
        skip();                          \
    } while (0)

/* $SYLVA_DATA (the shared trees; tests/run.sh sets it to ../shared/data) when
 * it names a directory; otherwise the calling test is skipped, saying `what`
 * needs it. A file missing inside an existing data set is a failure, not a
 * skip: callers fail_msg() on it. */
static inline const char *sv_test_data(const char *what)
{
    const char *d = getenv("SYLVA_DATA");
    struct stat st;
    if (!d || !*d || stat(d, &st) != 0 || !S_ISDIR(st.st_mode))
        SV_SKIP("SYLVA_DATA is not a directory (%s needs the shared trees)", what);
    return d;
}

static inline int sv_test_exit(int failed)
{
    if (failed) return 1;
    return sv_test_skipped ? 77 : 0;
}

#endif
