/* mesh_precheck.c — structural check of OBJ, PLY, FBX and COLLADA uploads
 * before assimp sees them (glTF/GLB have gltf_precheck.c).
 *
 * Why: assimp 5.2.5's readers trust what a file declares and some of them loop
 * when the bytes end early. One: the 38-byte PLY header
 * "ply\nformat ascii 1.0\nelement vertex 1\n" (no end_header) keeps
 * PLY::DOM::ParseHeader spinning at 100 % CPU forever. So every format sylva
 * passes on is walked here first, iteratively and bounded by the input size,
 * and refused with SV_ERR_PARSE naming the file and the problem when it is not
 * complete:
 *  - PLY: the header must be complete (end_header and its line end within
 *    SV_PLY_MAX_HEADER bytes), every line a known keyword with known types, and
 *    the body must hold every element instance the header declares: the ascii
 *    body is walked token by token (list lengths included), the binary body
 *    record by record. So element counts are bounded by the file size. A
 *    polygon list (vertex_index / vertex_indices) may not be empty: assimp's
 *    TriangulateProcess aborts on a face with no index (found by fuzz_import).
 *  - OBJ: text (no NUL byte anywhere), lines split and '\' continuations
 *    joined as assimp does, no joined line longer than SV_OBJ_MAX_LINE, no
 *    face of more than SV_OBJ_MAX_FACE_VERTICES vertices.
 *  - FBX binary: the node-record tree is walked: every end offset, property
 *    list and array inside the file and consistent, nesting at most
 *    SV_FBX_MAX_DEPTH. FBX ascii: no control byte, strings closed, braces balanced
 *    (depth at most SV_FBX_MAX_DEPTH), only "Key: ... {...}" at the top level.
 *    Both: the FBXHeaderExtension, Objects and Connections sections assimp
 *    requires are there (its parser leaks when it fails on their absence).
 *  - COLLADA: no NUL byte, a <COLLADA root and the closing </COLLADA> tag;
 *    every *_array element has a positive count attribute (assimp 5.2.5
 *    crashes on a missing or zero count).
 * Counts the mesh declares (OBJ v/f lines, PLY vertex/face elements) are also
 * held against the import limits here, before assimp allocates for them.
 */
#include "import.h"

#include <ctype.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define SV_PLY_MAX_HEADER 65536u
#define SV_PLY_MAX_ELEMENTS 64u
#define SV_PLY_MAX_PROPERTIES 256u
#define SV_OBJ_MAX_LINE 65536u
/* vertices of one OBJ face: assimp triangulates a polygon in time quadratic
 * in its size, so the face size bounds the CPU a file of a given triangle
 * count can cost */
#define SV_OBJ_MAX_FACE_VERTICES 256u
#define SV_FBX_MAX_DEPTH 64u

/* ---------------------------------------------------------------- PLY ---- */

typedef struct ply_prop {
    uint8_t size;       /* bytes of the value (binary); 0 unused */
    uint8_t count_size; /* list: bytes of the length; 0 for a scalar */
    bool count_float;   /* list length type is float/double: refused */
    bool indices;       /* list named vertex_index(ices): a polygon, never empty */
} ply_prop;

typedef struct ply_elem {
    char name[32];
    uint64_t count;
    uint32_t nprops;
    ply_prop props[SV_PLY_MAX_PROPERTIES];
} ply_elem;

typedef struct ply_header {
    int format; /* 0 ascii, 1 binary little endian, 2 binary big endian */
    uint32_t nelems;
    ply_elem elems[SV_PLY_MAX_ELEMENTS];
    size_t body; /* offset of the first byte after end_header's line end */
} ply_header;

/* Size in bytes of a PLY scalar type name; 0 when unknown. *is_float for
 * float/double. */
static unsigned ply_type_size(const char *t, size_t len, bool *is_float)
{
    static const struct {
        const char *name;
        unsigned size;
        bool fl;
    } types[] = {{"char", 1, 0},  {"uchar", 1, 0},  {"short", 2, 0},   {"ushort", 2, 0},
                 {"int", 4, 0},   {"uint", 4, 0},   {"float", 4, 1},   {"double", 8, 1},
                 {"int8", 1, 0},  {"uint8", 1, 0},  {"int16", 2, 0},   {"uint16", 2, 0},
                 {"int32", 4, 0}, {"uint32", 4, 0}, {"float32", 4, 1}, {"float64", 8, 1}};
    for (size_t i = 0; i < sizeof types / sizeof types[0]; i++)
        if (strlen(types[i].name) == len && memcmp(types[i].name, t, len) == 0) {
            if (is_float) *is_float = types[i].fl;
            return types[i].size;
        }
    return 0;
}

