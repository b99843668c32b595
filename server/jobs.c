/* jobs.c — job table, fair queue, journal-backed durability, long-poll
 * waiters and LRU store accounting (see jobs.h). */
#include "jobs.h"

#include <cjson/cJSON.h>
#include "error_body.h"
#include "json_strict.h"
#include <math.h>
#include <pthread.h>
#include <time.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <dirent.h>
#include <sys/stat.h>
#include <sys/statvfs.h>

#define NBUCKETS 4096

struct svd_job {
    char key[SVD_KEY_HEX];
    char client[96];
    svd_job_state state;
    uint64_t seq;      /* FIFO order */
    uint64_t lru;      /* last use, for eviction */
    unsigned attempts; /* attempts in the current run */
    int stage;         /* -1 before the first progress line */
    double progress;
    int try_k, tries; /* target search: try k of at most tries; 0 = none */
    double stage_start;
    double times[SVD_STAGE_COUNT];
    double t_started;
    char code[32];
    char *message;    /* failure reason */
    cJSON *manifest;  /* when done */
    uint64_t bytes;   /* on disk: inputs + result */
    uint64_t out_est; /* estimated output bytes, held on the disk while not final */
    bool cancel;
    bool resubmitted;  /* uploaded again while a DELETE was stopping it: run it again */
    double not_before; /* a retry waits until then (sv_now() clock; backoff) */
    char **owners;     /* callers besides `client` who uploaded these bytes too */
    uint32_t nowners;
    svd_waiter *waiters;
    svd_job *hnext;
    svd_job *lprev, *lnext; /* in the queue (QUEUED, by seq) or the running list */
    bool listed;            /* in one of them */
};

/* Bytes one client's uploads in progress hold (svd_jobs_reserve). */
struct client_hold {
    char client[96];
    uint64_t bytes;
    struct client_hold *next;
};

struct svd_jobs {
    const svd_config *cfg;
    svd_store *store;
    svd_log *log;
    svd_metrics *metrics;
    svd_journal *journal;
    pthread_mutex_t mu;        /* the table */
    pthread_cond_t cv;         /* work available / stopping */
    pthread_mutex_t commit_mu; /* serialises commits of new keys */
    svd_job *buckets[NBUCKETS];
    size_t count;
    uint64_t seq_next, lru_clock;
    uint64_t store_bytes;
    uint64_t uploading;        /* bytes reserved by uploads in progress (svd_jobs_reserve) */
    uint64_t pending_out;      /* out_est of every job not final: disk room held for outputs */
    struct client_hold *holds; /* the same, per client (only clients holding bytes) */
    bool stopping, aborting;
    /* The queued jobs in seq order and the running ones, so
     * taking work, a queue position, the queue's length and a client's load
     * are O(queued + running), not a scan of every stored job (30,000 stored
     * and 1,000 queued: 60 jobs/s dispatched, status p99 2.5 ms before). Valid
     * once recovery is done (lists_ready); every state change after that goes
     * through set_state. */
    svd_job *qhead, *qtail, *rhead;
    unsigned nqueued, nrunning;
    bool lists_ready;
};

static const char *const state_names[] = {"queued", "running", "done", "failed", "cancelled"};

const char *svd_job_state_name(svd_job_state s)
{
    return (unsigned)s < 5 ? state_names[s] : "unknown";
}

static bool is_final(svd_job_state s)
{
    return s == SVD_JOB_DONE || s == SVD_JOB_FAILED || s == SVD_JOB_CANCELLED;
}

/* Takes j out of the list its state puts it in (queue or running), if any. */
static void list_out(svd_jobs *jobs, svd_job *j)
{
    if (!j->listed) return;
    bool q = j->state == SVD_JOB_QUEUED;
    if (j->lprev) j->lprev->lnext = j->lnext;
    else if (q) jobs->qhead = j->lnext;
    else jobs->rhead = j->lnext;
    if (j->lnext) j->lnext->lprev = j->lprev;
    else if (q) jobs->qtail = j->lprev;
    j->lprev = j->lnext = NULL;
    j->listed = false;
    if (q) jobs->nqueued--;
    else jobs->nrunning--;
}

/* Puts j into the list of its state: the queue by seq (a retry keeps its old
 * seq and goes back near the front), or the running list. */
static void list_in(svd_jobs *jobs, svd_job *j)
{
    if (!jobs->lists_ready || j->listed) return;
    j->lprev = j->lnext = NULL;
    j->listed = j->state == SVD_JOB_RUNNING || j->state == SVD_JOB_QUEUED;
    if (j->state == SVD_JOB_RUNNING) {
        j->lnext = jobs->rhead;
        if (jobs->rhead) jobs->rhead->lprev = j;
        jobs->rhead = j;
        jobs->nrunning++;
    } else if (j->state == SVD_JOB_QUEUED) {
        svd_job *after = jobs->qtail;
        while (after && after->seq > j->seq) after = after->lprev;
        j->lprev = after;
        j->lnext = after ? after->lnext : jobs->qhead;
        if (j->lnext) j->lnext->lprev = j;
        else jobs->qtail = j;
        if (after) after->lnext = j;
        else jobs->qhead = j;
        jobs->nqueued++;
    }
}

/* Every state change after recovery: keeps the queue and running lists. */
static void set_state(svd_jobs *jobs, svd_job *j, svd_job_state s)
{
    list_out(jobs, j);
    if (!is_final(j->state) && is_final(s))
        jobs->pending_out -= j->out_est < jobs->pending_out ? j->out_est : jobs->pending_out;
    else if (is_final(j->state) && !is_final(s)) jobs->pending_out += j->out_est;
    j->state = s;
    list_in(jobs, j);
}

static int by_seq_asc(const void *a, const void *b)
{
    uint64_t x = (*(svd_job *const *)a)->seq, y = (*(svd_job *const *)b)->seq;
    return x < y ? -1 : x > y;
}

/* After recovery: the queue in seq order (no job is running then). */
static void build_lists(svd_jobs *jobs)
{
    size_t n = 0;
    for (size_t b = 0; b < NBUCKETS; b++)
        for (svd_job *j = jobs->buckets[b]; j; j = j->hnext)
            n += j->state == SVD_JOB_QUEUED || j->state == SVD_JOB_RUNNING;
    svd_job **v = n ? malloc(n * sizeof *v) : NULL;
    jobs->lists_ready = true;
    size_t k = 0;
    for (size_t b = 0; b < NBUCKETS; b++)
        for (svd_job *j = jobs->buckets[b]; j; j = j->hnext)
            if (j->state == SVD_JOB_QUEUED || j->state == SVD_JOB_RUNNING) {
                if (v) v[k++] = j;
                else list_in(jobs, j); /* out of memory: insertion by seq, slower */
            }
    if (k > 1) qsort(v, k, sizeof *v, by_seq_asc);
    for (size_t i = 0; i < k; i++) list_in(jobs, v[i]); /* in seq order: O(1) each */
    free(v);
}

/* A refusal: rc, with msg in err (its sv_status only as near as that enum
 * comes: callers go by rc). */
static svd_jobs_rc refuse(sv_error *err, svd_jobs_rc rc, const char *msg)
{
    sv_status st = rc == SVD_JOBS_IO          ? SV_ERR_IO
                   : rc == SVD_JOBS_NOMEM     ? SV_ERR_NOMEM
                   : rc == SVD_JOBS_NOT_FOUND ? SV_ERR_MISSING
                                              : SV_ERR_LIMIT;
    sv_fail(err, st, "%s", msg);
    return rc;
}

/* A failed job's record, error.json beside its inputs (malloc'ed): the
 * shape of the status document's "error". */
static char *error_doc(const char *code, const char *message)
{
    return sylva_error_body(code, message);
}

static size_t bucket_of(const char *key)
{
    size_t h = 0;
    for (int i = 0; i < 3; i++) {
        char c = key[i];
        h = h * 16 + (size_t)(c >= 'a' ? c - 'a' + 10 : c - '0');
    }
    return h % NBUCKETS;
}

static svd_job *find(svd_jobs *jobs, const char *key)
{
    for (svd_job *j = jobs->buckets[bucket_of(key)]; j; j = j->hnext)
        if (strcmp(j->key, key) == 0) return j;
    return NULL;
}

static svd_job *insert(svd_jobs *jobs, const char *key)
{
    svd_job *j = calloc(1, sizeof *j);
    if (!j) return NULL;
    snprintf(j->key, sizeof j->key, "%s", key);
    j->stage = -1;
    j->seq = ++jobs->seq_next;
    j->lru = ++jobs->lru_clock;
    size_t b = bucket_of(key);
    j->hnext = jobs->buckets[b];
    jobs->buckets[b] = j;
    jobs->count++;
    return j;
}

static void wake_all(svd_job *j)
{
    svd_waiter *w = j->waiters;
    j->waiters = NULL;
    while (w) {
        svd_waiter *next = w->next;
        w->job = NULL;
        w->next = NULL;
        w->wake(w->arg);
        w = next;
    }
}

