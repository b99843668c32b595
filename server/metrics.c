/* metrics.c — Prometheus text exposition of sylvad's counters (see metrics.h). */
#include "metrics.h"

#include <pthread.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

const char *const svd_stage_names[SVD_STAGE_COUNT] = {"import", "validate", "classify", "method",
                                                      "bake",   "pack",     "evaluate", "write"};

int svd_stage_index(const char *name)
{
    for (int i = 0; i < SVD_STAGE_COUNT; i++)
        if (name && strcmp(name, svd_stage_names[i]) == 0) return i;
    return -1;
}

static const unsigned statuses[] = {200, 201, 202, 204, 206, 304, 400, 401, 404, 405,
                                    409, 413, 415, 416, 422, 429, 500, 503, 507};
#define NSTATUS (sizeof statuses / sizeof statuses[0] + 1) /* + "other" */

static const char *const finals[] = {"done", "failed", "cancelled"};

struct svd_metrics {
    pthread_mutex_t mu;
    uint64_t requests[SVD_R_COUNT][NSTATUS];
    double stage_sum[SVD_STAGE_COUNT];
    uint64_t stage_count[SVD_STAGE_COUNT];
    uint64_t crashes, timeouts;
    uint64_t job_final[3];
    double job_seconds[3];
    uint64_t upload_bytes;
};

svd_metrics *svd_metrics_create(void)
{
    svd_metrics *m = calloc(1, sizeof *m);
    if (m) pthread_mutex_init(&m->mu, NULL);
    return m;
}

void svd_metrics_destroy(svd_metrics *m)
{
    if (!m) return;
    pthread_mutex_destroy(&m->mu);
    free(m);
}

void svd_metrics_request(svd_metrics *m, svd_route r, unsigned status)
{
    if (!m) return;
    size_t i = 0;
    while (i < NSTATUS - 1 && statuses[i] != status) i++;
    if ((unsigned)r >= SVD_R_COUNT) r = SVD_R_NONE;
    pthread_mutex_lock(&m->mu);
    m->requests[r][i]++;
    pthread_mutex_unlock(&m->mu);
}

void svd_metrics_stage(svd_metrics *m, int stage, double seconds)
{
    if (!m || stage < 0 || stage >= SVD_STAGE_COUNT) return;
    pthread_mutex_lock(&m->mu);
    m->stage_sum[stage] += seconds;
    m->stage_count[stage]++;
    pthread_mutex_unlock(&m->mu);
}

void svd_metrics_worker_crash(svd_metrics *m, int timed_out)
{
    if (!m) return;
    pthread_mutex_lock(&m->mu);
    if (timed_out) m->timeouts++;
    else m->crashes++;
    pthread_mutex_unlock(&m->mu);
}

void svd_metrics_job_final(svd_metrics *m, const char *state, double seconds)
{
    if (!m) return;
    for (int i = 0; i < 3; i++) {
        if (strcmp(state, finals[i]) == 0) {
            pthread_mutex_lock(&m->mu);
            m->job_final[i]++;
            m->job_seconds[i] += seconds;
            pthread_mutex_unlock(&m->mu);
        }
    }
}

void svd_metrics_upload_bytes(svd_metrics *m, uint64_t n)
{
    if (!m) return;
    pthread_mutex_lock(&m->mu);
    m->upload_bytes += n;
    pthread_mutex_unlock(&m->mu);
}

typedef struct sbuf {
    char *p;
    size_t len, cap;
    int oom;
} sbuf;

__attribute__((format(printf, 2, 3))) static void sb_printf(sbuf *b, const char *fmt, ...)
{
    if (b->oom) return;
    for (;;) {
        va_list ap;
        va_start(ap, fmt);
        int n = vsnprintf(b->p + b->len, b->cap - b->len, fmt, ap);
        va_end(ap);
        if (n < 0) {
            b->oom = 1;
            return;
        }
        if ((size_t)n < b->cap - b->len) {
            b->len += (size_t)n;
            return;
        }
        size_t nc = b->cap * 2 + (size_t)n;
        char *np = realloc(b->p, nc);
        if (!np) {
            b->oom = 1;
            return;
        }
        b->p = np;
        b->cap = nc;
    }
}

