/* Unit tests: server/store.c and server/jobs.c without a socket or a worker
 * process: commit, idempotence, verification and quarantine, recovery after a
 * simulated crash, retries, eviction, the fair queue and status documents. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <cjson/cJSON.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "jobs.h"
#include "store.h"

typedef struct fx {
    char dir[32];
    char root[64];
    svd_config cfg;
    svd_log *log;
    svd_metrics *metrics;
    svd_store *store;
    svd_jobs *jobs;
} fx;

static void open_all(fx *f)
{
    sv_error e = {0};
    f->store = svd_store_open(f->root, &e);
    assert_non_null(f->store);
    f->jobs = svd_jobs_create(&f->cfg, f->store, f->log, f->metrics, &e);
    assert_non_null(f->jobs);
    assert_int_equal(svd_jobs_recover(f->jobs, &e), SV_OK);
}

static void close_all(fx *f)
{
    svd_jobs_destroy(f->jobs);
    svd_store_close(f->store);
    f->jobs = NULL;
    f->store = NULL;
}

static int setup(void **state)
{
    fx *f = calloc(1, sizeof *f);
    strcpy(f->dir, "/tmp/svstXXXXXX");
    assert_non_null(mkdtemp(f->dir));
    snprintf(f->root, sizeof f->root, "%s/store", f->dir);
    svd_config_defaults(&f->cfg);
    char lp[96];
    snprintf(lp, sizeof lp, "%s/log", f->dir);
    f->log = svd_log_open(lp, SVD_LOG_DEBUG);
    f->metrics = svd_metrics_create();
    open_all(f);
    *state = f;
    return 0;
}

static int teardown(void **state)
{
    fx *f = *state;
    close_all(f);
    svd_metrics_destroy(f->metrics);
    svd_log_close(f->log);
    svd_rm_rf(f->dir);
    free(f);
    return 0;
}

/* Builds an upload directory the way http.c does; returns its key. */
static void make_upload(fx *f, const char *content, const char *client, svd_upload *up, char *tmp)
{
    sv_error e = {0};
    assert_int_equal(svd_store_mktemp(f->store, "up", tmp, &e), SV_OK);
    char in[SVD_STORE_PATH + 8];
    snprintf(in, sizeof in, "%s/in", tmp);
    mkdir(in, 0700);
    assert_int_equal(svd_store_write_file(in, "tree.obj", content, strlen(content), &e), SV_OK);
    char h[SVD_KEY_HEX];
    svd_sha256_hex(content, strlen(content), h);
    char inputs[512];
    snprintf(inputs, sizeof inputs,
             "{\"mesh\":\"tree.obj\",\"files\":[],\"objects\":{\"tree.obj\":{\"size\":%zu,"
             "\"sha256\":\"%s\"}}}",
             strlen(content), h);
    assert_int_equal(svd_store_write_file(tmp, "inputs.json", inputs, strlen(inputs), &e), SV_OK);
    assert_int_equal(svd_store_write_file(tmp, "spec.json", "{}", 2, &e), SV_OK);
    svd_key_part m = {
        .name = "tree.obj", .data = (const uint8_t *)content, .size = strlen(content)};
    memset(up, 0, sizeof *up);
    assert_int_equal(svd_key_compute(NULL, &m, NULL, 0, up->key, &e), SV_OK);
    up->tmpdir = tmp;
    up->client = client;
    up->bytes = svd_dir_bytes(tmp);
}

static svd_jobs_rc submit(fx *f, const char *content, const char *client, char key[SVD_KEY_HEX])
{
    svd_upload up;
    char tmp[SVD_STORE_PATH];
    make_upload(f, content, client, &up, tmp);
    char *body = NULL;
    svd_jobs_rc st = svd_jobs_submit(f->jobs, &up, &body, NULL);
    free(body);
    if (key) memcpy(key, up.key, SVD_KEY_HEX);
    return st;
}

static char *state_of(fx *f, const char *key)
{
    char *body = NULL;
    if (svd_jobs_status(f->jobs, key, &body, NULL) != SVD_JOBS_OK) {
        free(body);
        return strdup("missing");
    }
    cJSON *j = cJSON_Parse(body);
    free(body);
    char *s = strdup(cJSON_GetStringValue(cJSON_GetObjectItem(j, "state")));
    cJSON_Delete(j);
    return s;
}

static void assert_state(fx *f, const char *key, const char *want)
{
    char *s = state_of(f, key);
    assert_string_equal(s, want);
    free(s);
}

/* Plays a worker that succeeds: writes a result directory and finishes with a
 * manifest holding `extra` (JSON members after "artifacts", may be ""). */
