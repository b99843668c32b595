/* config.c — sylvad settings from a config file and flags (see config.h). */
#include "config.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void svd_config_defaults(svd_config *c)
{
    memset(c, 0, sizeof *c);
    snprintf(c->listen_host, sizeof c->listen_host, "127.0.0.1");
    c->port = 8080;
    snprintf(c->store, sizeof c->store, "sylva-store");
    snprintf(c->prlimit, sizeof c->prlimit, "/usr/bin/prlimit");
    c->log_level = SVD_LOG_INFO;
    c->http_threads = 4;
    c->connection_limit = 1024;
    c->max_conns_per_ip = 64;
    c->connection_memory = 64 * 1024;
    c->connection_timeout = 30;
    c->max_upload_bytes = (uint64_t)1 << 30;
    c->client_upload_bytes = (uint64_t)2 << 30;
    c->upload_timeout = 1800;
    c->disk_reserve_bytes = (uint64_t)256 << 20;
    c->max_mesh_bytes = (uint64_t)512 << 20;
    c->max_files = 256;
    c->queue_max = 1024;
    c->queue_per_client = 64;
    c->job_timeout = 900;
    c->attempts = 3;
    c->max_wait = 60;
    c->drain_timeout = 30;
    c->store_max_bytes = (uint64_t)20 << 30;
#if defined(__SANITIZE_ADDRESS__)
    /* A sanitizer build's worker is sanitized too, and ASan reserves terabytes
     * of virtual address space for its shadow: an RLIMIT_AS kills it at start.
     * Only sanitizer builds (tests) default to no address-space limit. */
    c->worker_as_bytes = 0;
#else
    c->worker_as_bytes = (uint64_t)8 << 30;
#endif
    c->worker_cpu_seconds = 1800;
    c->worker_nofile = 256;
    c->worker_fsize_bytes = (uint64_t)4 << 30;
    c->worker_sandbox = true;
    c->worker_nice = 10;
    c->worker_pool = true;
    c->worker_shader_cache = true;
}

bool svd_parse_bool(const char *s, bool *out)
{
    static const char *const yes[] = {"on", "true", "yes", "1"}, *const no[] = {"off", "false",
                                                                                "no", "0"};
    for (size_t i = 0; s && i < 4; i++) {
        if (strcmp(s, yes[i]) == 0) return *out = true, true;
        if (strcmp(s, no[i]) == 0) return *out = false, true;
    }
    return false;
}

bool svd_parse_size(const char *s, uint64_t *out)
{
    if (!s || !*s || *s == '-' || *s == '+') return false;
    errno = 0;
    char *end;
    unsigned long long v = strtoull(s, &end, 10);
    if (errno || end == s) return false;
    unsigned shift = 0;
    if (*end == 'K' || *end == 'k') shift = 10, end++;
    else if (*end == 'M' || *end == 'm') shift = 20, end++;
    else if (*end == 'G' || *end == 'g') shift = 30, end++;
    if (*end) return false;
    if (shift && v > (UINT64_MAX >> shift)) return false;
    *out = (uint64_t)v << shift;
    return true;
}

static bool parse_u32(const char *s, uint32_t *out)
{
    uint64_t v;
    if (!svd_parse_size(s, &v) || v > UINT32_MAX) return false;
    *out = (uint32_t)v;
    return true;
}

