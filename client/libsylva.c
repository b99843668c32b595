/* libsylva.c — the HTTP side of libsylva (libcurl): one easy handle per client,
 * every request through request_run(), which retries and fails over following
 * sylva_retry_delay(). API v1 as in docs/api.md; contracts in sylva.h. */
#include "clock.h"
#include "key_rules.h"
#include "out_names.h"
#include "sylva.h"

#include <cjson/cJSON.h>
#include <curl/curl.h>
#include <openssl/evp.h>

#include <dirent.h>
#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#define MAX_JSON_BYTES (16u << 20)         /* a status/health answer */
#define MAX_MEM_ARTIFACT ((size_t)1 << 31) /* sylva_fetch_mem */
/* How long a request retries while every attempt is refused and no server
 * has answered this handle yet: nothing listens there (no daemon running, a
 * wrong port), which retrying for the full policy would only hide. A daemon
 * still starting gets this long; once one has answered, a refused connection
 * is a restart and is retried as any transport error (sylva.h). */
#define REFUSED_WINDOW_MS 1500

struct sylva_client {
    char **urls;
    size_t url_count;
    size_t current; /* index of the server tried first next time */
    long connect_timeout_ms;
    long request_timeout_ms;
    int max_attempts;
    long backoff_base_ms;
    long backoff_max_ms;
    char *token;
    char *user_agent;
    sylva_options policy; /* the numbers above, for sylva_retry_delay */
    void (*on_retry)(void *, const char *, long, int, int);
    void *on_retry_user;
    CURL *curl;
    bool answered; /* a server answered this handle over HTTP at least once */
    long http_status;
    char error[1024];
    char error_code[32];
};

/* ---- small helpers ---------------------------------------------------------- */

static char *dup_str(const char *s)
{
    size_t n = strlen(s) + 1;
    char *d = malloc(n);
    if (d) memcpy(d, s, n);
    return d;
}

static sylva_status fail(sylva_client *c, sylva_status st, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));
static sylva_status fail(sylva_client *c, sylva_status st, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(c->error, sizeof c->error, fmt, ap);
    va_end(ap);
    return st;
}

static void clear_error(sylva_client *c)
{
    c->error[0] = '\0';
    c->error_code[0] = '\0';
}

static bool key_valid(const char *key)
{
    return sylva_key_hex_ok(key);
}

/* What the calls that name a bake take: the key, or a prefix of at least
 * SYLVA_KEY_PREFIX_MIN hex digits that the server resolves (docs/api.md). */
static bool key_name_ok(const char *key)
{
    return sylva_key_prefix_ok(key);
}

/* ---- create / destroy ------------------------------------------------------- */

sylva_status sylva_client_create(const char *const *urls, size_t url_count,
                                 const sylva_options *opts, sylva_client **out, char *errbuf,
                                 size_t errlen)
{
    if (errbuf && errlen) errbuf[0] = '\0';
    if (!out) return SYLVA_ERR_ARG;
    *out = NULL;
    if (!urls || url_count == 0) {
        if (errbuf) snprintf(errbuf, errlen, "no server URL given");
        return SYLVA_ERR_ARG;
    }
    for (size_t i = 0; i < url_count; i++) {
        if (!urls[i] ||
            (strncmp(urls[i], "http://", 7) != 0 && strncmp(urls[i], "https://", 8) != 0)) {
            if (errbuf)
                snprintf(errbuf, errlen,
                         "server URL \"%.200s\" must start with http:// or https://",
                         urls[i] ? urls[i] : "(null)");
            return SYLVA_ERR_ARG;
        }
    }
    sylva_options d;
    sylva_options_init(&d);
    sylva_client *c = calloc(1, sizeof *c);
    if (!c) return SYLVA_ERR_NOMEM;
    c->urls = calloc(url_count, sizeof *c->urls);
    if (!c->urls) goto nomem;
    c->url_count = url_count;
    for (size_t i = 0; i < url_count; i++) {
        c->urls[i] = dup_str(urls[i]);
        if (!c->urls[i]) goto nomem;
        size_t n = strlen(c->urls[i]);
        while (n > 0 && c->urls[i][n - 1] == '/') c->urls[i][--n] = '\0';
    }
    c->connect_timeout_ms = opts && opts->connect_timeout_ms > 0 ? opts->connect_timeout_ms
                                                                 : d.connect_timeout_ms;
    c->request_timeout_ms = opts && opts->request_timeout_ms > 0 ? opts->request_timeout_ms
                                                                 : d.request_timeout_ms;
    c->max_attempts = opts && opts->max_attempts > 0 ? opts->max_attempts : d.max_attempts;
    c->backoff_base_ms = opts && opts->backoff_base_ms > 0 ? opts->backoff_base_ms
                                                           : d.backoff_base_ms;
    c->backoff_max_ms = opts && opts->backoff_max_ms > 0 ? opts->backoff_max_ms : d.backoff_max_ms;
    c->policy = d;
    if (opts) {
        c->on_retry = opts->on_retry;
        c->on_retry_user = opts->on_retry_user;
    }
    c->policy.max_attempts = c->max_attempts;
    c->policy.backoff_base_ms = c->backoff_base_ms;
    c->policy.backoff_max_ms = c->backoff_max_ms;
    if (opts && opts->token && opts->token[0]) {
        if (strpbrk(opts->token, "\r\n")) {
            if (errbuf) snprintf(errbuf, errlen, "the token contains a line break");
            sylva_client_destroy(c);
            return SYLVA_ERR_ARG;
        }
        c->token = dup_str(opts->token);
        if (!c->token) goto nomem;
    }
    c->user_agent = dup_str(opts && opts->user_agent ? opts->user_agent : d.user_agent);
    if (!c->user_agent) goto nomem;
    /* curl_easy_init runs curl_global_init itself when nobody did (not thread-safe
     * then: documented in sylva.h). */
    c->curl = curl_easy_init();
    if (!c->curl) goto nomem;
    *out = c;
    return SYLVA_OK;
nomem:
    if (errbuf) snprintf(errbuf, errlen, "out of memory creating the client");
    sylva_client_destroy(c);
    return SYLVA_ERR_NOMEM;
}