/* Splits line[0..n) into at most max tokens (spaces and tabs). */
static size_t tokens(const char *line, size_t n, const char **tok, size_t *len, size_t max)
{
    size_t k = 0, i = 0;
    while (i < n && k < max) {
        while (i < n && (line[i] == ' ' || line[i] == '\t')) i++;
        if (i >= n) break;
        size_t s = i;
        while (i < n && line[i] != ' ' && line[i] != '\t') i++;
        tok[k] = line + s;
        len[k] = i - s;
        k++;
    }
    while (i < n && (line[i] == ' ' || line[i] == '\t')) i++;
    return i < n ? max + 1 : k; /* max + 1: more tokens than expected */
}

static bool tok_is(const char *t, size_t len, const char *word)
{
    return strlen(word) == len && memcmp(t, word, len) == 0;
}

static sv_status ply_parse_header(const uint8_t *d, size_t n, const char *shown, ply_header *h,
                                  sv_error *err)
{
    memset(h, 0, sizeof *h);
    size_t lim = n < SV_PLY_MAX_HEADER ? n : SV_PLY_MAX_HEADER;
    size_t i = 0;
    unsigned lineno = 0;
    bool ended = false;
    while (i < lim) {
        const uint8_t *nl = memchr(d + i, '\n', lim - i);
        if (!nl) break; /* the header's last line has no end within the bound */
        size_t eol = (size_t)(nl - d), len = eol - i;
        const char *line = (const char *)d + i;
        if (len && line[len - 1] == '\r') len--;
        lineno++;
        for (size_t k = 0; k < len; k++)
            if ((unsigned char)line[k] < 0x20 && line[k] != '\t')
                return sv_fail(err, SV_ERR_PARSE, "'%s': PLY header line %u has a control byte",
                               shown, lineno);
        const char *tok[8];
        size_t tl[8];
        size_t nt = tokens(line, len, tok, tl, 6);
        i = eol + 1;
        if (lineno == 1) continue; /* "ply", checked by the sniffer */
        if (nt == 0) continue;
        if (tok_is(tok[0], tl[0], "comment") || tok_is(tok[0], tl[0], "obj_info")) continue;
        if (nt > 6)
            return sv_fail(err, SV_ERR_PARSE, "'%s': PLY header line %u has too many words", shown,
                           lineno);
        if (lineno == 2) {
            if (nt != 3 || !tok_is(tok[0], tl[0], "format"))
                return sv_fail(err, SV_ERR_PARSE, "'%s': PLY header line 2 is not 'format ...'",
                               shown);
            if (tok_is(tok[1], tl[1], "ascii")) h->format = 0;
            else if (tok_is(tok[1], tl[1], "binary_little_endian")) h->format = 1;
            else if (tok_is(tok[1], tl[1], "binary_big_endian")) h->format = 2;
            else
                return sv_fail(err, SV_ERR_PARSE, "'%s': PLY format '%.*s' is not ascii or binary",
                               shown, (int)(tl[1] < 40 ? tl[1] : 40), tok[1]);
            continue;
        }
        if (tok_is(tok[0], tl[0], "end_header")) {
            if (nt != 1)
                return sv_fail(err, SV_ERR_PARSE, "'%s': PLY end_header line %u has extra words",
                               shown, lineno);
            ended = true;
            h->body = i;
            break;
        }
        if (tok_is(tok[0], tl[0], "element")) {
            if (nt != 3)
                return sv_fail(err, SV_ERR_PARSE,
                               "'%s': PLY header line %u: expected 'element NAME COUNT'", shown,
                               lineno);
            if (h->nelems >= SV_PLY_MAX_ELEMENTS)
                return sv_fail(err, SV_ERR_PARSE, "'%s': PLY header declares more than %u elements",
                               shown, SV_PLY_MAX_ELEMENTS);
            uint64_t c = 0;
            if (tl[2] == 0 || tl[2] > 10)
                return sv_fail(
                    err, SV_ERR_PARSE,
                    "'%s': PLY element count '%.*s' on line %u is not a count below 2^32", shown,
                    (int)(tl[2] < 40 ? tl[2] : 40), tok[2], lineno);
            for (size_t k = 0; k < tl[2]; k++) {
                if (!isdigit((unsigned char)tok[2][k]))
                    return sv_fail(err, SV_ERR_PARSE,
                                   "'%s': PLY element count '%.*s' on line %u is not a number",
                                   shown, (int)tl[2], tok[2], lineno);
                c = c * 10 + (uint64_t)(tok[2][k] - '0');
            }
            if (c > UINT32_MAX)
                return sv_fail(err, SV_ERR_PARSE,
                               "'%s': PLY element count %llu on line %u is not below 2^32", shown,
                               (unsigned long long)c, lineno);
            ply_elem *e = &h->elems[h->nelems++];
            memset(e, 0, sizeof *e);
            size_t nl2 = tl[1] < sizeof e->name - 1 ? tl[1] : sizeof e->name - 1;
            memcpy(e->name, tok[1], nl2);
            e->count = c;
            continue;
        }
        if (tok_is(tok[0], tl[0], "property")) {
            if (h->nelems == 0)
                return sv_fail(err, SV_ERR_PARSE,
                               "'%s': PLY property on line %u before any element", shown, lineno);
            ply_elem *e = &h->elems[h->nelems - 1];
            if (e->nprops >= SV_PLY_MAX_PROPERTIES)
                return sv_fail(err, SV_ERR_PARSE,
                               "'%s': PLY element '%s' has more than %u properties", shown, e->name,
                               SV_PLY_MAX_PROPERTIES);
            ply_prop *p = &e->props[e->nprops];
            bool fl = false;
            if (nt >= 2 && tok_is(tok[1], tl[1], "list")) {
                if (nt != 5)
                    return sv_fail(
                        err, SV_ERR_PARSE,
                        "'%s': PLY header line %u: expected 'property list TYPE TYPE NAME'", shown,
                        lineno);
                p->count_size = (uint8_t)ply_type_size(tok[2], tl[2], &fl);
                p->count_float = fl;
                p->size = (uint8_t)ply_type_size(tok[3], tl[3], NULL);
                p->indices = tok_is(tok[4], tl[4], "vertex_indices") ||
                             tok_is(tok[4], tl[4], "vertex_index");
                if (!p->count_size || !p->size || fl)
                    return sv_fail(err, SV_ERR_PARSE,
                                   "'%s': PLY list property on line %u has an unknown or "
                                   "non-integer type",
                                   shown, lineno);
            } else {
                if (nt != 3)
                    return sv_fail(err, SV_ERR_PARSE,
                                   "'%s': PLY header line %u: expected 'property TYPE NAME'", shown,
                                   lineno);
                p->size = (uint8_t)ply_type_size(tok[1], tl[1], NULL);
                if (!p->size)
                    return sv_fail(err, SV_ERR_PARSE,
                                   "'%s': PLY property type '%.*s' on line %u is unknown", shown,
                                   (int)(tl[1] < 40 ? tl[1] : 40), tok[1], lineno);
            }
            e->nprops++;
            continue;
        }
        return sv_fail(err, SV_ERR_PARSE, "'%s': PLY header line %u ('%.*s') is not a header line",
                       shown, lineno, (int)(tl[0] < 40 ? tl[0] : 40), tok[0]);
    }
    if (!ended) {
        if (n > SV_PLY_MAX_HEADER)
            return sv_fail(err, SV_ERR_PARSE,
                           "'%s': PLY header has no end_header line within its first %u bytes",
                           shown, SV_PLY_MAX_HEADER);
        return sv_fail(err, SV_ERR_PARSE,
                       "'%s': PLY header is incomplete: the file ends before its end_header line",
                       shown);
    }
    for (uint32_t k = 0; k < h->nelems; k++)
        if (h->elems[k].count && !h->elems[k].nprops)
            return sv_fail(err, SV_ERR_PARSE,
                           "'%s': PLY element '%s' has %llu instances and no properties", shown,
                           h->elems[k].name, (unsigned long long)h->elems[k].count);
    return SV_OK;
}

