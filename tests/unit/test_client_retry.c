/* test_client_retry.c — libsylva's retry/backoff/failover policy
 * (sylva_retry_delay), options defaults, and job/manifest parsing. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <stdlib.h>
#include <string.h>

#include "sylva.h"

static sylva_options opts(int attempts, long base, long cap)
{
    sylva_options o;
    sylva_options_init(&o);
    o.max_attempts = attempts;
    o.backoff_base_ms = base;
    o.backoff_max_ms = cap;
    return o;
}

static void retry_doubles_the_delay_each_round_up_to_the_cap(void **state)
{
    (void)state;
    sylva_options o = opts(10, 100, 1000);
    long want[] = {100, 200, 400, 800, 1000, 1000, 1000, 1000, 1000};
    for (int a = 1; a <= 9; a++)
        assert_int_equal(sylva_retry_delay(&o, a, 1, true, 0, -1), want[a - 1]);
}

static void retry_stops_after_max_attempts(void **state)
{
    (void)state;
    sylva_options o = opts(3, 100, 1000);
    assert_true(sylva_retry_delay(&o, 1, 1, true, 0, -1) >= 0);
    assert_true(sylva_retry_delay(&o, 2, 1, true, 0, -1) >= 0);
    assert_int_equal(sylva_retry_delay(&o, 3, 1, true, 0, -1), -1);
    o.max_attempts = 1; /* no retry at all */
    assert_int_equal(sylva_retry_delay(&o, 1, 1, true, 503, -1), -1);
}

static void retry_covers_connection_errors_429_and_5xx_only(void **state)
{
    (void)state;
    sylva_options o = opts(5, 100, 1000);
    assert_true(sylva_retry_delay(&o, 1, 1, true, 0, -1) > 0);
    long retryable[] = {429, 500, 502, 503, 504, 507};
    for (size_t i = 0; i < sizeof retryable / sizeof retryable[0]; i++)
        assert_true(sylva_retry_delay(&o, 1, 1, false, retryable[i], -1) > 0);
    long final[] = {200, 202, 304, 400, 401, 403, 404, 413, 415, 422};
    for (size_t i = 0; i < sizeof final / sizeof final[0]; i++)
        assert_int_equal(sylva_retry_delay(&o, 1, 1, false, final[i], -1), -1);
}

static void retry_honours_a_longer_retry_after(void **state)
{
    (void)state;
    sylva_options o = opts(5, 100, 1000);
    assert_int_equal(sylva_retry_delay(&o, 1, 1, false, 503, 3000), 3000);
    /* A shorter Retry-After does not shorten the backoff. */
    assert_int_equal(sylva_retry_delay(&o, 2, 1, false, 429, 50), 200);
    /* An absurd Retry-After is capped at 4x the maximum delay. */
    assert_int_equal(sylva_retry_delay(&o, 1, 1, false, 503, 3600 * 1000L), 4000);
}

static void retry_fails_over_at_once_and_sleeps_after_a_full_round(void **state)
{
    (void)state;
    sylva_options o = opts(9, 100, 1000);
    /* Three servers: attempts 1 and 2 move on without sleeping, attempt 3
     * completes round 1 (100 ms), attempt 6 round 2 (200 ms). */
    assert_int_equal(sylva_retry_delay(&o, 1, 3, true, 0, -1), 0);
    assert_int_equal(sylva_retry_delay(&o, 2, 3, false, 502, -1), 0);
    assert_int_equal(sylva_retry_delay(&o, 3, 3, true, 0, -1), 100);
    assert_int_equal(sylva_retry_delay(&o, 4, 3, true, 0, -1), 0);
    assert_int_equal(sylva_retry_delay(&o, 6, 3, true, 0, -1), 200);
    assert_int_equal(sylva_retry_delay(&o, 9, 3, true, 0, -1), -1);
}

