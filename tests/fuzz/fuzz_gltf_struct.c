/* fuzz_gltf_struct.c — libFuzzer target, structure-aware: the input bytes are
 * not the file but choices that build a GLB (glTF 2.0 §4.4.3) whose JSON is
 * always well-formed and close to valid: accessors (count, componentType,
 * type, byteOffset, normalized, min/max, sparse indices and values),
 * bufferViews (byteOffset, byteLength, byteStride), meshes, a node tree,
 * and now and then a duplicate key or a key with a NUL. Byte mutation rarely
 * gets past the JSON syntax; here every input reaches the accessor rules of
 * the pre-check (core/io/gltf_precheck.c) and, when it passes them, assimp
 * (core/io/import.c). Whatever the pre-check lets through must import or be
 * refused with a status: never crash, leak or read out of bounds. */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "import.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
const char *__lsan_default_suppressions(void);

/* as fuzz_import.c: assimp's parsers leak what they read when they fail */
const char *__lsan_default_suppressions(void)
{
    return "leak:libassimp.so\n";
}

typedef struct pick {
    const uint8_t *d;
    size_t n, i;
} pick;

/* The next choice in 0..k-1 (0 when the input is used up). */
static unsigned next(pick *p, unsigned k)
{
    return p->i < p->n ? p->d[p->i++] % k : 0;
}

/* An integer field's value: mostly small and in range, sometimes a boundary. */
static long long number(pick *p, long long typical)
{
    static const long long edge[] = {0, 1, 2, 3, 4, 12, 36, 255, 256, 65535, 4000000000LL,
                                     2147483648LL, 9007199254740992LL, -1};
    unsigned c = next(p, 4);
    if (c < 3) return typical + (long long)next(p, 4);
    return edge[next(p, sizeof edge / sizeof edge[0])];
}

typedef struct buf {
    char *s;
    size_t n, cap;
} buf;

/* Appends printf-style text to b (grown as needed; b->s stays NULL if out of
 * memory at the start). */