/* Next whitespace-separated token of the ascii body at *pos; false at the end. */
static bool next_token(const uint8_t *d, size_t n, size_t *pos, size_t *start, size_t *len)
{
    size_t i = *pos;
    while (i < n && isspace(d[i])) i++;
    if (i >= n) return false;
    *start = i;
    while (i < n && !isspace(d[i])) i++;
    *len = i - *start;
    *pos = i;
    return true;
}

static bool numeric_token(const uint8_t *t, size_t len)
{
    if (len == 0 || len > 64) return false;
    for (size_t k = 0; k < len; k++) {
        int c = t[k];
        if (!(isdigit(c) || c == '-' || c == '+' || c == '.' || c == 'e' || c == 'E')) return false;
    }
    return true;
}

static uint64_t rd_uint(const uint8_t *p, unsigned size, bool big)
{
    uint64_t v = 0;
    for (unsigned k = 0; k < size; k++) v |= (uint64_t)p[big ? size - 1 - k : k] << (8 * k);
    return v;
}

/* Walks the body: every declared instance must be there, whole. */
static sv_status ply_walk_body(const uint8_t *d, size_t n, const char *shown, const ply_header *h,
                               sv_error *err)
{
    size_t pos = h->body;
    for (uint32_t ei = 0; ei < h->nelems; ei++) {
        const ply_elem *e = &h->elems[ei];
        for (uint64_t inst = 0; inst < e->count; inst++) {
            for (uint32_t pi = 0; pi < e->nprops; pi++) {
                const ply_prop *p = &e->props[pi];
                uint64_t values = 1;
                if (h->format == 0) {
                    size_t s, len;
                    if (p->count_size) {
                        if (!next_token(d, n, &pos, &s, &len)) goto short_body;
                        uint64_t c = 0;
                        if (len > 10) goto bad_count;
                        for (size_t k = 0; k < len; k++) {
                            if (!isdigit(d[s + k])) goto bad_count;
                            c = c * 10 + (uint64_t)(d[s + k] - '0');
                        }
                        values = c;
                        if (!values && p->indices) goto empty_polygon;
                    }
                    for (uint64_t v = 0; v < values; v++) {
                        if (!next_token(d, n, &pos, &s, &len)) goto short_body;
                        if (!numeric_token(d + s, len))
                            return sv_fail(err, SV_ERR_PARSE,
                                           "'%s': PLY element '%s' %llu holds '%.*s', not a number",
                                           shown, e->name, (unsigned long long)inst,
                                           (int)(len < 40 ? len : 40), (const char *)d + s);
                    }
                } else {
                    bool big = h->format == 2;
                    if (p->count_size) {
                        if (n - pos < p->count_size) goto short_body;
                        uint64_t c = rd_uint(d + pos, p->count_size, big);
                        /* signed count types: a negative length is huge unsigned */
                        if (c > n) goto bad_count;
                        pos += p->count_size;
                        values = c;
                        if (!values && p->indices) goto empty_polygon;
                    }
                    if ((n - pos) / p->size < values) goto short_body;
                    pos += (size_t)(values * p->size);
                }
                continue;
            short_body:
                return sv_fail(err, SV_ERR_PARSE,
                               "'%s': PLY body ends inside element '%s' %llu of the %llu the "
                               "header declares",
                               shown, e->name, (unsigned long long)inst,
                               (unsigned long long)e->count);
            bad_count:
                return sv_fail(err, SV_ERR_PARSE,
                               "'%s': PLY element '%s' %llu has a bad list length", shown, e->name,
                               (unsigned long long)inst);
            empty_polygon:
                /* assimp 5.2.5 aborts on it (TriangulateProcess asserts) */
                return sv_fail(err, SV_ERR_PARSE,
                               "'%s': PLY element '%s' %llu has no vertex indices", shown, e->name,
                               (unsigned long long)inst);
            }
        }
    }
    return SV_OK;
}

