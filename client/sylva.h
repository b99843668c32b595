/* sylva.h — libsylva, the thin C client of the sylvad baking daemon (HTTP API v1,
 * docs/api.md; client guide docs/client.md).
 *
 * What it does: computes a bake's content key locally (the same framing as the
 * server), submits the bake as an idempotent `PUT /v1/bakes/{key}` (safe to
 * retry), waits with a progress callback, downloads the artifacts and verifies
 * each one's SHA-256 against the manifest, reads status, cancels, checks health.
 *
 * Conventions:
 *   - One opaque handle per caller thread: a sylva_client is not thread-safe,
 *     but separate handles are independent. No globals, no hidden threads: every
 *     call runs its requests (with libcurl) in the calling thread. The caller
 *     should have called curl_global_init() once before creating handles in a
 *     threaded program (libcurl's own rule); otherwise the first create does it.
 *   - Every call that can fail returns a sylva_status. The detail of the last
 *     failure (a one-line message naming the problem, the server's error code
 *     and the HTTP status) is kept in the handle: sylva_client_error().
 *   - Retries: connection errors, timeouts, HTTP 429, 5xx are retried with
 *     exponential backoff (Retry-After honoured), failing over between the
 *     configured servers in order (see sylva_retry_delay). Until some server
 *     has answered the handle, a request whose every attempt was refused
 *     (nothing listens there) stops after 1.5 s: SYLVA_ERR_CONNECT, detail
 *     "no sylva daemon answers at URL... (connection refused): is sylvad
 *     running?", and no on_retry call for those quick retries.
 *   - A `key` argument of the calls that name a bake (status, wait, cancel,
 *     fetch) is the 64-digit key or a prefix of at least 8 of its digits,
 *     which the server resolves (docs/api.md "Key prefixes": 404 when none,
 *     SYLVA_ERR_REJECTED for 409 when several bakes start with it).
 *   - destroy/clear functions accept NULL.
 */
#ifndef SYLVA_H
#define SYLVA_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define SYLVA_KEY_HEX 64   /* a key is 64 lowercase hex digits */
#define SYLVA_NAME_MAX 255 /* longest upload file name, bytes */

typedef enum sylva_status {
    SYLVA_OK = 0,
    SYLVA_ERR_NOMEM,       /* allocation failed or size overflow */
    SYLVA_ERR_ARG,         /* bad argument: NULL where not allowed, bad name, bad URL */
    SYLVA_ERR_IO,          /* reading or writing a local file failed */
    SYLVA_ERR_CONNECT,     /* no server could be reached (after retries) */
    SYLVA_ERR_TIMEOUT,     /* a request or the wait took longer than allowed */
    SYLVA_ERR_AUTH,        /* 401/403: missing or wrong token */
    SYLVA_ERR_NOT_FOUND,   /* 404: no such bake or artifact */
    SYLVA_ERR_REJECTED,    /* other 4xx: the server refused the input (spec, mesh, size) */
    SYLVA_ERR_BUSY,        /* 429/503 still answered after every retry */
    SYLVA_ERR_SERVER,      /* other 5xx still answered after every retry */
    SYLVA_ERR_PROTOCOL,    /* a response that does not follow the API */
    SYLVA_ERR_BAKE_FAILED, /* the bake ran and failed (state "failed") */
    SYLVA_ERR_CANCELLED,   /* cancelled: by the progress callback or on the server */
    SYLVA_ERR_INTEGRITY,   /* a downloaded artifact does not match its SHA-256 */
    SYLVA_STATUS_COUNT
} sylva_status;

/* Short stable name ("connect", "integrity", ...) for JSON output. Never NULL. */
const char *sylva_status_name(sylva_status st);
/* One-line description from a static table. Never NULL. */
const char *sylva_status_message(sylva_status st);

/* Client options. A zero-initialised struct is valid: every zero field means
 * "the default" listed beside it; sylva_options_init writes those defaults
 * explicitly. Strings are copied by sylva_client_create. */
typedef struct sylva_options {
    const char *token;       /* bearer token; NULL or "" = none */
    long connect_timeout_ms; /* per connection attempt; default 5000 */
    long request_timeout_ms; /* per request, excluding a long-poll's wait; default 300000 */
    int max_attempts;        /* tries per request incl. the first; default 8; 1 = no retry */
    long backoff_base_ms;    /* first retry delay, doubled each round; default 250 */
    long backoff_max_ms;     /* cap on one delay (Retry-After is capped at 4x this); default 8000 */
    const char *user_agent;  /* default "libsylva/<version>" */
    /* Called before each retry's wait (NULL = silent, the default): the last
     * attempt's error, the wait in ms, attempts made and allowed. For a
     * command-line tool to say why it is waiting instead of hanging mute. */
    void (*on_retry)(void *user, const char *error, long delay_ms, int attempt, int max_attempts);
    void *on_retry_user;
} sylva_options;