void sylva_client_destroy(sylva_client *c)
{
    if (!c) return;
    if (c->curl) curl_easy_cleanup(c->curl);
    for (size_t i = 0; c->urls && i < c->url_count; i++) free(c->urls[i]);
    free(c->urls);
    free(c->token);
    free(c->user_agent);
    free(c);
}

const char *sylva_client_error(const sylva_client *c)
{
    return c ? c->error : "no client";
}

const char *sylva_client_error_code(const sylva_client *c)
{
    return c ? c->error_code : "";
}

long sylva_client_http_status(const sylva_client *c)
{
    return c ? c->http_status : 0;
}

const char *sylva_client_server(const sylva_client *c)
{
    return c ? c->urls[c->current] : "";
}

/* ---- response sinks ----------------------------------------------------------- */

typedef struct sink {
    /* memory */
    char *buf;
    size_t len, cap, limit;
    bool overflow;
    /* file (when fd >= 0): bytes go to the file and through md */
    FILE *file;
    EVP_MD_CTX *md;
    bool write_failed;
} sink;

static size_t sink_write(char *ptr, size_t size, size_t nmemb, void *ud)
{
    sink *s = ud;
    size_t n = size * nmemb; /* libcurl guarantees size == 1 */
    if (s->file) {
        if (fwrite(ptr, 1, n, s->file) != n) {
            s->write_failed = true;
            return 0;
        }
        if (s->md && EVP_DigestUpdate(s->md, ptr, n) != 1) {
            s->write_failed = true;
            return 0;
        }
        s->len += n;
        return n;
    }
    if (n > s->limit - s->len) {
        s->overflow = true;
        return 0;
    }
    if (s->len + n + 1 > s->cap) {
        size_t cap = s->cap ? s->cap : 4096;
        while (cap < s->len + n + 1) cap = cap > SIZE_MAX / 2 ? SIZE_MAX : cap * 2;
        char *nb = realloc(s->buf, cap);
        if (!nb) {
            s->overflow = true;
            return 0;
        }
        s->buf = nb;
        s->cap = cap;
    }
    memcpy(s->buf + s->len, ptr, n);
    s->len += n;
    s->buf[s->len] = '\0';
    return n;
}

/* Empties the sink before a new attempt. */
static bool sink_reset(sink *s)
{
    s->len = 0;
    s->overflow = false;
    s->write_failed = false;
    if (s->buf) s->buf[0] = '\0';
    if (s->file) {
        if (fflush(s->file) != 0 || ftruncate(fileno(s->file), 0) != 0) return false;
        rewind(s->file);
        if (s->md && EVP_DigestInit_ex(s->md, EVP_sha256(), NULL) != 1) return false;
    }
    return true;
}

/* ---- uploads from memory (mime parts read through a cursor, not copied) ---- */

typedef struct cursor {
    const char *data;
    size_t size, pos;
} cursor;

static size_t cursor_read(char *buffer, size_t size, size_t nitems, void *arg)
{
    cursor *cu = arg;
    size_t want = size * nitems;
    size_t left = cu->size - cu->pos;
    size_t n = want < left ? want : left;
    memcpy(buffer, cu->data + cu->pos, n);
    cu->pos += n;
    return n;
}

static int cursor_seek(void *arg, curl_off_t offset, int origin)
{
    cursor *cu = arg;
    curl_off_t base = origin == SEEK_SET   ? 0
                      : origin == SEEK_CUR ? (curl_off_t)cu->pos
                                           : (curl_off_t)cu->size;
    curl_off_t p = base + offset;
    if (p < 0 || (uint64_t)p > cu->size) return CURL_SEEKFUNC_FAIL;
    cu->pos = (size_t)p;
    return CURL_SEEKFUNC_OK;
}

static const char *upload_name(const sylva_file *f)
{
    if (f->name) return f->name;
    const char *s = strrchr(f->path, '/');
    return s ? s + 1 : f->path;
}

static sylva_status add_part(sylva_client *c, curl_mime *mime, const char *field,
                             const sylva_file *f)
{
    curl_mimepart *part = curl_mime_addpart(mime);
    if (!part || curl_mime_name(part, field) != CURLE_OK)
        return fail(c, SYLVA_ERR_NOMEM, "cannot build the upload");
    CURLcode rc;
    if (f->data) {
        cursor *cu = malloc(sizeof *cu);
        if (!cu) return fail(c, SYLVA_ERR_NOMEM, "cannot build the upload");
        *cu = (cursor){f->data, f->size, 0};
        rc = curl_mime_data_cb(part, (curl_off_t)f->size, cursor_read, cursor_seek, free, cu);
    } else {
        rc = curl_mime_filedata(part, f->path);
        if (rc == CURLE_READ_ERROR) return fail(c, SYLVA_ERR_IO, "cannot read %s", f->path);
    }
    if (rc != CURLE_OK || curl_mime_filename(part, upload_name(f)) != CURLE_OK ||
        curl_mime_type(part, "application/octet-stream") != CURLE_OK)
        return fail(c, SYLVA_ERR_NOMEM, "cannot build the upload part %s", upload_name(f));
    return SYLVA_OK;
}