/* Declared counts against the limits, and a cheap bound before the walk: each
 * instance takes at least one byte per property (binary) or two (ascii: a
 * digit and a separator). */
static sv_status ply_check_counts(size_t n, const char *shown, const ply_header *h,
                                  const sv_limits *lim, sv_error *err)
{
    for (uint32_t k = 0; k < h->nelems; k++) {
        const ply_elem *e = &h->elems[k];
        if (e->count == 0) continue;
        if (strcmp(e->name, "vertex") == 0 && e->count > lim->max_vertices)
            return sv_fail(err, SV_ERR_LIMIT, "'%s' declares %llu vertices (limit %llu)", shown,
                           (unsigned long long)e->count, (unsigned long long)lim->max_vertices);
        if (strcmp(e->name, "face") == 0 && e->count > lim->max_triangles)
            return sv_fail(err, SV_ERR_LIMIT, "'%s' declares %llu triangles (limit %llu)", shown,
                           (unsigned long long)e->count, (unsigned long long)lim->max_triangles);
        uint64_t body = n - h->body, per = h->format == 0 ? 2 : 1;
        if (e->count > body / per / e->nprops + 1)
            return sv_fail(
                err, SV_ERR_PARSE,
                "'%s': PLY element '%s' declares %llu instances, more than its %llu-byte "
                "body can hold",
                shown, e->name, (unsigned long long)e->count, (unsigned long long)body);
    }
    return SV_OK;
}

static sv_status ply_check(const uint8_t *d, size_t n, const char *shown, const sv_limits *lim,
                           sv_error *err)
{
    ply_header *h = malloc(sizeof *h); /* ~50 KiB: not on the stack */
    if (!h) return sv_fail(err, SV_ERR_NOMEM, "'%s': out of memory for the PLY header", shown);
    sv_status st = ply_parse_header(d, n, shown, h, err);
    if (st == SV_OK) st = ply_check_counts(n, shown, h, lim, err);
    if (st == SV_OK) st = ply_walk_body(d, n, shown, h, err);
    free(h);
    return st;
}

/* ---------------------------------------------------------------- OBJ ---- */

/* Whether c ends a line for assimp's OBJ reader (ParsingUtils' IsLineEnd). */
static bool obj_line_end(uint8_t c)
{
    return c == '\n' || c == '\r' || c == '\f' || c == 0;
}