static void job_free(svd_job *j)
{
    for (uint32_t i = 0; i < j->nowners; i++) free(j->owners[i]);
    free(j->owners);
    free(j->message);
    cJSON_Delete(j->manifest);
    free(j);
}

static void unlink_job(svd_jobs *jobs, svd_job *j)
{
    svd_job **pp = &jobs->buckets[bucket_of(j->key)];
    while (*pp && *pp != j) pp = &(*pp)->hnext;
    if (*pp) *pp = j->hnext;
    list_out(jobs, j);
    if (!is_final(j->state))
        jobs->pending_out -= j->out_est < jobs->pending_out ? j->out_est : jobs->pending_out;
    jobs->count--;
    wake_all(j);
    jobs->store_bytes -= j->bytes < jobs->store_bytes ? j->bytes : jobs->store_bytes;
    job_free(j);
}

/* A bake belongs to every caller who uploaded its bytes
 * (holding them proves the right to them); others do not see it. */
static bool owned_by(const svd_job *j, const char *client)
{
    if (strcmp(j->client, client) == 0) return true;
    for (uint32_t i = 0; i < j->nowners; i++)
        if (strcmp(j->owners[i], client) == 0) return true;
    return false;
}

/* Adds client to j's owners; false only when out of memory (or already 1024). */
static bool add_owner(svd_job *j, const char *client)
{
    if (owned_by(j, client)) return true;
    if (j->nowners >= 1024) return false;
    char **no = realloc(j->owners, (j->nowners + 1) * sizeof *no);
    if (!no) return false;
    j->owners = no;
    if (!(no[j->nowners] = strdup(client))) return false;
    j->nowners++;
    return true;
}

/* Sets a job's error code and message. A message may quote an upload's bytes
 * (a worker's error names what it read): it is made valid UTF-8 so the status
 * document stays valid JSON. */
static void set_message(svd_job *j, const char *code, const char *msg)
{
    snprintf(j->code, sizeof j->code, "%s", code ? code : "");
    sylva_utf8_fix(j->code);
    free(j->message);
    j->message = msg ? strdup(msg) : NULL;
    if (j->message) sylva_utf8_fix(j->message);
}

/* ---- journal records ---- */

static sv_status journal_json(svd_jobs *jobs, cJSON *rec, sv_error *err)
{
    char *s = cJSON_PrintUnformatted(rec);
    cJSON_Delete(rec);
    if (!s) return sv_fail(err, SV_ERR_NOMEM, "journal: out of memory");
    sv_status st = svd_journal_append(jobs->journal, s, strlen(s), err);
    free(s);
    return st;
}

static cJSON *record(const char *op, const svd_job *j)
{
    cJSON *r = cJSON_CreateObject();
    cJSON_AddStringToObject(r, "op", op);
    cJSON_AddStringToObject(r, "key", j->key);
    return r;
}

/* The full description of a job, used by "accept" and by compaction. */
static cJSON *accept_record(const svd_job *j)
{
    cJSON *r = record("accept", j);
    cJSON_AddStringToObject(r, "client", j->client);
    if (j->nowners) {
        cJSON *o = cJSON_AddArrayToObject(r, "owners");
        for (uint32_t i = 0; o && i < j->nowners; i++)
            cJSON_AddItemToArray(o, cJSON_CreateString(j->owners[i]));
    }
    cJSON_AddStringToObject(r, "state",
                            j->state == SVD_JOB_RUNNING ? "queued" : svd_job_state_name(j->state));
    if (j->state == SVD_JOB_FAILED || j->state == SVD_JOB_CANCELLED) {
        cJSON_AddStringToObject(r, "code", j->code);
        cJSON_AddStringToObject(r, "message", j->message ? j->message : "");
    }
    return r;
}

static char *print_free(cJSON *r)
{
    char *s = cJSON_PrintUnformatted(r);
    cJSON_Delete(r);
    return s;
}

static void log_journal_error(svd_jobs *jobs, const char *key, const sv_error *e)
{
    svd_log_kv(jobs->log, SVD_LOG_ERROR, "journal_write_failed", "key", key, "msg", e->message,
               (const char *)NULL);
}

/* ---- create / recover ---- */

svd_jobs *svd_jobs_create(const svd_config *cfg, svd_store *store, svd_log *log,
                          svd_metrics *metrics, sv_error *err)
{
    svd_jobs *jobs = calloc(1, sizeof *jobs);
    if (!jobs) {
        sv_fail(err, SV_ERR_NOMEM, "jobs: out of memory");
        return NULL;
    }
    jobs->cfg = cfg;
    jobs->store = store;
    jobs->log = log;
    jobs->metrics = metrics;
    pthread_mutex_init(&jobs->mu, NULL);
    pthread_mutex_init(&jobs->commit_mu, NULL);
    pthread_cond_init(&jobs->cv, NULL);
    return jobs;
}

void svd_jobs_destroy(svd_jobs *jobs)
{
    if (!jobs) return;
    for (size_t b = 0; b < NBUCKETS; b++) {
        svd_job *j = jobs->buckets[b];
        while (j) {
            svd_job *next = j->hnext;
            wake_all(j);
            job_free(j);
            j = next;
        }
    }
    while (jobs->holds) {
        struct client_hold *c = jobs->holds;
        jobs->holds = c->next;
        free(c);
    }
    svd_journal_close(jobs->journal);
    pthread_cond_destroy(&jobs->cv);
    pthread_mutex_destroy(&jobs->commit_mu);
    pthread_mutex_destroy(&jobs->mu);
    free(jobs);
}

static svd_job_state state_from_name(const char *s)
{
    for (int i = 0; i < 5; i++)
        if (s && strcmp(s, state_names[i]) == 0) return (svd_job_state)i;
    return SVD_JOB_QUEUED;
}

static void replay_one(void *user, const char *payload, size_t size)
{
    svd_jobs *jobs = user;
    cJSON *r = sv_json_parse_strict(payload, size, "journal record", SV_ERR_PARSE, NULL);
    const char *op = cJSON_GetStringValue(cJSON_GetObjectItemCaseSensitive(r, "op"));
    const char *key = cJSON_GetStringValue(cJSON_GetObjectItemCaseSensitive(r, "key"));
    if (!op || !svd_key_valid(key)) {
        svd_log_kv(jobs->log, SVD_LOG_WARN, "journal_record_ignored", "msg",
                   "record without op or key", (const char *)NULL);
        cJSON_Delete(r);
        return;
    }
    svd_job *j = find(jobs, key);
    const char *code = cJSON_GetStringValue(cJSON_GetObjectItemCaseSensitive(r, "code"));
    const char *msg = cJSON_GetStringValue(cJSON_GetObjectItemCaseSensitive(r, "message"));
    if (strcmp(op, "accept") == 0) {
        if (!j) j = insert(jobs, key);
        if (j) {
            const char *client = cJSON_GetStringValue(
                cJSON_GetObjectItemCaseSensitive(r, "client"));
            snprintf(j->client, sizeof j->client, "%s", client ? client : "unknown");
            const cJSON *ow;
            cJSON_ArrayForEach(
                ow, cJSON_GetObjectItemCaseSensitive(r, "owners")) if (cJSON_IsString(ow))
                add_owner(j, ow->valuestring);
            j->state = state_from_name(
                cJSON_GetStringValue(cJSON_GetObjectItemCaseSensitive(r, "state")));
            if (j->state == SVD_JOB_RUNNING) j->state = SVD_JOB_QUEUED;
            if (code || msg) set_message(j, code, msg);
        }
    } else if (j && strcmp(op, "done") == 0) {
        j->state = SVD_JOB_DONE;
    } else if (j && strcmp(op, "failed") == 0) {
        j->state = SVD_JOB_FAILED;
        set_message(j, code, msg);
    } else if (j && strcmp(op, "cancel") == 0) {
        j->state = SVD_JOB_CANCELLED;
        set_message(j, "cancelled", "cancelled by DELETE");
    } else if (j && strcmp(op, "own") == 0) {
        const char *client = cJSON_GetStringValue(cJSON_GetObjectItemCaseSensitive(r, "client"));
        if (client) add_owner(j, client);
    } else if (j && strcmp(op, "requeue") == 0) {
        j->state = SVD_JOB_QUEUED;
        set_message(j, NULL, NULL);
    } else if (j && strcmp(op, "delete") == 0) {
        unlink_job(jobs, j);
    }
    cJSON_Delete(r);
}

static cJSON *read_json_file(const char *path)
{
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    char *buf = NULL;
    size_t cap = 0, n = 0;
    for (;;) {
        if (n == cap) {
            if (cap > (64u << 20)) break;
            size_t nc = cap ? cap * 2 : 4096;
            char *nb = realloc(buf, nc);
            if (!nb) break;
            buf = nb;
            cap = nc;
        }
        size_t got = fread(buf + n, 1, cap - n, f);
        n += got;
        if (got == 0) break;
    }
    fclose(f);
    cJSON *j = buf ? sv_json_parse_strict(buf, n, "stored JSON", SV_ERR_PARSE, NULL) : NULL;
    free(buf);
    return j;
}

