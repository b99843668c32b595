/* http.c — request handling on libmicrohttpd (see http.h, docs/api.md). */
#include "http.h"

#include <arpa/inet.h>
#include <cjson/cJSON.h>
#include <errno.h>
#include <fcntl.h>
#include <microhttpd.h>
#include <netdb.h>
#include <netinet/in.h>
#include <openssl/evp.h>
#include <poll.h>
#ifndef POLLRDHUP
#define POLLRDHUP 0x2000 /* Linux: the peer shut its side (poll.h with _GNU_SOURCE) */
#endif
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <unistd.h>

#include "error_body.h"
#include "import.h"
#include "method.h"
#include "multipart.h"
#include "openapi.h"
#include "spec.h"

#define SPEC_MAX (1u << 20)
/* Body bytes read and dropped on a route that takes no body (or a request
 * refused from its headers) so the connection stays usable; a larger or
 * chunked body is answered before it is read and the connection closed. */
#define SMALL_BODY 4096u

struct svd_http {
    struct MHD_Daemon *d;
    const svd_config *cfg;
    svd_jobs *jobs;
    svd_metrics *metrics;
    svd_log *log;
    const svd_tokens *tokens;
    atomic_bool draining;
    uint16_t port;
    /* Uploads whose body is still coming, watched by watch_uploads (see
     * there): under wmu; the thread stops when stopping is set. */
    pthread_mutex_t wmu;
    pthread_cond_t wcv;
    struct upload *watched;
    bool stopping, watcher_started;
    pthread_t watcher;
};

/* REQ_DRAIN: a PUT of a key already held whose body is not a form, read and
 * dropped before * the answer so the connection stays open (see upload_begin). */
enum req_kind { REQ_PLAIN, REQ_UPLOAD, REQ_WAIT, REQ_DRAIN };

typedef struct upload {
    svd_multipart *mp;
    char tmpdir[SVD_STORE_PATH];
    int fd; /* current file part, -1 if none */
    EVP_MD_CTX *md;
    int part; /* 0 none, 1 spec, 2 mesh, 3 file */
    char part_name[SVD_NAME_MAX + 1];
    uint64_t part_bytes, total;
    uint64_t file_bytes; /* of every mesh/file part so far */
    uint64_t reserved;   /* held against store_max_bytes (svd_jobs_reserve) */
    svd_jobs *jobs;
    const char *client; /* the request's client id (outlives the upload) */
    double started;     /* sv_now() at the headers: upload_timeout counts from here */
    bool known;         /* a PUT of a key held when its headers came */
    bool drop;          /* the rest of the body is read and dropped (upload_drop) */
    /* in h->watched while the body is coming (under h->wmu) */
    svd_http *h;
    int sock;
    bool in_watch, shut;
    struct upload *wnext;
    char *spec;
    size_t spec_len;
    char mesh[SVD_NAME_MAX + 1];
    char **files;
    size_t nfiles;
    cJSON *objects; /* name -> {size, sha256} */
    int err_status; /* first error: HTTP status */
    char err_code[32];
    char err_msg[600];
} upload;

typedef struct req {
    enum req_kind kind;
    svd_http *h;
    struct MHD_Connection *conn;
    svd_route_match m;
    char client[96];
    upload *up;
    uint64_t drained; /* REQ_DRAIN: body bytes read and dropped */
    /* long-poll */
    pthread_mutex_t mu;
    svd_waiter waiter;
    int suspended, woken;
    int authorized, answered;
} req;

/* ---- responses ---- */

/* What no response may be read as: a document that runs script. Every answer
 * says nosniff (a browser never guesses HTML from the bytes) and carries a
 * policy that allows nothing, so even a stored file opened as a page cannot
 * run script on the daemon's origin (the viewer's); the viewer page alone gets
 * its own policy (viewer_csp). */
#define CSP_NONE                                                                        \
    "default-src 'none'; base-uri 'none'; form-action 'none'; frame-ancestors 'none'; " \
    "sandbox"

/* Adds the headers every response carries (nosniff; csp, or CSP_NONE). */
static void harden(struct MHD_Response *r, const char *csp)
{
    MHD_add_response_header(r, "X-Content-Type-Options", "nosniff");
    MHD_add_response_header(r, "Content-Security-Policy", csp ? csp : CSP_NONE);
}

static enum MHD_Result send_text(svd_http *h, struct MHD_Connection *c, svd_route route,
                                 unsigned status, const char *body, const char *ctype)
{
    struct MHD_Response *r = MHD_create_response_from_buffer(strlen(body), (void *)body,
                                                             MHD_RESPMEM_MUST_COPY);
    if (!r) return MHD_NO;
    MHD_add_response_header(r, "Content-Type", ctype);
    harden(r, NULL);
    if (status == 401) MHD_add_response_header(r, "WWW-Authenticate", "Bearer realm=\"sylva\"");
    if (status == 429 || status == 503) MHD_add_response_header(r, "Retry-After", "5");
    enum MHD_Result ret = MHD_queue_response(c, status, r);
    MHD_destroy_response(r);
    svd_metrics_request(h->metrics, route, status);
    return ret;
}

static enum MHD_Result send_json(svd_http *h, struct MHD_Connection *c, svd_route route,
                                 unsigned status, char *body /* freed */)
{
    enum MHD_Result ret = send_text(h, c, route, status, body ? body : "{}", "application/json");
    free(body);
    return ret;
}

/* A JSON answer with one more header (Location, Content-Range). body freed. */
static enum MHD_Result send_json_with(svd_http *h, struct MHD_Connection *c, svd_route route,
                                      unsigned status, char *body, const char *header,
                                      const char *value)
{
    struct MHD_Response *r = MHD_create_response_from_buffer(
        body ? strlen(body) : 2, body ? body : (void *)"{}", MHD_RESPMEM_MUST_COPY);
    free(body);
    if (!r) return MHD_NO;
    MHD_add_response_header(r, "Content-Type", "application/json");
    harden(r, NULL);
    if (header && value && value[0]) MHD_add_response_header(r, header, value);
    enum MHD_Result ret = MHD_queue_response(c, status, r);
    MHD_destroy_response(r);
    svd_metrics_request(h->metrics, route, status);
    return ret;
}

/* The body of every error answer (docs/api.md): {"error":{"code","message"}}
 * (malloc'ed). A message quoting an upload's bytes is made valid UTF-8 first
 * (bad bytes become '?'), so the answer is always valid JSON. */
static char *error_body(const char *code, const char *message)
{
    char *m = strdup(message ? message : "");
    if (m) sylva_utf8_fix(m);
    char *s = sylva_error_body(code, m ? m : "");
    free(m);
    return s;
}

static enum MHD_Result send_error(svd_http *h, struct MHD_Connection *c, svd_route route,
                                  unsigned status, const char *code, const char *msg)
{
    return send_json(h, c, route, status, error_body(code, msg));
}

/* What the job table's answers are over HTTP: the one place they become
 * status codes and error codes (docs/design.md, "Errors"). */
static const struct {
    unsigned status;
    const char *code;
} jobs_http[] = {
    [SVD_JOBS_OK] = {MHD_HTTP_OK, NULL},
    [SVD_JOBS_ACCEPTED] = {MHD_HTTP_ACCEPTED, NULL},
    [SVD_JOBS_NOT_FOUND] = {MHD_HTTP_NOT_FOUND, "not_found"},
    [SVD_JOBS_NOT_DONE] = {MHD_HTTP_CONFLICT, "not_ready"},
    [SVD_JOBS_DRAINING] = {MHD_HTTP_SERVICE_UNAVAILABLE, "draining"},
    [SVD_JOBS_QUEUE_FULL] = {MHD_HTTP_SERVICE_UNAVAILABLE, "queue_full"},
    [SVD_JOBS_CLIENT_FULL] = {MHD_HTTP_TOO_MANY_REQUESTS, "client_queue_full"},
    [SVD_JOBS_STORE_FULL] = {MHD_HTTP_INSUFFICIENT_STORAGE, "store_full"},
    [SVD_JOBS_IO] = {MHD_HTTP_INTERNAL_SERVER_ERROR, "io"},
    [SVD_JOBS_NOMEM] = {MHD_HTTP_INTERNAL_SERVER_ERROR, "nomem"},
    [SVD_JOBS_AMBIGUOUS] = {MHD_HTTP_CONFLICT, "ambiguous_key"},
};

/* Answers a job-table call: its document (body, freed) when it succeeded,
 * else the error with the table's message. */
static enum MHD_Result send_jobs(svd_http *h, struct MHD_Connection *c, svd_route route,
                                 svd_jobs_rc rc, char *body, const sv_error *e)
{
    if (rc == SVD_JOBS_OK || rc == SVD_JOBS_ACCEPTED)
        return send_json(h, c, route, jobs_http[rc].status, body);
    free(body);
    return send_error(h, c, route, jobs_http[rc].status, jobs_http[rc].code, e->message);
}

/* ---- upload streaming ---- */

/* The import's pre-check (sv_gltf_precheck / sv_mesh_precheck) over the
 * uploaded files, mapped read-only. SV_OK, SV_ERR_NOMEM, or the check's
 * failure with err naming the file and the problem. */
static sv_status precheck_upload(const upload *u, sv_format fmt, sv_error *err)
{
    size_t n = 1 + u->nfiles;
    sv_file *files = sv_calloc(n, sizeof *files);
    size_t *lens = sv_calloc(n, sizeof *lens);
    if (!files || !lens) {
        free(files);
        free(lens);
        return SV_ERR_NOMEM;
    }
    sv_status st = SV_OK;
    for (size_t i = 0; i < n && st == SV_OK; i++) {
        const char *name = i == 0 ? u->mesh : u->files[i - 1];
        char path[SVD_STORE_PATH + 300];
        snprintf(path, sizeof path, "%s/in/%s", u->tmpdir, name);
        files[i].name = name;
        int fd = open(path, O_RDONLY | O_CLOEXEC);
        struct stat sb;
        if (fd < 0 || fstat(fd, &sb) != 0) {
            st = sv_fail(err, SV_ERR_IO, "cannot read the upload %s", name);
        } else if (sb.st_size > 0) {
            void *m = mmap(NULL, (size_t)sb.st_size, PROT_READ, MAP_PRIVATE, fd, 0);
            if (m == MAP_FAILED) st = sv_fail(err, SV_ERR_IO, "cannot map the upload %s", name);
            else {
                files[i].data = m;
                files[i].size = lens[i] = (size_t)sb.st_size;
            }
        }
        if (fd >= 0) close(fd);
    }
    if (st == SV_OK) {
        if (fmt == SV_FORMAT_GLTF || fmt == SV_FORMAT_GLB) {
            st = sv_gltf_precheck(files[0].data, files[0].size, fmt == SV_FORMAT_GLB, files, n,
                                  NULL, err);
            if (st != SV_OK) {
                char msg[sizeof err->message];
                snprintf(msg, sizeof msg, "%s", err->message);
                sv_fail(err, st, "'%s': %s", u->mesh, msg);
            }
        } else {
            st = sv_mesh_precheck(fmt, files[0].data, files[0].size, u->mesh, NULL, err);
        }
    }
    for (size_t i = 0; i < n; i++)
        if (lens[i]) munmap((void *)files[i].data, lens[i]);
    free(files);
    free(lens);
    return st == SV_ERR_IO ? SV_OK : st; /* an unreadable file is the worker's to report */
}