/* OBJ, read line by line exactly as assimp 5.2.5's reader reads it
 * (IOStreamBuffer::getNextDataLine): a line ends at '\n', '\r' or '\f', and a
 * '\' right before a line end joins the next line to it (assimp skips to the
 * next '\n'). Counts, lengths and the face size are held on those joined
 * lines, not on physical ones: a face continued over many short lines is one
 * face. A continuation assimp would read past the end, or that would hide the
 * rest of a line (a '\' then a lone '\r' or '\f'), is refused. */
static sv_status obj_check(const uint8_t *d, size_t n, const char *shown, const sv_limits *lim,
                           sv_error *err)
{
    if (memchr(d, 0, n))
        return sv_fail(err, SV_ERR_PARSE, "'%s': OBJ text holds a NUL byte at offset %zu", shown,
                       (size_t)((const uint8_t *)memchr(d, 0, n) - d));
    uint64_t verts = 0, tris = 0, line = 0;
    size_t i = 0;
    while (i < n) {
        line++;
        uint64_t start_line = line, len = 0, toks = 0;
        int kind = 0; /* 1: v, 2: f, 3: another keyword */
        bool in = false;
        size_t k = i;
        while (k < n && !obj_line_end(d[k])) {
            if (d[k] == '\\' && (k + 1 == n || obj_line_end(d[k + 1]))) {
                if (k + 1 < n && d[k + 1] == '\n') k += 2;
                else if (k + 2 < n && d[k + 1] == '\r' && d[k + 2] == '\n') k += 3;
                else
                    return sv_fail(err, SV_ERR_PARSE,
                                   "'%s': OBJ line %llu ends in a '\\' continuation that is not "
                                   "followed by a newline",
                                   shown, (unsigned long long)line);
                line++;
                continue;
            }
            bool sp = d[k] == ' ' || d[k] == '\t' || d[k] == '\v';
            if (!sp && !in) {
                toks++;
                if (toks == 1)
                    kind = d[k] == 'v' && (k + 1 == n || d[k + 1] == ' ' || d[k + 1] == '\t')   ? 1
                           : d[k] == 'f' && (k + 1 == n || d[k + 1] == ' ' || d[k + 1] == '\t') ? 2
                                                                                                : 3;
            }
            in = !sp;
            if (++len > SV_OBJ_MAX_LINE)
                return sv_fail(err, SV_ERR_PARSE,
                               "'%s': OBJ line %llu is longer than %u bytes (with its '\\' "
                               "continuations)",
                               shown, (unsigned long long)start_line, SV_OBJ_MAX_LINE);
            k++;
        }
        if (kind == 1) {
            verts++;
        } else if (kind == 2) {
            uint64_t nv = toks - 1;
            if (nv > SV_OBJ_MAX_FACE_VERTICES)
                return sv_fail(err, SV_ERR_LIMIT,
                               "'%s': OBJ face on line %llu has %llu vertices (limit %u)", shown,
                               (unsigned long long)start_line, (unsigned long long)nv,
                               SV_OBJ_MAX_FACE_VERTICES);
            if (nv >= 3) tris += nv - 2;
        }
        i = k < n && d[k] == '\r' && k + 1 < n && d[k + 1] == '\n' ? k + 2 : k + 1;
    }
    if (tris > lim->max_triangles)
        return sv_fail(err, SV_ERR_LIMIT, "'%s' declares %llu triangles (limit %llu)", shown,
                       (unsigned long long)tris, (unsigned long long)lim->max_triangles);
    if (verts > lim->max_vertices)
        return sv_fail(err, SV_ERR_LIMIT, "'%s' declares %llu vertices (limit %llu)", shown,
                       (unsigned long long)verts, (unsigned long long)lim->max_vertices);
    return SV_OK;
}

/* ---------------------------------------------------------------- FBX ---- */

typedef struct fbx_walk {
    const uint8_t *d;
    size_t n;
    bool wide; /* version >= 7500: 64-bit offsets and counts */
    const char *shown;
    sv_error *err;
} fbx_walk;

/* The top-level sections assimp's FBX reader requires (it fails without them,
 * and its parser leaks what it has read when it fails). */
static const char *const fbx_required[] = {"FBXHeaderExtension", "Objects", "Connections"};
#define FBX_NREQUIRED 3u

/* Marks name[0..len) in *seen (bit i for fbx_required[i]). */
static void fbx_note_section(const uint8_t *name, size_t len, unsigned *seen)
{
    for (unsigned k = 0; k < FBX_NREQUIRED; k++)
        if (strlen(fbx_required[k]) == len && memcmp(fbx_required[k], name, len) == 0)
            *seen |= 1u << k;
}