/* Removes job directories the journal does not know (a crash between the
 * rename and the journal append: never acknowledged, so safe to drop). */
/* qsort order of jobs by their sequence number (seqs are unique) */
static int by_seq(const void *a, const void *b)
{
    uint64_t x = (*(svd_job *const *)a)->seq, y = (*(svd_job *const *)b)->seq;
    return x < y ? -1 : x > y;
}

static void drop_orphans(svd_jobs *jobs)
{
    char dir[SVD_STORE_PATH];
    snprintf(dir, sizeof dir, "%s/jobs", svd_store_root(jobs->store));
    DIR *d = opendir(dir);
    if (!d) return;
    struct dirent *e;
    while ((e = readdir(d))) {
        if (e->d_name[0] == '.') continue;
        if (svd_key_valid(e->d_name) && find(jobs, e->d_name)) continue;
        char path[SVD_STORE_PATH + 300];
        snprintf(path, sizeof path, "%s/%s", dir, e->d_name);
        svd_log_kv(jobs->log, SVD_LOG_WARN, "store_orphan_removed", "path", path,
                   (const char *)NULL);
        svd_rm_rf(path);
    }
    closedir(d);
}

sv_status svd_jobs_recover(svd_jobs *jobs, sv_error *err)
{
    char path[SVD_STORE_PATH];
    snprintf(path, sizeof path, "%s/journal", svd_store_root(jobs->store));
    svd_journal_stats stats;
    jobs->journal = svd_journal_open(path, replay_one, jobs, &stats, err);
    if (!jobs->journal) return err ? err->status : SV_ERR_IO;
    char n1[32], n2[32], n3[32];
    snprintf(n1, sizeof n1, "%llu", (unsigned long long)stats.records);
    snprintf(n2, sizeof n2, "%llu", (unsigned long long)stats.torn_bytes);
    snprintf(n3, sizeof n3, "%llu", (unsigned long long)stats.corrupt);
    svd_log_kv(jobs->log, stats.corrupt ? SVD_LOG_ERROR : SVD_LOG_INFO, "journal_replayed",
               "records", n1, "torn_bytes", n2, "corrupt_records", n3, (const char *)NULL);
    /* Reconcile with the store. */
    size_t live = 0;
    for (size_t b = 0; b < NBUCKETS; b++) {
        svd_job *j = jobs->buckets[b], *next;
        for (; j; j = next) {
            next = j->hnext;
            char p[SVD_STORE_PATH];
            svd_store_job_path(jobs->store, j->key, "inputs.json", p);
            struct stat sb;
            bool inputs = stat(p, &sb) == 0;
            if (j->state == SVD_JOB_DONE) {
                svd_store_job_path(jobs->store, j->key, "result/manifest.json", p);
                j->manifest = read_json_file(p);
                if (!j->manifest) {
                    svd_log_kv(jobs->log, SVD_LOG_WARN, "result_missing_requeued", "key", j->key,
                               (const char *)NULL);
                    j->state = SVD_JOB_QUEUED;
                }
            }
            if (!inputs && j->state != SVD_JOB_DONE) {
                svd_log_kv(jobs->log, SVD_LOG_ERROR, "job_inputs_missing", "key", j->key, "msg",
                           "inputs of an accepted job are gone; dropping it", (const char *)NULL);
                unlink_job(jobs, j);
                continue;
            }
            if (j->state == SVD_JOB_QUEUED) svd_store_remove(jobs->store, j->key, "result");
            svd_store_job_path(jobs->store, j->key, NULL, p);
            j->bytes = svd_dir_bytes(p);
            jobs->store_bytes += j->bytes;
            live++;
        }
    }
    drop_orphans(jobs);
    build_lists(jobs);
    /* Compact: one record per live job, ordered by seq so FIFO order survives.
     * A failure here is not fatal: the journal as it is replays to the same
     * jobs (what reconciliation changed above, it finds again at the next
     * start), so the daemon serves on a full disk rather than not at all. */
    svd_job **order = sv_calloc(live ? live : 1, sizeof *order);
    char **recs = sv_calloc(live ? live : 1, sizeof *recs);
    size_t *sizes = sv_calloc(live ? live : 1, sizeof *sizes);
    size_t n = 0;
    sv_error ce = {0};
    sv_status st = order && recs && sizes ? SV_OK
                                          : sv_fail(&ce, SV_ERR_NOMEM, "jobs: out of memory");
    for (size_t b = 0; st == SV_OK && b < NBUCKETS; b++)
        for (svd_job *j = jobs->buckets[b]; j && n < live; j = j->hnext) order[n++] = j;
    if (st == SV_OK && n > 1) qsort(order, n, sizeof *order, by_seq); /* was O(n²) */
    for (size_t i = 0; st == SV_OK && i < n; i++) {
        recs[i] = print_free(accept_record(order[i]));
        if (!recs[i]) st = sv_fail(&ce, SV_ERR_NOMEM, "jobs: out of memory");
        else sizes[i] = strlen(recs[i]);
    }
    if (st == SV_OK)
        st = svd_journal_rewrite(jobs->journal, (const char *const *)recs, sizes, n, &ce);
    if (st != SV_OK)
        svd_log_kv(jobs->log, SVD_LOG_ERROR, "journal_compaction_failed", "msg", ce.message,
                   "effect",
                   "the journal is kept as it is; stored results are served, uploads may fail as "
                   "store_full",
                   (const char *)NULL);
    char q[32];
    size_t queued = 0;
    for (size_t b = 0; b < NBUCKETS; b++)
        for (svd_job *j = jobs->buckets[b]; j; j = j->hnext) queued += j->state == SVD_JOB_QUEUED;
    snprintf(n1, sizeof n1, "%zu", live);
    snprintf(q, sizeof q, "%zu", queued);
    svd_log_kv(jobs->log, SVD_LOG_INFO, "jobs_recovered", "jobs", n1, "requeued", q,
               (const char *)NULL);
    free(order);
    for (size_t i = 0; recs && i < n; i++) free(recs[i]);
    free(recs);
    free(sizes);
    return SV_OK;
}

/* ---- status documents ---- */

static cJSON *status_json(svd_jobs *jobs, const svd_job *j)
{
    cJSON *r = cJSON_CreateObject();
    cJSON_AddStringToObject(r, "key", j->key);
    cJSON_AddStringToObject(r, "state", svd_job_state_name(j->state));
    if (j->stage >= 0) cJSON_AddStringToObject(r, "stage", svd_stage_names[j->stage]);
    else cJSON_AddNullToObject(r, "stage");
    cJSON_AddNumberToObject(r, "progress", j->state == SVD_JOB_DONE ? 1.0 : j->progress);
    cJSON_AddNumberToObject(r, "attempts", j->attempts);
    if (j->state == SVD_JOB_RUNNING && j->cancel) cJSON_AddTrueToObject(r, "cancel_requested");
    if (j->state == SVD_JOB_RUNNING && j->try_k > 0) {
        cJSON_AddNumberToObject(r, "try", j->try_k);
        cJSON_AddNumberToObject(r, "tries", j->tries);
    }
    if (j->state == SVD_JOB_QUEUED) {
        unsigned pos = 0; /* the queued jobs before it: the queue is in seq order */
        for (const svd_job *o = j->lprev; o; o = o->lprev) pos++;
        (void)jobs;
        cJSON_AddNumberToObject(r, "queue_position", pos);
    }
    cJSON *t = cJSON_AddObjectToObject(r, "times");
    for (int s = 0; s < SVD_STAGE_COUNT; s++)
        if (j->times[s] > 0 || (s == j->stage && j->state == SVD_JOB_RUNNING))
            cJSON_AddNumberToObject(t, svd_stage_names[s],
                                    j->times[s] + (s == j->stage && j->state == SVD_JOB_RUNNING
                                                       ? sv_now() - j->stage_start
                                                       : 0));
    if (j->state == SVD_JOB_FAILED || j->state == SVD_JOB_CANCELLED) {
        sylva_error_add(r, j->code[0] ? j->code : "failed", j->message ? j->message : "");
    }
    if (j->state == SVD_JOB_DONE && j->manifest) {
        /* every warning of the bake, at the top where a client looks first */
        const cJSON *w = cJSON_GetObjectItemCaseSensitive(j->manifest, "warnings");
        cJSON_AddItemToObject(r, "warnings",
                              cJSON_IsArray(w) ? cJSON_Duplicate(w, 1) : cJSON_CreateArray());
        /* a bake with a "target": whether it was met, and why not, at the top
         * too (the whole search is in manifest.summary.target) */
        const cJSON *tg = cJSON_GetObjectItemCaseSensitive(
            cJSON_GetObjectItemCaseSensitive(j->manifest, "summary"), "target");
        if (cJSON_IsObject(tg)) {
            cJSON *o = cJSON_AddObjectToObject(r, "target");
            static const char *const keys[] = {"goal", "met", "chosen", "reason"};
            for (size_t k = 0; o && k < sizeof keys / sizeof keys[0]; k++) {
                const cJSON *v = cJSON_GetObjectItemCaseSensitive(tg, keys[k]);
                if (v) cJSON_AddItemToObject(o, keys[k], cJSON_Duplicate(v, 1));
            }
        }
        cJSON_AddItemToObject(r, "manifest", cJSON_Duplicate(j->manifest, 1));
    }
    return r;
}

