/* jobs.h — the job table: accepted bakes, their states, the fair queue,
 * durability through the journal, long-poll waiters and store accounting.
 *
 * States: queued → running → done | failed | cancelled (running → queued again
 * on a retry or a drain). Every transition to a final state is journaled
 * (fsync) before it becomes visible. Thread-safe: one mutex guards the table;
 * no disk I/O but journal appends and small deletes happens under it.
 *
 * Fair queue: workers take the oldest queued job among the clients with the
 * fewest running jobs; one client may hold at most queue_per_client queued or
 * running jobs (SVD_JOBS_CLIENT_FULL beyond), all clients together queue_max
 * queued (SVD_JOBS_QUEUE_FULL).
 *
 * The table knows no HTTP (docs/design.md, "Errors"): a call says what it
 * came to as an svd_jobs_rc, with a message in its sv_error when it refuses;
 * server/http.c alone turns that into a status code and a body.
 */
#ifndef SVD_JOBS_H
#define SVD_JOBS_H

#include <stdbool.h>
#include <stdint.h>
#include <sys/types.h>

#include "config.h"
#include "journal.h"
#include "key.h"
#include "log.h"
#include "metrics.h"
#include "store.h"

typedef enum svd_job_state {
    SVD_JOB_QUEUED = 0,
    SVD_JOB_RUNNING,
    SVD_JOB_DONE,
    SVD_JOB_FAILED,
    SVD_JOB_CANCELLED
} svd_job_state;

/* "queued", "running", ... */
const char *svd_job_state_name(svd_job_state s);

typedef struct svd_jobs svd_jobs;
typedef struct svd_job svd_job;

/* What a call on the table came to. The refusals carry a message (the
 * sv_error of the call, when it has one) naming what to do. */
typedef enum svd_jobs_rc {
    SVD_JOBS_OK = 0,      /* done, or found */
    SVD_JOBS_ACCEPTED,    /* new work queued, or a running bake told to stop */
    SVD_JOBS_NOT_FOUND,   /* no such bake (artifact, input file) */
    SVD_JOBS_NOT_DONE,    /* the bake has not finished: no artifacts yet */
    SVD_JOBS_DRAINING,    /* the server is shutting down */
    SVD_JOBS_QUEUE_FULL,  /* queue_max bakes queued */
    SVD_JOBS_CLIENT_FULL, /* this client holds queue_per_client bakes */
    SVD_JOBS_STORE_FULL,  /* the store cannot make room */
    SVD_JOBS_IO,          /* the journal or the store failed */
    SVD_JOBS_NOMEM,       /* out of memory */
    SVD_JOBS_AMBIGUOUS    /* a key prefix that names more than one bake */
} svd_jobs_rc;

/* A long-poll registration owned by the caller (the HTTP layer). wake() is
 * called once, under the table lock, when the job changes state or stage, is
 * removed, or the deadline passes; it must not call back into svd_jobs. */
typedef struct svd_waiter {
    void (*wake)(void *arg);
    void *arg;
    double deadline;         /* sv_now() seconds */
    struct svd_waiter *next; /* private */
    svd_job *job;            /* private: NULL when not registered */
} svd_waiter;

/* Creates the table. The config, store, log and metrics must outlive it. */
svd_jobs *svd_jobs_create(const svd_config *cfg, svd_store *store, svd_log *log,
                          svd_metrics *metrics, sv_error *err);

/* Opens ROOT/journal, replays it, reconciles with the store (requeues every
 * accepted job that had not finished, drops orphan directories, counts store
 * bytes), and compacts the journal. Call once before serving. Fails only when
 * the journal cannot be opened or read; a compaction that fails (a full
 * disk) is logged (journal_compaction_failed) and the journal kept as it
 * is: it replays to the same jobs, and appends go on after it. */
sv_status svd_jobs_recover(svd_jobs *jobs, sv_error *err);

/* Frees the table (after the workers stopped). NULL is a no-op. */
void svd_jobs_destroy(svd_jobs *jobs);

/* An upload ready to be committed: a directory under ROOT/tmp laid out like
 * a job directory (spec.json, inputs.json, in/), already fsynced. */
typedef struct svd_upload {
    const char *tmpdir;
    char key[SVD_KEY_HEX];
    const char *client;
    uint64_t bytes;
    uint64_t out_bytes; /* estimated output bytes (svd_output_estimate): room the store's
                           disk must have at acceptance, held until the bake is final */
} svd_upload;