static sv_status fbx_missing_section(unsigned seen, const char *shown, sv_error *err)
{
    for (unsigned k = 0; k < FBX_NREQUIRED; k++)
        if (!(seen & (1u << k)))
            return sv_fail(err, SV_ERR_PARSE, "'%s': FBX file has no top-level %s section", shown,
                           fbx_required[k]);
    return SV_OK;
}

static sv_status fbx_fail(const fbx_walk *w, size_t at, const char *what)
{
    return sv_fail(w->err, SV_ERR_PARSE, "'%s': FBX record at offset %zu: %s", w->shown, at, what);
}

/* Checks the property list [p, end) holding `count` properties. */
static sv_status fbx_props(const fbx_walk *w, size_t rec, size_t p, size_t end, uint64_t count)
{
    const uint8_t *d = w->d;
    for (uint64_t k = 0; k < count; k++) {
        if (p >= end) return fbx_fail(w, rec, "property list is shorter than its count");
        uint8_t t = d[p++];
        size_t left = end - p;
        switch (t) {
        case 'C':
        case 'B':
            if (left < 1) goto short_prop;
            p += 1;
            break;
        case 'Y':
            if (left < 2) goto short_prop;
            p += 2;
            break;
        case 'I':
        case 'F':
            if (left < 4) goto short_prop;
            p += 4;
            break;
        case 'D':
        case 'L':
            if (left < 8) goto short_prop;
            p += 8;
            break;
        case 'S':
        case 'R': {
            if (left < 4) goto short_prop;
            uint64_t len = rd_uint(d + p, 4, false);
            if (left - 4 < len) goto short_prop;
            p += 4 + (size_t)len;
            break;
        }
        case 'f':
        case 'd':
        case 'l':
        case 'i':
        case 'b': {
            if (left < 12) goto short_prop;
            uint64_t alen = rd_uint(d + p, 4, false), enc = rd_uint(d + p + 4, 4, false),
                     clen = rd_uint(d + p + 8, 4, false);
            unsigned es = (t == 'd' || t == 'l') ? 8 : (t == 'b') ? 1 : 4;
            if (left - 12 < clen) goto short_prop;
            if (enc == 0) {
                if (alen * es != clen)
                    return fbx_fail(w, rec, "array length disagrees with its size");
            } else if (enc == 1) {
                /* zlib inflates at most ~1032:1 */
                if (alen * es > clen * 1032 + 64)
                    return fbx_fail(w, rec, "compressed array claims more than zlib can inflate");
            } else {
                return fbx_fail(w, rec, "array has an unknown encoding");
            }
            p += 12 + (size_t)clen;
            break;
        }
        default:
            return fbx_fail(w, rec, "property has an unknown type");
        }
    }
    if (p != end) return fbx_fail(w, rec, "property list length disagrees with its properties");
    return SV_OK;
short_prop:
    return fbx_fail(w, rec, "property runs past its list");
}

/* Walks the records of one list starting at pos and ending before `end`
 * (the file end for the top level), iteratively with an explicit stack. A
 * nested list ends with a null record; so does the top-level one. */
static sv_status fbx_binary_check(const uint8_t *d, size_t n, const char *shown, sv_error *err)
{
    if (n < 27) return sv_fail(err, SV_ERR_PARSE, "'%s': FBX binary header is cut short", shown);
    uint64_t version = rd_uint(d + 23, 4, false);
    fbx_walk w = {d, n, version >= 7500, shown, err};
    size_t hdr = w.wide ? 25 : 13, osz = w.wide ? 8 : 4;
    size_t stack[SV_FBX_MAX_DEPTH + 1]; /* end offsets of the open records */
    unsigned depth = 0;
    size_t pos = 27, limit = n;
    unsigned seen = 0;
    for (;;) {
        if (pos == limit) { /* a list that fills its parent (or the file) exactly */
            if (depth == 0) return fbx_missing_section(seen, shown, err);
            limit = depth >= 2 ? stack[depth - 2] : n;
            depth--;
            continue;
        }
        if (limit - pos < hdr)
            return fbx_fail(&w, pos, "record header runs past its parent or the file");
        uint64_t endo = rd_uint(d + pos, (unsigned)osz, false);
        uint64_t nprops = rd_uint(d + pos + osz, (unsigned)osz, false);
        uint64_t plen = rd_uint(d + pos + 2 * osz, (unsigned)osz, false);
        uint8_t namelen = d[pos + 3 * osz];
        if (endo == 0) { /* null record: the list closes */
            for (size_t k = 0; k < hdr; k++)
                if (d[pos + k]) return fbx_fail(&w, pos, "null record is not all zero");
            pos += hdr;
            if (depth == 0) /* the footer follows; assimp stops here */
                return fbx_missing_section(seen, shown, err);
            if (pos != stack[depth - 1])
                return fbx_fail(&w, pos, "nested list ends before its record does");
            limit = depth >= 2 ? stack[depth - 2] : n;
            depth--;
            continue;
        }
        if (endo > limit || endo <= pos + hdr)
            return fbx_fail(&w, pos, "end offset is outside its parent or the file");
        size_t end = (size_t)endo, p = pos + hdr;
        if (end - p < namelen) return fbx_fail(&w, pos, "name runs past the record");
        if (depth == 0) fbx_note_section(d + p, namelen, &seen);
        p += namelen;
        if (end - p < plen) return fbx_fail(&w, pos, "property list runs past the record");
        sv_status st = fbx_props(&w, pos, p, p + (size_t)plen, nprops);
        if (st != SV_OK) return st;
        p += (size_t)plen;
        if (p == end) { /* no nested list */
            pos = end;
            continue;
        }
        if (depth >= SV_FBX_MAX_DEPTH)
            return sv_fail(err, SV_ERR_PARSE, "'%s': FBX records nest deeper than %u", shown,
                           SV_FBX_MAX_DEPTH);
        stack[depth++] = end;
        pos = p;
        limit = end;
    }
}