static void fake_done_with(fx *f, svd_ticket *t, const char *artifact, const char *extra)
{
    sv_error e = {0};
    char out[SVD_STORE_PATH];
    assert_int_equal(svd_store_mktemp(f->store, "out", out, &e), SV_OK);
    assert_int_equal(svd_store_write_file(out, "model.glb", artifact, strlen(artifact), &e), SV_OK);
    char h[SVD_KEY_HEX], manifest[2048];
    svd_sha256_hex(artifact, strlen(artifact), h);
    snprintf(manifest, sizeof manifest,
             "{\"key\":\"%s\",\"artifacts\":[{\"name\":\"model.glb\",\"size\":%zu,\"sha256\":\"%"
             "s\"}]%s%s}",
             t->key, strlen(artifact), h, extra[0] ? "," : "", extra);
    assert_int_equal(svd_store_write_file(out, "manifest.json", manifest, strlen(manifest), &e),
                     SV_OK);
    assert_int_equal(svd_store_install(f->store, out, t->key, "result", &e), SV_OK);
    svd_jobs_finish(f->jobs, t, SVD_OUT_DONE, NULL, NULL, manifest);
}

/* Plays a worker that succeeds: writes a result directory and finishes. */
static void fake_done(fx *f, svd_ticket *t, const char *artifact)
{
    sv_error e = {0};
    char out[SVD_STORE_PATH];
    assert_int_equal(svd_store_mktemp(f->store, "out", out, &e), SV_OK);
    assert_int_equal(svd_store_write_file(out, "model.glb", artifact, strlen(artifact), &e), SV_OK);
    char h[SVD_KEY_HEX], manifest[512];
    svd_sha256_hex(artifact, strlen(artifact), h);
    snprintf(
        manifest, sizeof manifest,
        "{\"key\":\"%s\",\"artifacts\":[{\"name\":\"model.glb\",\"size\":%zu,\"sha256\":\"%s\"}]}",
        t->key, strlen(artifact), h);
    assert_int_equal(svd_store_write_file(out, "manifest.json", manifest, strlen(manifest), &e),
                     SV_OK);
    assert_int_equal(svd_store_install(f->store, out, t->key, "result", &e), SV_OK);
    svd_jobs_finish(f->jobs, t, SVD_OUT_DONE, NULL, NULL, manifest);
}

static void submit_accepts_new_work_and_answers_known_key_at_once(void **state)
{
    fx *f = *state;
    char k1[SVD_KEY_HEX], k2[SVD_KEY_HEX];
    assert_int_equal(submit(f, "v 0 0 0\n", "addr:a", k1), SVD_JOBS_ACCEPTED);
    assert_int_equal(submit(f, "v 0 0 0\n", "addr:b", k2), SVD_JOBS_OK);
    assert_string_equal(k1, k2);
    assert_state(f, k1, "queued");
    svd_gauges g;
    svd_jobs_gauges(f->jobs, &g);
    assert_int_equal(g.jobs, 1);
    assert_int_equal(g.queued, 1);
    /* the duplicate's temp directory is gone */
    char tmpdir[SVD_STORE_PATH];
    snprintf(tmpdir, sizeof tmpdir, "%s/tmp", f->root);
    assert_int_equal(svd_dir_bytes(tmpdir), 0);
}

static void accepted_jobs_survive_a_crash_and_are_requeued(void **state)
{
    fx *f = *state;
    char k1[SVD_KEY_HEX], k2[SVD_KEY_HEX], k3[SVD_KEY_HEX];
    assert_int_equal(submit(f, "v 1 0 0\n", "addr:a", k1), SVD_JOBS_ACCEPTED);
    assert_int_equal(submit(f, "v 2 0 0\n", "addr:a", k2), SVD_JOBS_ACCEPTED);
    assert_int_equal(submit(f, "v 3 0 0\n", "addr:a", k3), SVD_JOBS_ACCEPTED);
    svd_ticket t;
    assert_true(svd_jobs_take(f->jobs, &t));
    fake_done(f, &t, "GLB1");
    assert_true(svd_jobs_take(f->jobs, &t)); /* running when the "crash" happens */
    close_all(f);                            /* no finish: as if killed */
    open_all(f);
    assert_state(f, k1, "done");
    assert_state(f, k2, "queued");
    assert_state(f, k3, "queued");
    /* FIFO order survives: k2 then k3 */
    assert_true(svd_jobs_take(f->jobs, &t));
    assert_string_equal(t.key, k2);
    svd_jobs_finish(f->jobs, &t, SVD_OUT_REQUEUE, NULL, NULL, NULL);
}