svd_jobs_rc svd_jobs_status(svd_jobs *jobs, const char *key, char **json_out, sv_error *err)
{
    *json_out = NULL;
    pthread_mutex_lock(&jobs->mu);
    svd_job *j = find(jobs, key);
    if (!j) {
        pthread_mutex_unlock(&jobs->mu);
        return refuse(err, SVD_JOBS_NOT_FOUND, "no bake with this key");
    }
    j->lru = ++jobs->lru_clock;
    *json_out = print_free(status_json(jobs, j));
    pthread_mutex_unlock(&jobs->mu);
    return SVD_JOBS_OK;
}

static int by_seq_desc(const void *a, const void *b)
{
    return -by_seq(a, b);
}

svd_jobs_rc svd_jobs_list(svd_jobs *jobs, const char *client, uint64_t before, unsigned limit,
                          char **json_out, sv_error *err)
{
    *json_out = NULL;
    if (before == 0) before = UINT64_MAX;
    pthread_mutex_lock(&jobs->mu);
    size_t n = 0;
    for (size_t b = 0; b < NBUCKETS; b++)
        for (svd_job *o = jobs->buckets[b]; o; o = o->hnext)
            n += owned_by(o, client) && o->seq < before;
    svd_job **v = malloc((n ? n : 1) * sizeof *v);
    cJSON *r = cJSON_CreateObject(), *a = r ? cJSON_AddArrayToObject(r, "bakes") : NULL;
    if (!v || !a) {
        pthread_mutex_unlock(&jobs->mu);
        free(v);
        cJSON_Delete(r);
        return refuse(err, SVD_JOBS_IO, "out of memory"); /* "io", as it always answered */
    }
    n = 0;
    for (size_t b = 0; b < NBUCKETS; b++)
        for (svd_job *o = jobs->buckets[b]; o; o = o->hnext)
            if (owned_by(o, client) && o->seq < before) v[n++] = o;
    qsort(v, n, sizeof *v, by_seq_desc);
    size_t k = n < limit ? n : limit;
    char cur[24];
    for (size_t i = 0; i < k; i++) {
        cJSON *e = cJSON_CreateObject();
        cJSON_AddStringToObject(e, "key", v[i]->key);
        cJSON_AddStringToObject(e, "state", svd_job_state_name(v[i]->state));
        if (v[i]->state == SVD_JOB_RUNNING && v[i]->stage >= 0)
            cJSON_AddStringToObject(e, "stage", svd_stage_names[v[i]->stage]);
        else cJSON_AddNullToObject(e, "stage");
        cJSON_AddNumberToObject(e, "progress", v[i]->state == SVD_JOB_DONE ? 1.0 : v[i]->progress);
        snprintf(cur, sizeof cur, "%llu", (unsigned long long)v[i]->seq);
        cJSON_AddStringToObject(e, "cursor", cur);
        cJSON_AddItemToArray(a, e);
    }
    if (k < n && k > 0) {
        snprintf(cur, sizeof cur, "%llu", (unsigned long long)v[k - 1]->seq);
        cJSON_AddStringToObject(r, "next", cur);
    } else {
        cJSON_AddNullToObject(r, "next");
    }
    pthread_mutex_unlock(&jobs->mu);
    free(v);
    *json_out = print_free(r);
    return *json_out ? SVD_JOBS_OK : refuse(err, SVD_JOBS_NOMEM, "out of memory");
}

static int by_strcmp(const void *a, const void *b)
{
    return strcmp(*(const char *const *)a, *(const char *const *)b);
}

svd_jobs_rc svd_jobs_resolve(svd_jobs *jobs, const char *prefix, const char *client,
                             char key[SVD_KEY_HEX], char **candidates_json, sv_error *err)
{
    if (candidates_json) *candidates_json = NULL;
    size_t pl = prefix ? strlen(prefix) : 0;
    if (!sylva_key_prefix_ok(prefix)) {
        sv_fail(err, SV_ERR_SPEC,
                "bad key: expected 64 lowercase hex digits, or a unique prefix of at least %d "
                "of them",
                SYLVA_KEY_PREFIX_MIN);
        return SVD_JOBS_NOT_FOUND;
    }
    /* The bucket is the key's first three hex digits (bucket_of), which a
     * prefix holds: one bucket is scanned, not the table. */
    const char *found[SVD_KEY_CANDIDATES_MAX];
    size_t n = 0;
    pthread_mutex_lock(&jobs->mu);
    for (svd_job *j = jobs->buckets[bucket_of(prefix)]; j; j = j->hnext) {
        if (strncmp(j->key, prefix, pl) != 0 || (client && !owned_by(j, client))) continue;
        if (n < SVD_KEY_CANDIDATES_MAX) found[n] = j->key;
        n++;
    }
    svd_jobs_rc rc = SVD_JOBS_OK;
    if (n == 0) {
        rc = SVD_JOBS_NOT_FOUND;
        sv_fail(err, SV_ERR_MISSING, "no bake whose key starts with %s", prefix);
    } else if (n == 1) {
        snprintf(key, SVD_KEY_HEX, "%s", found[0]);
    } else {
        size_t shown = n < SVD_KEY_CANDIDATES_MAX ? n : SVD_KEY_CANDIDATES_MAX;
        qsort(found, shown, sizeof found[0], by_strcmp);
        sv_fail(err, SV_ERR_SPEC, "key prefix %s names %zu bakes: give more of the key", prefix, n);
        rc = SVD_JOBS_AMBIGUOUS;
        if (candidates_json) {
            cJSON *a = cJSON_CreateArray();
            for (size_t i = 0; a && i < shown; i++)
                cJSON_AddItemToArray(a, cJSON_CreateString(found[i]));
            *candidates_json = a ? cJSON_PrintUnformatted(a) : NULL;
            cJSON_Delete(a);
            if (!*candidates_json) rc = refuse(err, SVD_JOBS_NOMEM, "out of memory");
        }
    }
    pthread_mutex_unlock(&jobs->mu);
    return rc;
}

bool svd_jobs_has(svd_jobs *jobs, const char *key)
{
    pthread_mutex_lock(&jobs->mu);
    bool has = find(jobs, key) != NULL;
    pthread_mutex_unlock(&jobs->mu);
    return has;
}

/* ---- submit ---- */

/* Queued + running (or running only) jobs of a client: the two lists. */
static unsigned client_load(svd_jobs *jobs, const char *client, bool running_only)
{
    unsigned n = 0;
    for (svd_job *o = jobs->rhead; o; o = o->lnext) n += strcmp(o->client, client) == 0;
    if (!running_only)
        for (svd_job *o = jobs->qhead; o; o = o->lnext) n += strcmp(o->client, client) == 0;
    return n;
}

static unsigned count_state(svd_jobs *jobs, svd_job_state s)
{
    if (s == SVD_JOB_QUEUED) return jobs->nqueued;
    if (s == SVD_JOB_RUNNING) return jobs->nrunning;
    unsigned n = 0;
    for (size_t b = 0; b < NBUCKETS; b++)
        for (svd_job *o = jobs->buckets[b]; o; o = o->hnext) n += o->state == s;
    return n;
}

/* Evicts least-recently-used finished jobs until need more bytes fit under
 * the limit. Never touches queued or running jobs (their inputs are needed).
 * Called with mu held. */
/* Bytes free on the store's filesystem for the daemon (statvfs f_bavail), or
 * UINT64_MAX when that cannot be known (the quota alone decides then). */
static uint64_t disk_free(svd_jobs *jobs)
{
    struct statvfs sv;
    if (statvfs(svd_store_root(jobs->store), &sv) != 0) return UINT64_MAX;
    return (uint64_t)sv.f_bavail * (uint64_t)sv.f_frsize;
}

/* Whether the store's filesystem lacks room for disk_need more bytes of
 * outputs beside those of the bakes not finished (pending_out) and the
 * disk_reserve_bytes kept free. Called with mu held. */
static bool disk_short(svd_jobs *jobs, uint64_t disk_need)
{
    uint64_t f = disk_free(jobs);
    return f != UINT64_MAX && f < jobs->pending_out + disk_need + jobs->cfg->disk_reserve_bytes;
}

/* Evicts least-recently-used finished jobs until need more bytes fit under
 * store_max_bytes and, when disk, until the filesystem has room for
 * disk_need more output bytes (disk_short). Never touches queued or running
 * jobs (their inputs are needed). Called with mu and commit_mu held. */