/* Commits an upload: a known key is OK with its status document (the upload
 * is discarded; a cancelled job is requeued); new work is installed in the
 * store, journaled (fsync) and queued: ACCEPTED with its status document in
 * *json_out (malloc'ed). Refused: DRAINING, QUEUE_FULL, CLIENT_FULL,
 * STORE_FULL, IO or NOMEM, with err's message and *json_out NULL. */
svd_jobs_rc svd_jobs_submit(svd_jobs *jobs, const svd_upload *up, char **json_out, sv_error *err);

/* Uploads in progress hold against store_max_bytes the bytes they have
 * received, never what they declare (a declared length is a promise a client
 * need not keep). Reserves `bytes` more for `client`, evicting finished bakes
 * LRU-first if needed; false, with why (cap bytes) saying what is full, when
 * that client already holds client_upload_bytes or even eviction cannot make
 * room. On false the `held` bytes this upload reserved before are given back
 * in the same step, so of uploads racing for the last room one fails and the
 * others see its room. */
bool svd_jobs_reserve(svd_jobs *jobs, const char *client, uint64_t bytes, uint64_t held, char *why,
                      size_t cap);
/* Gives back bytes `client` reserved with svd_jobs_reserve (an upload that
 * ended: committed, refused or aborted). */
void svd_jobs_unreserve(svd_jobs *jobs, const char *client, uint64_t bytes);

/* Resolves a key prefix (SYLVA_KEY_PREFIX_MIN..64 lowercase hex digits) to
 * the one key that starts with it into key: OK. Only the bakes `client`
 * owns (svd_jobs_owned) count when client is non-NULL (sylvad with tokens:
 * others' keys are neither found nor listed). NOT_FOUND when none matches;
 * AMBIGUOUS when several do, with *candidates_json (malloc'ed; may be NULL
 * to skip) a JSON array of their keys in bytewise order, at most
 * SVD_KEY_CANDIDATES_MAX of them. err says which, naming the prefix. */
#define SVD_KEY_CANDIDATES_MAX 16
svd_jobs_rc svd_jobs_resolve(svd_jobs *jobs, const char *prefix, const char *client,
                             char key[SVD_KEY_HEX], char **candidates_json, sv_error *err);

/* True if a job with this key exists (and its inputs are kept). */
bool svd_jobs_has(svd_jobs *jobs, const char *key);

/* Status document of a job (see docs/api.md) into *json_out: OK, or
 * NOT_FOUND (err says so, *json_out NULL). */
svd_jobs_rc svd_jobs_status(svd_jobs *jobs, const char *key, char **json_out, sv_error *err);

/* The bakes submitted by `client` (the id svd_client_id gives: its token, or
 * its address without auth), newest first: those submitted before the
 * cursor `before` (0: from the newest), at most `limit`. *json_out =
 * {"bakes": [{"key", "state", "stage", "progress", "cursor"}...], "next":
 * cursor of the next page or null}. OK, or IO or NOMEM when out of memory
 * (err says so). */
svd_jobs_rc svd_jobs_list(svd_jobs *jobs, const char *client, uint64_t before, unsigned limit,
                          char **json_out, sv_error *err);

/* Registers w to be woken when the job with this key changes state or stage.
 * Returns false (nothing registered) if the job is missing or already final. */
bool svd_jobs_wait(svd_jobs *jobs, const char *key, svd_waiter *w);

/* Unregisters w if still registered. */
void svd_jobs_unwait(svd_jobs *jobs, svd_waiter *w);

/* Wakes waiters whose deadline passed (or all of them when all is true). */
void svd_jobs_sweep(svd_jobs *jobs, double now, bool all);

/* DELETE: cancels a queued job (OK) or a running one (ACCEPTED: the worker
 * stops it), or deletes a finished one (OK), with the document to answer in
 * *json_out. NOT_FOUND if unknown, IO when the journal cannot record it
 * (err says which). */
svd_jobs_rc svd_jobs_delete(svd_jobs *jobs, const char *key, char **json_out, sv_error *err);

/* True when `client` (svd_client_id) uploaded the bake's bytes (first or
 * later: each upload of the same bytes adds its caller, journaled), or the
 * key is unknown. sylvad with --tokens answers anyone else as if the bake
 * did not exist, on its status, artifacts and DELETE. */
bool svd_jobs_owned(svd_jobs *jobs, const char *key, const char *client);

/* Looks up an artifact of a done job in its manifest: path, size, SHA-256.
 * OK, NOT_FOUND (no job / no such artifact) or NOT_DONE. */