static void crashing_job_fails_after_three_attempts_with_reason(void **state)
{
    fx *f = *state;
    char k[SVD_KEY_HEX];
    assert_int_equal(submit(f, "# poison\n", "addr:a", k), SVD_JOBS_ACCEPTED);
    svd_ticket t;
    for (int i = 1; i <= 3; i++) {
        assert_true(svd_jobs_take(f->jobs, &t));
        assert_int_equal(t.attempt, (unsigned)i);
        svd_jobs_finish(f->jobs, &t, SVD_OUT_RETRY, NULL, "worker killed by signal 11", NULL);
    }
    char *body = NULL;
    assert_int_equal(svd_jobs_status(f->jobs, k, &body, NULL), SVD_JOBS_OK);
    assert_non_null(strstr(body, "\"state\":\"failed\""));
    assert_non_null(strstr(body, "worker killed by signal 11 on 3 attempts"));
    free(body);
    /* the failure is durable */
    close_all(f);
    open_all(f);
    assert_state(f, k, "failed");
    /* The server's failure (a crash on every attempt) is not
     * the input's verdict: uploading the same bytes again bakes it again */
    assert_int_equal(submit(f, "# poison\n", "addr:a", NULL), SVD_JOBS_OK);
    assert_state(f, k, "queued");
}

/* A retry waits (0.5 s, then 1 s, ... 8 s) instead of
 * meeting a full disk again at once; a failure the input caused is final,
 * also when uploaded again. */
static void retries_back_off_and_input_failures_stay(void **state)
{
    fx *f = *state;
    char k[SVD_KEY_HEX];
    assert_int_equal(submit(f, "v 6 6 6\n", "addr:a", k), SVD_JOBS_ACCEPTED);
    svd_ticket t;
    assert_true(svd_jobs_take(f->jobs, &t));
    svd_jobs_finish(f->jobs, &t, SVD_OUT_RETRY, "io", "no space left on device", NULL);
    double t0 = sv_now();
    assert_true(svd_jobs_take(f->jobs, &t)); /* blocks until the backoff is over */
    assert_true(sv_now() - t0 >= 0.45);
    assert_int_equal(t.attempt, 2u);
    svd_jobs_finish(f->jobs, &t, SVD_OUT_FAILED, "parse", "'x.obj' line 1: bad vertex", NULL);
    assert_state(f, k, "failed");
    assert_int_equal(submit(f, "v 6 6 6\n", "addr:a", NULL), SVD_JOBS_OK);
    assert_state(f, k, "failed");
}

static void delete_cancels_queued_and_removes_finished(void **state)
{
    fx *f = *state;
    char k[SVD_KEY_HEX];
    assert_int_equal(submit(f, "v 9 9 9\n", "addr:a", k), SVD_JOBS_ACCEPTED);
    char *body = NULL;
    assert_int_equal(svd_jobs_delete(f->jobs, k, &body, NULL), SVD_JOBS_OK);
    free(body);
    assert_state(f, k, "cancelled");
    assert_int_equal(svd_jobs_delete(f->jobs, k, &body, NULL), SVD_JOBS_OK);
    free(body);
    assert_state(f, k, "missing");
    char jd[SVD_STORE_PATH];
    svd_store_job_path(f->store, k, NULL, jd);
    struct stat sb;
    assert_int_not_equal(stat(jd, &sb), 0);
    assert_int_equal(svd_jobs_delete(f->jobs, k, &body, NULL), SVD_JOBS_NOT_FOUND);
    free(body);
}

/* An upload of a running bake that a DELETE is stopping is
 * not lost: before the worker stops, the cancel is withdrawn; after, the
 * bake is queued again. */
static void reupload_racing_a_delete_of_a_running_bake_wins(void **state)
{
    fx *f = *state;
    char k[SVD_KEY_HEX];
    char *body = NULL;
    assert_int_equal(submit(f, "v 4 4 4\n", "addr:a", k), SVD_JOBS_ACCEPTED);
    svd_ticket t;
    assert_true(svd_jobs_take(f->jobs, &t));
    assert_int_equal(svd_jobs_delete(f->jobs, k, &body, NULL), SVD_JOBS_ACCEPTED);
    free(body);
    assert_true(svd_jobs_cancelled(f->jobs, &t));
    assert_int_equal(submit(f, "v 4 4 4\n", "addr:a", NULL),
                     SVD_JOBS_OK); /* before the worker stops */
    assert_false(svd_jobs_cancelled(f->jobs, &t));
    fake_done(f, &t, "X");
    assert_state(f, k, "done");
    /* the worker had stopped already: the bake runs again */
    char k2[SVD_KEY_HEX];
    assert_int_equal(submit(f, "v 5 5 5\n", "addr:a", k2), SVD_JOBS_ACCEPTED);
    assert_true(svd_jobs_take(f->jobs, &t));
    assert_int_equal(svd_jobs_delete(f->jobs, k2, &body, NULL), SVD_JOBS_ACCEPTED);
    free(body);
    assert_true(svd_jobs_cancelled(f->jobs, &t)); /* the worker kills the process ... */
    assert_int_equal(submit(f, "v 5 5 5\n", "addr:a", NULL), SVD_JOBS_OK);
    svd_jobs_finish(f->jobs, &t, SVD_OUT_CANCELLED, NULL, "cancelled", NULL); /* ... reports */
    assert_state(f, k2, "queued");
    /* and a DELETE alone still cancels */
    assert_true(svd_jobs_take(f->jobs, &t));
    assert_int_equal(svd_jobs_delete(f->jobs, k2, &body, NULL), SVD_JOBS_ACCEPTED);
    free(body);
    svd_jobs_finish(f->jobs, &t, SVD_OUT_CANCELLED, NULL, "cancelled", NULL);
    assert_state(f, k2, "cancelled");
}