static void zeroed_options_mean_the_defaults(void **state)
{
    (void)state;
    sylva_options zero = {0}, def;
    sylva_options_init(&def);
    assert_int_equal(def.max_attempts, 8);
    assert_int_equal(def.backoff_base_ms, 250);
    assert_int_equal(def.backoff_max_ms, 8000);
    assert_true(def.connect_timeout_ms > 0 && def.request_timeout_ms > 0);
    for (int a = 1; a <= 8; a++)
        assert_int_equal(sylva_retry_delay(&zero, a, 1, true, 0, -1),
                         sylva_retry_delay(&def, a, 1, true, 0, -1));
    assert_int_equal(sylva_retry_delay(NULL, 1, 1, true, 0, -1), 250);
    assert_int_equal(sylva_retry_delay(&zero, 8, 1, true, 0, -1), -1);
}

static void client_create_refuses_urls_without_a_scheme(void **state)
{
    (void)state;
    const char *bad[] = {"127.0.0.1:8080"};
    sylva_client *c = (sylva_client *)(uintptr_t)1;
    char err[256] = "";
    assert_int_equal(sylva_client_create(bad, 1, NULL, &c, err, sizeof err), SYLVA_ERR_ARG);
    assert_null(c);
    assert_non_null(strstr(err, "127.0.0.1:8080"));
    assert_int_equal(sylva_client_create(bad, 0, NULL, &c, err, sizeof err), SYLVA_ERR_ARG);
    const char *good[] = {"http://127.0.0.1:1/", "http://127.0.0.1:2"};
    assert_int_equal(sylva_client_create(good, 2, NULL, &c, err, sizeof err), SYLVA_OK);
    assert_string_equal(sylva_client_server(c), "http://127.0.0.1:1"); /* trailing / dropped */
    sylva_client_destroy(c);
    sylva_client_destroy(NULL);
}

#define K64 "0123456789abcdef0123456789abcdef0123456789abcdef0123456789abcdef"

static void job_parse_reads_state_stage_progress_and_error(void **state)
{
    (void)state;
    const char *body = "{\"key\":\"" K64 "\",\"state\":\"failed\",\"stage\":\"import\","
                       "\"progress\":0.25,\"error\":{\"code\":\"parse\",\"message\":\"bad obj\"}}";
    sylva_job job = {0};
    assert_int_equal(sylva_job_parse(body, strlen(body), &job), SYLVA_OK);
    assert_string_equal(job.key, K64);
    assert_int_equal(job.state, SYLVA_STATE_FAILED);
    assert_string_equal(job.stage, "import");
    assert_true(job.progress > 0.24 && job.progress < 0.26);
    assert_string_equal(job.error_code, "parse");
    assert_string_equal(job.error_message, "bad obj");
    assert_string_equal(job.json, body);
    sylva_job_clear(&job);
    assert_null(job.json);
    sylva_job_clear(NULL);
}

static void job_parse_accepts_a_null_stage(void **state)
{
    (void)state;
    const char *body = "{\"key\":\"" K64 "\",\"state\":\"queued\",\"stage\":null,\"progress\":0}";
    sylva_job job = {0};
    assert_int_equal(sylva_job_parse(body, strlen(body), &job), SYLVA_OK);
    assert_int_equal(job.state, SYLVA_STATE_QUEUED);
    assert_string_equal(job.stage, "");
    sylva_job_clear(&job);
}

/* A done bake whose target was not met says so in the job. */
static void job_parse_reads_an_unmet_target(void **state)
{
    (void)state;
    const char *body = "{\"key\":\"" K64 "\",\"state\":\"done\",\"target\":{\"met\":false,"
                       "\"chosen\":1,\"reason\":\"goal IoU 0.99: no setting reached it\"}}";
    sylva_job job = {0};
    assert_int_equal(sylva_job_parse(body, strlen(body), &job), SYLVA_OK);
    assert_true(job.target_unmet);
    assert_string_equal(job.target_reason, "goal IoU 0.99: no setting reached it");
    const char *met = "{\"key\":\"" K64 "\",\"state\":\"done\",\"target\":{\"met\":true}}";
    assert_int_equal(sylva_job_parse(met, strlen(met), &job), SYLVA_OK);
    assert_false(job.target_unmet);
    assert_string_equal(job.target_reason, "");
    const char *none = "{\"key\":\"" K64 "\",\"state\":\"done\"}";
    assert_int_equal(sylva_job_parse(none, strlen(none), &job), SYLVA_OK);
    assert_false(job.target_unmet);
    sylva_job_clear(&job);
}