static sylva_status build_mime(sylva_client *c, const sylva_input *in, curl_mime **out)
{
    curl_mime *mime = curl_mime_init(c->curl);
    if (!mime) return fail(c, SYLVA_ERR_NOMEM, "cannot build the upload");
    sylva_status st = SYLVA_OK;
    curl_mimepart *spec = curl_mime_addpart(mime);
    bool empty = !in->spec || in->spec_len == 0;
    const char *sp = empty ? "{}" : in->spec;
    size_t sl = empty ? 2 : in->spec_len;
    if (!spec || curl_mime_name(spec, "spec") != CURLE_OK ||
        curl_mime_data(spec, sp, sl) != CURLE_OK ||
        curl_mime_type(spec, "application/json") != CURLE_OK) {
        st = fail(c, SYLVA_ERR_NOMEM, "cannot build the upload");
        goto out;
    }
    st = add_part(c, mime, "mesh", &in->mesh);
    for (size_t i = 0; st == SYLVA_OK && i < in->file_count; i++)
        st = add_part(c, mime, "file", &in->files[i]);
out:
    if (st != SYLVA_OK) {
        curl_mime_free(mime);
        mime = NULL;
    }
    *out = mime;
    return st;
}

/* ---- one request with retries and failover ---------------------------------- */

typedef struct request {
    const char *method;        /* GET, PUT, DELETE */
    char path[512];            /* "/v1/..." (query included) */
    const sylva_input *upload; /* PUT body, or NULL */
    long extra_timeout_ms;     /* added to the request timeout (long-poll) */
    sink *out;
} request;

/* Reads {"error":{"code","message"}} from a body into the handle's detail. */
static void take_server_error(sylva_client *c, const char *body, const char *what)
{
    const char *code = "", *msg = "";
    cJSON *doc = body ? cJSON_Parse(body) : NULL;
    const cJSON *e = cJSON_GetObjectItemCaseSensitive(doc, "error");
    const cJSON *jc = cJSON_GetObjectItemCaseSensitive(e, "code");
    const cJSON *jm = cJSON_GetObjectItemCaseSensitive(e, "message");
    if (cJSON_IsString(jc)) code = jc->valuestring;
    if (cJSON_IsString(jm)) msg = jm->valuestring;
    snprintf(c->error_code, sizeof c->error_code, "%s", code);
    if (msg[0]) {
        int n = snprintf(c->error, sizeof c->error, "%s: HTTP %ld %s%s%s", what, c->http_status,
                         code, code[0] ? ": " : "", msg);
        /* a key prefix that names several bakes: the keys it could mean */
        const cJSON *k;
        size_t used = n > 0 ? (size_t)n : 0, i = 0;
        cJSON_ArrayForEach(k, cJSON_GetObjectItemCaseSensitive(e, "candidates"))
        {
            if (!cJSON_IsString(k) || used >= sizeof c->error) break;
            n = snprintf(c->error + used, sizeof c->error - used, "%s%.64s", i++ ? ", " : " (",
                         k->valuestring);
            used += n > 0 ? (size_t)n : 0;
        }
        if (i && used < sizeof c->error) snprintf(c->error + used, sizeof c->error - used, ")");
    } else
        snprintf(c->error, sizeof c->error, "%s: HTTP %ld from %s", what, c->http_status,
                 c->urls[c->current]);
    cJSON_Delete(doc);
}

/* The detail when no server ever answered and each refused the connection. */
static void refused_error(sylva_client *c)
{
    size_t used = (size_t)snprintf(c->error, sizeof c->error, "no sylva daemon answers at ");
    for (size_t i = 0; i < c->url_count && used < sizeof c->error; i++)
        used += (size_t)snprintf(c->error + used, sizeof c->error - used, "%s%s", i ? ", " : "",
                                 c->urls[i]);
    if (used < sizeof c->error)
        snprintf(c->error + used, sizeof c->error - used,
                 " (connection refused): is sylvad running?");
}

static sylva_status status_for_http(long code)
{
    if (code == 401 || code == 403) return SYLVA_ERR_AUTH;
    if (code == 404) return SYLVA_ERR_NOT_FOUND;
    if (code == 429 || code == 503) return SYLVA_ERR_BUSY;
    if (code >= 500) return SYLVA_ERR_SERVER;
    if (code >= 400) return SYLVA_ERR_REJECTED;
    return SYLVA_ERR_PROTOCOL;
}

/* Runs r against the servers in order, retrying per sylva_retry_delay. Returns
 * SYLVA_OK for a 2xx or 304 answer (c->http_status holds it); otherwise the
 * status for the last failure with the detail set. */