enum kind { K_STR, K_U32, K_SIZE, K_BOOL, K_LISTEN, K_LEVEL };
static const struct setting {
    const char *name;
    enum kind kind;
    size_t off;
    size_t cap;
} settings[] = {
#define S(n, k, f)                                                  \
    {                                                               \
        n, k, offsetof(svd_config, f), sizeof(((svd_config *)0)->f) \
    }
    S("listen", K_LISTEN, listen_host),
    S("port_file", K_STR, port_file),
    S("store", K_STR, store),
    S("worker", K_STR, worker),
    S("prlimit", K_STR, prlimit),
    S("viewer_dir", K_STR, viewer_dir),
    S("tokens", K_STR, tokens),
    S("log_file", K_STR, log_file),
    S("log_level", K_LEVEL, log_level),
    S("workers", K_U32, workers),
    S("http_threads", K_U32, http_threads),
    S("connection_limit", K_U32, connection_limit),
    S("max_conns_per_ip", K_U32, max_conns_per_ip),
    S("reuse_port", K_BOOL, reuse_port),
    S("connection_memory", K_SIZE, connection_memory),
    S("connection_timeout", K_U32, connection_timeout),
    S("max_upload_bytes", K_SIZE, max_upload_bytes),
    S("client_upload_bytes", K_SIZE, client_upload_bytes),
    S("upload_timeout", K_U32, upload_timeout),
    S("disk_reserve_bytes", K_SIZE, disk_reserve_bytes),
    S("max_mesh_bytes", K_SIZE, max_mesh_bytes),
    S("max_files", K_U32, max_files),
    S("queue_max", K_U32, queue_max),
    S("queue_per_client", K_U32, queue_per_client),
    S("job_timeout", K_U32, job_timeout),
    S("attempts", K_U32, attempts),
    S("max_wait", K_U32, max_wait),
    S("drain_timeout", K_U32, drain_timeout),
    S("store_max_bytes", K_SIZE, store_max_bytes),
    S("worker_as_bytes", K_SIZE, worker_as_bytes),
    S("worker_cpu_seconds", K_U32, worker_cpu_seconds),
    S("worker_nofile", K_U32, worker_nofile),
    S("worker_fsize_bytes", K_SIZE, worker_fsize_bytes),
    S("worker_sandbox", K_BOOL, worker_sandbox),
    S("worker_nice", K_U32, worker_nice),
    S("worker_pool", K_BOOL, worker_pool),
    S("worker_shader_cache", K_BOOL, worker_shader_cache),
#undef S
};

static sv_status set_listen(svd_config *c, const char *v, sv_error *err)
{
    const char *colon = strrchr(v, ':');
    if (!colon || colon == v)
        return sv_fail(err, SV_ERR_SPEC, "listen: expected HOST:PORT, got '%s'", v);
    size_t hl = (size_t)(colon - v);
    const char *h = v;
    if (hl >= 2 && h[0] == '[' && h[hl - 1] == ']') h++, hl -= 2; /* [::1]:8080 */
    if (hl == 0 || hl >= sizeof c->listen_host)
        return sv_fail(err, SV_ERR_SPEC, "listen: bad host in '%s'", v);
    uint32_t port;
    if (!parse_u32(colon + 1, &port) || port > 65535 || strpbrk(colon + 1, "KkMmGg"))
        return sv_fail(err, SV_ERR_SPEC, "listen: bad port in '%s' (0..65535)", v);
    memcpy(c->listen_host, h, hl);
    c->listen_host[hl] = '\0';
    c->port = port;
    return SV_OK;
}

sv_status svd_config_set(svd_config *c, const char *key, const char *value, sv_error *err)
{
    char k[64];
    size_t n = strlen(key);
    if (n >= sizeof k) return sv_fail(err, SV_ERR_SPEC, "unknown setting '%s'", key);
    for (size_t i = 0; i <= n; i++) k[i] = key[i] == '-' ? '_' : key[i];
    for (size_t i = 0; i < sizeof settings / sizeof settings[0]; i++) {
        const struct setting *s = &settings[i];
        if (strcmp(s->name, k) != 0) continue;
        char *field = (char *)c + s->off;
        switch (s->kind) {
        case K_STR:
            if (strlen(value) >= s->cap) return sv_fail(err, SV_ERR_SPEC, "%s: value too long", k);
            memcpy(field, value, strlen(value) + 1);
            return SV_OK;
        case K_U32:
            if (!parse_u32(value, (uint32_t *)(void *)field))
                return sv_fail(err, SV_ERR_SPEC, "%s: expected a non-negative integer, got '%s'", k,
                               value);
            if (field == (char *)&c->worker_nice && c->worker_nice > 19)
                return sv_fail(err, SV_ERR_SPEC, "worker_nice: expected 0..19, got '%s'", value);
            return SV_OK;
        case K_SIZE:
            if (!svd_parse_size(value, (uint64_t *)(void *)field))
                return sv_fail(err, SV_ERR_SPEC, "%s: expected a size like 512M, got '%s'", k,
                               value);
            return SV_OK;
        case K_BOOL:
            if (!svd_parse_bool(value, (bool *)(void *)field))
                return sv_fail(err, SV_ERR_SPEC, "%s: expected on or off, got '%s'", k, value);
            return SV_OK;
        case K_LISTEN:
            return set_listen(c, value, err);
        case K_LEVEL:
            if (!svd_log_level_parse(value, &c->log_level))
                return sv_fail(err, SV_ERR_SPEC,
                               "log_level: expected debug, info, warn or error, got '%s'", value);
            return SV_OK;
        }
    }
    return sv_fail(err, SV_ERR_SPEC, "unknown setting '%s'", key);
}