static bool make_room_disk(svd_jobs *jobs, uint64_t need, bool disk, uint64_t disk_need)
{
    uint64_t limit = jobs->cfg->store_max_bytes;
    bool quota = jobs->store_bytes + jobs->uploading + need > limit;
    bool short_ = disk && disk_short(jobs, disk_need);
    if (!quota && !short_) return true;
    /* Nothing is evicted for a request that evicting every finished bake
     * could not satisfy: what is stored is not thrown away for nothing. */
    uint64_t evictable = 0;
    for (size_t b = 0; b < NBUCKETS; b++)
        for (svd_job *o = jobs->buckets[b]; o; o = o->hnext)
            if (is_final(o->state)) evictable += o->bytes;
    if (quota && jobs->store_bytes -
                         (evictable < jobs->store_bytes ? evictable : jobs->store_bytes) +
                         jobs->uploading + need >
                     limit)
        return false;
    if (short_) {
        uint64_t f = disk_free(jobs);
        if (f + evictable < jobs->pending_out + disk_need + jobs->cfg->disk_reserve_bytes)
            return false;
    }
    while (jobs->store_bytes + jobs->uploading + need > limit ||
           (disk && disk_short(jobs, disk_need))) {
        svd_job *victim = NULL;
        for (size_t b = 0; b < NBUCKETS; b++)
            for (svd_job *o = jobs->buckets[b]; o; o = o->hnext)
                if (is_final(o->state) && (!victim || o->lru < victim->lru)) victim = o;
        if (!victim) return false;
        sv_error e = {0};
        if (journal_json(jobs, record("delete", victim), &e) != SV_OK) {
            log_journal_error(jobs, victim->key, &e);
            return false;
        }
        svd_log_kv(jobs->log, SVD_LOG_INFO, "store_evicted", "key", victim->key,
                   (const char *)NULL);
        svd_store_remove(jobs->store, victim->key, NULL);
        unlink_job(jobs, victim);
    }
    return true;
}

/* make_room_disk for the quota alone. */
static bool make_room(svd_jobs *jobs, uint64_t need)
{
    return make_room_disk(jobs, need, false, 0);
}

/* Failure codes the server caused, not the input (docs/api.md): such a
 * failed bake is baked again when it is uploaded again. */
static bool server_side_code(const char *code)
{
    static const char *const codes[] = {"crash", "io", "internal", "corrupt"};
    for (size_t i = 0; i < sizeof codes / sizeof codes[0]; i++)
        if (strcmp(code, codes[i]) == 0) return true;
    return false;
}

/* How the store's bytes are used, for an exact store_full message. */
static void store_use(svd_jobs *jobs, uint64_t need, char *out, size_t cap)
{
    uint64_t unfinished = 0;
    for (size_t b = 0; b < NBUCKETS; b++)
        for (svd_job *o = jobs->buckets[b]; o; o = o->hnext)
            if (!is_final(o->state)) unfinished += o->bytes;
    snprintf(out, cap,
             "the store cannot take %llu more bytes: store_max_bytes is %llu, bakes not finished "
             "(never evicted) hold %llu, uploads in progress %llu",
             (unsigned long long)need, (unsigned long long)jobs->cfg->store_max_bytes,
             (unsigned long long)unfinished, (unsigned long long)jobs->uploading);
}

/* The hold of `client`, created (zero bytes) when create; NULL if none or out
 * of memory. Called with mu held. */
static struct client_hold *client_hold(svd_jobs *jobs, const char *client, bool create)
{
    for (struct client_hold *c = jobs->holds; c; c = c->next)
        if (strcmp(c->client, client) == 0) return c;
    if (!create) return NULL;
    struct client_hold *c = calloc(1, sizeof *c);
    if (!c) return NULL;
    snprintf(c->client, sizeof c->client, "%s", client);
    c->next = jobs->holds;
    jobs->holds = c;
    return c;
}

/* Lowers `client`'s hold by bytes; a hold of zero is freed (only clients
 * holding bytes stay listed). Called with mu held. */
static void give_back(svd_jobs *jobs, const char *client, uint64_t bytes)
{
    for (struct client_hold **pc = &jobs->holds; *pc; pc = &(*pc)->next) {
        struct client_hold *c = *pc;
        if (strcmp(c->client, client) != 0) continue;
        c->bytes -= bytes < c->bytes ? bytes : c->bytes;
        if (c->bytes == 0) {
            *pc = c->next;
            free(c);
        }
        return;
    }
}

/* Takes `bytes` for `client` if its hold and the store have room (evicting
 * when evict); false with why set otherwise. Called with mu held. */
static bool take_hold(svd_jobs *jobs, const char *client, uint64_t bytes, bool evict, char *why,
                      size_t cap, bool *full)
{
    struct client_hold *c = client_hold(jobs, client, true);
    *full = false;
    if (!c) {
        if (why && cap) snprintf(why, cap, "out of memory");
        return false;
    }
    uint64_t lim = jobs->cfg->client_upload_bytes;
    if (lim && c->bytes + bytes > lim) {
        uint64_t held = c->bytes;
        give_back(jobs, client, 0);
        if (why && cap)
            snprintf(why, cap,
                     "this client's uploads in progress hold %llu bytes: client_upload_bytes is "
                     "%llu; retry when one has finished",
                     (unsigned long long)held, (unsigned long long)lim);
        return false;
    }
    bool ok = evict ? make_room(jobs, bytes)
                    : jobs->store_bytes + jobs->uploading + bytes <= jobs->cfg->store_max_bytes;
    if (ok) {
        c->bytes += bytes;
        jobs->uploading += bytes;
    } else {
        *full = true;
        if (evict && why && cap) store_use(jobs, bytes, why, cap);
        give_back(jobs, client, 0);
    }
    return ok;
}

bool svd_jobs_reserve(svd_jobs *jobs, const char *client, uint64_t bytes, uint64_t held, char *why,
                      size_t cap)
{
    /* the common case, room without eviction: the table lock only */
    bool full;
    pthread_mutex_lock(&jobs->mu);
    bool ok = take_hold(jobs, client, bytes, false, why, cap, &full);
    if (!ok && !full) {
        jobs->uploading -= held < jobs->uploading ? held : jobs->uploading;
        give_back(jobs, client, held);
    }
    pthread_mutex_unlock(&jobs->mu);
    if (ok || !full) return ok;
    pthread_mutex_lock(&jobs->commit_mu); /* evictions are journaled: commit_mu, then mu */
    pthread_mutex_lock(&jobs->mu);
    ok = take_hold(jobs, client, bytes, true, why, cap, &full);
    if (!ok) {
        jobs->uploading -= held < jobs->uploading ? held : jobs->uploading;
        give_back(jobs, client, held);
    }
    pthread_mutex_unlock(&jobs->mu);
    pthread_mutex_unlock(&jobs->commit_mu);
    return ok;
}

void svd_jobs_unreserve(svd_jobs *jobs, const char *client, uint64_t bytes)
{
    pthread_mutex_lock(&jobs->mu);
    jobs->uploading -= bytes < jobs->uploading ? bytes : jobs->uploading;
    give_back(jobs, client, bytes);
    pthread_mutex_unlock(&jobs->mu);
}