static sylva_status request_run(sylva_client *c, request *r, const char *what)
{
    sylva_status st = SYLVA_OK;
    curl_mime *mime = NULL;
    struct curl_slist *headers = NULL;
    char auth[1024];
    if (c->token) {
        if (snprintf(auth, sizeof auth, "Authorization: Bearer %s", c->token) >= (int)sizeof auth)
            return fail(c, SYLVA_ERR_ARG, "the token is too long");
        headers = curl_slist_append(headers, auth);
        if (!headers) return fail(c, SYLVA_ERR_NOMEM, "out of memory");
    }
    double t_start = sylva_now_s();
    bool only_refused = true; /* every attempt of this request: connection refused */
    for (int attempt = 1;; attempt++) {
        char url[2048];
        if (snprintf(url, sizeof url, "%s%s", c->urls[c->current], r->path) >= (int)sizeof url) {
            st = fail(c, SYLVA_ERR_ARG, "URL too long");
            break;
        }
        if (!sink_reset(r->out)) {
            st = fail(c, SYLVA_ERR_IO, "cannot rewind the download file: %s", strerror(errno));
            break;
        }
        curl_easy_reset(c->curl);
        CURL *h = c->curl;
        curl_mime_free(mime);
        mime = NULL;
        if (r->upload) {
            st = build_mime(c, r->upload, &mime);
            if (st != SYLVA_OK) break;
            curl_easy_setopt(h, CURLOPT_MIMEPOST, mime);
        }
        if (strcmp(r->method, "GET") != 0) curl_easy_setopt(h, CURLOPT_CUSTOMREQUEST, r->method);
        char errbuf[CURL_ERROR_SIZE] = "";
        curl_easy_setopt(h, CURLOPT_URL, url);
        curl_easy_setopt(h, CURLOPT_NOSIGNAL, 1L);
        curl_easy_setopt(h, CURLOPT_ERRORBUFFER, errbuf);
        curl_easy_setopt(h, CURLOPT_USERAGENT, c->user_agent);
        curl_easy_setopt(h, CURLOPT_CONNECTTIMEOUT_MS, c->connect_timeout_ms);
        curl_easy_setopt(h, CURLOPT_TIMEOUT_MS, c->request_timeout_ms + r->extra_timeout_ms);
        curl_easy_setopt(h, CURLOPT_WRITEFUNCTION, sink_write);
        curl_easy_setopt(h, CURLOPT_WRITEDATA, r->out);
        curl_easy_setopt(h, CURLOPT_PROTOCOLS_STR, "http,https");
        if (headers) curl_easy_setopt(h, CURLOPT_HTTPHEADER, headers);
        CURLcode rc = curl_easy_perform(h);
        long code = 0;
        curl_off_t retry_after = -1;
        bool transport = false;
        if (rc == CURLE_OK) {
            curl_easy_getinfo(h, CURLINFO_RESPONSE_CODE, &code);
            c->http_status = code;
            c->answered = true;
            only_refused = false;
            if ((code >= 200 && code < 300) || code == 304) {
                st = SYLVA_OK;
                break;
            }
            if (curl_easy_getinfo(h, CURLINFO_RETRY_AFTER, &retry_after) != CURLE_OK ||
                retry_after <= 0)
                retry_after = -1;
            take_server_error(c, r->out->file ? NULL : r->out->buf, what);
            st = status_for_http(code);
        } else if (r->out->overflow) {
            st = fail(c, SYLVA_ERR_PROTOCOL, "%s: the answer from %s is too large", what,
                      c->urls[c->current]);
            break;
        } else if (r->out->write_failed) {
            st = fail(c, SYLVA_ERR_IO, "%s: cannot write the download: %s", what, strerror(errno));
            break;
        } else if (rc == CURLE_READ_ERROR && r->upload) {
            st = fail(c, SYLVA_ERR_IO, "%s: cannot read an upload file: %s", what,
                      errbuf[0] ? errbuf : curl_easy_strerror(rc));
            break;
        } else {
            transport = true;
            if (rc != CURLE_COULDNT_CONNECT) only_refused = false;
            c->http_status = 0;
            st = rc == CURLE_OPERATION_TIMEDOUT ? SYLVA_ERR_TIMEOUT : SYLVA_ERR_CONNECT;
            fail(c, st, "%s: %s: %s", what, c->urls[c->current],
                 errbuf[0] ? errbuf : curl_easy_strerror(rc));
        }
        long ra_ms = retry_after > 0 && retry_after < 86400 ? (long)retry_after * 1000 : -1;
        long delay = sylva_retry_delay(&c->policy, attempt, c->url_count, transport, code, ra_ms);
        bool probing = !c->answered && only_refused;
        if (probing && delay >= 0 &&
            (sylva_now_s() - t_start) * 1000.0 + (double)delay > REFUSED_WINDOW_MS)
            delay = -1; /* nothing listens: say so now, not after every retry */
        if (delay < 0) {
            if (probing) refused_error(c);
            break;
        }
        c->current = (c->current + 1) % c->url_count;
        if (c->on_retry && delay > 0 && !probing)
            c->on_retry(c->on_retry_user, c->error, delay, attempt, c->max_attempts);
        sylva_sleep_ms(delay);
    }
    curl_mime_free(mime);
    curl_slist_free_all(headers);
    if (st == SYLVA_OK) clear_error(c);
    return st;
}

/* ---- jobs ------------------------------------------------------------------------ */

static const char *const state_names[] = {"unknown", "queued", "running",
                                          "done",    "failed", "cancelled"};

const char *sylva_state_name(sylva_state s)
{
    if ((unsigned)s >= sizeof state_names / sizeof state_names[0]) return "unknown";
    return state_names[s];
}

void sylva_job_clear(sylva_job *job)
{
    if (!job) return;
    free(job->json);
    memset(job, 0, sizeof *job);
}