static char *trim(char *s)
{
    while (*s == ' ' || *s == '\t') s++;
    size_t n = strlen(s);
    while (n && (s[n - 1] == ' ' || s[n - 1] == '\t' || s[n - 1] == '\r' || s[n - 1] == '\n'))
        s[--n] = '\0';
    return s;
}

sv_status svd_config_load_file(svd_config *c, const char *path, sv_error *err)
{
    FILE *f = fopen(path, "re");
    if (!f) return sv_fail(err, SV_ERR_IO, "%s: cannot open config: %s", path, strerror(errno));
    char line[2048];
    unsigned lineno = 0;
    sv_status st = SV_OK;
    while (fgets(line, sizeof line, f)) {
        lineno++;
        if (!strchr(line, '\n') && !feof(f)) {
            st = sv_fail(err, SV_ERR_SPEC, "%s:%u: line too long", path, lineno);
            break;
        }
        char *hash = strchr(line, '#');
        if (hash) *hash = '\0';
        char *s = trim(line);
        if (!*s) continue;
        char *eq = strchr(s, '=');
        if (!eq) {
            st = sv_fail(err, SV_ERR_SPEC, "%s:%u: expected 'key = value'", path, lineno);
            break;
        }
        *eq = '\0';
        sv_error e = {0};
        if (svd_config_set(c, trim(s), trim(eq + 1), &e) != SV_OK) {
            st = sv_fail(err, SV_ERR_SPEC, "%s:%u: %s", path, lineno, e.message);
            break;
        }
    }
    fclose(f);
    return st;
}

sv_status svd_config_from_args(svd_config *c, int argc, char **argv, sv_error *err)
{
    svd_config_defaults(c);
    for (int i = 1; i < argc; i++) {
        if (strcmp(argv[i], "--help") == 0 || strcmp(argv[i], "-h") == 0)
            return sv_fail(err, SV_ERR_CANCELLED, "help");
        if (strcmp(argv[i], "--config") == 0 || strncmp(argv[i], "--config=", 9) == 0) {
            const char *path = argv[i][8] == '=' ? argv[i] + 9
                                                 : (i + 1 < argc ? argv[i + 1] : NULL);
            if (!path) return sv_fail(err, SV_ERR_SPEC, "--config needs a file");
            sv_status st = svd_config_load_file(c, path, err);
            if (st != SV_OK) return st;
        }
    }
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (strncmp(a, "--", 2) != 0)
            return sv_fail(err, SV_ERR_SPEC, "unexpected argument '%s'", a);
        char key[64];
        const char *val;
        const char *eq = strchr(a, '=');
        size_t kl = eq ? (size_t)(eq - a - 2) : strlen(a + 2);
        if (kl == 0 || kl >= sizeof key) return sv_fail(err, SV_ERR_SPEC, "unknown flag '%s'", a);
        memcpy(key, a + 2, kl);
        key[kl] = '\0';
        if (eq) {
            val = eq + 1;
        } else {
            if (i + 1 >= argc) return sv_fail(err, SV_ERR_SPEC, "flag %s needs a value", a);
            val = argv[++i];
        }
        if (strcmp(key, "config") == 0) continue;
        sv_error e = {0};
        if (svd_config_set(c, key, val, &e) != SV_OK)
            return sv_fail(err, SV_ERR_SPEC, "--%s: %s", key, e.message);
    }
    return SV_OK;
}

bool svd_config_is_loopback(const svd_config *c)
{
    const char *h = c->listen_host;
    return strncmp(h, "127.", 4) == 0 || strcmp(h, "::1") == 0 || strcmp(h, "localhost") == 0;
}

const char *svd_config_usage(void)
{
    return "usage: sylvad [--config FILE] [--listen HOST:PORT] [--store DIR] [--workers N]\n"
           "              [--worker PATH] [--tokens FILE] [--port-file FILE] [--log-level LEVEL]\n"
           "              [--log-file FILE] [--SETTING VALUE ...]\n"
           "Every config-file setting is also a flag (max_upload_bytes -> --max-upload-bytes).\n"
           "See docs/operations.md.\n";
}

int svd_config_write_port_file(const char *path, unsigned port)
{
    char tmp[SVD_PATH_MAX + 8];
    snprintf(tmp, sizeof tmp, "%s.tmp", path);
    FILE *f = fopen(tmp, "w");
    if (!f) return -1;
    fprintf(f, "%u\n", port);
    if (fclose(f) != 0) return -1;
    return rename(tmp, path);
}