/* Records the upload's first error. The rest of the body is read and
 * dropped (nothing more is written), so what it holds goes at once: its
 * reservation and its files, not when the request ends. */
static void upload_fail(upload *u, int status, const char *code, const char *fmt, const char *arg)
{
    if (u->err_status) return; /* keep the first */
    u->err_status = status;
    snprintf(u->err_code, sizeof u->err_code, "%s", code);
    snprintf(u->err_msg, sizeof u->err_msg, fmt, arg ? arg : "");
    if (u->fd >= 0) close(u->fd);
    u->fd = -1;
    if (u->tmpdir[0]) svd_rm_rf(u->tmpdir);
    u->tmpdir[0] = '\0';
    if (u->reserved) svd_jobs_unreserve(u->jobs, u->client, u->reserved);
    u->reserved = 0;
}

/* A PUT of a held key that the store has no room for: what it wrote and
 * holds is given back, the rest of its body is read and dropped, and the held
 * bake is answered at its end (upload_end). */
static void upload_drop(upload *u)
{
    u->drop = true;
    if (u->fd >= 0) close(u->fd);
    u->fd = -1;
    if (u->tmpdir[0]) svd_rm_rf(u->tmpdir);
    u->tmpdir[0] = '\0';
    if (u->reserved) svd_jobs_unreserve(u->jobs, u->client, u->reserved);
    u->reserved = 0;
}

static bool name_taken(const upload *u, const char *name)
{
    if (strcmp(u->mesh, name) == 0) return true;
    for (size_t i = 0; i < u->nfiles; i++)
        if (strcmp(u->files[i], name) == 0) return true;
    return false;
}