sylva_status sylva_job_parse(const char *body, size_t len, sylva_job *job)
{
    if (!body || !job) return SYLVA_ERR_ARG;
    sylva_job_clear(job);
    cJSON *doc = cJSON_ParseWithLength(body, len);
    sylva_status st = SYLVA_ERR_PROTOCOL;
    const cJSON *key = cJSON_GetObjectItemCaseSensitive(doc, "key");
    const cJSON *state = cJSON_GetObjectItemCaseSensitive(doc, "state");
    if (!cJSON_IsObject(doc) || !cJSON_IsString(key) || !key_valid(key->valuestring) ||
        !cJSON_IsString(state))
        goto out;
    snprintf(job->key, sizeof job->key, "%s", key->valuestring);
    for (size_t i = 1; i < sizeof state_names / sizeof state_names[0]; i++)
        if (strcmp(state->valuestring, state_names[i]) == 0) job->state = (sylva_state)i;
    if (job->state == SYLVA_STATE_UNKNOWN) goto out;
    const cJSON *stage = cJSON_GetObjectItemCaseSensitive(doc, "stage");
    if (cJSON_IsString(stage)) snprintf(job->stage, sizeof job->stage, "%s", stage->valuestring);
    const cJSON *progress = cJSON_GetObjectItemCaseSensitive(doc, "progress");
    if (cJSON_IsNumber(progress))
        job->progress = progress->valuedouble < 0   ? 0
                        : progress->valuedouble > 1 ? 1
                                                    : progress->valuedouble;
    if (job->state == SYLVA_STATE_DONE) job->progress = 1;
    const cJSON *tk = cJSON_GetObjectItemCaseSensitive(doc, "try");
    const cJSON *tn = cJSON_GetObjectItemCaseSensitive(doc, "tries");
    if (cJSON_IsNumber(tk) && cJSON_IsNumber(tn) && tk->valueint >= 1 &&
        tk->valueint <= tn->valueint && tn->valueint <= 1000) {
        job->search_try = tk->valueint;
        job->search_tries = tn->valueint;
    }
    const cJSON *err = cJSON_GetObjectItemCaseSensitive(doc, "error");
    const cJSON *ec = cJSON_GetObjectItemCaseSensitive(err, "code");
    const cJSON *em = cJSON_GetObjectItemCaseSensitive(err, "message");
    if (cJSON_IsString(ec))
        snprintf(job->error_code, sizeof job->error_code, "%s", ec->valuestring);
    if (cJSON_IsString(em))
        snprintf(job->error_message, sizeof job->error_message, "%s", em->valuestring);
    const cJSON *target = cJSON_GetObjectItemCaseSensitive(doc, "target");
    if (job->state == SYLVA_STATE_DONE &&
        cJSON_IsFalse(cJSON_GetObjectItemCaseSensitive(target, "met"))) {
        const cJSON *why = cJSON_GetObjectItemCaseSensitive(target, "reason");
        job->target_unmet = true;
        snprintf(job->target_reason, sizeof job->target_reason, "%s",
                 cJSON_IsString(why) ? why->valuestring : "the spec's target was not met");
    }
    job->json = malloc(len + 1);
    if (!job->json) {
        st = SYLVA_ERR_NOMEM;
        goto out;
    }
    memcpy(job->json, body, len);
    job->json[len] = '\0';
    st = SYLVA_OK;
out:
    if (st != SYLVA_OK) sylva_job_clear(job);
    cJSON_Delete(doc);
    return st;
}

static sylva_status parse_job_answer(sylva_client *c, const sink *s, sylva_job *job,
                                     const char *what)
{
    sylva_job tmp = {0};
    sylva_status st = sylva_job_parse(s->buf ? s->buf : "", s->len, &tmp);
    if (st == SYLVA_ERR_PROTOCOL)
        return fail(c, st, "%s: the answer of %s (HTTP %ld) is not a job", what,
                    c->urls[c->current], c->http_status);
    if (st != SYLVA_OK) return fail(c, st, "%s: out of memory", what);
    if (job) {
        sylva_job_clear(job);
        *job = tmp;
    } else {
        sylva_job_clear(&tmp);
    }
    return SYLVA_OK;
}

sylva_status sylva_submit(sylva_client *c, const sylva_input *in, sylva_job *job)
{
    if (!c) return SYLVA_ERR_ARG;
    clear_error(c);
    if (!in) return fail(c, SYLVA_ERR_ARG, "sylva_submit: no input");
    char key[SYLVA_KEY_HEX + 1];
    sylva_status st = sylva_key_compute(in, key, c->error, sizeof c->error);
    if (st != SYLVA_OK) return st;
    sink s = {.limit = MAX_JSON_BYTES};
    request r = {.method = "PUT", .upload = in, .out = &s};
    snprintf(r.path, sizeof r.path, "/v1/bakes/%s", key);
    st = request_run(c, &r, "upload");
    if (st == SYLVA_OK) {
        if (c->http_status != 200 && c->http_status != 202)
            st = fail(c, SYLVA_ERR_PROTOCOL, "upload: unexpected HTTP %ld", c->http_status);
        else st = parse_job_answer(c, &s, job, "upload");
        if (st == SYLVA_OK && job && strcmp(job->key, key) != 0)
            st = fail(c, SYLVA_ERR_PROTOCOL, "upload: the server answered for key %s, not %s",
                      job->key, key);
    }
    free(s.buf);
    return st;
}

sylva_status sylva_status_get(sylva_client *c, const char *key, double wait_s, sylva_job *job)
{
    if (!c) return SYLVA_ERR_ARG;
    clear_error(c);
    if (!key_name_ok(key))
        return fail(c, SYLVA_ERR_ARG,
                    "\"%.80s\" is not a key (64 lowercase hex digits, or a prefix of at least "
                    "8)",
                    key ? key : "");
    sink s = {.limit = MAX_JSON_BYTES};
    request r = {.method = "GET", .out = &s};
    if (wait_s > 0) {
        long ws = wait_s > 600 ? 600 : (long)(wait_s + 0.999);
        snprintf(r.path, sizeof r.path, "/v1/bakes/%s?wait=%ld", key, ws);
        r.extra_timeout_ms = ws * 1000;
    } else {
        snprintf(r.path, sizeof r.path, "/v1/bakes/%s", key);
    }
    sylva_status st = request_run(c, &r, "status");
    if (st == SYLVA_OK) st = parse_job_answer(c, &s, job, "status");
    free(s.buf);
    return st;
}