#define SYLVA_VERSION "0.1.0"

/* Fills *opts with the defaults above (token NULL). */
void sylva_options_init(sylva_options *opts);

/* The retry policy, as a pure function (used by every request; public so it can
 * be tested and documented). `attempt` is the number of attempts made so far
 * (>= 1) and `servers` the number of configured servers. Returns the delay in
 * milliseconds before the next attempt, or -1 when no further attempt is made.
 * Retryable: transport_error (connection refused/reset, timeout) or HTTP 429,
 * 500-599. A failed attempt moves to the next server; the client sleeps only
 * when a full round over all servers has failed: round r (1, 2, ...) waits
 * min(backoff_base * 2^(r-1), backoff_max), or the server's Retry-After when
 * that is longer (capped at 4 * backoff_max). retry_after_ms < 0 = absent. */
long sylva_retry_delay(const sylva_options *opts, int attempt, size_t servers, bool transport_error,
                       long http_status, long retry_after_ms);

/* ---- keys ---------------------------------------------------------------- */

/* One uploaded file: from memory (data != NULL: not copied, must stay valid for
 * the call) or from disk (path). name is the upload name; NULL = base name of
 * path. Names are base names: no '/', '\\', control characters or spaces, not
 * "." or "..", 1..255 bytes. */
typedef struct sylva_file {
    const char *name;
    const char *path;
    const void *data;
    size_t size;
} sylva_file;

/* A bake: the spec (JSON text, sent exactly as given; NULL or empty = "{}"), the mesh
 * and its companion files (.mtl, .bin, textures) in any order. */
typedef struct sylva_input {
    const char *spec;
    size_t spec_len; /* bytes of spec; ignored when spec is NULL */
    sylva_file mesh;
    const sylva_file *files;
    size_t file_count;
} sylva_input;

/* Checks an upload name against the rules above. */
bool sylva_name_valid(const char *name);

/* Computes the content key (lowercase hex SHA-256, OpenSSL EVP) of in:
 *   "sylva-key-v1\n"
 *   "spec " <len> "\n" <spec bytes> "\n"
 *   "mesh " <name> " " <len> "\n" <mesh bytes> "\n"
 *   for each companion in bytewise order of name:
 *   "file " <name> " " <len> "\n" <bytes> "\n"
 * Files on disk are streamed. Fails with SYLVA_ERR_ARG on an invalid or
 * duplicate name (the mesh's included), SYLVA_ERR_IO when a file cannot be
 * read. key receives 64 hex digits and a NUL. errbuf (may be NULL) receives
 * the detail on failure. */
sylva_status sylva_key_compute(const sylva_input *in, char key[SYLVA_KEY_HEX + 1], char *errbuf,
                               size_t errlen);

/* Lowercase hex SHA-256 of a memory buffer or of a file (streamed). */
sylva_status sylva_sha256_hex(const void *data, size_t size, char hex[SYLVA_KEY_HEX + 1]);
sylva_status sylva_sha256_file(const char *path, char hex[SYLVA_KEY_HEX + 1]);

/* ---- the handle ---------------------------------------------------------- */

typedef struct sylva_client sylva_client;

/* Creates a client for url_count >= 1 server base URLs ("http://host:port",
 * tried in this order on failover; a trailing '/' is ignored). opts may be
 * NULL (defaults). On failure *out is NULL and errbuf (may be NULL) names the
 * problem. */
sylva_status sylva_client_create(const char *const *urls, size_t url_count,
                                 const sylva_options *opts, sylva_client **out, char *errbuf,
                                 size_t errlen);

/* Frees the handle. NULL is a no-op. */
void sylva_client_destroy(sylva_client *c);

/* Detail of the last failed call on this handle ("" after a success). Valid
 * until the next call on the handle. */
const char *sylva_client_error(const sylva_client *c);
/* The server's error code of the last failure ("spec", "unbakeable", ... or ""). */
const char *sylva_client_error_code(const sylva_client *c);
/* The HTTP status of the last response (0 when none arrived). */
long sylva_client_http_status(const sylva_client *c);
/* Base URL of the server that answered last (or the first one). */
const char *sylva_client_server(const sylva_client *c);

/* ---- jobs ------------------------------------------------------------------ */

typedef enum sylva_state {
    SYLVA_STATE_UNKNOWN = 0,
    SYLVA_STATE_QUEUED,
    SYLVA_STATE_RUNNING,
    SYLVA_STATE_DONE,
    SYLVA_STATE_FAILED,
    SYLVA_STATE_CANCELLED
} sylva_state;

/* "queued", "running", ...; "unknown" for SYLVA_STATE_UNKNOWN. */
const char *sylva_state_name(sylva_state s);

/* A job as the server described it. json holds the whole response body
 * (NUL-terminated, owned; NULL when none): the manifest, times and summary
 * are read from it. Zero-initialise before first use; sylva_job_clear frees. */