static void corrupt_artifact_is_quarantined_and_job_requeued(void **state)
{
    fx *f = *state;
    char k[SVD_KEY_HEX];
    assert_int_equal(submit(f, "v 5 5 5\n", "addr:a", k), SVD_JOBS_ACCEPTED);
    svd_ticket t;
    assert_true(svd_jobs_take(f->jobs, &t));
    fake_done(f, &t, "GLBDATA");
    char path[SVD_STORE_PATH], sha[SVD_KEY_HEX];
    uint64_t size;
    assert_int_equal(svd_jobs_artifact(f->jobs, k, "model.glb", path, &size, sha), SVD_JOBS_OK);
    assert_int_equal(svd_store_verify(f->store, path, size, sha, NULL), SV_OK);
    assert_int_equal(svd_jobs_artifact(f->jobs, k, "../inputs.json", path, &size, sha),
                     SVD_JOBS_NOT_FOUND);
    /* flip a byte (new mtime defeats the verify cache) */
    usleep(10000);
    int fd = open(path, O_RDWR);
    assert_int_equal(pwrite(fd, "X", 1, 0), 1);
    close(fd);
    assert_int_equal(svd_store_verify(f->store, path, size, sha, NULL), SV_ERR_INVALID);
    svd_jobs_result_corrupt(f->jobs, k, path);
    assert_state(f, k, "queued");
    char q[SVD_STORE_PATH];
    snprintf(q, sizeof q, "%s/quarantine", f->root);
    assert_true(svd_dir_bytes(q) > 0);
    struct stat sb;
    assert_int_not_equal(stat(path, &sb), 0);
}

static void eviction_drops_least_recent_finished_job_never_a_queued_one(void **state)
{
    fx *f = *state;
    char ka[SVD_KEY_HEX], kb[SVD_KEY_HEX], kc[SVD_KEY_HEX], kd[SVD_KEY_HEX];
    assert_int_equal(submit(f, "v 1 1 1\n", "addr:a", ka), SVD_JOBS_ACCEPTED);
    assert_int_equal(submit(f, "v 2 2 2\n", "addr:a", kb), SVD_JOBS_ACCEPTED);
    svd_ticket t;
    assert_true(svd_jobs_take(f->jobs, &t));
    fake_done(f, &t, "A");
    svd_gauges g;
    svd_jobs_gauges(f->jobs, &g);
    /* limit: what is there now plus a little; the next upload does not fit */
    f->cfg.store_max_bytes = g.store_bytes + 50;
    assert_int_equal(submit(f, "v 3 3 3\n", "addr:a", kc),
                     SVD_JOBS_ACCEPTED); /* evicts the done job */
    assert_state(f, ka, "missing");
    assert_state(f, kb, "queued");
    /* only queued jobs left: nothing can be evicted */
    f->cfg.store_max_bytes = 10;
    assert_int_equal(submit(f, "v 4 4 4\n", "addr:a", kd), SVD_JOBS_STORE_FULL);
    assert_state(f, kb, "queued");
    assert_state(f, kc, "queued");
}

/* A result that has just been installed is a use: when it takes the store
 * over the limit, an older finished job is evicted, not the new result (whose
 * last use was its upload, before the others). */