sylva_status sylva_cancel_state(sylva_client *c, const char *key, char *state, size_t state_len)
{
    if (state && state_len) state[0] = '\0';
    if (!c) return SYLVA_ERR_ARG;
    clear_error(c);
    if (!key_name_ok(key))
        return fail(c, SYLVA_ERR_ARG,
                    "\"%.80s\" is not a key (64 lowercase hex digits, or a prefix of at least "
                    "8)",
                    key ? key : "");
    sink s = {.limit = MAX_JSON_BYTES};
    request r = {.method = "DELETE", .out = &s};
    snprintf(r.path, sizeof r.path, "/v1/bakes/%s", key);
    sylva_status st = request_run(c, &r, "cancel");
    if (st == SYLVA_OK && state && state_len) {
        cJSON *doc = s.buf ? cJSON_ParseWithLength(s.buf, s.len) : NULL;
        const cJSON *js = cJSON_GetObjectItemCaseSensitive(doc, "state");
        const char *v = cJSON_IsTrue(cJSON_GetObjectItemCaseSensitive(doc, "cancel_requested"))
                            ? "cancel_requested"
                        : cJSON_IsString(js) ? js->valuestring
                                             : "";
        snprintf(state, state_len, "%s", v);
        cJSON_Delete(doc);
    }
    free(s.buf);
    return st;
}

sylva_status sylva_cancel(sylva_client *c, const char *key)
{
    return sylva_cancel_state(c, key, NULL, 0);
}

sylva_status sylva_health(sylva_client *c, char **body)
{
    if (!c) return SYLVA_ERR_ARG;
    clear_error(c);
    if (body) *body = NULL;
    sink s = {.limit = MAX_JSON_BYTES};
    request r = {.method = "GET", .out = &s};
    snprintf(r.path, sizeof r.path, "/v1/health");
    sylva_status st = request_run(c, &r, "health");
    if (st == SYLVA_OK && body) {
        *body = s.buf ? s.buf : dup_str("");
        s.buf = NULL;
        if (!*body) st = fail(c, SYLVA_ERR_NOMEM, "out of memory");
    }
    free(s.buf);
    return st;
}

sylva_status sylva_wait(sylva_client *c, const char *key, const sylva_input *in, double timeout_s,
                        sylva_progress_fn progress, void *user_data, sylva_job *job)
{
    if (!c) return SYLVA_ERR_ARG;
    clear_error(c);
    if (!key_name_ok(key))
        return fail(c, SYLVA_ERR_ARG,
                    "\"%.80s\" is not a key (64 lowercase hex digits, or a prefix of at least "
                    "8)",
                    key ? key : "");
    sylva_job local = {0};
    sylva_job *j = job ? job : &local;
    double start = sylva_now_s();
    char last_stage[32] = "";
    double last_progress = -1;
    int resubmits = 0;
    sylva_status st;
    for (;;) {
        double left = timeout_s > 0 ? timeout_s - (sylva_now_s() - start) : 1e9;
        if (left <= 0) {
            st = fail(c, SYLVA_ERR_TIMEOUT, "bake %.12s did not finish within %.0f s", key,
                      timeout_s);
            break;
        }
        /* Short long-polls while someone shows progress, longer ones otherwise. */
        double w = progress ? 1.0 : 10.0;
        if (w > left) w = left;
        double t0 = sylva_now_s();
        st = sylva_status_get(c, key, w, j);
        if (st == SYLVA_ERR_NOT_FOUND && in && resubmits < 3) {
            /* The server lost the job (another node after failover, or its store
             * was wiped): the key names the same bake, so submit it again. */
            resubmits++;
            st = sylva_submit(c, in, j);
            if (st != SYLVA_OK) break;
            continue;
        }
        if (st != SYLVA_OK) break;
        const char *stage = j->state == SYLVA_STATE_QUEUED ? "queued"
                            : j->stage[0]                  ? j->stage
                                                           : sylva_state_name(j->state);
        bool changed = strcmp(stage, last_stage) != 0 || j->progress != last_progress;
        if (changed) {
            snprintf(last_stage, sizeof last_stage, "%s", stage);
            last_progress = j->progress;
            if (progress && !progress(stage, j->progress, user_data)) {
                sylva_status cst = sylva_cancel(c, key);
                if (cst != SYLVA_OK && cst != SYLVA_ERR_NOT_FOUND) {
                    st = cst;
                    break;
                }
                st = fail(c, SYLVA_ERR_CANCELLED, "bake %.12s cancelled by the caller", key);
                break;
            }
        }
        if (j->state == SYLVA_STATE_DONE) {
            st = SYLVA_OK;
            break;
        }
        if (j->state == SYLVA_STATE_FAILED) {
            snprintf(c->error_code, sizeof c->error_code, "%s", j->error_code);
            st = fail(c, SYLVA_ERR_BAKE_FAILED, "bake failed: %s%s%s",
                      j->error_code[0] ? j->error_code : "error", j->error_message[0] ? ": " : "",
                      j->error_message);
            break;
        }
        if (j->state == SYLVA_STATE_CANCELLED) {
            st = fail(c, SYLVA_ERR_CANCELLED, "bake %.12s was cancelled on the server", key);
            break;
        }
        /* A server that answers a long-poll at once with nothing new must not be
         * hammered. */
        if (!changed && sylva_now_s() - t0 < 0.2) sylva_sleep_ms(250);
    }
    sylva_job_clear(&local);
    return st;
}

/* ---- artifacts ----------------------------------------------------------------- */

static bool hex64(const char *s)
{
    return key_valid(s);
}

