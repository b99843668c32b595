/* sv.c — status codes, errors, limits and small helpers shared by core. */
#define _POSIX_C_SOURCE 200809L
#include "sv.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

static const struct {
    const char *code;
    const char *message;
} status_table[SV_STATUS_COUNT] = {
    [SV_OK] = {"ok", "success"},
    [SV_ERR_NOMEM] = {"nomem", "out of memory or size overflow"},
    [SV_ERR_IO] = {"io", "input/output error"},
    [SV_ERR_FORMAT] = {"format", "unknown or unsupported file format"},
    [SV_ERR_PARSE] = {"parse", "malformed file"},
    [SV_ERR_INVALID] = {"invalid", "mesh fails validation"},
    [SV_ERR_LIMIT] = {"limit", "over a configured limit"},
    [SV_ERR_REFUSED] = {"refused", "reference to a file outside the upload"},
    [SV_ERR_MISSING] = {"missing", "a file the mesh references was not supplied"},
    [SV_ERR_SPEC] = {"spec", "bad bake spec"},
    [SV_ERR_RENDER] = {"render", "rendering failed"},
    [SV_ERR_UNBAKEABLE] = {"unbakeable", "mesh imports but cannot be baked"},
    [SV_ERR_CANCELLED] = {"cancelled", "cancelled by the caller"},
    [SV_ERR_INTERNAL] = {"internal", "internal error"},
};

const char *sv_status_code(sv_status st)
{
    if ((unsigned)st >= SV_STATUS_COUNT) return "unknown";
    return status_table[st].code;
}

const char *sv_status_message(sv_status st)
{
    if ((unsigned)st >= SV_STATUS_COUNT) return "unknown status";
    return status_table[st].message;
}

sv_status sv_fail(sv_error *err, sv_status st, const char *fmt, ...)
{
    if (err) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(err->message, sizeof err->message, fmt, ap);
        va_end(ap);
        err->status = st;
    }
    return st;
}

sv_limits sv_limits_resolve(sv_limits l)
{
    if (!l.max_triangles) l.max_triangles = 5000000;
    if (!l.max_vertices) l.max_vertices = 15000000;
    if (!l.max_texture_size) l.max_texture_size = 16384;
    if (!l.max_materials) l.max_materials = 4096;
    if (!l.max_node_depth) l.max_node_depth = 256;
    if (!l.max_nodes) l.max_nodes = 100000;
    if (!l.max_file_bytes) l.max_file_bytes = (uint64_t)1 << 30;
    if (!l.max_texture_bytes) l.max_texture_bytes = (uint64_t)1 << 30;
    if (!l.max_textures_bytes) l.max_textures_bytes = (uint64_t)1 << 30;
    return l;
}

bool sv_mul_size(size_t a, size_t b, size_t *out)
{
    if (b && a > SIZE_MAX / b) return false;
    *out = a * b;
    return true;
}

void *sv_calloc(size_t a, size_t b)
{
    size_t n;
    if (!sv_mul_size(a, b, &n)) return NULL;
    return calloc(n ? n : 1, 1);
}

double sv_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

sv_status sv_write_file(const char *path, const void *data, size_t size, sv_error *err)
{
    size_t plen = strlen(path);
    char *tmp = malloc(plen + 5);
    if (!tmp) return sv_fail(err, SV_ERR_NOMEM, "cannot write %s: out of memory", path);
    memcpy(tmp, path, plen);
    memcpy(tmp + plen, ".tmp", 5);
    FILE *f = fopen(tmp, "wb");
    int e = f ? 0 : errno;
    if (f && fwrite(data, 1, size, f) != size) e = errno ? errno : EIO;
    if (f && fclose(f) != 0 && !e) e = errno ? errno : EIO;
    if (!e && rename(tmp, path) != 0) e = errno;
    if (e && f) unlink(tmp);
    free(tmp);
    if (e) return sv_fail(err, SV_ERR_IO, "cannot write %s: %s", path, strerror(e));
    return SV_OK;
}