/* Ascii FBX: no NUL, strings closed, braces balanced, and at the top level
 * only "Key: values {...}" elements (assimp's parser leaks every element it
 * has read when it meets a top-level element without its block, or stray
 * text, at the end of the file; real files have nothing else at top level). */
static sv_status fbx_ascii_check(const uint8_t *d, size_t n, const char *shown, sv_error *err)
{
    for (size_t i = 0; i < n; i++)
        if ((d[i] < 0x20 && d[i] != '\t' && d[i] != '\n' && d[i] != '\r') || d[i] == 0x7f)
            return sv_fail(err, SV_ERR_PARSE,
                           "'%s': FBX text holds control byte 0x%02x at offset %zu", shown, d[i],
                           i);
    unsigned depth = 0, elements = 0, seen = 0;
    bool in_values = false; /* top level: after "Key:", before its '{' */
    size_t line = 1, key_line = 0;
    for (size_t i = 0; i < n; i++) {
        uint8_t c = d[i];
        if (c == '\n') {
            line++;
            continue;
        }
        if (c == ';') { /* comment to the line end */
            while (i + 1 < n && d[i + 1] != '\n') i++;
            continue;
        }
        if (depth == 0 && !in_values) {
            if (isspace(c)) continue;
            size_t s = i;
            while (i < n && (isalnum(d[i]) || d[i] == '_' || d[i] == '|' || d[i] == '-')) i++;
            if (i == s || i >= n || d[i] != ':')
                return sv_fail(err, SV_ERR_PARSE,
                               "'%s': FBX line %zu: expected 'Key: ... {' at the top level", shown,
                               line);
            in_values = true;
            key_line = line;
            elements++;
            fbx_note_section(d + s, i - s, &seen);
            continue;
        }
        if (c == '"') {
            size_t s = i++;
            while (i < n && d[i] != '"') {
                if (d[i] == '\n') line++;
                i++;
            }
            if (i >= n)
                return sv_fail(err, SV_ERR_PARSE, "'%s': FBX string at offset %zu is not closed",
                               shown, s);
        } else if (c == '{') {
            if (++depth > SV_FBX_MAX_DEPTH)
                return sv_fail(err, SV_ERR_PARSE, "'%s': FBX braces nest deeper than %u (line %zu)",
                               shown, SV_FBX_MAX_DEPTH, line);
            in_values = false;
        } else if (c == '}') {
            if (depth == 0)
                return sv_fail(err, SV_ERR_PARSE, "'%s': FBX '}' without '{' on line %zu", shown,
                               line);
            depth--;
        }
    }
    if (depth)
        return sv_fail(err, SV_ERR_PARSE, "'%s': FBX text ends with %u braces open", shown, depth);
    if (in_values)
        return sv_fail(err, SV_ERR_PARSE,
                       "'%s': FBX top-level element on line %zu has no {...} block", shown,
                       key_line);
    if (!elements) return sv_fail(err, SV_ERR_PARSE, "'%s': FBX text holds no element", shown);
    return fbx_missing_section(seen, shown, err);
}

/* ------------------------------------------------------------ COLLADA ---- */

static const uint8_t *find(const uint8_t *d, size_t n, const char *needle)
{
    size_t m = strlen(needle);
    for (size_t i = 0; n >= m && i <= n - m; i++) {
        const uint8_t *p = memchr(d + i, needle[0], n - m + 1 - i);
        if (!p) return NULL;
        i = (size_t)(p - d);
        if (memcmp(p, needle, m) == 0) return p;
    }
    return NULL;
}