sylva_status sylva_job_artifacts(const sylva_job *job, sylva_artifact **out, size_t *count)
{
    if (!job || !out || !count) return SYLVA_ERR_ARG;
    *out = NULL;
    *count = 0;
    cJSON *doc = job->json ? cJSON_Parse(job->json) : NULL;
    const cJSON *man = cJSON_GetObjectItemCaseSensitive(doc, "manifest");
    const cJSON *arts = cJSON_GetObjectItemCaseSensitive(man, "artifacts");
    sylva_status st = SYLVA_ERR_PROTOCOL;
    sylva_artifact *list = NULL;
    if (!cJSON_IsArray(arts)) goto out;
    size_t n = (size_t)cJSON_GetArraySize(arts);
    list = calloc(n ? n : 1, sizeof *list);
    if (!list) {
        st = SYLVA_ERR_NOMEM;
        goto out;
    }
    size_t i = 0;
    const cJSON *a;
    cJSON_ArrayForEach(a, arts)
    {
        const cJSON *name = cJSON_GetObjectItemCaseSensitive(a, "name");
        const cJSON *size = cJSON_GetObjectItemCaseSensitive(a, "size");
        const cJSON *sha = cJSON_GetObjectItemCaseSensitive(a, "sha256");
        if (!cJSON_IsString(name) || !sylva_name_valid(name->valuestring) ||
            !cJSON_IsNumber(size) || size->valuedouble < 0 || size->valuedouble > 9.0e15 ||
            !cJSON_IsString(sha) || !hex64(sha->valuestring))
            goto out;
        snprintf(list[i].name, sizeof list[i].name, "%s", name->valuestring);
        list[i].size = (uint64_t)size->valuedouble;
        snprintf(list[i].sha256, sizeof list[i].sha256, "%s", sha->valuestring);
        i++;
    }
    *out = list;
    *count = n;
    list = NULL;
    st = SYLVA_OK;
out:
    free(list);
    cJSON_Delete(doc);
    return st;
}

/* Makes sure `job` is a done job for key: uses the caller's, else fetches it. */
static sylva_status done_job(sylva_client *c, const char *key, const sylva_job *job, sylva_job *tmp,
                             const sylva_job **use)
{
    *use = job;
    if (!job || !job->json || strncmp(job->key, key, strlen(key)) != 0) {
        sylva_status st = sylva_status_get(c, key, 0, tmp);
        if (st != SYLVA_OK) return st;
        *use = tmp;
    }
    if ((*use)->state == SYLVA_STATE_FAILED)
        return fail(c, SYLVA_ERR_BAKE_FAILED, "bake %.12s failed: %s%s%s", key, (*use)->error_code,
                    (*use)->error_message[0] ? ": " : "", (*use)->error_message);
    if ((*use)->state != SYLVA_STATE_DONE)
        return fail(c, SYLVA_ERR_NOT_FOUND, "bake %.12s has no artifacts yet (state %s)", key,
                    sylva_state_name((*use)->state));
    return SYLVA_OK;
}

static sylva_status mkdir_p(sylva_client *c, const char *dir)
{
    char path[4096];
    if (snprintf(path, sizeof path, "%s", dir) >= (int)sizeof path)
        return fail(c, SYLVA_ERR_ARG, "directory name too long");
    for (char *p = path + 1;; p++) {
        if (*p == '/' || *p == '\0') {
            char saved = *p;
            *p = '\0';
            if (mkdir(path, 0777) != 0 && errno != EEXIST)
                return fail(c, SYLVA_ERR_IO, "cannot create %s: %s", path, strerror(errno));
            *p = saved;
            if (saved == '\0') break;
        }
    }
    struct stat sb;
    if (stat(dir, &sb) != 0 || !S_ISDIR(sb.st_mode))
        return fail(c, SYLVA_ERR_IO, "%s is not a directory", dir);
    return SYLVA_OK;
}

static sylva_status fetch_one_to_file(sylva_client *c, const char *key, const sylva_artifact *a,
                                      const char *dir)
{
    char final[4400], tmpl[4400];
    snprintf(final, sizeof final, "%s/%s", dir, a->name);
    snprintf(tmpl, sizeof tmpl, "%s/.%s.partXXXXXX", dir, a->name);
    int fd = mkstemp(tmpl);
    if (fd < 0)
        return fail(c, SYLVA_ERR_IO, "cannot create a file in %s: %s", dir, strerror(errno));
    /* mkstemp makes 0600; artifacts are ordinary output files. */
    (void)fchmod(fd, 0644);
    sylva_status st = SYLVA_OK;
    FILE *f = fdopen(fd, "w+b");
    EVP_MD_CTX *md = EVP_MD_CTX_new();
    if (!f || !md) {
        if (!f) close(fd);
        st = fail(c, SYLVA_ERR_NOMEM, "out of memory");
        goto out;
    }
    sink s = {.file = f, .md = md};
    request r = {.method = "GET", .out = &s};
    char *esc = curl_easy_escape(c->curl, a->name, 0);
    if (!esc) {
        st = fail(c, SYLVA_ERR_NOMEM, "out of memory");
        goto out;
    }
    snprintf(r.path, sizeof r.path, "/v1/bakes/%s/artifacts/%s", key, esc);
    curl_free(esc);
    char what[300];
    snprintf(what, sizeof what, "download %s", a->name);
    st = request_run(c, &r, what);
    if (st != SYLVA_OK) goto out;
    unsigned char dg[EVP_MAX_MD_SIZE];
    unsigned int dl = 0;
    char hex[SYLVA_KEY_HEX + 1];
    if (EVP_DigestFinal_ex(md, dg, &dl) != 1 || dl != 32) {
        st = fail(c, SYLVA_ERR_NOMEM, "SHA-256 failed");
        goto out;
    }
    sylva_hex32(dg, hex);
    if (strcmp(hex, a->sha256) != 0 || s.len != a->size) {
        st = fail(c, SYLVA_ERR_INTEGRITY,
                  "%s: downloaded %zu bytes with SHA-256 %.16s..., the manifest says %llu "
                  "bytes with %.16s...; refused",
                  a->name, s.len, hex, (unsigned long long)a->size, a->sha256);
        goto out;
    }
    if (fflush(f) != 0 || fsync(fileno(f)) != 0) {
        st = fail(c, SYLVA_ERR_IO, "cannot write %s: %s", final, strerror(errno));
        goto out;
    }
out:
    if (f && fclose(f) != 0 && st == SYLVA_OK)
        st = fail(c, SYLVA_ERR_IO, "cannot write %s: %s", final, strerror(errno));
    EVP_MD_CTX_free(md);
    if (st == SYLVA_OK && rename(tmpl, final) != 0)
        st = fail(c, SYLVA_ERR_IO, "cannot rename to %s: %s", final, strerror(errno));
    if (st != SYLVA_OK) unlink(tmpl);
    return st;
}