svd_jobs_rc svd_jobs_submit(svd_jobs *jobs, const svd_upload *up, char **json_out, sv_error *err)
{
    svd_jobs_rc rc;
    char why[300];
    sv_error e = {0};
    *json_out = NULL;
    pthread_mutex_lock(&jobs->commit_mu);
    pthread_mutex_lock(&jobs->mu);
    svd_job *j = find(jobs, up->key);
    if (j) {
        j->lru = ++jobs->lru_clock;
        if (!owned_by(j, up->client)) { /* these bytes make this caller an owner too */
            cJSON *rec = record("own", j);
            cJSON_AddStringToObject(rec, "client", up->client);
            if (journal_json(jobs, rec, &e) != SV_OK || !add_owner(j, up->client))
                log_journal_error(jobs, j->key, &e);
        }
        /* A re-upload racing a DELETE of the running bake
         * was answered "running" and then the bake ended cancelled: the
         * upload was lost. The upload wins: the cancel is withdrawn (the
         * worker has not stopped yet) or, if the worker already stopped, the
         * bake is queued again when it reports (svd_jobs_finish). */
        if (j->state == SVD_JOB_RUNNING && j->cancel) {
            j->cancel = false;
            j->resubmitted = true;
        }
        /* A bake that failed for the server's sake (crashed
         * or timed out on every attempt, the store's disk, memory) is not the
         * input's verdict: uploading it again runs it again, as a cancelled
         * one. A failure the input caused stays (baking it again would fail
         * the same way). */
        if (j->state == SVD_JOB_CANCELLED ||
            (j->state == SVD_JOB_FAILED && server_side_code(j->code))) {
            if (journal_json(jobs, record("requeue", j), &e) == SV_OK) {
                j->seq = ++jobs->seq_next; /* before set_state: the queue is by seq */
                set_state(jobs, j, SVD_JOB_QUEUED);
                j->attempts = 0;
                set_message(j, NULL, NULL);
                pthread_cond_broadcast(&jobs->cv);
            } else {
                log_journal_error(jobs, j->key, &e);
            }
        }
        *json_out = print_free(status_json(jobs, j));
        pthread_mutex_unlock(&jobs->mu);
        pthread_mutex_unlock(&jobs->commit_mu);
        svd_rm_rf(up->tmpdir);
        return SVD_JOBS_OK;
    }
    if (jobs->stopping) {
        rc = refuse(err, SVD_JOBS_DRAINING,
                    "the server is shutting down; retry on another node or later");
    } else if (count_state(jobs, SVD_JOB_QUEUED) >= jobs->cfg->queue_max) {
        rc = refuse(err, SVD_JOBS_QUEUE_FULL, "the bake queue is full; retry later");
    } else if (client_load(jobs, up->client, false) >= jobs->cfg->queue_per_client) {
        rc = refuse(err, SVD_JOBS_CLIENT_FULL,
                    "this client has too many bakes queued or running; retry later");
    } else if (!make_room_disk(jobs, up->bytes, true, up->out_bytes)) {
        if (disk_short(jobs, up->out_bytes)) {
            uint64_t f = disk_free(jobs);
            snprintf(why, sizeof why,
                     "the store's disk has %llu bytes free: bakes not finished will write about "
                     "%llu, this one about %llu, and disk_reserve_bytes keeps %llu free",
                     (unsigned long long)f, (unsigned long long)jobs->pending_out,
                     (unsigned long long)up->out_bytes,
                     (unsigned long long)jobs->cfg->disk_reserve_bytes);
        } else {
            store_use(jobs, up->bytes, why, sizeof why);
        }
        rc = refuse(err, SVD_JOBS_STORE_FULL, why);
    } else {
        rc = SVD_JOBS_OK;
    }
    if (rc != SVD_JOBS_OK) {
        pthread_mutex_unlock(&jobs->mu);
        pthread_mutex_unlock(&jobs->commit_mu);
        svd_rm_rf(up->tmpdir);
        return rc;
    }
    jobs->store_bytes += up->bytes; /* reserved while we commit */
    pthread_mutex_unlock(&jobs->mu);

    /* Install and journal outside the table lock (GETs go on meanwhile). */
    svd_job tmp = {0};
    snprintf(tmp.key, sizeof tmp.key, "%s", up->key);
    snprintf(tmp.client, sizeof tmp.client, "%s", up->client);
    tmp.state = SVD_JOB_QUEUED;
    sv_status st = svd_store_install(jobs->store, up->tmpdir, up->key, NULL, &e);
    if (st == SV_OK) {
        st = journal_json(jobs, accept_record(&tmp), &e);
        if (st != SV_OK) svd_store_remove(jobs->store, up->key, NULL);
    }
    pthread_mutex_lock(&jobs->mu);
    if (st != SV_OK) {
        jobs->store_bytes -= up->bytes;
        pthread_mutex_unlock(&jobs->mu);
        pthread_mutex_unlock(&jobs->commit_mu);
        svd_rm_rf(up->tmpdir);
        svd_log_kv(jobs->log, SVD_LOG_ERROR, "commit_failed", "key", up->key, "msg", e.message,
                   (const char *)NULL);
        return refuse(err, st == SV_ERR_LIMIT ? SVD_JOBS_STORE_FULL : SVD_JOBS_IO,
                      "could not store the upload durably");
    }
    j = insert(jobs, up->key);
    if (!j) {
        pthread_mutex_unlock(&jobs->mu);
        pthread_mutex_unlock(&jobs->commit_mu);
        return refuse(err, SVD_JOBS_NOMEM,
                      "out of memory"); /* journaled: the job runs after a restart */
    }
    snprintf(j->client, sizeof j->client, "%s", up->client);
    j->bytes = up->bytes;
    set_state(jobs, j, SVD_JOB_QUEUED);
    j->out_est = up->out_bytes; /* its outputs' room, held until it is final */
    jobs->pending_out += j->out_est;
    pthread_cond_broadcast(&jobs->cv);
    *json_out = print_free(status_json(jobs, j));
    pthread_mutex_unlock(&jobs->mu);
    pthread_mutex_unlock(&jobs->commit_mu);
    svd_log_kv(jobs->log, SVD_LOG_INFO, "job_accepted", "key", up->key, "client", up->client,
               (const char *)NULL);
    return SVD_JOBS_ACCEPTED;
}

/* ---- waiters ---- */

bool svd_jobs_wait(svd_jobs *jobs, const char *key, svd_waiter *w)
{
    pthread_mutex_lock(&jobs->mu);
    svd_job *j = find(jobs, key);
    bool ok = j && !is_final(j->state);
    if (ok) {
        w->job = j;
        w->next = j->waiters;
        j->waiters = w;
    }
    pthread_mutex_unlock(&jobs->mu);
    return ok;
}

void svd_jobs_unwait(svd_jobs *jobs, svd_waiter *w)
{
    pthread_mutex_lock(&jobs->mu);
    if (w->job) {
        svd_waiter **pp = &w->job->waiters;
        while (*pp && *pp != w) pp = &(*pp)->next;
        if (*pp) *pp = w->next;
        w->job = NULL;
        w->next = NULL;
    }
    pthread_mutex_unlock(&jobs->mu);
}

void svd_jobs_sweep(svd_jobs *jobs, double now, bool all)
{
    pthread_mutex_lock(&jobs->mu);
    for (size_t b = 0; b < NBUCKETS; b++)
        for (svd_job *j = jobs->buckets[b]; j; j = j->hnext) {
            svd_waiter **pp = &j->waiters;
            while (*pp) {
                svd_waiter *w = *pp;
                if (all || w->deadline <= now) {
                    *pp = w->next;
                    w->job = NULL;
                    w->next = NULL;
                    w->wake(w->arg);
                } else {
                    pp = &w->next;
                }
            }
        }
    pthread_mutex_unlock(&jobs->mu);
}

/* ---- delete / artifacts ---- */

bool svd_jobs_owned(svd_jobs *jobs, const char *key, const char *client)
{
    pthread_mutex_lock(&jobs->mu);
    svd_job *j = find(jobs, key);
    bool ok = !j || owned_by(j, client); /* an unknown key is the route's not found */
    pthread_mutex_unlock(&jobs->mu);
    return ok;
}

svd_jobs_rc svd_jobs_delete(svd_jobs *jobs, const char *key, char **json_out, sv_error *err)
{
    sv_error e = {0};
    *json_out = NULL;
    pthread_mutex_lock(&jobs->commit_mu);
    pthread_mutex_lock(&jobs->mu);
    svd_job *j = find(jobs, key);
    svd_jobs_rc rc = SVD_JOBS_OK;
    if (!j) {
        rc = refuse(err, SVD_JOBS_NOT_FOUND, "no bake with this key");
    } else if (j->state == SVD_JOB_RUNNING) {
        j->cancel = true; /* the worker stops the process and reports cancelled */
        *json_out = print_free(status_json(jobs, j));
        rc = SVD_JOBS_ACCEPTED;
    } else if (j->state == SVD_JOB_QUEUED) {
        if (journal_json(jobs, record("cancel", j), &e) != SV_OK) {
            log_journal_error(jobs, key, &e);
            rc = refuse(err, SVD_JOBS_IO, "could not record the cancellation");
        } else {
            set_state(jobs, j, SVD_JOB_CANCELLED);
            set_message(j, "cancelled", "cancelled by DELETE");
            wake_all(j);
            svd_metrics_job_final(jobs->metrics, "cancelled", 0);
            *json_out = print_free(status_json(jobs, j));
        }
    } else {
        if (journal_json(jobs, record("delete", j), &e) != SV_OK) {
            log_journal_error(jobs, key, &e);
            rc = refuse(err, SVD_JOBS_IO, "could not record the deletion");
        } else {
            cJSON *r = cJSON_CreateObject();
            cJSON_AddStringToObject(r, "key", key);
            cJSON_AddStringToObject(r, "state", "deleted");
            *json_out = print_free(r);
            svd_store_remove(jobs->store, key, NULL);
            unlink_job(jobs, j);
        }
    }
    pthread_mutex_unlock(&jobs->mu);
    pthread_mutex_unlock(&jobs->commit_mu);
    if (rc == SVD_JOBS_OK || rc == SVD_JOBS_ACCEPTED)
        svd_log_kv(jobs->log, SVD_LOG_INFO, "job_deleted", "key", key, (const char *)NULL);
    return rc;
}