static int on_part_begin(void *user, const svd_part_info *info)
{
    req *q = user;
    upload *u = q->up;
    const svd_config *cfg = q->h->cfg;
    if (u->drop) return 0;
    if (strcmp(info->name, "spec") == 0) {
        if (u->spec)
            return upload_fail(u, 400, "bad_request", "more than one spec part%s", NULL), 1;
        u->spec = malloc(SPEC_MAX);
        if (!u->spec) return upload_fail(u, 500, "nomem", "out of memory%s", NULL), 1;
        u->part = 1;
        return 0;
    }
    int is_mesh = strcmp(info->name, "mesh") == 0;
    if (!is_mesh && strcmp(info->name, "file") != 0)
        return upload_fail(u, 400, "bad_request",
                           "unknown form field '%s' (expected spec, mesh, file)", info->name),
               1;
    if (info->has_filename && info->filename_len > SVD_NAME_MAX) {
        char head[48];
        snprintf(head, sizeof head, "%.40s", info->filename);
        return upload_fail(u, 400, "bad_name",
                           "file name '%s...' is longer than 255 bytes (names are never truncated)",
                           head),
               1;
    }
    if (info->has_filename && !sylva_utf8_ok(info->filename, strlen(info->filename)))
        return upload_fail(u, 400, "bad_name",
                           "a file name is not valid UTF-8 (names are UTF-8 text, RFC 3629)%s",
                           NULL),
               1;
    if (!info->has_filename || !svd_name_valid(info->filename))
        return upload_fail(
                   u, 400, "bad_name",
                   "invalid file name '%s': a base name without '/', '\\\\', spaces or control "
                   "characters, not '.' or '..', at most 255 bytes",
                   info->filename),
               1;
    if (is_mesh && u->mesh[0])
        return upload_fail(u, 400, "bad_request", "more than one mesh part%s", NULL), 1;
    if (name_taken(u, info->filename))
        return upload_fail(u, 400, "bad_name", "duplicate file name '%s'", info->filename), 1;
    if (!is_mesh && u->nfiles >= cfg->max_files)
        return upload_fail(u, 413, "too_many_files", "too many companion files%s", NULL), 1;
    char path[SVD_STORE_PATH + 300];
    snprintf(path, sizeof path, "%s/in/%s", u->tmpdir, info->filename);
    u->fd = open(path, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
    if (u->fd < 0)
        return upload_fail(u, 500, "io", "cannot store the upload: %s", strerror(errno)), 1;
    if (is_mesh) {
        snprintf(u->mesh, sizeof u->mesh, "%s", info->filename);
    } else {
        char **nf = realloc(u->files, (u->nfiles + 1) * sizeof *nf);
        if (!nf) return upload_fail(u, 500, "nomem", "out of memory%s", NULL), 1;
        u->files = nf;
        u->files[u->nfiles] = strdup(info->filename);
        if (!u->files[u->nfiles]) return upload_fail(u, 500, "nomem", "out of memory%s", NULL), 1;
        u->nfiles++;
    }
    snprintf(u->part_name, sizeof u->part_name, "%s", info->filename);
    u->part = is_mesh ? 2 : 3;
    u->part_bytes = 0;
    EVP_DigestInit_ex(u->md, EVP_sha256(), NULL);
    return 0;
}

static int on_part_data(void *user, const uint8_t *data, size_t size)
{
    req *q = user;
    upload *u = q->up;
    if (u->drop) return 0;
    if (u->part == 1) {
        if (u->spec_len + size > SPEC_MAX)
            return upload_fail(u, 413, "too_large", "spec part over 1 MiB%s", NULL), 1;
        memcpy(u->spec + u->spec_len, data, size);
        u->spec_len += size;
        return 0;
    }
    u->part_bytes += size;
    if (u->part_bytes > q->h->cfg->max_mesh_bytes)
        return upload_fail(u, 413, "too_large", "file '%s' is over max_mesh_bytes", u->part_name),
               1;
    u->file_bytes += size;
    EVP_DigestUpdate(u->md, data, size);
    while (size) {
        ssize_t w = write(u->fd, data, size);
        if (w < 0 && errno == EINTR) continue;
        if (w <= 0) {
            int e = errno;
            return upload_fail(u, e == ENOSPC ? 507 : 500, e == ENOSPC ? "store_full" : "io",
                               "cannot store the upload: %s", strerror(e)),
                   1;
        }
        data += w;
        size -= (size_t)w;
    }
    /* Bytes are held against store_max_bytes once they are on disk, never
     * before: only bytes a client has really sent can make finished bakes
     * be evicted, and a client's uploads together hold at most
     * client_upload_bytes. */
    if (u->file_bytes > u->reserved) {
        uint64_t more = u->file_bytes - u->reserved;
        char why[300];
        if (!svd_jobs_reserve(u->jobs, u->client, more, u->reserved, why, sizeof why)) {
            u->reserved = 0; /* given back by svd_jobs_reserve */
            if (u->known && svd_jobs_has(u->jobs, q->m.key)) return upload_drop(u), 0;
            return upload_fail(u, 507, "store_full", "%s", why), 1;
        }
        u->reserved += more;
    }
    return 0;
}

static int on_part_end(void *user)
{
    req *q = user;
    upload *u = q->up;
    if (u->part >= 2 && !u->drop) {
        close(u->fd);
        u->fd = -1;
        unsigned char md[32];
        unsigned int ml = 0;
        EVP_DigestFinal_ex(u->md, md, &ml);
        char hex[SVD_KEY_HEX];
        static const char dg[] = "0123456789abcdef";
        for (int i = 0; i < 32; i++) hex[2 * i] = dg[md[i] >> 4], hex[2 * i + 1] = dg[md[i] & 15];
        hex[64] = '\0';
        cJSON *o = cJSON_CreateObject();
        cJSON_AddNumberToObject(o, "size", (double)u->part_bytes);
        cJSON_AddStringToObject(o, "sha256", hex);
        cJSON_AddItemToObject(u->objects, u->part_name, o);
    }
    u->part = 0;
    return 0;
}

/* Puts u in the watched list (its body is coming on socket sock). */
static void watch_add(svd_http *h, upload *u, int sock)
{
    pthread_mutex_lock(&h->wmu);
    u->h = h;
    u->sock = sock;
    u->in_watch = true;
    u->wnext = h->watched;
    h->watched = u;
    pthread_mutex_unlock(&h->wmu);
}

/* Takes u out of the watched list (its body is complete, or it ends). */
static void watch_remove(upload *u)
{
    if (!u->h) return;
    pthread_mutex_lock(&u->h->wmu);
    for (upload **p = &u->h->watched; *p; p = &(*p)->wnext)
        if (*p == u) {
            *p = u->wnext;
            break;
        }
    u->in_watch = false;
    pthread_mutex_unlock(&u->h->wmu);
}

/* The watcher thread. libmicrohttpd 0.9.75 (epoll) can miss the end of a
 * connection whose last body bytes and FIN arrived together: the socket sat
 * in CLOSE-WAIT, the upload holding its bytes and its tmp/ folder until the
 * idle timeout. Every quarter second each upload whose body is still coming
 * is looked at: a peer that closed (POLLRDHUP with nothing left unread) will
 * never finish the body, and an upload older than upload_timeout has had its
 * time (a trickle of one byte every few seconds never trips the idle timeout).
 * Either socket is shut down: libmicrohttpd then reads its end at once and
 * ends the request, which frees the upload (on_completed). The socket is
 * never closed here, so its descriptor cannot be reused under us: entries
 * leave the list (on_completed, under wmu) before libmicrohttpd closes it. */
static void *watch_uploads(void *arg)
{
    svd_http *h = arg;
    pthread_mutex_lock(&h->wmu);
    while (!h->stopping) {
        struct timespec ts;
        clock_gettime(CLOCK_REALTIME, &ts);
        ts.tv_nsec += 250 * 1000 * 1000;
        if (ts.tv_nsec >= 1000000000L) ts.tv_sec++, ts.tv_nsec -= 1000000000L;
        pthread_cond_timedwait(&h->wcv, &h->wmu, &ts);
        double now = sv_now();
        for (upload *u = h->watched; u && !h->stopping; u = u->wnext) {
            if (u->shut) continue;
            const char *why = NULL;
            struct pollfd pf = {.fd = u->sock, .events = POLLIN | POLLRDHUP};
            int unread = 0;
            if (h->cfg->upload_timeout && now - u->started > h->cfg->upload_timeout)
                why = "upload over upload_timeout";
            else if (poll(&pf, 1, 0) == 1 && (pf.revents & (POLLRDHUP | POLLHUP | POLLERR)) &&
                     ioctl(u->sock, FIONREAD, &unread) == 0 && unread == 0)
                why = "the client closed before the end of the body";
            if (!why) continue;
            u->shut = true;
            shutdown(u->sock, SHUT_RDWR);
            svd_log_kv(h->log, SVD_LOG_INFO, "upload_ended_early", "client", u->client, "msg", why,
                       (const char *)NULL);
        }
    }
    pthread_mutex_unlock(&h->wmu);
    return NULL;
}

static void upload_free(upload *u)
{
    if (!u) return;
    watch_remove(u);
    if (u->reserved) svd_jobs_unreserve(u->jobs, u->client, u->reserved);
    if (u->fd >= 0) close(u->fd);
    svd_multipart_destroy(u->mp);
    EVP_MD_CTX_free(u->md);
    free(u->spec);
    for (size_t i = 0; i < u->nfiles; i++) free(u->files[i]);
    free(u->files);
    cJSON_Delete(u->objects);
    if (u->tmpdir[0]) svd_rm_rf(u->tmpdir); /* committed uploads were renamed away */
    free(u);
}

static const svd_multipart_callbacks mp_cb = {on_part_begin, on_part_data, on_part_end};

/* Answers a PUT of a key already held: its status, as GET would. */
static enum MHD_Result answer_known(req *q)
{
    char *body = NULL;
    sv_error e = {0};
    svd_jobs_rc rc = svd_jobs_status(q->h->jobs, q->m.key, &body, &e);
    return send_jobs(q->h, q->conn, q->m.route, rc, body, &e);
}

/* A chunked body grew over max_upload_bytes: libmicrohttpd cannot answer in
 * mid-body, so the connection is closed (cut off), logged and counted 413. */
static enum MHD_Result cut_off(req *q)
{
    svd_log_kv(q->h->log, SVD_LOG_WARN, "upload_cut_off", "client", q->client, "msg",
               "chunked upload over max_upload_bytes", (const char *)NULL);
    svd_metrics_request(q->h->metrics, q->m.route, 413);
    return MHD_NO;
}

/* First call of an upload: checks before any body byte is read. Returns 0 to
 * go on reading, or an HTTP status already answered. */
static enum MHD_Result upload_begin(req *q, int *answered)
{
    svd_http *h = q->h;
    struct MHD_Connection *c = q->conn;
    *answered = 1;
    if (atomic_load(&h->draining))
        return send_error(h, c, q->m.route, 503, "draining",
                          "the server is shutting down; retry later");
    const char *cl = MHD_lookup_connection_value(c, MHD_HEADER_KIND,
                                                 MHD_HTTP_HEADER_CONTENT_LENGTH);
    uint64_t body_len = 0;
    if (cl) {
        uint64_t n;
        if (!svd_parse_size(cl, &n) || strpbrk(cl, "KkMmGg"))
            return send_error(h, c, q->m.route, 400, "bad_request", "bad Content-Length");
        if (n > h->cfg->max_upload_bytes) {
            char msg[160];
            snprintf(msg, sizeof msg, "upload of %llu bytes is over the limit of %llu bytes",
                     (unsigned long long)n, (unsigned long long)h->cfg->max_upload_bytes);
            return send_error(h, c, q->m.route, 413, "too_large", msg);
        }
        body_len = n;
    }
    /* A PUT of a key we already hold does not need its body. With
     * "Expect: 100-continue" the client has not sent it yet: answer at once
     * (the body never comes). Without, the body is already on its way, and an
     * answer now makes libmicrohttpd close the connection with body bytes
     * unread: the kernel resets it, and the peer can lose the answer or fail
     * its next write. Behind nginx (which never forwards Expect) that reads
     * as a failed node: nginx marks a healthy node down for fail_timeout and
     * sends its keys to another node, which bakes them again. So the body is
     * read first, then answered on a live connection. It is read as an
     * upload, not dropped: the key can be evicted or deleted while the body
     * comes, and then the upload is a new one (202), not a 404 that loses it.
     * If the store has no room for it while the key is still held, the rest
     * is dropped and the held bake answered (upload_drop). */
    /* (with tokens only for an owner: anyone else proves possession by
     * sending the bytes) */
    bool known = false;
    if (q->m.route == SVD_R_PUT && svd_jobs_has(h->jobs, q->m.key) &&
        (!h->tokens || svd_jobs_owned(h->jobs, q->m.key, q->client))) {
        const char *ex = MHD_lookup_connection_value(c, MHD_HEADER_KIND, MHD_HTTP_HEADER_EXPECT);
        if (ex && strcasecmp(ex, "100-continue") == 0) return answer_known(q);
        known = true;
    }
    const char *ct = MHD_lookup_connection_value(c, MHD_HEADER_KIND, MHD_HTTP_HEADER_CONTENT_TYPE);
    char boundary[71];
    sv_error e = {0};
    sv_status st = svd_multipart_boundary(ct, boundary, &e);
    if (st != SV_OK && known) { /* not a form: read and dropped, the held bake answered */
        q->kind = REQ_DRAIN;
        *answered = 0;
        return MHD_YES;
    }
    if (st != SV_OK)
        return send_error(h, c, q->m.route, st == SV_ERR_FORMAT ? 415 : 400,
                          st == SV_ERR_FORMAT ? "unsupported_media_type" : "bad_request",
                          e.message);
    upload *u = calloc(1, sizeof *u);
    if (!u) return send_error(h, c, q->m.route, 500, "nomem", "out of memory");
    u->fd = -1;
    u->jobs = h->jobs;
    u->known = known;
    u->client = q->client;
    u->started = sv_now();
    q->up = u;
    /* Nothing is reserved for the declared length: a client that declares
     * the limit and sends nothing must not make finished bakes be evicted or
     * other uploads be refused. Bytes are reserved as they reach the disk
     * (on_part_data). */
    (void)body_len;
    u->md = EVP_MD_CTX_new();
    u->objects = cJSON_CreateObject();
    u->mp = svd_multipart_create(boundary, &mp_cb, q);
    if (!u->md || !u->objects || !u->mp)
        return send_error(h, c, q->m.route, 500, "nomem", "out of memory");
    char in[SVD_STORE_PATH + 4];
    sv_status ms = svd_store_mktemp(svd_jobs_store(h->jobs), "up", u->tmpdir, &e);
    if (ms == SV_OK && (snprintf(in, sizeof in, "%s/in", u->tmpdir), mkdir(in, 0700)) != 0)
        ms = errno == ENOSPC ? SV_ERR_LIMIT : SV_ERR_IO;
    if (ms != SV_OK && known) { /* no room to read it as an upload: the held bake answers */
        if (u->tmpdir[0]) svd_rm_rf(u->tmpdir);
        u->tmpdir[0] = '\0';
        q->kind = REQ_DRAIN;
        *answered = 0;
        return MHD_YES;
    }
    if (ms == SV_ERR_LIMIT) /* a full disk: the 507 an upload gets later, before its body */
        return send_error(h, c, q->m.route, 507, "store_full", "the store's disk is full");
    if (ms != SV_OK)
        return send_error(h, c, q->m.route, 500, "io", "cannot create upload space in the store");
    q->kind = REQ_UPLOAD;
    const union MHD_ConnectionInfo *ci = MHD_get_connection_info(c,
                                                                 MHD_CONNECTION_INFO_CONNECTION_FD);
    if (ci) watch_add(h, u, ci->connect_fd);
    *answered = 0;
    return MHD_YES;
}

static const char *status_code_for(sv_status st)
{
    return sv_status_code(st);
}

/* Last call of an upload: validate, key, commit. */
static enum MHD_Result upload_end(req *q)
{
    svd_http *h = q->h;
    struct MHD_Connection *c = q->conn;
    upload *u = q->up;
    svd_route route = q->m.route;
    sv_error e = {0};
    watch_remove(u); /* the body is complete */
    /* A PUT of a key still held is answered with the held bake, whatever its
     * body was; only when the key went away while the body came does the
     * upload count (see upload_begin). */
    if (u->drop || (u->known && svd_jobs_has(h->jobs, q->m.key))) return answer_known(q);
    if (!u->err_status && svd_multipart_finish(u->mp, &e) != SV_OK)
        upload_fail(u, 400, "bad_multipart", "%s", e.message);
    if (!u->err_status && !u->mesh[0])
        upload_fail(u, 400, "bad_request", "no mesh part (a form field 'mesh' with a filename)%s",
                    NULL);
    if (u->err_status)
        return send_error(h, c, route, (unsigned)u->err_status, u->err_code, u->err_msg);
    svd_metrics_upload_bytes(h->metrics, u->total);

    /* The spec, checked as the worker will check it. */
    const char *spec = u->spec && u->spec_len ? u->spec : "{}";
    size_t spec_len = u->spec && u->spec_len ? u->spec_len : 2;
    sv_spec parsed;
    memset(&parsed, 0, sizeof parsed);
    if (sv_spec_parse(spec, spec_len, &parsed, &e) != SV_OK) {
        sv_spec_free(&parsed);
        char msg[700];
        snprintf(msg, sizeof msg, "bad spec: %s", e.message);
        return send_error(h, c, route, 400, "spec", msg);
    }
    uint64_t out_est = sv_spec_output_estimate(&parsed, u->file_bytes);
    sv_spec_free(&parsed);

    /* The format, sniffed from the mesh's first bytes. */
    char mpath[SVD_STORE_PATH + 300];
    snprintf(mpath, sizeof mpath, "%s/in/%s", u->tmpdir, u->mesh);
    uint8_t head[65536];
    ssize_t hn = 0;
    int fd = open(mpath, O_RDONLY | O_CLOEXEC);
    if (fd >= 0) {
        hn = read(fd, head, sizeof head);
        close(fd);
    }
    if (hn < 0) hn = 0;
    sv_format fmt = sv_sniff_format(head, (size_t)hn);
    if (fmt == SV_FORMAT_UNKNOWN) {
        char msg[400];
        snprintf(msg, sizeof msg,
                 "'%.255s' is not a mesh format sylva accepts (glTF/GLB, OBJ, PLY, FBX, COLLADA)",
                 u->mesh);
        return send_error(h, c, route, 415, "format", msg);
    }

    /* What the import's pre-checks decide (structure,
     * declared counts against the limits, glTF buffers and URIs against the
     * uploaded files) is answered now, 422 with the worker's code, instead of
     * a 202 and a bake that fails. Same functions, same default limits as the
     * worker's import; bounded by the file's size and iterative (fuzzed). */
    {
        sv_error pe = {0};
        sv_status pst = precheck_upload(u, fmt, &pe);
        if (pst == SV_ERR_NOMEM) return send_error(h, c, route, 500, "nomem", "out of memory");
        if (pst != SV_OK) return send_error(h, c, route, 422, sv_status_code(pst), pe.message);
    }

    /* The key over exactly the uploaded bytes. */
    svd_key_part sp = {.data = (const uint8_t *)spec, .size = spec_len};
    svd_key_part mp = {.name = u->mesh, .path = mpath};
    svd_key_part *fp = sv_calloc(u->nfiles ? u->nfiles : 1, sizeof *fp);
    char(*paths)[SVD_STORE_PATH + 300] = sv_calloc(u->nfiles ? u->nfiles : 1, sizeof *paths);
    if (!fp || !paths) {
        free(fp);
        free(paths);
        return send_error(h, c, route, 500, "nomem", "out of memory");
    }
    for (size_t i = 0; i < u->nfiles; i++) {
        snprintf(paths[i], sizeof paths[i], "%s/in/%s", u->tmpdir, u->files[i]);
        fp[i].name = u->files[i];
        fp[i].path = paths[i];
    }
    svd_upload up = {.tmpdir = u->tmpdir, .client = q->client};
    sv_status st = svd_key_compute(&sp, &mp, fp, u->nfiles, up.key, &e);
    free(fp);
    free(paths);
    if (st != SV_OK)
        return send_error(h, c, route, st == SV_ERR_SPEC ? 400 : 500, status_code_for(st),
                          e.message);
    if (route == SVD_R_PUT && strcmp(up.key, q->m.key) != 0) {
        char msg[300];
        snprintf(msg, sizeof msg,
                 "key mismatch: the uploaded bytes hash to %s (see docs/api.md, content key)",
                 up.key);
        return send_error(h, c, route, 400, "key_mismatch", msg);
    }

    /* Lay out the job directory, fsync it, commit. */
    cJSON *in = cJSON_CreateObject();
    cJSON_AddStringToObject(in, "mesh", u->mesh);
    cJSON *fl = cJSON_AddArrayToObject(in, "files");
    for (size_t i = 0; i < u->nfiles; i++)
        cJSON_AddItemToArray(fl, cJSON_CreateString(u->files[i]));
    cJSON_AddItemReferenceToObject(in, "objects", u->objects);
    cJSON_AddStringToObject(in, "format", sv_format_name(fmt));
    char *intext = cJSON_PrintUnformatted(in);
    cJSON_Delete(in);
    st = intext ? SV_OK : sv_fail(&e, SV_ERR_NOMEM, "out of memory");
    if (st == SV_OK)
        st = svd_store_write_file(u->tmpdir, "inputs.json", intext, strlen(intext), &e);
    free(intext);
    if (st == SV_OK) st = svd_store_write_file(u->tmpdir, "spec.json", spec, spec_len, &e);
    if (st == SV_OK) st = svd_store_sync_tree(u->tmpdir, &e);
    if (st != SV_OK) {
        svd_log_kv(h->log, SVD_LOG_ERROR, "upload_store_failed", "msg", e.message,
                   (const char *)NULL);
        return send_error(h, c, route, st == SV_ERR_LIMIT ? 507 : 500,
                          st == SV_ERR_LIMIT ? "store_full" : "io", "could not store the upload");
    }
    up.bytes = svd_dir_bytes(u->tmpdir);
    up.out_bytes = out_est;
    char *body = NULL;
    /* the reservation becomes the job's bytes in submit (make_room again) */
    svd_jobs_unreserve(h->jobs, u->client, u->reserved);
    u->reserved = 0;
    svd_jobs_rc rc = svd_jobs_submit(h->jobs, &up, &body, &e);
    u->tmpdir[0] = '\0'; /* submit consumed (installed or removed) it */
    if (rc != SVD_JOBS_OK && rc != SVD_JOBS_ACCEPTED) return send_jobs(h, c, route, rc, body, &e);
    /* accepted (or already known): Location names the bake's status document */
    cJSON *j = body ? cJSON_Parse(body) : NULL;
    const char *key = cJSON_GetStringValue(cJSON_GetObjectItemCaseSensitive(j, "key"));
    char loc[SVD_KEY_HEX + 16] = "";
    if (key && strlen(key) < SVD_KEY_HEX) snprintf(loc, sizeof loc, "/v1/bakes/%s", key);
    cJSON_Delete(j);
    return send_json_with(h, c, route, jobs_http[rc].status, body, MHD_HTTP_HEADER_LOCATION, loc);
}

/* ---- long-poll ---- */

static void wake_req(void *arg)
{
    req *q = arg;
    pthread_mutex_lock(&q->mu);
    q->woken = 1;
    if (q->suspended) {
        q->suspended = 0;
        MHD_resume_connection(q->conn);
    }
    pthread_mutex_unlock(&q->mu);
}

static enum MHD_Result handle_status(req *q, int allow_wait)
{
    svd_http *h = q->h;
    const char *w = MHD_lookup_connection_value(q->conn, MHD_GET_ARGUMENT_KIND, "wait");
    if (allow_wait && w && !q->woken) {
        char *end;
        double s = strtod(w, &end);
        if (end == w || *end || !(s >= 0) || s > 1e6)
            return send_error(h, q->conn, q->m.route, 400, "bad_request",
                              "wait: expected seconds (a number >= 0)");
        if (s > h->cfg->max_wait) s = h->cfg->max_wait;
        if (s > 0) {
            q->kind = REQ_WAIT;
            q->waiter.wake = wake_req;
            q->waiter.arg = q;
            q->waiter.deadline = sv_now() + s;
            pthread_mutex_lock(&q->mu);
            if (svd_jobs_wait(h->jobs, q->m.key, &q->waiter)) {
                q->suspended = 1;
                MHD_suspend_connection(q->conn);
                pthread_mutex_unlock(&q->mu);
                return MHD_YES;
            }
            pthread_mutex_unlock(&q->mu);
        }
    }
    char *body = NULL;
    sv_error e = {0};
    svd_jobs_rc rc = svd_jobs_status(h->jobs, q->m.key, &body, &e);
    return send_jobs(h, q->conn, q->m.route, rc, body, &e);
}

/* ---- other routes ---- */

static const char *content_type_of(const char *name)
{
    const char *dot = strrchr(name, '.');
    if (!dot) return "application/octet-stream";
    if (strcmp(dot, ".glb") == 0) return "model/gltf-binary";
    if (strcmp(dot, ".json") == 0) return "application/json";
    if (strcmp(dot, ".png") == 0) return "image/png";
    if (strcmp(dot, ".jpg") == 0) return "image/jpeg";
    if (strcmp(dot, ".ktx2") == 0) return "image/ktx2";
    if (strcmp(dot, ".html") == 0) return "text/html; charset=utf-8";
    if (strcmp(dot, ".js") == 0 || strcmp(dot, ".mjs") == 0)
        return "text/javascript; charset=utf-8";
    if (strcmp(dot, ".css") == 0) return "text/css; charset=utf-8";
    if (strcmp(dot, ".glsl") == 0 || strcmp(dot, ".mtl") == 0 || strcmp(dot, ".obj") == 0 ||
        strcmp(dot, ".txt") == 0)
        return "text/plain; charset=utf-8";
    if (strcmp(dot, ".gltf") == 0) return "model/gltf+json";
    return "application/octet-stream";
}

/* One byte range of a file of `size` bytes (RFC 9110 §14.1.2): "bytes=a-b",
 * "bytes=a-" or "bytes=-n". 1: satisfiable, [*off, *off + *len); -1: not
 * satisfiable (416); 0: not one range this parser takes (several ranges,
 * another unit, a malformed value), so the header is ignored and the whole
 * file is sent, as the RFC allows. */
static int parse_range(const char *v, uint64_t size, uint64_t *off, uint64_t *len)
{
    if (strncmp(v, "bytes=", 6) != 0 || strchr(v, ',')) return 0;
    const char *p = v + 6, *dash = strchr(p, '-');
    if (!dash) return 0;
    char *end;
    if (p == dash) { /* suffix: the last n bytes */
        if (dash[1] < '0' || dash[1] > '9') return 0;
        unsigned long long n = strtoull(dash + 1, &end, 10);
        if (*end) return 0;
        if (n == 0 || size == 0) return -1;
        *len = n < size ? n : size;
        *off = size - *len;
        return 1;
    }
    if (*p < '0' || *p > '9') return 0;
    unsigned long long a = strtoull(p, &end, 10), b = UINT64_MAX;
    if (end != dash) return 0;
    if (dash[1]) {
        if (dash[1] < '0' || dash[1] > '9') return 0;
        b = strtoull(dash + 1, &end, 10);
        if (*end || b < a) return 0;
    }
    if (a >= size) return -1;
    *off = a;
    *len = (b >= size - 1 ? size - 1 : b) - a + 1;
    return 1;
}

/* The 409 of a route that needs a finished bake: 422 with the bake's own
 * error when it failed, else 409 not_ready naming its state. */
static enum MHD_Result answer_not_done(req *q)
{
    svd_http *h = q->h;
    char *body = NULL;
    svd_jobs_status(h->jobs, q->m.key, &body, NULL);
    cJSON *s = body ? cJSON_Parse(body) : NULL;
    free(body);
    const char *state = cJSON_GetStringValue(cJSON_GetObjectItemCaseSensitive(s, "state"));
    const cJSON *err = cJSON_GetObjectItemCaseSensitive(s, "error");
    enum MHD_Result r;
    if (state && strcmp(state, "failed") == 0 && err) {
        const char *code = cJSON_GetStringValue(cJSON_GetObjectItemCaseSensitive(err, "code"));
        const char *msg = cJSON_GetStringValue(cJSON_GetObjectItemCaseSensitive(err, "message"));
        r = send_error(h, q->conn, q->m.route, 422, code ? code : "failed",
                       msg ? msg : "the bake failed");
    } else {
        char msg[80];
        snprintf(msg, sizeof msg, "the bake is %s, not done", state ? state : "not done");
        r = send_error(h, q->conn, q->m.route, 409, "not_ready", msg);
    }
    cJSON_Delete(s);
    return r;
}

/* Serves a stored file whose SHA-256 was verified (vs: svd_store_verify's
 * answer, SV_OK or SV_ERR_IO) with its ETag, If-None-Match (304) and one
 * byte range (206/416), as docs/api.md says for artifacts; `missing` is the
 * 404 message when it cannot be opened. */
static enum MHD_Result serve_stored(req *q, const char *path, uint64_t size, const char *sha,
                                    sv_status vs, const char *missing, bool attachment)
{
    svd_http *h = q->h;
    struct MHD_Connection *c = q->conn;
    char etag[SVD_KEY_HEX + 2];
    snprintf(etag, sizeof etag, "\"%s\"", sha);
    /* Range (one range; If-Range must name this ETag, else the whole file) */
    uint64_t off = 0, len = size;
    int ranged = 0;
    const char *rg = MHD_lookup_connection_value(c, MHD_HEADER_KIND, MHD_HTTP_HEADER_RANGE);
    const char *ifr = MHD_lookup_connection_value(c, MHD_HEADER_KIND, MHD_HTTP_HEADER_IF_RANGE);
    if (rg && (!ifr || strstr(ifr, sha))) ranged = parse_range(rg, size, &off, &len);
    char crange[96];
    if (ranged < 0) {
        snprintf(crange, sizeof crange, "bytes */%llu", (unsigned long long)size);
        return send_json_with(
            h, c, q->m.route, MHD_HTTP_RANGE_NOT_SATISFIABLE,
            error_body("range", "the range starts at or past the end of the file"),
            MHD_HTTP_HEADER_CONTENT_RANGE, crange);
    }
    int fd = vs == SV_OK ? open(path, O_RDONLY | O_CLOEXEC) : -1;
    if (fd < 0) return send_error(h, c, q->m.route, 404, "not_found", missing);
    struct MHD_Response *r = MHD_create_response_from_fd_at_offset64(len, fd, off); /* closes fd */
    if (!r) {
        close(fd);
        return MHD_NO;
    }
    MHD_add_response_header(r, MHD_HTTP_HEADER_ETAG, etag);
    /* An uploaded file is the client's bytes, whatever its name says: never
     * a page of this origin. */
    MHD_add_response_header(r, MHD_HTTP_HEADER_CONTENT_TYPE,
                            attachment ? "application/octet-stream" : content_type_of(q->m.name));
    if (attachment) MHD_add_response_header(r, MHD_HTTP_HEADER_CONTENT_DISPOSITION, "attachment");
    harden(r, NULL);
    MHD_add_response_header(r, MHD_HTTP_HEADER_ACCEPT_RANGES, "bytes");
    if (ranged > 0) {
        snprintf(crange, sizeof crange, "bytes %llu-%llu/%llu", (unsigned long long)off,
                 (unsigned long long)(off + len - 1), (unsigned long long)size);
        MHD_add_response_header(r, MHD_HTTP_HEADER_CONTENT_RANGE, crange);
    }
    unsigned code = ranged > 0 ? MHD_HTTP_PARTIAL_CONTENT : MHD_HTTP_OK;
    enum MHD_Result ret = MHD_queue_response(c, code, r);
    MHD_destroy_response(r);
    svd_metrics_request(h->metrics, q->m.route, code);
    return ret;
}

/* If-None-Match naming sha (or *): answers 304 and returns 1; else 0. */
static int answer_not_modified(req *q, const char *sha, enum MHD_Result *ret)
{
    struct MHD_Connection *c = q->conn;
    const char *inm = MHD_lookup_connection_value(c, MHD_HEADER_KIND,
                                                  MHD_HTTP_HEADER_IF_NONE_MATCH);
    if (!inm || !(strstr(inm, sha) || strcmp(inm, "*") == 0)) return 0;
    char etag[SVD_KEY_HEX + 2];
    snprintf(etag, sizeof etag, "\"%s\"", sha);
    struct MHD_Response *r = MHD_create_response_from_buffer(0, (void *)"", MHD_RESPMEM_PERSISTENT);
    if (!r) {
        *ret = MHD_NO;
        return 1;
    }
    MHD_add_response_header(r, MHD_HTTP_HEADER_ETAG, etag);
    harden(r, NULL);
    /* RFC 9110 §8.6 wants no Content-Length on a 304, or the 200's;
     * libmicrohttpd 0.9.75 writes "Content-Length: 0" and, given the
     * artifact's length as well, sends both: its 0 is left (clients
     * ignore a 304's length; the connection stays usable, tested). */
    MHD_add_response_header(r, MHD_HTTP_HEADER_ACCEPT_RANGES, "bytes");
    *ret = MHD_queue_response(c, MHD_HTTP_NOT_MODIFIED, r);
    MHD_destroy_response(r);
    svd_metrics_request(q->h->metrics, q->m.route, 304);
    return 1;
}

static enum MHD_Result handle_artifact(req *q)
{
    svd_http *h = q->h;
    struct MHD_Connection *c = q->conn;
    char path[SVD_STORE_PATH], sha[SVD_KEY_HEX];
    uint64_t size = 0;
    svd_jobs_rc rc = svd_jobs_artifact(h->jobs, q->m.key, q->m.name, path, &size, sha);
    if (rc == SVD_JOBS_NOT_FOUND)
        return send_error(h, c, q->m.route, 404, "not_found", "no such bake or artifact");
    if (rc == SVD_JOBS_NOT_DONE) return answer_not_done(q);
    enum MHD_Result ret;
    if (answer_not_modified(q, sha, &ret)) return ret;
    sv_error e = {0};
    sv_status vs = svd_store_verify(svd_jobs_store(h->jobs), path, size, sha, &e);
    if (vs == SV_ERR_INVALID) {
        svd_jobs_result_corrupt(h->jobs, q->m.key, path);
        return send_error(h, c, q->m.route, 503, "corrupt",
                          "the stored artifact failed its SHA-256 check; it was quarantined and "
                          "the bake requeued");
    }
    return serve_stored(q, path, size, sha, vs, "artifact missing from the store", false);
}

/* GET /v1/bakes/{key}/inputs/{name}: a file the bake was uploaded with, as
 * an artifact is served (ETag, ranges), in any state. A file that fails its
 * SHA-256 check is left where it is (the worker refuses it as `corrupt` if
 * the bake runs again) and answered 500 corrupt: nothing will mend it. */
static enum MHD_Result handle_input(req *q)
{
    svd_http *h = q->h;
    struct MHD_Connection *c = q->conn;
    char path[SVD_STORE_PATH], sha[SVD_KEY_HEX];
    uint64_t size = 0;
    if (svd_jobs_input(h->jobs, q->m.key, q->m.name, path, &size, sha) != SVD_JOBS_OK)
        return send_error(h, c, q->m.route, 404, "not_found", "no such bake or input file");
    enum MHD_Result ret;
    if (answer_not_modified(q, sha, &ret)) return ret;
    sv_error e = {0};
    sv_status vs = svd_store_verify(svd_jobs_store(h->jobs), path, size, sha, &e);
    if (vs == SV_ERR_INVALID) {
        svd_log_kv(h->log, SVD_LOG_ERROR, "input_corrupt", "key", q->m.key, "path", path, "msg",
                   "SHA-256 mismatch of an uploaded file", (const char *)NULL);
        return send_error(h, c, q->m.route, 500, "corrupt",
                          "the stored input failed its SHA-256 check; upload the bake again");
    }
    return serve_stored(q, path, size, sha, vs, "input missing from the store", true);
}

/* The first needle[0..nl) in hay[0..hl), or NULL (memmem is a GNU extension). */
static const char *find_bytes(const char *hay, size_t hl, const char *needle, size_t nl)
{
    for (size_t i = 0; nl && i + nl <= hl; i++)
        if (hay[i] == needle[0] && memcmp(hay + i, needle, nl) == 0) return hay + i;
    return NULL;
}

/* The Content-Security-Policy of a viewer page whose bytes are html[0..n):
 * scripts from this origin and the page's inline import maps only (each by
 * its SHA-256, so no other inline script runs), styles from this origin,
 * images and fetches from this origin or blob:/data: (GLTFLoader decodes
 * embedded textures through blob: URLs), WebAssembly compiled (three.js's
 * meshopt decoder, for output.compress "meshopt" files; no JavaScript eval),
 * nothing framed or posted. Written
 * into out (cap bytes); false if it does not fit. */
static bool viewer_csp(const char *html, size_t n, char *out, size_t cap)
{
    static const char open_tag[] = "<script type=\"importmap\">", close_tag[] = "</script>";
    char hashes[512] = "";
    const char *p = html, *end = html + n;
    while (p < end) {
        const char *o = find_bytes(p, (size_t)(end - p), open_tag, sizeof open_tag - 1);
        if (!o) break;
        const char *body = o + sizeof open_tag - 1;
        const char *c = find_bytes(body, (size_t)(end - body), close_tag, sizeof close_tag - 1);
        if (!c) break;
        unsigned char md[32];
        unsigned int ml = 0;
        EVP_Digest(body, (size_t)(c - body), md, &ml, EVP_sha256(), NULL);
        unsigned char b64[48];
        EVP_EncodeBlock(b64, md, 32);
        size_t hl = strlen(hashes);
        int k = snprintf(hashes + hl, sizeof hashes - hl, " 'sha256-%s'", (const char *)b64);
        if (k < 0 || (size_t)k >= sizeof hashes - hl) return false;
        p = c + sizeof close_tag - 1;
    }
    int k = snprintf(
        out, cap,
        "default-src 'none'; script-src 'self'%s 'wasm-unsafe-eval'; style-src 'self'; "
        "img-src 'self' blob: data:; connect-src 'self' blob: data:; "
        "base-uri 'none'; form-action 'none'; frame-ancestors 'none'",
        hashes);
    return k > 0 && (size_t)k < cap;
}

/* A file of the viewer directory (cfg->viewer_dir): rel is a path that
 * svd_viewer_path_valid accepted. Regular files only; no range, no ETag
 * (they are small and change only with a deployment). */
static enum MHD_Result serve_viewer_file(req *q, const char *rel, const char *ctype)
{
    svd_http *h = q->h;
    char path[SVD_PATH_MAX + SVD_NAME_MAX + 2];
    int n = snprintf(path, sizeof path, "%s/%s", h->cfg->viewer_dir, rel);
    int fd = n > 0 && (size_t)n < sizeof path ? open(path, O_RDONLY | O_CLOEXEC) : -1;
    struct stat sb;
    if (fd >= 0 && (fstat(fd, &sb) != 0 || !S_ISREG(sb.st_mode))) {
        close(fd);
        fd = -1;
    }
    if (fd < 0)
        return send_error(h, q->conn, q->m.route, 404, "not_found",
                          q->m.route == SVD_R_VIEW ? "the viewer page is not installed (viewer_dir)"
                                                   : "no such viewer file");
    struct MHD_Response *r = NULL;
    char csp[1024];
    if (strncmp(ctype, "text/html", 9) == 0) { /* read whole: its policy hashes its import map */
        size_t len = (size_t)sb.st_size;
        char *html = len <= (1u << 20) ? malloc(len ? len : 1) : NULL;
        bool ok = html && read(fd, html, len) == (ssize_t)len &&
                  viewer_csp(html, len, csp, sizeof csp);
        close(fd);
        if (ok) r = MHD_create_response_from_buffer(len, html, MHD_RESPMEM_MUST_FREE);
        if (!r) {
            free(html);
            return send_error(h, q->conn, q->m.route, 500, "io", "cannot read the viewer page");
        }
    } else {
        r = MHD_create_response_from_fd64((uint64_t)sb.st_size, fd); /* closes fd */
        if (!r) {
            close(fd);
            return MHD_NO;
        }
    }
    MHD_add_response_header(r, MHD_HTTP_HEADER_CONTENT_TYPE, ctype);
    MHD_add_response_header(r, MHD_HTTP_HEADER_CACHE_CONTROL, "no-cache");
    harden(r, strncmp(ctype, "text/html", 9) == 0 ? csp : NULL);
    enum MHD_Result ret = MHD_queue_response(q->conn, MHD_HTTP_OK, r);
    MHD_destroy_response(r);
    svd_metrics_request(h->metrics, q->m.route, MHD_HTTP_OK);
    return ret;
}

/* GET /v1/bakes/{key}/view: the viewer page (viewer_dir/index.html), for a
 * finished bake only; the page reads the key from its own address. */
static enum MHD_Result handle_view(req *q)
{
    char path[SVD_STORE_PATH], sha[SVD_KEY_HEX];
    uint64_t size = 0;
    svd_jobs_rc rc = svd_jobs_artifact(q->h->jobs, q->m.key, "report.json", path, &size, sha);
    if (rc == SVD_JOBS_NOT_DONE) return answer_not_done(q);
    if (rc != SVD_JOBS_OK)
        return send_error(q->h, q->conn, q->m.route, 404, "not_found",
                          rc == SVD_JOBS_NOT_FOUND && svd_jobs_has(q->h->jobs, q->m.key)
                              ? "the bake has no report.json to view"
                              : "no bake with this key");
    return serve_viewer_file(q, "index.html", "text/html; charset=utf-8");
}

/* GET /v1/bakes[?limit=N][&before=CURSOR]: the caller's bakes, newest first
 * (docs/api.md). */
#define LIST_DEFAULT 50
#define LIST_MAX 1000

static enum MHD_Result handle_list(req *q)
{
    svd_http *h = q->h;
    const char *ls = MHD_lookup_connection_value(q->conn, MHD_GET_ARGUMENT_KIND, "limit");
    const char *bs = MHD_lookup_connection_value(q->conn, MHD_GET_ARGUMENT_KIND, "before");
    unsigned long limit = LIST_DEFAULT;
    unsigned long long before = 0;
    char *end;
    if (ls) {
        limit = strtoul(ls, &end, 10);
        if (end == ls || *end || *ls == '-' || limit < 1 || limit > LIST_MAX)
            return send_error(h, q->conn, q->m.route, 400, "bad_request",
                              "limit: expected an integer from 1 to 1000");
    }
    if (bs) {
        before = strtoull(bs, &end, 10);
        if (end == bs || *end || *bs == '-' || before == 0)
            return send_error(h, q->conn, q->m.route, 400, "bad_request",
                              "before: expected a cursor from an earlier page (\"next\")");
    }
    char *body = NULL;
    sv_error e = {0};
    svd_jobs_rc rc = svd_jobs_list(h->jobs, q->client, (uint64_t)before, (unsigned)limit, &body,
                                   &e);
    return send_jobs(h, q->conn, q->m.route, rc, body, &e);
}

static enum MHD_Result handle_info(req *q)
{
    svd_http *h = q->h;
    const svd_config *c = h->cfg;
    cJSON *r = cJSON_CreateObject();
    cJSON_AddStringToObject(r, "name", "sylvad");
    cJSON_AddStringToObject(r, "version", SV_VERSION);
    cJSON_AddNumberToObject(r, "api", 1);
    cJSON *m = cJSON_AddArrayToObject(r, "methods");
    size_t n = 0;
    const sv_method *const *ms = sv_method_list(&n);
    for (size_t i = 0; i < n; i++) cJSON_AddItemToArray(m, cJSON_CreateString(ms[i]->name));
    cJSON *fx = cJSON_AddArrayToObject(r, "effects");
    const char *effects[] = {"lighting:static", "lighting:dynamic", "ambient_occlusion",
                             "shadows",         "viewer:ground",    "viewer:aerial",
                             "viewer:orbit",    "camera_motion"};
    for (size_t i = 0; i < sizeof effects / sizeof effects[0]; i++)
        cJSON_AddItemToArray(fx, cJSON_CreateString(effects[i]));
    cJSON *fm = cJSON_AddArrayToObject(r, "formats");
    const char *formats[] = {"glb", "gltf", "obj", "ply", "fbx", "dae"};
    for (size_t i = 0; i < 6; i++) cJSON_AddItemToArray(fm, cJSON_CreateString(formats[i]));
    cJSON *l = cJSON_AddObjectToObject(r, "limits");
    cJSON_AddNumberToObject(l, "max_upload_bytes", (double)c->max_upload_bytes);
    cJSON_AddNumberToObject(l, "max_mesh_bytes", (double)c->max_mesh_bytes);
    cJSON_AddNumberToObject(l, "max_files", c->max_files);
    cJSON_AddNumberToObject(l, "queue_max", c->queue_max);
    cJSON_AddNumberToObject(l, "queue_per_client", c->queue_per_client);
    cJSON_AddNumberToObject(l, "job_timeout", c->job_timeout);
    cJSON_AddNumberToObject(l, "attempts", c->attempts);
    cJSON_AddNumberToObject(l, "max_wait", c->max_wait);
    cJSON_AddNumberToObject(l, "store_max_bytes", (double)c->store_max_bytes);
    cJSON_AddNumberToObject(r, "workers", c->workers);
    cJSON_AddBoolToObject(r, "auth", h->tokens != NULL);
    char *s = cJSON_PrintUnformatted(r);
    cJSON_Delete(r);
    return send_json(h, q->conn, q->m.route, 200, s);
}

static enum MHD_Result handle_metrics(req *q)
{
    svd_gauges g;
    svd_jobs_gauges(q->h->jobs, &g);
    g.workers = q->h->cfg->workers;
    /* count this request before rendering so a scrape sees itself */
    char *text = svd_metrics_render(q->h->metrics, &g);
    if (!text) return send_error(q->h, q->conn, q->m.route, 500, "nomem", "out of memory");
    enum MHD_Result r = send_text(q->h, q->conn, q->m.route, 200, text,
                                  "text/plain; version=0.0.4");
    free(text);
    return r;
}

/* ---- dispatch ---- */

/* A bake route named by a key prefix (routes.h): the one key of the
 * caller's bakes (every bake without tokens) that starts with it goes into
 * q->m.key. True when resolved; else the answer was queued into *ret: 404
 * when none starts with it, 409 "ambiguous_key" with the error's
 * "candidates" (the keys, bytewise order) when several do. */
static bool resolve_prefix(req *q, enum MHD_Result *ret)
{
    svd_http *h = q->h;
    char key[SVD_KEY_HEX], *cands = NULL;
    sv_error e = {0};
    svd_jobs_rc rc = svd_jobs_resolve(h->jobs, q->m.key, h->tokens ? q->client : NULL, key, &cands,
                                      &e);
    if (rc == SVD_JOBS_OK) {
        memcpy(q->m.key, key, SVD_KEY_HEX);
        q->m.key_prefix = false;
        return true;
    }
    if (rc == SVD_JOBS_AMBIGUOUS) {
        cJSON *doc = cJSON_CreateObject();
        cJSON *err = cJSON_AddObjectToObject(doc, "error");
        cJSON_AddStringToObject(err, "code", jobs_http[rc].code);
        cJSON_AddStringToObject(err, "message", e.message);
        cJSON *list = cands ? cJSON_Parse(cands) : NULL;
        if (list) cJSON_AddItemToObject(err, "candidates", list);
        *ret = send_json(h, q->conn, q->m.route, jobs_http[rc].status, cJSON_PrintUnformatted(doc));
        cJSON_Delete(doc);
    } else {
        *ret = send_error(h, q->conn, q->m.route, jobs_http[rc].status, jobs_http[rc].code,
                          e.message);
    }
    free(cands);
    return false;
}

static void remote_addr(struct MHD_Connection *c, char *out, size_t cap)
{
    const union MHD_ConnectionInfo *ci = MHD_get_connection_info(
        c, MHD_CONNECTION_INFO_CLIENT_ADDRESS);
    out[0] = '\0';
    if (!ci || !ci->client_addr) return;
    const struct sockaddr *sa = ci->client_addr;
    if (sa->sa_family == AF_INET)
        inet_ntop(AF_INET, &((const struct sockaddr_in *)(const void *)sa)->sin_addr, out,
                  (socklen_t)cap);
    else if (sa->sa_family == AF_INET6)
        inet_ntop(AF_INET6, &((const struct sockaddr_in6 *)(const void *)sa)->sin6_addr, out,
                  (socklen_t)cap);
}

/* Whether the request's body, which its route does not take, is small enough
 * to be read and dropped (at most SMALL_BODY bytes declared by
 * Content-Length, or none). *declared: the Content-Length, 0 when chunked. */
static bool body_is_small(struct MHD_Connection *c, uint64_t *declared)
{
    *declared = 0;
    if (MHD_lookup_connection_value(c, MHD_HEADER_KIND, MHD_HTTP_HEADER_TRANSFER_ENCODING))
        return false;
    const char *cl = MHD_lookup_connection_value(c, MHD_HEADER_KIND,
                                                 MHD_HTTP_HEADER_CONTENT_LENGTH);
    if (!cl) return true;
    char *end;
    errno = 0;
    unsigned long long n = strtoull(cl, &end, 10);
    if (end == cl || errno) return false; /* libmicrohttpd refuses those before we see them */
    *declared = n;
    return n <= SMALL_BODY;
}

/* Answers a request refused from its headers alone: no such route (404), a
 * bad key (400), a method the path does not take (405, with Allow), or no
 * valid token (401). */
static enum MHD_Result answer_refused(req *q)
{
    svd_http *h = q->h;
    struct MHD_Connection *c = q->conn;
    if (q->m.status == 405) {
        char *body = error_body("method_not_allowed", q->m.message);
        struct MHD_Response *r = body ? MHD_create_response_from_buffer(strlen(body), body,
                                                                        MHD_RESPMEM_MUST_COPY)
                                      : NULL;
        free(body);
        if (!r) return MHD_NO;
        MHD_add_response_header(r, "Allow", q->m.allow);
        MHD_add_response_header(r, "Content-Type", "application/json");
        harden(r, NULL);
        enum MHD_Result ret = MHD_queue_response(c, 405, r);
        MHD_destroy_response(r);
        svd_metrics_request(h->metrics, SVD_R_NONE, 405);
        return ret;
    }
    if (q->m.status)
        return send_error(h, c, SVD_R_NONE, (unsigned)q->m.status,
                          q->m.status == 404 ? "not_found" : "bad_request", q->m.message);
    return send_error(h, c, q->m.route, 401, "unauthorized", "a valid bearer token is required");
}

/* Counts a request's Content-Length and Transfer-Encoding headers. */
struct framing {
    unsigned cl, te;
};
static enum MHD_Result count_framing(void *cls, enum MHD_ValueKind kind, const char *key,
                                     const char *value)
{
    (void)kind;
    (void)value;
    struct framing *f = cls;
    if (key && strcasecmp(key, MHD_HTTP_HEADER_CONTENT_LENGTH) == 0) f->cl++;
    if (key && strcasecmp(key, MHD_HTTP_HEADER_TRANSFER_ENCODING) == 0) f->te++;
    return MHD_YES;
}

/* Whether the request's body length is ambiguous (RFC 9112 §6.3): more than
 * one Content-Length, more than one Transfer-Encoding, or both. A proxy in
 * front may have framed the body otherwise, and a request hidden in it would
 * be answered (request smuggling): such a request is refused. */
static bool framing_ambiguous(struct MHD_Connection *c)
{
    struct framing f = {0, 0};
    MHD_get_connection_values(c, MHD_HEADER_KIND, count_framing, &f);
    return f.cl > 1 || f.te > 1 || (f.cl && f.te);
}

static enum MHD_Result on_request(void *cls, struct MHD_Connection *c, const char *url,
                                  const char *method, const char *version, const char *upload_data,
                                  size_t *upload_data_size, void **con_cls)
{
    (void)version;
    svd_http *h = cls;
    req *q = *con_cls;
    if (!q) { /* first call: headers only, no body byte read yet */
        q = calloc(1, sizeof *q);
        if (!q) return MHD_NO;
        pthread_mutex_init(&q->mu, NULL);
        q->h = h;
        q->conn = c;
        *con_cls = q;
        svd_route_find(method, url, &q->m);
        const char *auth = MHD_lookup_connection_value(c, MHD_HEADER_KIND,
                                                       MHD_HTTP_HEADER_AUTHORIZATION);
        char addr[64];
        remote_addr(c, addr, sizeof addr);
        svd_client_id(h->tokens ? auth : NULL, addr, q->client, sizeof q->client);
        q->authorized = !h->tokens || q->m.route == SVD_R_HEALTH ||
                        svd_tokens_check(h->tokens, auth);
        if (framing_ambiguous(c)) { /* answered now: the body is never read */
            q->answered = 1;
            return send_error(h, c, SVD_R_NONE, 400, "bad_request",
                              "the body's length is ambiguous: more than one Content-Length or "
                              "Transfer-Encoding header, or both (RFC 9112 section 6.3)");
        }
        /* The answer is decided here, before any body byte is read. An answer
         * queued now makes libmicrohttpd send it and close the connection
         * without reading the body (docs/reliability.md, "Bounded reads"). */
        if (q->m.status == 0 && q->authorized &&
            (q->m.route == SVD_R_SUBMIT || q->m.route == SVD_R_PUT)) {
            int answered;
            enum MHD_Result r = upload_begin(q, &answered);
            if (answered) q->answered = 1;
            return r;
        }
        /* Not an upload: the body is not wanted. Up to SMALL_BODY declared
         * bytes are read and dropped and the answer comes after them, on a
         * connection that stays open; a larger or chunked body gets its
         * answer now, and the connection is closed. */
        uint64_t declared = 0;
        if (!body_is_small(c, &declared)) {
            q->answered = 1;
            if (q->m.status || !q->authorized) return answer_refused(q);
            char msg[200];
            if (declared)
                snprintf(msg, sizeof msg,
                         "this route takes no request body (%llu bytes declared, at most %u "
                         "are read)",
                         (unsigned long long)declared, SMALL_BODY);
            else
                snprintf(msg, sizeof msg,
                         "this route takes no request body (a chunked body is not read)");
            return send_error(h, c, q->m.route, 413, "too_large", msg);
        }
        return MHD_YES;
    }
    if (q->answered) { /* answered early; libmicrohttpd reads no body after that */
        *upload_data_size = 0;
        return MHD_YES;
    }
    if (q->m.status || !q->authorized) {
        if (*upload_data_size) { /* at most SMALL_BODY bytes: see the first call */
            *upload_data_size = 0;
            return MHD_YES;
        }
        return answer_refused(q);
    }
    if (q->kind == REQ_DRAIN) {
        if (*upload_data_size) {
            q->drained += *upload_data_size;
            *upload_data_size = 0;
            /* only a chunked body can get here: Content-Length was checked */
            return q->drained > h->cfg->max_upload_bytes ? cut_off(q) : MHD_YES;
        }
        return answer_known(q);
    }
    if (q->kind == REQ_UPLOAD) {
        upload *u = q->up;
        if (*upload_data_size) {
            size_t n = *upload_data_size;
            *upload_data_size = 0;
            u->total += n;
            if (u->total > h->cfg->max_upload_bytes) return cut_off(q);
            if (h->cfg->upload_timeout && sv_now() - u->started > h->cfg->upload_timeout) {
                svd_log_kv(h->log, SVD_LOG_WARN, "upload_cut_off", "client", q->client, "msg",
                           "upload over upload_timeout", (const char *)NULL);
                svd_metrics_request(h->metrics, q->m.route, 408);
                return MHD_NO;
            }
            if (!u->err_status) {
                sv_error e = {0};
                if (svd_multipart_feed(u->mp, (const uint8_t *)upload_data, n, &e) != SV_OK)
                    upload_fail(u, 400, "bad_multipart", "%s", e.message);
            }
            return MHD_YES;
        }
        return upload_end(q);
    }
    if (q->kind == REQ_WAIT) return handle_status(q, 0); /* resumed */
    if (q->m.key_prefix) { /* once: resolved, the full key replaces it */
        enum MHD_Result r;
        if (!resolve_prefix(q, &r)) {
            *upload_data_size = 0;
            return r;
        }
    }
    /* With tokens, a bake is its uploaders' alone; anyone
     * else gets the unknown key's own 404, so a key cannot be probed. */
    if (h->tokens &&
        (q->m.route == SVD_R_STATUS || q->m.route == SVD_R_ARTIFACT || q->m.route == SVD_R_DELETE ||
         q->m.route == SVD_R_VIEW || q->m.route == SVD_R_INPUT || q->m.route == SVD_R_INPUTS) &&
        !svd_jobs_owned(h->jobs, q->m.key, q->client)) {
        if (*upload_data_size) *upload_data_size = 0;
        return send_error(h, c, q->m.route, 404, "not_found",
                          q->m.route == SVD_R_ARTIFACT ? "no such bake or artifact"
                          : q->m.route == SVD_R_INPUT  ? "no such bake or input file"
                                                       : "no bake with this key");
    }
    if (q->m.route == SVD_R_STATUS && !*upload_data_size) return handle_status(q, 1);
    if (*upload_data_size) { /* a small body on a GET/DELETE (at most SMALL_BODY): dropped */
        *upload_data_size = 0;
        return MHD_YES;
    }
    switch (q->m.route) {
    case SVD_R_HEALTH: {
        /* the store's disk too: a node whose disk is low refuses new bakes
         * (507) but serves what it holds, so it stays 200 */
        bool d = atomic_load(&h->draining), low = false;
        uint64_t free_bytes = 0;
        svd_jobs_disk(h->jobs, &free_bytes, &low);
        char body[160];
        if (free_bytes == UINT64_MAX)
            snprintf(body, sizeof body, "{\"status\":\"%s\"}", d ? "draining" : "ok");
        else
            snprintf(body, sizeof body,
                     "{\"status\":\"%s\",\"disk\":\"%s\",\"disk_free_bytes\":%llu}",
                     d ? "draining" : "ok", low ? "low" : "ok", (unsigned long long)free_bytes);
        return send_text(h, c, q->m.route, d ? 503 : 200, body, "application/json");
    }
    case SVD_R_METRICS:
        return handle_metrics(q);
    case SVD_R_INFO:
        return handle_info(q);
    case SVD_R_OPENAPI:
        return send_text(h, c, q->m.route, 200, svd_openapi_json(NULL), "application/json");
    case SVD_R_ARTIFACT:
        return handle_artifact(q);
    case SVD_R_INPUT:
        return handle_input(q);
    case SVD_R_INPUTS: {
        char *body = NULL;
        sv_error e = {0};
        svd_jobs_rc rc = svd_jobs_inputs(h->jobs, q->m.key, &body, &e);
        return send_jobs(h, c, q->m.route, rc, body, &e);
    }
    case SVD_R_VIEW:
        return handle_view(q);
    case SVD_R_VIEWER:
        return serve_viewer_file(q, q->m.name, content_type_of(q->m.name));
    case SVD_R_DELETE: {
        char *body = NULL;
        sv_error e = {0};
        svd_jobs_rc rc = svd_jobs_delete(h->jobs, q->m.key, &body, &e);
        return send_jobs(h, c, q->m.route, rc, body, &e);
    }
    case SVD_R_STATUS:
        return handle_status(q, 0);
    case SVD_R_LIST:
        return handle_list(q);
    default:
        return send_error(h, c, SVD_R_NONE, 404, "not_found", "no such resource");
    }
}

/* libmicrohttpd 0.9.75 stores every query argument in the
 * connection's memory pool; ~1000 of them exhaust it, and the 431 it then
 * means to send needs that pool too: the connection hung until the idle
 * timeout (30 s) with no answer. MHD calls this with the raw request line
 * before it parses the arguments: a request with more arguments than any
 * route takes gets its 431 here, written on the socket, which is then shut
 * for writing (MHD's own failing answer finds it closed and drops the
 * connection at once). Returns NULL: the per-request context stays on_request's. */
#define URI_ARGS_MAX 64
static void *on_uri(void *cls, const char *uri, struct MHD_Connection *c)
{
    svd_http *h = cls;
    const char *qm = uri ? strchr(uri, '?') : NULL;
    size_t args = 0;
    if (qm) {
        args = 1;
        for (const char *p = qm; *p; p++) args += *p == '&' || *p == ';';
    }
    if (args <= URI_ARGS_MAX) return NULL;
    const union MHD_ConnectionInfo *ci = MHD_get_connection_info(c,
                                                                 MHD_CONNECTION_INFO_CONNECTION_FD);
    if (ci) {
        char *body = sylva_error_body("too_large", "more than 64 query arguments: no route "
                                                   "takes more than 3");
        char resp[512];
        int n = snprintf(resp, sizeof resp,
                         "HTTP/1.1 431 Request Header Fields Too Large\r\n"
                         "Content-Type: application/json\r\nConnection: close\r\n"
                         "Content-Length: %zu\r\n\r\n%s",
                         body ? strlen(body) : 0, body ? body : "");
        free(body);
        if (n > 0 && send(ci->connect_fd, resp, (size_t)n, MSG_NOSIGNAL | MSG_DONTWAIT) < 0) {
            /* the client is gone: MHD closes the connection anyway */
        }
        shutdown(ci->connect_fd, SHUT_WR);
    }
    char msg[96];
    snprintf(msg, sizeof msg, "refused a request line with %zu query arguments (431)", args);
    svd_log_kv(h->log, SVD_LOG_WARN, "http", "msg", msg, (const char *)NULL);
    return NULL;
}

static void on_completed(void *cls, struct MHD_Connection *c, void **con_cls,
                         enum MHD_RequestTerminationCode toe)
{
    (void)c;
    svd_http *h = cls;
    req *q = *con_cls;
    if (!q) return;
    if (q->kind == REQ_UPLOAD && toe != MHD_REQUEST_TERMINATED_COMPLETED_OK)
        svd_log_kv(h->log, SVD_LOG_INFO, "upload_aborted", "client", q->client, (const char *)NULL);
    if (q->kind == REQ_WAIT) svd_jobs_unwait(h->jobs, &q->waiter);
    upload_free(q->up);
    pthread_mutex_destroy(&q->mu);
    free(q);
    *con_cls = NULL;
}

static void mhd_logger(void *cls, const char *fmt, va_list ap)
{
    svd_http *h = cls;
    char msg[512];
    vsnprintf(msg, sizeof msg, fmt, ap);
    size_t n = strlen(msg);
    while (n && msg[n - 1] == '\n') msg[--n] = '\0';
    svd_log_kv(h->log, SVD_LOG_WARN, "http", "msg", msg, (const char *)NULL);
}

svd_http *svd_http_start(const svd_config *cfg, svd_jobs *jobs, svd_metrics *metrics, svd_log *log,
                         const svd_tokens *tokens, sv_error *err)
{
    svd_http *h = calloc(1, sizeof *h);
    if (!h) {
        sv_fail(err, SV_ERR_NOMEM, "http: out of memory");
        return NULL;
    }
    h->cfg = cfg;
    h->jobs = jobs;
    h->metrics = metrics;
    h->log = log;
    h->tokens = tokens;
    atomic_init(&h->draining, false);

    struct addrinfo hints = {0}, *ai = NULL;
    hints.ai_family = AF_UNSPEC;
    hints.ai_socktype = SOCK_STREAM;
    hints.ai_flags = AI_NUMERICSERV | AI_PASSIVE;
    char port[16];
    snprintf(port, sizeof port, "%u", cfg->port);
    int gai = getaddrinfo(cfg->listen_host, port, &hints, &ai);
    if (gai != 0 || !ai) {
        sv_fail(err, SV_ERR_IO, "listen: cannot resolve '%s': %s", cfg->listen_host,
                gai_strerror(gai));
        free(h);
        return NULL;
    }
    /* The listening socket is ours: SO_REUSEADDR always, so a
     * restart binds while the old connections linger (TIME_WAIT, FIN_WAIT);
     * SO_REUSEPORT only with reuse_port = on, so a second daemon on a port
     * in use fails instead of sharing it (the kernel split requests between
     * two stores). MHD 0.9.75's own option cannot say that: 0 there also
     * drops SO_REUSEADDR. */
    int lfd = socket(ai->ai_family, SOCK_STREAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
    int one = 1, e = 0;
    if (lfd < 0 || setsockopt(lfd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one) != 0 ||
        (cfg->reuse_port && setsockopt(lfd, SOL_SOCKET, SO_REUSEPORT, &one, sizeof one) != 0) ||
        bind(lfd, ai->ai_addr, ai->ai_addrlen) != 0 || listen(lfd, SOMAXCONN) != 0) {
        e = errno;
        if (lfd >= 0) close(lfd);
        freeaddrinfo(ai);
        sv_fail(err, SV_ERR_IO, "cannot listen on %s:%u: %s", cfg->listen_host, cfg->port,
                e == EADDRINUSE ? "address in use (another sylvad? reuse_port is off)"
                                : strerror(e));
        free(h);
        return NULL;
    }
    unsigned flags = MHD_USE_EPOLL_INTERNAL_THREAD | MHD_ALLOW_SUSPEND_RESUME | MHD_USE_ERROR_LOG;
    if (ai->ai_family == AF_INET6) flags |= MHD_USE_IPv6;
    freeaddrinfo(ai);
    h->d = MHD_start_daemon(flags, 0, NULL, NULL, on_request, h, MHD_OPTION_EXTERNAL_LOGGER,
                            mhd_logger, h, MHD_OPTION_LISTEN_SOCKET, (MHD_socket)lfd,
                            MHD_OPTION_THREAD_POOL_SIZE,
                            (unsigned int)(cfg->http_threads ? cfg->http_threads : 1),
                            MHD_OPTION_CONNECTION_LIMIT, (unsigned int)cfg->connection_limit,
                            /* one address holding many slow-header or long-poll
         * connections must not stop /v1/health for everyone */
                            MHD_OPTION_PER_IP_CONNECTION_LIMIT, (unsigned int)cfg->max_conns_per_ip,
                            MHD_OPTION_CONNECTION_MEMORY_LIMIT, (size_t)cfg->connection_memory,
                            MHD_OPTION_CONNECTION_TIMEOUT, (unsigned int)cfg->connection_timeout,
                            MHD_OPTION_NOTIFY_COMPLETED, on_completed, h,
                            MHD_OPTION_URI_LOG_CALLBACK, on_uri, h, MHD_OPTION_END);
    pthread_mutex_init(&h->wmu, NULL);
    pthread_cond_init(&h->wcv, NULL);
    if (h->d) h->watcher_started = pthread_create(&h->watcher, NULL, watch_uploads, h) == 0;
    if (!h->d || !h->watcher_started) {
        if (h->d) MHD_stop_daemon(h->d); /* closes lfd */
        else close(lfd);
        pthread_cond_destroy(&h->wcv);
        pthread_mutex_destroy(&h->wmu);
        sv_fail(err, SV_ERR_IO, "cannot start the HTTP server on %s:%u", cfg->listen_host,
                cfg->port);
        free(h);
        return NULL;
    }
    /* the bound port (port 0 picks one): from our socket */
    struct sockaddr_storage sa;
    socklen_t sl = sizeof sa;
    h->port = (uint16_t)cfg->port;
    if (getsockname(lfd, (struct sockaddr *)&sa, &sl) == 0)
        h->port = ntohs(sa.ss_family == AF_INET6 ? ((struct sockaddr_in6 *)&sa)->sin6_port
                                                 : ((struct sockaddr_in *)&sa)->sin_port);
    return h;
}

uint16_t svd_http_port(const svd_http *h)
{
    return h->port;
}

void svd_http_set_draining(svd_http *h)
{
    atomic_store(&h->draining, true);
}

void svd_http_stop(svd_http *h)
{
    if (!h) return;
    svd_jobs_sweep(h->jobs, 0, true); /* resume every long-poll first */
    pthread_mutex_lock(&h->wmu);
    h->stopping = true;
    pthread_cond_signal(&h->wcv);
    pthread_mutex_unlock(&h->wmu);
    pthread_join(h->watcher, NULL);
    MHD_stop_daemon(h->d);
    pthread_cond_destroy(&h->wcv);
    pthread_mutex_destroy(&h->wmu);
    free(h);
}