/* Removes from dir the files an earlier bake wrote (sylva's output names,
 * out_names.h) that are not among this bake's n artifacts. */
static sylva_status remove_stale_outputs(sylva_client *c, const char *dir,
                                         const sylva_artifact *arts, size_t n)
{
    DIR *d = opendir(dir);
    if (!d) return fail(c, SYLVA_ERR_IO, "cannot list %s: %s", dir, strerror(errno));
    sylva_status st = SYLVA_OK;
    for (struct dirent *e; st == SYLVA_OK && (e = readdir(d));) {
        if (!sylva_is_output_name(e->d_name)) continue;
        bool ours = false;
        for (size_t i = 0; i < n && !ours; i++) ours = strcmp(arts[i].name, e->d_name) == 0;
        if (!ours && unlinkat(dirfd(d), e->d_name, 0) != 0 && errno != ENOENT)
            st = fail(c, SYLVA_ERR_IO, "cannot remove the stale %s/%s: %s", dir, e->d_name,
                      strerror(errno));
    }
    closedir(d);
    return st;
}

sylva_status sylva_fetch_dir(sylva_client *c, const char *key, const sylva_job *job,
                             const char *dir)
{
    if (!c) return SYLVA_ERR_ARG;
    clear_error(c);
    if (!key_name_ok(key))
        return fail(c, SYLVA_ERR_ARG,
                    "\"%.80s\" is not a key (64 lowercase hex digits, or a prefix of at least "
                    "8)",
                    key ? key : "");
    if (!dir || !dir[0]) return fail(c, SYLVA_ERR_ARG, "no output directory");
    sylva_job tmp = {0};
    const sylva_job *use = NULL;
    sylva_artifact *arts = NULL;
    size_t n = 0;
    sylva_status st = done_job(c, key, job, &tmp, &use);
    if (st != SYLVA_OK) goto out;
    st = sylva_job_artifacts(use, &arts, &n);
    if (st != SYLVA_OK) {
        fail(c, st, "bake %.12s: the manifest has no valid artifact list", key);
        goto out;
    }
    st = mkdir_p(c, dir);
    for (size_t i = 0; st == SYLVA_OK && i < n; i++)
        st = fetch_one_to_file(c, use->key, &arts[i], dir);
    if (st == SYLVA_OK) st = remove_stale_outputs(c, dir, arts, n);
out:
    free(arts);
    sylva_job_clear(&tmp);
    return st;
}

sylva_status sylva_fetch_mem(sylva_client *c, const char *key, const sylva_job *job,
                             const char *name, void **data, size_t *size)
{
    if (!c) return SYLVA_ERR_ARG;
    clear_error(c);
    if (!data || !size || !name) return fail(c, SYLVA_ERR_ARG, "sylva_fetch_mem: NULL argument");
    *data = NULL;
    *size = 0;
    if (!key_name_ok(key))
        return fail(c, SYLVA_ERR_ARG,
                    "\"%.80s\" is not a key (64 lowercase hex digits, or a prefix of at least "
                    "8)",
                    key ? key : "");
    sylva_job tmp = {0};
    const sylva_job *use = NULL;
    sylva_artifact *arts = NULL;
    size_t n = 0;
    sink s = {.limit = MAX_MEM_ARTIFACT};
    sylva_status st = done_job(c, key, job, &tmp, &use);
    if (st != SYLVA_OK) goto out;
    st = sylva_job_artifacts(use, &arts, &n);
    if (st != SYLVA_OK) {
        fail(c, st, "bake %.12s: the manifest has no valid artifact list", key);
        goto out;
    }
    const sylva_artifact *a = NULL;
    for (size_t i = 0; i < n; i++)
        if (strcmp(arts[i].name, name) == 0) a = &arts[i];
    if (!a) {
        st = fail(c, SYLVA_ERR_NOT_FOUND, "bake %.12s has no artifact \"%.100s\"", key, name);
        goto out;
    }
    request r = {.method = "GET", .out = &s};
    char *esc = curl_easy_escape(c->curl, name, 0);
    if (!esc) {
        st = fail(c, SYLVA_ERR_NOMEM, "out of memory");
        goto out;
    }
    snprintf(r.path, sizeof r.path, "/v1/bakes/%s/artifacts/%s", use->key, esc);
    curl_free(esc);
    st = request_run(c, &r, "download");
    if (st != SYLVA_OK) goto out;
    char hex[SYLVA_KEY_HEX + 1];
    st = sylva_sha256_hex(s.buf, s.len, hex);
    if (st != SYLVA_OK) goto out;
    if (strcmp(hex, a->sha256) != 0 || s.len != a->size) {
        st = fail(c, SYLVA_ERR_INTEGRITY,
                  "%s: downloaded bytes do not match the manifest's "
                  "SHA-256 %.16s...; refused",
                  name, a->sha256);
        goto out;
    }
    if (!s.buf) {
        s.buf = malloc(1);
        if (!s.buf) {
            st = fail(c, SYLVA_ERR_NOMEM, "out of memory");
            goto out;
        }
        s.buf[0] = '\0';
    }
    *data = s.buf;
    *size = s.len;
    s.buf = NULL;
out:
    free(s.buf);
    free(arts);
    sylva_job_clear(&tmp);
    return st;
}