svd_jobs_rc svd_jobs_artifact(svd_jobs *jobs, const char *key, const char *name,
                              char path[SVD_STORE_PATH], uint64_t *size, char sha[SVD_KEY_HEX])
{
    svd_jobs_rc rc = SVD_JOBS_NOT_FOUND;
    pthread_mutex_lock(&jobs->mu);
    svd_job *j = find(jobs, key);
    if (j && j->state != SVD_JOB_DONE) rc = SVD_JOBS_NOT_DONE;
    if (j && j->state == SVD_JOB_DONE) {
        j->lru = ++jobs->lru_clock;
        const cJSON *a;
        cJSON_ArrayForEach(a, cJSON_GetObjectItemCaseSensitive(j->manifest, "artifacts"))
        {
            const char *n = cJSON_GetStringValue(cJSON_GetObjectItemCaseSensitive(a, "name"));
            const char *h = cJSON_GetStringValue(cJSON_GetObjectItemCaseSensitive(a, "sha256"));
            const cJSON *sz = cJSON_GetObjectItemCaseSensitive(a, "size");
            if (n && h && cJSON_IsNumber(sz) && strcmp(n, name) == 0 && svd_name_valid(n)) {
                char sub[SVD_NAME_MAX + 16];
                snprintf(sub, sizeof sub, "result/%s", n);
                svd_store_job_path(jobs->store, key, sub, path);
                *size = (uint64_t)sz->valuedouble;
                snprintf(sha, SVD_KEY_HEX, "%s", h);
                rc = SVD_JOBS_OK;
                break;
            }
        }
    }
    pthread_mutex_unlock(&jobs->mu);
    return rc;
}

svd_jobs_rc svd_jobs_input(svd_jobs *jobs, const char *key, const char *name,
                           char path[SVD_STORE_PATH], uint64_t *size, char sha[SVD_KEY_HEX])
{
    char ipath[SVD_STORE_PATH];
    pthread_mutex_lock(&jobs->mu);
    bool has = find(jobs, key) != NULL;
    pthread_mutex_unlock(&jobs->mu);
    if (!has || !svd_name_valid(name)) return SVD_JOBS_NOT_FOUND;
    /* read outside the lock: a job deleted meanwhile has no inputs.json (not
     * found), or no in/NAME by the time it is opened (the caller's not found) */
    svd_store_job_path(jobs->store, key, "inputs.json", ipath);
    cJSON *in = read_json_file(ipath);
    const cJSON *o = cJSON_GetObjectItemCaseSensitive(
        cJSON_GetObjectItemCaseSensitive(in, "objects"), name);
    const char *h = cJSON_GetStringValue(cJSON_GetObjectItemCaseSensitive(o, "sha256"));
    const cJSON *sz = cJSON_GetObjectItemCaseSensitive(o, "size");
    svd_jobs_rc rc = SVD_JOBS_NOT_FOUND;
    if (h && strlen(h) == SVD_KEY_HEX - 1 && cJSON_IsNumber(sz) && sz->valuedouble >= 0) {
        char sub[SVD_NAME_MAX + 8];
        snprintf(sub, sizeof sub, "in/%s", name);
        svd_store_job_path(jobs->store, key, sub, path);
        *size = (uint64_t)sz->valuedouble;
        snprintf(sha, SVD_KEY_HEX, "%s", h);
        rc = SVD_JOBS_OK;
    }
    cJSON_Delete(in);
    return rc;
}

svd_jobs_rc svd_jobs_inputs(svd_jobs *jobs, const char *key, char **json_out, sv_error *err)
{
    *json_out = NULL;
    if (!svd_jobs_has(jobs, key)) return refuse(err, SVD_JOBS_NOT_FOUND, "no bake with this key");
    char ipath[SVD_STORE_PATH];
    svd_store_job_path(jobs->store, key, "inputs.json", ipath);
    cJSON *in = read_json_file(ipath);
    const char *mesh = cJSON_GetStringValue(cJSON_GetObjectItemCaseSensitive(in, "mesh"));
    const cJSON *objs = cJSON_GetObjectItemCaseSensitive(in, "objects");
    if (!mesh || !cJSON_IsObject(objs)) {
        cJSON_Delete(in);
        return refuse(err, SVD_JOBS_NOT_FOUND, "no bake with this key");
    }
    cJSON *out = cJSON_CreateObject(), *files = cJSON_AddArrayToObject(out, "files");
    cJSON_AddStringToObject(out, "mesh", mesh);
    /* the mesh first, then every other object in upload order */
    for (int pass = 0; pass < 2; pass++) {
        const cJSON *o;
        cJSON_ArrayForEach(o, objs)
        {
            if (!o->string || (strcmp(o->string, mesh) == 0) != (pass == 0)) continue;
            const cJSON *sz = cJSON_GetObjectItemCaseSensitive(o, "size");
            cJSON *f = cJSON_CreateObject();
            cJSON_AddStringToObject(f, "name", o->string);
            cJSON_AddNumberToObject(f, "size", cJSON_IsNumber(sz) ? sz->valuedouble : 0);
            const char *h = cJSON_GetStringValue(cJSON_GetObjectItemCaseSensitive(o, "sha256"));
            cJSON_AddStringToObject(f, "sha256", h ? h : "");
            cJSON_AddItemToArray(files, f);
        }
    }
    cJSON_Delete(in);
    *json_out = cJSON_PrintUnformatted(out);
    cJSON_Delete(out);
    return *json_out ? SVD_JOBS_OK : refuse(err, SVD_JOBS_NOMEM, "out of memory");
}

void svd_jobs_result_corrupt(svd_jobs *jobs, const char *key, const char *path)
{
    sv_error e = {0};
    pthread_mutex_lock(&jobs->commit_mu);
    pthread_mutex_lock(&jobs->mu);
    svd_job *j = find(jobs, key);
    if (j && j->state == SVD_JOB_DONE) {
        svd_log_kv(jobs->log, SVD_LOG_ERROR, "store_object_corrupt", "key", key, "path", path,
                   "msg", "SHA-256 mismatch: result quarantined, job requeued", (const char *)NULL);
        char rdir[SVD_STORE_PATH];
        svd_store_job_path(jobs->store, key, "result", rdir);
        uint64_t rb = svd_dir_bytes(rdir);
        svd_store_quarantine(jobs->store, key, rdir);
        j->bytes -= rb < j->bytes ? rb : j->bytes;
        jobs->store_bytes -= rb < jobs->store_bytes ? rb : jobs->store_bytes;
        if (journal_json(jobs, record("requeue", j), &e) != SV_OK) log_journal_error(jobs, key, &e);
        set_state(jobs, j, SVD_JOB_QUEUED);
        j->attempts = 0;
        cJSON_Delete(j->manifest);
        j->manifest = NULL;
        pthread_cond_broadcast(&jobs->cv);
    }
    pthread_mutex_unlock(&jobs->mu);
    pthread_mutex_unlock(&jobs->commit_mu);
}

void svd_jobs_disk(svd_jobs *jobs, uint64_t *free_bytes, bool *low)
{
    pthread_mutex_lock(&jobs->mu);
    *free_bytes = disk_free(jobs);
    *low = disk_short(jobs, 0);
    pthread_mutex_unlock(&jobs->mu);
}

void svd_jobs_gauges(svd_jobs *jobs, svd_gauges *g)
{
    memset(g, 0, sizeof *g);
    pthread_mutex_lock(&jobs->mu);
    for (size_t b = 0; b < NBUCKETS; b++)
        for (svd_job *j = jobs->buckets[b]; j; j = j->hnext) {
            g->queued += j->state == SVD_JOB_QUEUED;
            g->running += j->state == SVD_JOB_RUNNING;
            for (svd_waiter *w = j->waiters; w; w = w->next) g->waiters++;
        }
    g->jobs = jobs->count;
    g->store_bytes = jobs->store_bytes;
    pthread_mutex_unlock(&jobs->mu);
    g->store_limit = jobs->cfg->store_max_bytes;
}

/* ---- worker side ---- */

bool svd_jobs_take(svd_jobs *jobs, svd_ticket *t)
{
    pthread_mutex_lock(&jobs->mu);
    for (;;) {
        if (jobs->stopping) {
            pthread_mutex_unlock(&jobs->mu);
            return false;
        }
        /* Oldest queued job among the clients with the fewest running jobs,
         * from the queue (in seq order) and the running list: the first job
         * whose client runs nothing is the answer. Once a scan of every
         * stored job per take. */
        svd_job *best = NULL;
        unsigned best_load = 0;
        double now = sv_now(), next = 0; /* the earliest retry still backing off */
        for (svd_job *j = jobs->qhead; j; j = j->lnext) {
            if (j->not_before > now) {
                if (!next || j->not_before < next) next = j->not_before;
                continue;
            }
            unsigned load = 0;
            for (svd_job *r = jobs->rhead; r; r = r->lnext)
                load += strcmp(r->client, j->client) == 0;
            if (!best || load < best_load) {
                best = j;
                best_load = load;
                if (load == 0) break;
            }
        }
        if (best) {
            set_state(jobs, best, SVD_JOB_RUNNING);
            best->attempts++;
            best->cancel = false;
            best->stage = -1;
            best->progress = 0;
            best->try_k = best->tries = 0;
            memset(best->times, 0, sizeof best->times);
            best->t_started = sv_now();
            best->stage_start = best->t_started;
            t->job = best;
            snprintf(t->key, sizeof t->key, "%s", best->key);
            t->attempt = best->attempts;
            wake_all(best);
            pthread_mutex_unlock(&jobs->mu);
            return true;
        }
        if (next > 0) { /* a retry becomes due: wake then, or at a change */
            struct timespec ts;
            clock_gettime(CLOCK_REALTIME, &ts);
            double d = next - now + 0.001;
            ts.tv_sec += (time_t)d;
            ts.tv_nsec += (long)((d - (double)(time_t)d) * 1e9);
            if (ts.tv_nsec >= 1000000000L) ts.tv_sec++, ts.tv_nsec -= 1000000000L;
            pthread_cond_timedwait(&jobs->cv, &jobs->mu, &ts);
            continue;
        }
        pthread_cond_wait(&jobs->cv, &jobs->mu);
    }
}