svd_jobs_rc svd_jobs_artifact(svd_jobs *jobs, const char *key, const char *name,
                              char path[SVD_STORE_PATH], uint64_t *size, char sha[SVD_KEY_HEX]);

/* Looks up a file the job was uploaded with (the mesh or a companion) in
 * its inputs.json: path (ROOT/jobs/KEY/in/NAME), size, SHA-256, in any
 * state (inputs are kept while the job exists). OK, or NOT_FOUND (no job,
 * no such input, an inputs.json that cannot be read). The file is not
 * opened: the caller verifies it (svd_store_verify) as it serves it. */
svd_jobs_rc svd_jobs_input(svd_jobs *jobs, const char *key, const char *name,
                           char path[SVD_STORE_PATH], uint64_t *size, char sha[SVD_KEY_HEX]);

/* The files a job was uploaded with, into *json_out:
 * {"mesh": NAME, "files": [{"name", "size", "sha256"}...]} (the mesh first,
 * then the companions as uploaded). OK, NOT_FOUND (no job, or its
 * inputs.json cannot be read) or NOMEM, err saying which. */
svd_jobs_rc svd_jobs_inputs(svd_jobs *jobs, const char *key, char **json_out, sv_error *err);

/* A stored artifact failed verification: quarantines the job's result and
 * requeues the job so it is rebaked. */
void svd_jobs_result_corrupt(svd_jobs *jobs, const char *key, const char *path);

/* Gauges for metrics and /v1/info. */
void svd_jobs_gauges(svd_jobs *jobs, svd_gauges *g);

/* The store's disk: *free_bytes free for the daemon (UINT64_MAX if unknown)
 * and whether it is low, i.e. below what the bakes not finished will write
 * plus disk_reserve_bytes (new bakes are then refused 507 unless evicting
 * finished ones makes room). */
void svd_jobs_disk(svd_jobs *jobs, uint64_t *free_bytes, bool *low);

/* ---- worker side ---- */

/* What a worker needs to run a job; valid until svd_jobs_finish. */
typedef struct svd_ticket {
    svd_job *job;
    char key[SVD_KEY_HEX];
    unsigned attempt; /* 1-based */
} svd_ticket;

/* Blocks until a job is runnable (marks it running) or the table is stopping
 * (returns false). */
bool svd_jobs_take(svd_jobs *jobs, svd_ticket *t);

/* Progress line from the worker: stage name, overall fraction, and during a
 * target search try k of at most `tries` (k = 0: not searching). */
void svd_jobs_progress(svd_jobs *jobs, svd_ticket *t, const char *stage, double progress, int try_k,
                       int tries);

/* True if the job was cancelled (the worker must stop the process). */
bool svd_jobs_cancelled(svd_jobs *jobs, svd_ticket *t);

/* True once the drain deadline passed (running workers must stop and requeue). */
bool svd_jobs_aborting(svd_jobs *jobs);

typedef enum svd_outcome {
    SVD_OUT_DONE,      /* result installed; manifest given */
    SVD_OUT_FAILED,    /* final failure: code + message */
    SVD_OUT_RETRY,     /* crash or timeout: retry if attempts remain, else fail with message */
    SVD_OUT_CANCELLED, /* stopped because of DELETE */
    SVD_OUT_REQUEUE    /* stopped by a drain: stays accepted, runs after restart */
} svd_outcome;

/* Ends a run. For RETRY, message says what happened in this attempt
 * ("worker killed by signal 11"); after cfg->attempts the job fails with
 * "<message> on N attempts". manifest_json is the result manifest for DONE. */
void svd_jobs_finish(svd_jobs *jobs, svd_ticket *t, svd_outcome out, const char *code,
                     const char *message, const char *manifest_json);

/* Stops taking jobs (drain). svd_jobs_take returns false from now on. */
void svd_jobs_stop(svd_jobs *jobs);

/* After the drain timeout: asks running workers to stop and requeue. */
void svd_jobs_abort(svd_jobs *jobs);

/* Number of running jobs. */
unsigned svd_jobs_running(svd_jobs *jobs);

/* Store paths a worker uses: inputs manifest of the job. */
svd_store *svd_jobs_store(svd_jobs *jobs);
const svd_config *svd_jobs_config(svd_jobs *jobs);
svd_log *svd_jobs_log(svd_jobs *jobs);
svd_metrics *svd_jobs_metrics(svd_jobs *jobs);

#endif
