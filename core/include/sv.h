/* sv.h — sylva core: status codes, error struct, limits and shared conventions.
 *
 * Conventions used by every core header (stated once, here):
 *   - Units: metres. Axes: right-handed, +Y up (glTF's convention). Importers
 *     convert other units/up axes into this on the way in.
 *   - Front faces wind counter-clockwise; foliage is rendered two-sided.
 *   - Positions are stored as float; geometric algorithms compute in double.
 *   - Every function that can fail returns sv_status and, when the caller passes
 *     a non-NULL sv_error, writes a one-line message naming the problem.
 *   - create/destroy pairs: destroy(NULL) is a no-op.
 *   - No mutable globals: everything is passed in a context or options struct.
 */
#ifndef SV_H
#define SV_H

#include <stdarg.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#define SV_VERSION "0.1.0"

typedef enum sv_status {
    SV_OK = 0,
    SV_ERR_NOMEM,      /* allocation failed or size overflow */
    SV_ERR_IO,         /* reading/writing a file failed */
    SV_ERR_FORMAT,     /* unknown or unsupported file format (HTTP 415) */
    SV_ERR_PARSE,      /* malformed file: truncated, lying header, bad syntax */
    SV_ERR_INVALID,    /* mesh content fails validation (NaN, bad index, empty) */
    SV_ERR_LIMIT,      /* over a configured limit (counts, sizes, depth) (413) */
    SV_ERR_REFUSED,    /* a reference to a file outside the upload (abs, .., file:) */
    SV_ERR_MISSING,    /* a file the mesh references (.mtl, texture) was not supplied */
    SV_ERR_SPEC,       /* bad bake spec (400) */
    SV_ERR_RENDER,     /* the renderer failed */
    SV_ERR_UNBAKEABLE, /* imports, but cannot be baked (422) */
    SV_ERR_CANCELLED,  /* the caller's progress callback returned false */
    SV_ERR_INTERNAL,   /* a bug: an invariant did not hold */
    SV_STATUS_COUNT
} sv_status;

/* Short stable code for a status ("parse", "limit", ...), for JSON and logs.
 * Never returns NULL. */
const char *sv_status_code(sv_status st);

/* Human-readable description of a status. Never returns NULL. */
const char *sv_status_message(sv_status st);

typedef struct sv_error {
    sv_status status;
    char message[512];
} sv_error;

/* Records st and a printf-style message in err (if err is non-NULL) and returns
 * st, so callers can write `return sv_fail(err, SV_ERR_PARSE, "...", ...);`.
 * An existing message is overwritten. */
sv_status sv_fail(sv_error *err, sv_status st, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));

/* Limits on what the importer and validator accept. Zero fields mean "use the
 * default" (see sv_limits_default). */
typedef struct sv_limits {
    uint64_t max_triangles;    /* default 5,000,000 */
    uint64_t max_vertices;     /* default 15,000,000 */
    uint32_t max_texture_size; /* per side, default 16384 */
    uint32_t max_materials;    /* default 4096 */
    uint32_t max_node_depth;   /* glTF node depth, default 256 */
    uint32_t max_nodes;        /* glTF node count, default 100,000 */
    uint64_t max_file_bytes;   /* per file, default 1 GiB */
    uint64_t max_texture_bytes; /* memory one texture's decode may take (its decoded
                                   pixels and the decoder's own copy), default 1 GiB */
    uint64_t max_textures_bytes; /* decoded RGBA8 bytes of all an import's textures,
                                    default 1 GiB */
} sv_limits;

/* Returns l with every zero field replaced by its default. */
sv_limits sv_limits_resolve(sv_limits l);

/* Overflow-checked size arithmetic: returns false on overflow. */
bool sv_mul_size(size_t a, size_t b, size_t *out);

/* malloc(a*b) with overflow check; NULL on overflow or failure. calloc'ed (zeroed). */
void *sv_calloc(size_t a, size_t b);

/* Monotonic clock in seconds (for per-stage timings). */
double sv_now(void);

/* Writes size bytes to path through path.tmp and a rename, so no reader ever
 * sees a partial file. SV_ERR_IO naming the path and the system's reason. */
sv_status sv_write_file(const char *path, const void *data, size_t size, sv_error *err);

/* 64-bit FNV-1a over n bytes at p, continuing h (start from
 * SV_FNV1A_BASIS): a dedup or memo key, never a checksum (the image memo,
 * texture names, the billboard cloud's ε memo). */
#define SV_FNV1A_BASIS 14695981039346656037ull
static inline uint64_t sv_fnv1a(uint64_t h, const void *p, size_t n)
{
    const unsigned char *c = (const unsigned char *)p;
    for (size_t i = 0; i < n; i++) h = (h ^ c[i]) * 1099511628211ull;
    return h;
}

#endif