typedef struct sylva_job {
    char key[SYLVA_KEY_HEX + 1];
    sylva_state state;
    char stage[32];      /* current or last stage, "" when unknown */
    double progress;     /* 0..1 */
    int search_try;      /* running a target search: try k (1..search_tries), else 0 */
    int search_tries;    /* the search's bound on tries (it often needs fewer) */
    char error_code[32]; /* when failed */
    char error_message[512];
    bool target_unmet;       /* done, but the spec's "target" was not met: the outputs
                                  are the best try's bake (docs/spec.md "target") */
    char target_reason[512]; /* why, when target_unmet ("" otherwise) */
    char *json;
} sylva_job;

/* Frees job->json and zeroes the job. NULL is fine. */
void sylva_job_clear(sylva_job *job);

/* Parses a job response body into *job (replacing its contents; json is copied).
 * SYLVA_ERR_PROTOCOL when it is not a job object. */
sylva_status sylva_job_parse(const char *body, size_t len, sylva_job *job);

/* Submits a bake with `PUT /v1/bakes/{key}` (key computed locally). Returns
 * SYLVA_OK when the server answered 200 or 202; *job (may be NULL) receives
 * the state. A known key answers at once: nothing is baked twice. */
sylva_status sylva_submit(sylva_client *c, const sylva_input *in, sylva_job *job);

/* `GET /v1/bakes/{key}` (with `?wait=S` when wait_s > 0: the server holds the
 * answer until the state changes or S seconds pass). */
sylva_status sylva_status_get(sylva_client *c, const char *key, double wait_s, sylva_job *job);

/* Progress callback: stage name ("queued", "import", ..., "write"), overall
 * fraction 0..1, user data. Return false to cancel the bake (DELETE). */
typedef bool (*sylva_progress_fn)(const char *stage, double fraction, void *user_data);

/* Waits until the bake is done, failed or cancelled, calling progress (may be
 * NULL) whenever the stage or progress changes. timeout_s <= 0 = no limit.
 * Returns SYLVA_OK when done, SYLVA_ERR_BAKE_FAILED (detail and job->error_*
 * set), SYLVA_ERR_CANCELLED (callback returned false: the bake was deleted on
 * the server; or cancelled there), SYLVA_ERR_TIMEOUT. When the server does not
 * know the key any more (404, e.g. after failover to another server) and in
 * is non-NULL, the bake is submitted again. job (may be NULL) gets the last state. */
sylva_status sylva_wait(sylva_client *c, const char *key, const sylva_input *in, double timeout_s,
                        sylva_progress_fn progress, void *user_data, sylva_job *job);

/* `DELETE /v1/bakes/{key}`: cancels a queued or running bake, deletes a finished one. */
sylva_status sylva_cancel(sylva_client *c, const char *key);

/* As sylva_cancel, and says what happened in state (NUL-terminated, cut to
 * state_len): "cancelled" (it was queued), "cancel_requested" (it was running;
 * it ends cancelled shortly), "deleted" (it had finished: its results are
 * gone). */
sylva_status sylva_cancel_state(sylva_client *c, const char *key, char *state, size_t state_len);

/* `GET /v1/health`. body (may be NULL) receives the response body (free()). */
sylva_status sylva_health(sylva_client *c, char **body);

/* One artifact listed in a manifest. */
typedef struct sylva_artifact {
    char name[SYLVA_NAME_MAX + 1];
    uint64_t size;
    char sha256[SYLVA_KEY_HEX + 1];
} sylva_artifact;

/* Lists the artifacts of a done job's manifest. *out (free()) receives *count
 * entries. SYLVA_ERR_PROTOCOL when the manifest is missing or malformed (bad
 * name, bad hash). */
sylva_status sylva_job_artifacts(const sylva_job *job, sylva_artifact **out, size_t *count);

/* Downloads every artifact of a done bake into dir (created if missing; files
 * written to a temporary name and renamed only once their SHA-256 matches).
 * A mismatch fails with SYLVA_ERR_INTEGRITY and leaves no file behind. Once
 * every artifact is there, files of an earlier bake in dir that this one does
 * not have are removed: only sylva's output names (model.glb, planes.json,
 * report.json, preview.png, impostor.json, error.json, lod<i>_*.glb,
 * atlas_*.png); other files are never touched. job may be a done job from
 * sylva_wait / sylva_status_get, or NULL (then it is fetched). */
sylva_status sylva_fetch_dir(sylva_client *c, const char *key, const sylva_job *job,
                             const char *dir);

/* Downloads one artifact into memory, verified against the manifest (job as
 * above). *data (free()) receives *size bytes, NUL-terminated for convenience. */
sylva_status sylva_fetch_mem(sylva_client *c, const char *key, const sylva_job *job,
                             const char *name, void **data, size_t *size);

#ifdef __cplusplus
}
#endif

#endif