char *svd_metrics_render(svd_metrics *m, const svd_gauges *g)
{
    sbuf b = {malloc(8192), 0, 8192, 0};
    if (!b.p) return NULL;
    b.p[0] = '\0';
    pthread_mutex_lock(&m->mu);
    sb_printf(&b, "# HELP sylva_requests_total HTTP requests answered, by route and status.\n"
                  "# TYPE sylva_requests_total counter\n");
    for (int r = 0; r < SVD_R_COUNT; r++)
        for (size_t i = 0; i < NSTATUS; i++) {
            if (!m->requests[r][i]) continue;
            if (i < NSTATUS - 1)
                sb_printf(&b, "sylva_requests_total{route=\"%s\",status=\"%u\"} %llu\n",
                          svd_route_label((svd_route)r), statuses[i],
                          (unsigned long long)m->requests[r][i]);
            else
                sb_printf(&b, "sylva_requests_total{route=\"%s\",status=\"other\"} %llu\n",
                          svd_route_label((svd_route)r), (unsigned long long)m->requests[r][i]);
        }
    sb_printf(&b, "# HELP sylva_stage_seconds Worker time per bake stage.\n"
                  "# TYPE sylva_stage_seconds summary\n");
    for (int s = 0; s < SVD_STAGE_COUNT; s++) {
        sb_printf(&b, "sylva_stage_seconds_sum{stage=\"%s\"} %.6f\n", svd_stage_names[s],
                  m->stage_sum[s]);
        sb_printf(&b, "sylva_stage_seconds_count{stage=\"%s\"} %llu\n", svd_stage_names[s],
                  (unsigned long long)m->stage_count[s]);
    }
    sb_printf(&b, "# HELP sylva_jobs_finished_total Jobs that reached a final state.\n"
                  "# TYPE sylva_jobs_finished_total counter\n");
    for (int i = 0; i < 3; i++)
        sb_printf(&b, "sylva_jobs_finished_total{state=\"%s\"} %llu\n", finals[i],
                  (unsigned long long)m->job_final[i]);
    sb_printf(&b, "# HELP sylva_job_seconds_total Wall time from start to final state.\n"
                  "# TYPE sylva_job_seconds_total counter\n");
    for (int i = 0; i < 3; i++)
        sb_printf(&b, "sylva_job_seconds_total{state=\"%s\"} %.6f\n", finals[i], m->job_seconds[i]);
    sb_printf(&b,
              "# HELP sylva_worker_crashes_total Worker attempts that crashed or timed out.\n"
              "# TYPE sylva_worker_crashes_total counter\n"
              "sylva_worker_crashes_total{reason=\"crash\"} %llu\n"
              "sylva_worker_crashes_total{reason=\"timeout\"} %llu\n",
              (unsigned long long)m->crashes, (unsigned long long)m->timeouts);
    sb_printf(&b, "# TYPE sylva_upload_bytes_total counter\nsylva_upload_bytes_total %llu\n",
              (unsigned long long)m->upload_bytes);
    pthread_mutex_unlock(&m->mu);
    sb_printf(&b,
              "# TYPE sylva_queue_depth gauge\nsylva_queue_depth %llu\n"
              "# TYPE sylva_running_jobs gauge\nsylva_running_jobs %llu\n"
              "# TYPE sylva_jobs gauge\nsylva_jobs %llu\n"
              "# TYPE sylva_workers gauge\nsylva_workers %llu\n"
              "# TYPE sylva_waiting_requests gauge\nsylva_waiting_requests %llu\n"
              "# TYPE sylva_store_bytes gauge\nsylva_store_bytes %llu\n"
              "# TYPE sylva_store_limit_bytes gauge\nsylva_store_limit_bytes %llu\n",
              (unsigned long long)g->queued, (unsigned long long)g->running,
              (unsigned long long)g->jobs, (unsigned long long)g->workers,
              (unsigned long long)g->waiters, (unsigned long long)g->store_bytes,
              (unsigned long long)g->store_limit);
    if (b.oom) {
        free(b.p);
        return NULL;
    }
    return b.p;
}