static void fresh_result_is_not_the_eviction_victim(void **state)
{
    fx *f = *state;
    char ka[SVD_KEY_HEX], kb[SVD_KEY_HEX];
    assert_int_equal(submit(f, "v 5 5 5\n", "addr:a", ka),
                     SVD_JOBS_ACCEPTED); /* long bake, uploaded first */
    assert_int_equal(submit(f, "v 6 6 6\n", "addr:a", kb), SVD_JOBS_ACCEPTED);
    svd_ticket ta, tb;
    assert_true(svd_jobs_take(f->jobs, &ta));
    assert_string_equal(ta.key, ka);
    assert_true(svd_jobs_take(f->jobs, &tb));
    fake_done(f, &tb, "B");
    assert_state(f, kb, "done"); /* B was used after A's upload */
    svd_gauges g;
    svd_jobs_gauges(f->jobs, &g);
    f->cfg.store_max_bytes = g.store_bytes + 10; /* A's result does not fit */
    char big[101];
    memset(big, 'A', 100);
    big[100] = '\0';
    fake_done(f, &ta, big);
    svd_jobs_gauges(f->jobs, &g);
    assert_true(g.store_bytes <= f->cfg.store_max_bytes);
    assert_state(f, kb, "missing"); /* the older result made room */
    assert_state(f, ka, "done");    /* the fresh one is served */
}

static void per_client_cap_answers_429_and_queue_cap_503(void **state)
{
    fx *f = *state;
    f->cfg.queue_per_client = 2;
    f->cfg.queue_max = 3;
    assert_int_equal(submit(f, "v 1 0 1\n", "addr:farm", NULL), SVD_JOBS_ACCEPTED);
    assert_int_equal(submit(f, "v 1 0 2\n", "addr:farm", NULL), SVD_JOBS_ACCEPTED);
    assert_int_equal(submit(f, "v 1 0 3\n", "addr:farm", NULL), SVD_JOBS_CLIENT_FULL);
    assert_int_equal(submit(f, "v 1 0 4\n", "addr:editor", NULL), SVD_JOBS_ACCEPTED);
    assert_int_equal(submit(f, "v 1 0 5\n", "addr:editor2", NULL), SVD_JOBS_QUEUE_FULL);
}

static void fair_queue_prefers_client_with_fewer_running_jobs(void **state)
{
    fx *f = *state;
    char f1[SVD_KEY_HEX], f2[SVD_KEY_HEX], e1[SVD_KEY_HEX];
    assert_int_equal(submit(f, "v 7 0 1\n", "addr:farm", f1), SVD_JOBS_ACCEPTED);
    assert_int_equal(submit(f, "v 7 0 2\n", "addr:farm", f2), SVD_JOBS_ACCEPTED);
    assert_int_equal(submit(f, "v 7 0 3\n", "addr:editor", e1), SVD_JOBS_ACCEPTED);
    svd_ticket t1, t2;
    assert_true(svd_jobs_take(f->jobs, &t1));
    assert_string_equal(t1.key, f1); /* oldest first */
    assert_true(svd_jobs_take(f->jobs, &t2));
    assert_string_equal(t2.key, e1); /* the farm already runs one: the editor goes next */
    svd_jobs_finish(f->jobs, &t1, SVD_OUT_REQUEUE, NULL, NULL, NULL);
    svd_jobs_finish(f->jobs, &t2, SVD_OUT_REQUEUE, NULL, NULL, NULL);
}

static void status_reports_stage_progress_and_manifest(void **state)
{
    fx *f = *state;
    char k[SVD_KEY_HEX];
    assert_int_equal(submit(f, "v 8 8 8\n", "addr:a", k), SVD_JOBS_ACCEPTED);
    svd_ticket t;
    assert_true(svd_jobs_take(f->jobs, &t));
    svd_jobs_progress(f->jobs, &t, "import", 0.0, 0, 0);
    svd_jobs_progress(f->jobs, &t, "bake", 0.5, 2, 4);
    char *body = NULL;
    svd_jobs_status(f->jobs, k, &body, NULL);
    cJSON *j = cJSON_Parse(body);
    free(body);
    assert_string_equal(cJSON_GetStringValue(cJSON_GetObjectItem(j, "state")), "running");
    assert_string_equal(cJSON_GetStringValue(cJSON_GetObjectItem(j, "stage")), "bake");
    assert_true(cJSON_GetObjectItem(j, "progress")->valuedouble == 0.5);
    assert_non_null(cJSON_GetObjectItem(cJSON_GetObjectItem(j, "times"), "import"));
    /* a target search's try k of at most n */
    assert_int_equal(cJSON_GetObjectItem(j, "try")->valueint, 2);
    assert_int_equal(cJSON_GetObjectItem(j, "tries")->valueint, 4);
    cJSON_Delete(j);
    svd_jobs_progress(f->jobs, &t, "write", 0.9, 0, 4); /* the search is over */
    svd_jobs_status(f->jobs, k, &body, NULL);
    j = cJSON_Parse(body);
    free(body);
    assert_null(cJSON_GetObjectItem(j, "try"));
    cJSON_Delete(j);
    fake_done(f, &t, "X");
    svd_jobs_status(f->jobs, k, &body, NULL);
    j = cJSON_Parse(body);
    free(body);
    cJSON *a = cJSON_GetArrayItem(
        cJSON_GetObjectItem(cJSON_GetObjectItem(j, "manifest"), "artifacts"), 0);
    assert_string_equal(cJSON_GetStringValue(cJSON_GetObjectItem(a, "name")), "model.glb");
    assert_int_equal((int)cJSON_GetObjectItem(a, "size")->valuedouble, 1);
    cJSON_Delete(j);
}

