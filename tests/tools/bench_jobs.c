/* bench_jobs.c — the job table's scale figure: the job table with many
 * stored bakes and a long queue, through the same API sylvad's HTTP threads
 * and workers use (server/jobs.h), without HTTP or a worker process.
 *
 * usage: bench_jobs DIR N_DONE N_QUEUED [--prepare]
 *   1. N_DONE bakes are submitted, taken and finished (a one-file result):
 *      the stored history;
 *   2. N_QUEUED more are submitted: the queue;
 *   3. a no-op worker thread takes and finishes every queued bake as fast as
 *      the table lets it, while this thread asks for the status of random
 *      keys (stored and queued) without pause.
 * --prepare stops after step 2 and prints the queued keys, one per line: the
 * store (DIR/store) is then sylvad's to dispatch (scale.sh's HTTP form).
 * Prints one JSON line: dispatch rate (jobs/s), status latency p50/p99/max
 * (ms) during the dispatch, and the set-up time. DIR should be on tmpfs
 * (/dev/shm): the journal fsyncs every record, and the figure is the table's,
 * not the disk's. Used by tests/reliability/scale.sh (make reliability; the
 * short form in reliability_short.sh).
 */
#include <pthread.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "config.h"
#include "jobs.h"
#include "key.h"
#include "log.h"
#include "metrics.h"
#include "store.h"

typedef struct ctx {
    svd_jobs *jobs;
    svd_store *store;
    unsigned todo;
    double t_end;
} ctx;

static void die(const char *what, const sv_error *e)
{
    fprintf(stderr, "bench_jobs: %s: %s\n", what, e ? e->message : "");
    exit(1);
}

/* An upload directory as http.c makes it; its key in key. */
static void upload(svd_store *store, unsigned n, svd_upload *up, char *tmp)
{
    sv_error e = {0};
    if (svd_store_mktemp(store, "up", tmp, &e) != SV_OK) die("mktemp", &e);
    char in[SVD_STORE_PATH + 8], content[64];
    snprintf(in, sizeof in, "%s/in", tmp);
    mkdir(in, 0700);
    int len = snprintf(content, sizeof content, "v %u 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\n", n);
    if (svd_store_write_file(in, "tree.obj", content, (size_t)len, &e) != SV_OK) die("write", &e);
    char h[SVD_KEY_HEX], inputs[512];
    svd_sha256_hex(content, (size_t)len, h);
    snprintf(inputs, sizeof inputs,
             "{\"mesh\":\"tree.obj\",\"files\":[],\"objects\":{\"tree.obj\":{\"size\":%d,"
             "\"sha256\":\"%s\"}}}",
             len, h);
    if (svd_store_write_file(tmp, "inputs.json", inputs, strlen(inputs), &e) != SV_OK)
        die("write", &e);
    if (svd_store_write_file(tmp, "spec.json", "{}", 2, &e) != SV_OK) die("write", &e);
    svd_key_part m = {.name = "tree.obj", .data = (const uint8_t *)content, .size = (size_t)len};
    memset(up, 0, sizeof *up);
    if (svd_key_compute(NULL, &m, NULL, 0, up->key, &e) != SV_OK) die("key", &e);
    up->tmpdir = tmp;
    up->client = n % 2 ? "addr:10.0.0.1" : "addr:10.0.0.2";
    up->bytes = svd_dir_bytes(tmp);
}

/* The no-op worker's result: one small artifact, then finish. */
static void finish_done(svd_jobs *jobs, svd_store *store, svd_ticket *t)
{
    sv_error e = {0};
    char out[SVD_STORE_PATH];
    if (svd_store_mktemp(store, "out", out, &e) != SV_OK) die("mktemp", &e);
    if (svd_store_write_file(out, "model.glb", "X", 1, &e) != SV_OK) die("write", &e);
    char h[SVD_KEY_HEX], manifest[512];
    svd_sha256_hex("X", 1, h);
    snprintf(
        manifest, sizeof manifest,
        "{\"key\":\"%s\",\"artifacts\":[{\"name\":\"model.glb\",\"size\":1,\"sha256\":\"%s\"}]}",
        t->key, h);
    if (svd_store_write_file(out, "manifest.json", manifest, strlen(manifest), &e) != SV_OK)
        die("write", &e);
    if (svd_store_install(store, out, t->key, "result", &e) != SV_OK) die("install", &e);
    svd_jobs_finish(jobs, t, SVD_OUT_DONE, NULL, NULL, manifest);
}

static void *worker(void *arg)
{
    ctx *c = arg;
    svd_ticket t;
    for (unsigned i = 0; i < c->todo && svd_jobs_take(c->jobs, &t); i++)
        finish_done(c->jobs, c->store, &t);
    c->t_end = sv_now();
    return NULL;
}