static void job_parse_refuses_what_is_not_a_job(void **state)
{
    (void)state;
    const char *bad[] = {
        "",
        "[]",
        "{\"state\":\"done\"}",
        "{\"key\":\"abc\",\"state\":\"done\"}",
        "{\"key\":\"" K64 "\",\"state\":\"exploded\"}",
        "{\"key\":\"" K64 "\"}",
        "{\"error\":{\"code\":\"x\",\"message\":\"y\"}}",
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        sylva_job job = {0};
        assert_int_equal(sylva_job_parse(bad[i], strlen(bad[i]), &job), SYLVA_ERR_PROTOCOL);
        assert_null(job.json);
    }
}

static void manifest_artifacts_are_listed_with_size_and_hash(void **state)
{
    (void)state;
    const char *body = "{\"key\":\"" K64 "\",\"state\":\"done\",\"manifest\":{\"artifacts\":["
                       "{\"name\":\"model.glb\",\"size\":1234,\"sha256\":\"" K64 "\"},"
                       "{\"name\":\"planes.json\",\"size\":0,\"sha256\":\"" K64 "\"}]}}";
    sylva_job job = {0};
    assert_int_equal(sylva_job_parse(body, strlen(body), &job), SYLVA_OK);
    assert_true(job.progress == 1.0);
    sylva_artifact *a = NULL;
    size_t n = 0;
    assert_int_equal(sylva_job_artifacts(&job, &a, &n), SYLVA_OK);
    assert_int_equal(n, 2);
    assert_string_equal(a[0].name, "model.glb");
    assert_int_equal(a[0].size, 1234);
    assert_string_equal(a[1].sha256, K64);
    free(a);
    sylva_job_clear(&job);
}

static void manifest_with_a_path_as_artifact_name_is_refused(void **state)
{
    (void)state;
    const char *bad[] = {
        "{\"key\":\"" K64 "\",\"state\":\"done\",\"manifest\":{\"artifacts\":["
        "{\"name\":\"../../etc/passwd\",\"size\":1,\"sha256\":\"" K64 "\"}]}}",
        "{\"key\":\"" K64 "\",\"state\":\"done\",\"manifest\":{\"artifacts\":["
        "{\"name\":\"a.png\",\"size\":1,\"sha256\":\"ABCDEF\"}]}}",
        "{\"key\":\"" K64 "\",\"state\":\"done\"}",
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        sylva_job job = {0};
        assert_int_equal(sylva_job_parse(bad[i], strlen(bad[i]), &job), SYLVA_OK);
        sylva_artifact *a = (sylva_artifact *)(uintptr_t)1;
        size_t n = 7;
        assert_int_equal(sylva_job_artifacts(&job, &a, &n), SYLVA_ERR_PROTOCOL);
        assert_null(a);
        assert_int_equal(n, 0);
        sylva_job_clear(&job);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(retry_doubles_the_delay_each_round_up_to_the_cap),
        cmocka_unit_test(retry_stops_after_max_attempts),
        cmocka_unit_test(retry_covers_connection_errors_429_and_5xx_only),
        cmocka_unit_test(retry_honours_a_longer_retry_after),
        cmocka_unit_test(retry_fails_over_at_once_and_sleeps_after_a_full_round),
        cmocka_unit_test(zeroed_options_mean_the_defaults),
        cmocka_unit_test(client_create_refuses_urls_without_a_scheme),
        cmocka_unit_test(job_parse_reads_state_stage_progress_and_error),
        cmocka_unit_test(job_parse_accepts_a_null_stage),
        cmocka_unit_test(job_parse_reads_an_unmet_target),
        cmocka_unit_test(job_parse_refuses_what_is_not_a_job),
        cmocka_unit_test(manifest_artifacts_are_listed_with_size_and_hash),
        cmocka_unit_test(manifest_with_a_path_as_artifact_name_is_refused),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