/* A bake whose target was not met is done, and its status document
 * says so at the top ("target": met false and why) beside every warning; a
 * bake without a target has no "target". */
static void status_lifts_an_unmet_target_and_the_warnings_to_the_top(void **state)
{
    fx *f = *state;
    char k[SVD_KEY_HEX], k2[SVD_KEY_HEX];
    assert_int_equal(submit(f, "v 9 9 9\n", "addr:a", k), SVD_JOBS_ACCEPTED);
    svd_ticket t;
    assert_true(svd_jobs_take(f->jobs, &t));
    fake_done_with(f, &t, "X",
                   "\"summary\":{\"target\":{\"goal\":{\"iou\":0.99},\"met\":false,\"chosen\":3,"
                   "\"reason\":\"goal IoU 0.99: no setting reached it\",\"tries\":[{},{},{},{}]}},"
                   "\"warnings\":[\"'leaf.png' was not supplied: drawn without its texture\"]");
    char *body = NULL;
    assert_int_equal(svd_jobs_status(f->jobs, k, &body, NULL), SVD_JOBS_OK);
    cJSON *j = cJSON_Parse(body);
    free(body);
    assert_string_equal(cJSON_GetStringValue(cJSON_GetObjectItem(j, "state")), "done");
    const cJSON *tg = cJSON_GetObjectItem(j, "target");
    assert_true(cJSON_IsFalse(cJSON_GetObjectItem(tg, "met")));
    assert_string_equal(cJSON_GetStringValue(cJSON_GetObjectItem(tg, "reason")),
                        "goal IoU 0.99: no setting reached it");
    assert_int_equal((int)cJSON_GetNumberValue(cJSON_GetObjectItem(tg, "chosen")), 3);
    assert_null(cJSON_GetObjectItem(tg, "tries")); /* the search itself stays in the manifest */
    assert_int_equal(cJSON_GetArraySize(cJSON_GetObjectItem(j, "warnings")), 1);
    cJSON_Delete(j);
    assert_int_equal(submit(f, "v 7 7 7\n", "addr:a", k2), SVD_JOBS_ACCEPTED);
    assert_true(svd_jobs_take(f->jobs, &t));
    fake_done(f, &t, "Y");
    assert_int_equal(svd_jobs_status(f->jobs, k2, &body, NULL), SVD_JOBS_OK);
    j = cJSON_Parse(body);
    free(body);
    assert_null(cJSON_GetObjectItem(j, "target"));
    assert_int_equal(cJSON_GetArraySize(cJSON_GetObjectItem(j, "warnings")), 0);
    cJSON_Delete(j);
}

static void on_wake(void *arg)
{
    (*(int *)arg)++;
}

static void waiter_wakes_on_state_change_and_on_deadline(void **state)
{
    fx *f = *state;
    char k[SVD_KEY_HEX];
    assert_int_equal(submit(f, "v 6 6 6\n", "addr:a", k), SVD_JOBS_ACCEPTED);
    int woken = 0;
    svd_waiter w = {.wake = on_wake, .arg = &woken, .deadline = sv_now() + 100};
    assert_true(svd_jobs_wait(f->jobs, k, &w));
    svd_jobs_sweep(f->jobs, sv_now(), false);
    assert_int_equal(woken, 0);
    svd_ticket t;
    assert_true(svd_jobs_take(f->jobs, &t)); /* queued -> running */
    assert_int_equal(woken, 1);
    svd_waiter w2 = {.wake = on_wake, .arg = &woken, .deadline = sv_now() - 1};
    assert_true(svd_jobs_wait(f->jobs, k, &w2));
    svd_jobs_sweep(f->jobs, sv_now(), false);
    assert_int_equal(woken, 2);
    fake_done(f, &t, "Y");
    svd_waiter w3 = {.wake = on_wake, .arg = &woken, .deadline = sv_now() + 100};
    assert_false(svd_jobs_wait(f->jobs, k, &w3)); /* final: nothing to wait for */
}

static void orphan_job_directory_without_journal_record_is_removed(void **state)
{
    fx *f = *state;
    char orphan[SVD_STORE_PATH];
    snprintf(orphan, sizeof orphan, "%s/jobs/%064d", f->root, 0);
    mkdir(orphan, 0700);
    close_all(f);
    open_all(f);
    struct stat sb;
    assert_int_not_equal(stat(orphan, &sb), 0);
}