static void put(buf *b, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void put(buf *b, const char *fmt, ...)
{
    va_list ap;
    if (!b->s) {
        b->s = malloc(4096);
        if (!b->s) return;
        b->cap = 4096;
        b->n = 0;
    }
    for (;;) {
        va_start(ap, fmt);
        int k = vsnprintf(b->s + b->n, b->cap - b->n, fmt, ap);
        va_end(ap);
        if (k < 0) return;
        if ((size_t)k < b->cap - b->n) {
            b->n += (size_t)k;
            return;
        }
        size_t nc = (b->cap + (size_t)k + 1) * 2;
        char *ns = realloc(b->s, nc);
        if (!ns) return;
        b->s = ns;
        b->cap = nc;
    }
}

/* A key: now and then a decoy with a NUL, or written twice by the caller. */
static void key(buf *b, pick *p, const char *k)
{
    if (next(p, 32) == 0) put(b, "\"%s\\u0000\":0,", k);
    put(b, "\"%s\":", k);
}

static const char *const types[] = {"SCALAR", "VEC2", "VEC3", "VEC4", "MAT4"};
static const int ctypes[] = {5120, 5121, 5122, 5123, 5125, 5126, 5124};

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    pick p = {data, size, 0};
    buf j = {0};
    unsigned nview = 1 + next(&p, 3), nacc = 1 + next(&p, 4), nbin = 16 * (1 + next(&p, 8));
    put(&j, "{\"asset\":{\"version\":\"2.0\"},\"buffers\":[{\"byteLength\":%u}],", nbin);
    put(&j, "\"bufferViews\":[");
    for (unsigned v = 0; v < nview; v++) {
        put(&j, "%s{\"buffer\":0,", v ? "," : "");
        key(&j, &p, "byteOffset");
        put(&j, "%lld,", number(&p, 0));
        if (next(&p, 3) == 0) put(&j, "\"byteStride\":%lld,", number(&p, 12));
        key(&j, &p, "byteLength");
        put(&j, "%lld}", number(&p, nbin / 2));
    }
    put(&j, "],\"accessors\":[");
    for (unsigned a = 0; a < nacc; a++) {
        put(&j, "%s{", a ? "," : "");
        if (next(&p, 8)) put(&j, "\"bufferView\":%lld,", number(&p, 0) % (nview + 1));
        if (next(&p, 4) == 0) put(&j, "\"byteOffset\":%lld,", number(&p, 0));
        put(&j, "\"componentType\":%d,", ctypes[next(&p, 7)]);
        if (next(&p, 6) == 0) put(&j, "\"normalized\":%s,", next(&p, 2) ? "true" : "1");
        unsigned t = next(&p, 5);
        if (next(&p, 6) == 0) {
            unsigned k = next(&p, 5);
            put(&j, "\"min\":[");
            for (unsigned c = 0; c < k; c++) put(&j, "%s%d", c ? "," : "", (int)next(&p, 9) - 4);
            put(&j, "],");
        }
        if (next(&p, 3) == 0) {
            put(&j, "\"sparse\":{\"count\":%lld,\"indices\":{\"bufferView\":%lld,", number(&p, 1),
                number(&p, 0) % (nview + 1));
            key(&j, &p, "byteOffset");
            put(&j, "%lld,\"componentType\":%d},\"values\":{\"bufferView\":%lld,\"byteOffset\":%lld}},",
                number(&p, 0), ctypes[next(&p, 7)], number(&p, 0) % (nview + 1), number(&p, 0));
        }
        key(&j, &p, "count");
        put(&j, "%lld,\"type\":\"%s\"}", number(&p, 3), types[t]);
    }
    unsigned prims = 1 + next(&p, 2);
    put(&j, "],\"meshes\":[{\"primitives\":[");
    for (unsigned k = 0; k < prims; k++) {
        put(&j, "%s{\"attributes\":{\"POSITION\":%u}", k ? "," : "", next(&p, nacc));
        if (next(&p, 2)) put(&j, ",\"indices\":%u", next(&p, nacc));
        if (next(&p, 4) == 0) put(&j, ",\"mode\":%u", next(&p, 7));
        put(&j, "}");
    }
    unsigned nnode = 1 + next(&p, 4);
    put(&j, "]}],\"nodes\":[");
    for (unsigned k = 0; k < nnode; k++) {
        put(&j, "%s{\"mesh\":0", k ? "," : "");
        if (k + 1 < nnode && next(&p, 2)) {
            put(&j, ",");
            key(&j, &p, "children");
            put(&j, "[%u]", k + 1 + next(&p, 2));
        }
        put(&j, "}");
    }
    put(&j, "],\"scenes\":[{\"nodes\":[0]}],\"scene\":0");
    if (next(&p, 16) == 0) put(&j, ",\"nodes\":[]"); /* a duplicate top-level key */
    put(&j, "}");
    if (!j.s) return 0;
    /* the GLB: header, JSON chunk padded with spaces, BIN chunk from the rest */
    size_t jl = (j.n + 3) & ~(size_t)3, bl = nbin;
    size_t total = 12 + 8 + jl + 8 + bl;
    uint8_t *g = calloc(1, total);
    if (!g) {
        free(j.s);
        return 0;
    }
    uint32_t hdr[5] = {0x46546C67u, 2, (uint32_t)total, (uint32_t)jl, 0x4E4F534Au};
    memcpy(g, hdr, sizeof hdr);
    memcpy(g + 20, j.s, j.n);
    memset(g + 20 + j.n, ' ', jl - j.n);
    uint32_t bh[2] = {(uint32_t)bl, 0x004E4942u};
    memcpy(g + 20 + jl, bh, sizeof bh);
    for (size_t k = 0; k < bl; k++) g[28 + jl + k] = (uint8_t)next(&p, 256);
    free(j.s);
    sv_limits lim = {0};
    lim.max_triangles = 100000;
    lim.max_vertices = 300000;
    lim.max_node_depth = 32;
    lim.max_nodes = 1000;
    sv_file files[1] = {{"s.glb", g, total}};
    sv_import_options opt = {0};
    opt.limits = lim;
    sv_mesh *mesh = NULL;
    sv_import_info info;
    sv_error e = {0};
    if (sv_import(files, 1, &opt, &mesh, &info, &e) == SV_OK) sv_mesh_destroy(mesh);
    free(g);
    return 0;
}