/* Checks the start tag of a COLLADA *_array element at d[0] == '<' (its name
 * ends in "_array"): it must carry count="N" with N a positive decimal. assimp
 * 5.2.5 dereferences a null pointer when the count is missing, empty, not a
 * number or 0 (found by fuzz_import). Malformed markup is left to assimp's XML
 * parser, which refuses it. *end gets the offset just past the tag. */
static sv_status dae_array_tag(const uint8_t *d, size_t n, size_t name_len, const char *shown,
                               size_t *end, sv_error *err)
{
    size_t i = 1 + name_len;
    bool counted = false;
    for (;;) {
        while (i < n && isspace(d[i])) i++;
        if (i >= n || d[i] == '>' || d[i] == '/') break;
        size_t an = i;
        while (i < n && !isspace(d[i]) && d[i] != '=' && d[i] != '>' && d[i] != '/') i++;
        size_t al = i - an;
        while (i < n && isspace(d[i])) i++;
        if (i >= n || d[i] != '=') break;
        i++;
        while (i < n && isspace(d[i])) i++;
        if (i >= n || (d[i] != '"' && d[i] != '\'')) break;
        uint8_t q = d[i++];
        size_t vs = i;
        while (i < n && d[i] != q) i++;
        if (i >= n) break;
        size_t vl = i - vs;
        i++;
        if (al == 5 && memcmp(d + an, "count", 5) == 0) {
            uint64_t c = 0;
            bool digits = vl > 0 && vl <= 10;
            for (size_t k = 0; digits && k < vl; k++) {
                if (!isdigit(d[vs + k])) digits = false;
                else c = c * 10 + (uint64_t)(d[vs + k] - '0');
            }
            if (!digits || c == 0)
                return sv_fail(err, SV_ERR_PARSE,
                               "'%s': COLLADA <%.*s> has count=\"%.*s\": a positive count is "
                               "needed",
                               shown, (int)name_len, (const char *)d + 1, (int)(vl < 20 ? vl : 20),
                               (const char *)d + vs);
            counted = true;
        }
    }
    while (i < n && d[i] != '>') i++;
    *end = i;
    if (!counted)
        return sv_fail(err, SV_ERR_PARSE, "'%s': COLLADA <%.*s> has no count attribute", shown,
                       (int)name_len, (const char *)d + 1);
    return SV_OK;
}

static sv_status dae_check(const uint8_t *d, size_t n, const char *shown, sv_error *err)
{
    if (memchr(d, 0, n))
        return sv_fail(err, SV_ERR_PARSE, "'%s': COLLADA text holds a NUL byte", shown);
    const uint8_t *root = find(d, n, "<COLLADA");
    if (!root) return sv_fail(err, SV_ERR_PARSE, "'%s': no <COLLADA> root element", shown);
    size_t after = (size_t)(root - d);
    if (!find(root, n - after, "</COLLADA>"))
        return sv_fail(err, SV_ERR_PARSE,
                       "'%s': COLLADA document is incomplete: no closing </COLLADA> tag", shown);
    for (size_t i = 0; i < n; i++) {
        if (d[i] != '<') continue;
        size_t k = i + 1;
        while (k < n && (isalnum(d[k]) || d[k] == '_' || d[k] == ':' || d[k] == '-' || d[k] == '.'))
            k++;
        size_t len = k - i - 1;
        if (len < 6 || memcmp(d + k - 6, "_array", 6) != 0) continue;
        size_t end = k;
        sv_status st = dae_array_tag(d + i, n - i, len, shown, &end, err);
        if (st != SV_OK) return st;
        i += end;
    }
    return SV_OK;
}

/* -------------------------------------------------------------- entry ---- */

sv_status sv_mesh_precheck(sv_format fmt, const uint8_t *data, size_t size, const char *shown,
                           const sv_limits *limits, sv_error *err)
{
    sv_limits lim = sv_limits_resolve(limits ? *limits : (sv_limits){0});
    if (!shown) shown = "(unnamed)";
    if (!data || size == 0) return sv_fail(err, SV_ERR_PARSE, "'%s' is empty", shown);
    switch (fmt) {
    case SV_FORMAT_PLY:
        return ply_check(data, size, shown, &lim, err);
    case SV_FORMAT_OBJ:
        return obj_check(data, size, shown, &lim, err);
    case SV_FORMAT_FBX:
        if (size >= 18 && memcmp(data, "Kaydara FBX Binary", 18) == 0)
            return fbx_binary_check(data, size, shown, err);
        return fbx_ascii_check(data, size, shown, err);
    case SV_FORMAT_COLLADA:
        return dae_check(data, size, shown, err);
    case SV_FORMAT_GLB:
    case SV_FORMAT_GLTF:
        return SV_OK; /* sv_gltf_precheck */
    case SV_FORMAT_UNKNOWN:
        break;
    }
    return sv_fail(err, SV_ERR_FORMAT, "'%s' is not a mesh format sylva accepts", shown);
}