/* One daemon per store: a second open of a held store fails naming
 * the holder's pid and leaves its tmp/ alone; after close it opens again. */
static void a_held_store_is_refused_naming_the_holder(void **state)
{
    fx *f = *state;
    char tmpf[160];
    snprintf(tmpf, sizeof tmpf, "%s/tmp/in-flight", f->root);
    FILE *t = fopen(tmpf, "w");
    assert_non_null(t);
    fclose(t);
    sv_error e = {0};
    assert_null(svd_store_open(f->root, &e));
    char want[64];
    snprintf(want, sizeof want, "in use by another sylvad (pid %ld", (long)getpid());
    assert_non_null(strstr(e.message, want));
    struct stat sb;
    assert_int_equal(stat(tmpf, &sb), 0); /* the holder's temp file survives */
    close_all(f);
    open_all(f); /* released: opens again (and now clears tmp/) */
    assert_int_not_equal(stat(tmpf, &sb), 0);
}

static char *slurp_file(const char *path, size_t *n)
{
    FILE *fp = fopen(path, "rb");
    assert_non_null(fp);
    char *buf = malloc(1 << 16);
    *n = fread(buf, 1, 1 << 16, fp);
    fclose(fp);
    return buf;
}

static void start_up_survives_a_journal_that_cannot_be_compacted(void **state)
{
    fx *f = *state;
    char k1[SVD_KEY_HEX], k2[SVD_KEY_HEX], k3[SVD_KEY_HEX];
    assert_int_equal(submit(f, "v 1 0 0\n", "addr:a", k1), SVD_JOBS_ACCEPTED);
    assert_int_equal(submit(f, "v 2 0 0\n", "addr:a", k2), SVD_JOBS_ACCEPTED);
    svd_ticket t;
    assert_true(svd_jobs_take(f->jobs, &t));
    fake_done(f, &t, "GLB1");
    close_all(f);
    /* journal.tmp cannot be written (a directory stands in its place, as a
     * full disk would refuse it): compaction fails; start-up must not */
    char journal[SVD_STORE_PATH], jtmp[SVD_STORE_PATH + 8];
    snprintf(journal, sizeof journal, "%s/journal", f->root);
    snprintf(jtmp, sizeof jtmp, "%s.tmp", journal);
    assert_int_equal(mkdir(jtmp, 0700), 0);
    size_t n0, n1;
    char *before = slurp_file(journal, &n0);
    open_all(f); /* asserts svd_jobs_recover == SV_OK */
    char *after = slurp_file(journal, &n1);
    assert_int_equal(n0, n1);
    assert_memory_equal(before, after, n0); /* kept as it was */
    free(before);
    free(after);
    assert_state(f, k1, "done");
    assert_state(f, k2, "queued");
    char path[SVD_STORE_PATH], sha[SVD_KEY_HEX];
    uint64_t size = 0;
    assert_int_equal(svd_jobs_artifact(f->jobs, k1, "model.glb", path, &size, sha), SVD_JOBS_OK);
    char log[96];
    snprintf(log, sizeof log, "%s/log", f->dir);
    size_t ln;
    char *text = slurp_file(log, &ln);
    text[ln < (1 << 16) ? ln : (1 << 16) - 1] = '\0';
    assert_non_null(strstr(text, "\"event\":\"journal_compaction_failed\""));
    free(text);
    /* appends go on after the kept journal: a new job and k2's end survive */
    assert_int_equal(submit(f, "v 3 0 0\n", "addr:a", k3), SVD_JOBS_ACCEPTED);
    assert_true(svd_jobs_take(f->jobs, &t));
    fake_done(f, &t, "GLB2");
    close_all(f);
    rmdir(jtmp);
    open_all(f);
    assert_state(f, k1, "done");
    assert_state(f, k2, "done");
    assert_state(f, k3, "queued");
}

/* Submits content under a key chosen by the test (the table takes the key
 * the HTTP layer computed): two keys that share a prefix cost a birthday
 * search over SHA-256 otherwise. */
static void submit_as(fx *f, const char *content, const char *client, const char *key)
{
    svd_upload up;
    char tmp[SVD_STORE_PATH];
    make_upload(f, content, client, &up, tmp);
    snprintf(up.key, sizeof up.key, "%s", key);
    char *body = NULL;
    assert_int_equal(svd_jobs_submit(f->jobs, &up, &body, NULL), SVD_JOBS_ACCEPTED);
    free(body);
}