void svd_jobs_progress(svd_jobs *jobs, svd_ticket *t, const char *stage, double progress, int try_k,
                       int tries)
{
    int s = svd_stage_index(stage);
    pthread_mutex_lock(&jobs->mu);
    svd_job *j = t->job;
    double now = sv_now();
    if (s >= 0 && s != j->stage) {
        if (j->stage >= 0) {
            double d = now - j->stage_start;
            j->times[j->stage] += d;
            svd_metrics_stage(jobs->metrics, j->stage, d);
        }
        j->stage = s;
        j->stage_start = now;
        wake_all(j);
    }
    if (progress >= 0 && progress <= 1) j->progress = progress;
    bool searching = try_k > 0 && try_k <= tries && tries <= 1000;
    j->try_k = searching ? try_k : 0;
    j->tries = searching ? tries : 0;
    pthread_mutex_unlock(&jobs->mu);
}

bool svd_jobs_cancelled(svd_jobs *jobs, svd_ticket *t)
{
    pthread_mutex_lock(&jobs->mu);
    bool c = t->job->cancel;
    pthread_mutex_unlock(&jobs->mu);
    return c;
}

bool svd_jobs_aborting(svd_jobs *jobs)
{
    pthread_mutex_lock(&jobs->mu);
    bool a = jobs->aborting;
    pthread_mutex_unlock(&jobs->mu);
    return a;
}

void svd_jobs_finish(svd_jobs *jobs, svd_ticket *t, svd_outcome out, const char *code,
                     const char *message, const char *manifest_json)
{
    sv_error e = {0};
    char jdir[SVD_STORE_PATH];
    svd_store_job_path(jobs->store, t->key, NULL, jdir);
    uint64_t bytes = out == SVD_OUT_DONE ? svd_dir_bytes(jdir) : 0;
    char msg[700];
    snprintf(msg, sizeof msg, "%s", message ? message : "");
    if (out == SVD_OUT_RETRY && t->attempt >= jobs->cfg->attempts) {
        snprintf(msg, sizeof msg, "%s on %u attempts", message ? message : "worker failed",
                 t->attempt);
        out = SVD_OUT_FAILED;
        code = code ? code : "crash";
    }
    if (out == SVD_OUT_RETRY) {
        /* A failure the server caused may be a full disk: finished bakes are
         * evicted until the disk has room for the outputs of the bakes not
         * finished, so the retry does not meet the same full disk. */
        pthread_mutex_lock(&jobs->commit_mu);
        pthread_mutex_lock(&jobs->mu);
        if (disk_short(jobs, 0)) make_room_disk(jobs, 0, true, 0);
        pthread_mutex_unlock(&jobs->mu);
        pthread_mutex_unlock(&jobs->commit_mu);
    }
    if (out == SVD_OUT_FAILED) { /* error.json beside the inputs, for operators */
        char *ej = error_doc(code ? code : "failed", msg);
        if (ej) svd_store_write_file(jdir, "error.json", ej, strlen(ej), NULL);
        free(ej);
    }
    pthread_mutex_lock(&jobs->mu);
    svd_job *j = t->job;
    double now = sv_now();
    if (j->stage >= 0) {
        double d = now - j->stage_start;
        j->times[j->stage] += d;
        svd_metrics_stage(jobs->metrics, j->stage, d);
    }
    const char *final = NULL;
    switch (out) {
    case SVD_OUT_DONE: {
        cJSON *rec = record("done", j);
        if (journal_json(jobs, rec, &e) != SV_OK) log_journal_error(jobs, j->key, &e);
        cJSON_Delete(j->manifest);
        j->manifest = manifest_json ? cJSON_Parse(manifest_json) : NULL;
        set_state(jobs, j, SVD_JOB_DONE);
        j->progress = 1;
        /* A fresh result is a use: else make_room() below picks it as the LRU
         * victim (its last use was its upload) and it is gone before its
         * client, polling later, ever sees it. */
        j->lru = ++jobs->lru_clock;
        jobs->store_bytes += bytes > j->bytes ? bytes - j->bytes : 0;
        j->bytes = bytes > j->bytes ? bytes : j->bytes;
        final = "done";
        break;
    }
    case SVD_OUT_FAILED: {
        cJSON *rec = record("failed", j);
        cJSON_AddStringToObject(rec, "code", code ? code : "failed");
        cJSON_AddStringToObject(rec, "message", msg);
        if (journal_json(jobs, rec, &e) != SV_OK) log_journal_error(jobs, j->key, &e);
        set_state(jobs, j, SVD_JOB_FAILED);
        set_message(j, code ? code : "failed", msg);
        final = "failed";
        break;
    }
    case SVD_OUT_CANCELLED:
        if (j->resubmitted) { /* uploaded again after the DELETE: run it again */
            list_out(jobs, j);
            j->seq = ++jobs->seq_next; /* the queue is by seq: out, renumbered, in */
            set_state(jobs, j, SVD_JOB_QUEUED);
            j->attempts = 0;
            break;
        }
        if (journal_json(jobs, record("cancel", j), &e) != SV_OK)
            log_journal_error(jobs, j->key, &e);
        set_state(jobs, j, SVD_JOB_CANCELLED);
        set_message(j, "cancelled", "cancelled by DELETE");
        final = "cancelled";
        break;
    case SVD_OUT_RETRY: {
        set_state(jobs, j, SVD_JOB_QUEUED); /* keeps its seq: first in line again, */
        /* after a backoff: 0.5 s, 1 s, 2 s ... 8 s (a full disk or a memory
         * squeeze may pass; an instant retry meets it again) */
        double wait = 0.5 * ldexp(1.0, t->attempt > 1 ? (int)t->attempt - 1 : 0);
        j->not_before = now + (wait < 8 ? wait : 8);
        break;
    }
    case SVD_OUT_REQUEUE:
        set_state(jobs, j, SVD_JOB_QUEUED);
        if (j->attempts) j->attempts--;
        break;
    }
    j->stage = out == SVD_OUT_DONE ? j->stage : -1;
    j->cancel = false;
    j->resubmitted = false;
    if (final) svd_metrics_job_final(jobs->metrics, final, now - j->t_started);
    /* Logged before anyone can see the new state: a reader of the log that
     * finds no job_finished line knows no client has seen the job finish. */
    svd_log_kv(jobs->log, out == SVD_OUT_FAILED ? SVD_LOG_WARN : SVD_LOG_INFO, "job_finished",
               "key", t->key, "state", final ? final : "queued", "msg", msg[0] ? msg : NULL,
               (const char *)NULL);
    wake_all(j);
    pthread_cond_broadcast(&jobs->cv);
    if (j->state == SVD_JOB_DONE) make_room(jobs, 0);
    pthread_mutex_unlock(&jobs->mu);
    t->job = NULL;
}

void svd_jobs_stop(svd_jobs *jobs)
{
    pthread_mutex_lock(&jobs->mu);
    jobs->stopping = true;
    pthread_cond_broadcast(&jobs->cv);
    pthread_mutex_unlock(&jobs->mu);
}

void svd_jobs_abort(svd_jobs *jobs)
{
    pthread_mutex_lock(&jobs->mu);
    jobs->aborting = true;
    pthread_mutex_unlock(&jobs->mu);
}

unsigned svd_jobs_running(svd_jobs *jobs)
{
    pthread_mutex_lock(&jobs->mu);
    unsigned n = count_state(jobs, SVD_JOB_RUNNING);
    pthread_mutex_unlock(&jobs->mu);
    return n;
}

svd_store *svd_jobs_store(svd_jobs *jobs)
{
    return jobs->store;
}
const svd_config *svd_jobs_config(svd_jobs *jobs)
{
    return jobs->cfg;
}
svd_log *svd_jobs_log(svd_jobs *jobs)
{
    return jobs->log;
}
svd_metrics *svd_jobs_metrics(svd_jobs *jobs)
{
    return jobs->metrics;
}
