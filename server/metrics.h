/* metrics.h — counters for GET /v1/metrics (Prometheus text format 0.0.4).
 * One svd_metrics per daemon, passed to whoever counts; thread-safe. */
#ifndef SVD_METRICS_H
#define SVD_METRICS_H

#include <stdint.h>

#include "routes.h"

#define SVD_STAGE_COUNT 8
/* The worker's stages, in order (worker protocol, --progress-fd). */
extern const char *const svd_stage_names[SVD_STAGE_COUNT];
/* Index of a stage name, or -1. */
int svd_stage_index(const char *name);

typedef struct svd_metrics svd_metrics;

typedef struct svd_gauges {
    uint64_t queued, running, jobs, store_bytes, store_limit, workers, waiters;
} svd_gauges;

/* NULL when out of memory. */
svd_metrics *svd_metrics_create(void);
/* NULL is a no-op. */
void svd_metrics_destroy(svd_metrics *m);

/* Counts one answered request. */
void svd_metrics_request(svd_metrics *m, svd_route r, unsigned status);
/* Adds a finished stage's duration. */
void svd_metrics_stage(svd_metrics *m, int stage, double seconds);
/* Counts a worker attempt that crashed (signal/odd exit) or timed out. */
void svd_metrics_worker_crash(svd_metrics *m, int timed_out);
/* Counts a job reaching a final state ("done", "failed", "cancelled"). */
void svd_metrics_job_final(svd_metrics *m, const char *state, double seconds);
/* Counts bytes received in uploads. */
void svd_metrics_upload_bytes(svd_metrics *m, uint64_t n);

/* Renders everything as Prometheus text into a malloc'ed string (NULL on OOM). */
char *svd_metrics_render(svd_metrics *m, const svd_gauges *g);

#endif