static void close_all(svd_jobs *jobs, svd_store *store, svd_metrics *metrics, svd_log *log)
{
    svd_jobs_destroy(jobs);
    svd_store_close(store);
    svd_metrics_destroy(metrics);
    svd_log_close(log);
}

static int cmp_d(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

int main(int argc, char **argv)
{
    bool prepare = argc == 5 && strcmp(argv[4], "--prepare") == 0;
    if (argc != 4 && !prepare) {
        fprintf(stderr, "usage: bench_jobs DIR N_DONE N_QUEUED [--prepare]\n");
        return 2;
    }
    unsigned ndone = (unsigned)strtoul(argv[2], NULL, 10),
             nq = (unsigned)strtoul(argv[3], NULL, 10);
    char root[1100], lp[1100];
    snprintf(root, sizeof root, "%s/store", argv[1]);
    snprintf(lp, sizeof lp, "%s/log", argv[1]);
    svd_config cfg;
    svd_config_defaults(&cfg);
    cfg.store_max_bytes = (uint64_t)1 << 40;
    cfg.queue_max = nq + 16;
    cfg.queue_per_client = nq + ndone + 16;
    sv_error e = {0};
    svd_log *log = svd_log_open(lp, SVD_LOG_WARN);
    svd_metrics *metrics = svd_metrics_create();
    svd_store *store = svd_store_open(root, &e);
    if (!log || !metrics || !store) die("open", &e);
    svd_jobs *jobs = svd_jobs_create(&cfg, store, log, metrics, &e);
    if (!jobs || svd_jobs_recover(jobs, &e) != SV_OK) die("jobs", &e);
    char(*keys)[SVD_KEY_HEX] = calloc((size_t)ndone + nq, sizeof *keys);
    if (!keys) die("out of memory", NULL);

    double t0 = sv_now();
    char tmp[SVD_STORE_PATH];
    for (unsigned i = 0; i < ndone + nq; i++) {
        svd_upload up;
        upload(store, i, &up, tmp);
        memcpy(keys[i], up.key, SVD_KEY_HEX);
        char *body = NULL;
        sv_error e = {0};
        svd_jobs_rc st = svd_jobs_submit(jobs, &up, &body, &e);
        free(body);
        if (st != SVD_JOBS_ACCEPTED) {
            fprintf(stderr, "bench_jobs: submit %u refused (%d): %s\n", i, (int)st, e.message);
            return 1;
        }
        if (i < ndone) {
            svd_ticket t;
            if (!svd_jobs_take(jobs, &t)) die("take", NULL);
            finish_done(jobs, store, &t);
        }
    }
    double setup = sv_now() - t0;
    if (prepare) {
        for (unsigned i = ndone; i < ndone + nq; i++) printf("%.64s\n", keys[i]);
        fprintf(stderr, "bench_jobs: %u stored, %u queued in %.1f s\n", ndone, nq, setup);
        free(keys);
        close_all(jobs, store, metrics, log);
        return 0;
    }

    ctx c = {jobs, store, nq, 0};
    pthread_t th;
    double d0 = sv_now();
    pthread_create(&th, NULL, worker, &c);
    size_t cap = 1 << 16, n = 0;
    double *lat = malloc(cap * sizeof *lat);
    unsigned long long seed = 88172645463325252ull;
    while (!c.t_end && lat) {
        seed ^= seed << 13, seed ^= seed >> 7, seed ^= seed << 17;
        const char *k = keys[seed % (ndone + nq)];
        char *body = NULL;
        double s0 = sv_now();
        svd_jobs_status(jobs, k, &body, NULL);
        double dt = sv_now() - s0;
        free(body);
        if (n == cap) {
            double *nl = realloc(lat, 2 * cap * sizeof *lat);
            if (!nl) break;
            lat = nl, cap *= 2;
        }
        lat[n++] = dt * 1e3;
    }
    pthread_join(th, NULL);
    double dispatch = c.t_end - d0;
    if (!lat || n == 0) die("no status measured", NULL);
    qsort(lat, n, sizeof *lat, cmp_d);
    printf("{\"done\":%u,\"queued\":%u,\"setup_s\":%.2f,\"dispatch_s\":%.3f,\"jobs_per_s\":%.1f,"
           "\"status_calls\":%zu,\"status_p50_ms\":%.3f,\"status_p99_ms\":%.3f,\"status_max_ms\":%."
           "3f}\n",
           ndone, nq, setup, dispatch, nq / dispatch, n, lat[n / 2], lat[(size_t)(n * 0.99)],
           lat[n - 1]);
    free(lat);
    free(keys);
    close_all(jobs, store, metrics, log);
    return 0;
}