static void a_key_prefix_resolves_when_unique_and_lists_candidates_when_not(void **state)
{
    fx *f = *state;
    const char *ka = "abcdef0100000000000000000000000000000000000000000000000000000001";
    const char *kb = "abcdef0199999999999999999999999999999999999999999999999999999999";
    const char *kc = "abcdef0299999999999999999999999999999999999999999999999999999999";
    submit_as(f, "v 1 0 0\n", "tok:a", kb); /* out of order: candidates come sorted */
    submit_as(f, "v 2 0 0\n", "tok:a", ka);
    submit_as(f, "v 3 0 0\n", "tok:b", kc);
    char key[SVD_KEY_HEX], *cands = NULL;
    sv_error e = {0};
    /* the whole key and a unique prefix */
    assert_int_equal(svd_jobs_resolve(f->jobs, ka, NULL, key, &cands, &e), SVD_JOBS_OK);
    assert_string_equal(key, ka);
    assert_int_equal(svd_jobs_resolve(f->jobs, "abcdef02", NULL, key, &cands, &e), SVD_JOBS_OK);
    assert_string_equal(key, kc);
    assert_int_equal(svd_jobs_resolve(f->jobs, "abcdef019", NULL, key, &cands, &e), SVD_JOBS_OK);
    assert_string_equal(key, kb);
    /* two bakes start with abcdef01: both listed, in bytewise order */
    assert_int_equal(svd_jobs_resolve(f->jobs, "abcdef01", NULL, key, &cands, &e),
                     SVD_JOBS_AMBIGUOUS);
    assert_non_null(cands);
    char want[200];
    snprintf(want, sizeof want, "[\"%s\",\"%s\"]", ka, kb);
    assert_string_equal(cands, want);
    assert_non_null(strstr(e.message, "abcdef01"));
    free(cands);
    cands = NULL;
    /* none */
    assert_int_equal(svd_jobs_resolve(f->jobs, "abcdef03", NULL, key, &cands, &e),
                     SVD_JOBS_NOT_FOUND);
    assert_non_null(strstr(e.message, "abcdef03"));
    assert_null(cands);
    /* too short, not hex, upper case: refused as not found, never matched */
    assert_int_equal(svd_jobs_resolve(f->jobs, "abcdef0", NULL, key, NULL, &e), SVD_JOBS_NOT_FOUND);
    assert_int_equal(svd_jobs_resolve(f->jobs, "ABCDEF01", NULL, key, NULL, &e),
                     SVD_JOBS_NOT_FOUND);
    /* with tokens only the caller's bakes count: b sees its one, a its two */
    assert_int_equal(svd_jobs_resolve(f->jobs, "abcdef0", "tok:b", key, NULL, &e),
                     SVD_JOBS_NOT_FOUND);
    assert_int_equal(svd_jobs_resolve(f->jobs, "abcdef01", "tok:b", key, NULL, &e),
                     SVD_JOBS_NOT_FOUND);
    assert_int_equal(svd_jobs_resolve(f->jobs, "abcdef02", "tok:a", key, NULL, &e),
                     SVD_JOBS_NOT_FOUND);
    assert_int_equal(svd_jobs_resolve(f->jobs, "abcdef02", "tok:b", key, NULL, &e), SVD_JOBS_OK);
    assert_int_equal(svd_jobs_resolve(f->jobs, "abcdef01", "tok:a", key, NULL, &e),
                     SVD_JOBS_AMBIGUOUS);
}

int main(void)
{
#define T(fn) cmocka_unit_test_setup_teardown(fn, setup, teardown)
    const struct CMUnitTest tests[] = {
        T(submit_accepts_new_work_and_answers_known_key_at_once),
        T(accepted_jobs_survive_a_crash_and_are_requeued),
        T(crashing_job_fails_after_three_attempts_with_reason),
        T(delete_cancels_queued_and_removes_finished),
        T(retries_back_off_and_input_failures_stay),
        T(reupload_racing_a_delete_of_a_running_bake_wins),
        T(corrupt_artifact_is_quarantined_and_job_requeued),
        T(eviction_drops_least_recent_finished_job_never_a_queued_one),
        T(fresh_result_is_not_the_eviction_victim),
        T(per_client_cap_answers_429_and_queue_cap_503),
        T(fair_queue_prefers_client_with_fewer_running_jobs),
        T(status_reports_stage_progress_and_manifest),
        T(status_lifts_an_unmet_target_and_the_warnings_to_the_top),
        T(waiter_wakes_on_state_change_and_on_deadline),
        T(orphan_job_directory_without_journal_record_is_removed),
        T(a_held_store_is_refused_naming_the_holder),
        T(start_up_survives_a_journal_that_cannot_be_compacted),
        T(a_key_prefix_resolves_when_unique_and_lists_candidates_when_not),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
