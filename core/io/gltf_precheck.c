/* gltf_precheck.c — structural check of a glTF 2.0 document (JSON or GLB) before
 * assimp sees it.
 *
 * Implements the container and reference rules of the glTF 2.0 specification
 * (Khronos, §4.4 "File names and URIs", §4.4.3 "GLB file format specification",
 * §3.5 "Concepts: Nodes and hierarchy" — the node hierarchy must be a set of
 * disjoint strict trees — §3.6 "Binary data storage" — accessor bounds). It
 * exists because assimp 5.2.5 recurses once per node level (a 20,000-deep chain
 * overflows its stack), opens whatever local path a uri names, and trusts
 * declared lengths. Everything here is iterative and bounded by the input size.
 */
#include "import.h"
#include "json_strict.h"

#include <cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define GLB_MAGIC 0x46546C67u /* "glTF" */
#define GLB_JSON 0x4E4F534Au  /* "JSON" */
#define GLB_BIN 0x004E4942u   /* "BIN\0" */

static uint32_t rd32(const uint8_t *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

typedef struct buffer_info {
    uint64_t declared;   /* byteLength */
    const uint8_t *data; /* bytes, when available in memory */
    size_t size;         /* actual size of data */
    uint8_t *owned;      /* decoded data: URI, freed at the end */
} buffer_info;

typedef struct precheck {
    const sv_file *files;
    size_t count;
    sv_limits lim;
    sv_error *err;
    const cJSON *nodes, *meshes, *accessors, *views, *buffers, *images, *materials;
    int n_nodes, n_meshes, n_accessors, n_views, n_buffers, n_images, n_materials;
    buffer_info *buf;
    int32_t *parent;
    uint32_t *stack;
    uint64_t *mesh_tris, *mesh_verts;
} precheck;

/* Reads an optional non-negative integer member. Returns SV_OK with *present
 * false when absent; SV_ERR_PARSE naming `what` when present but not an integer. */
static sv_status get_uint(precheck *pc, const cJSON *obj, const char *key, const char *what,
                          int idx, uint64_t *out, bool *present)
{
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(obj, key);
    *present = false;
    if (!v) return SV_OK;
    double d = v->valuedouble;
    if (!cJSON_IsNumber(v) || !(d >= 0) || d > 9007199254740992.0 || floor(d) != d)
        return sv_fail(pc->err, SV_ERR_PARSE, "glTF %s %d: '%s' is not a non-negative integer",
                       what, idx, key);
    *out = (uint64_t)d;
    *present = true;
    return SV_OK;
}

/* An optional index member that must be < n. Returns -1 in *out when absent. */
static sv_status get_index(precheck *pc, const cJSON *obj, const char *key, const char *what,
                           int idx, int n, const char *target, int64_t *out)
{
    uint64_t v = 0;
    bool present;
    sv_status st = get_uint(pc, obj, key, what, idx, &v, &present);
    if (st != SV_OK) return st;
    *out = -1;
    if (!present) return SV_OK;
    if (v >= (uint64_t)n)
        return sv_fail(pc->err, SV_ERR_PARSE, "glTF %s %d: '%s' refers to %s %llu of %d", what, idx,
                       key, target, (unsigned long long)v, n);
    *out = (int64_t)v;
    return SV_OK;
}

static sv_status get_array(precheck *pc, const cJSON *root, const char *key, const cJSON **arr,
                           int *n)
{
    const cJSON *a = cJSON_GetObjectItemCaseSensitive(root, key);
    *arr = NULL;
    *n = 0;
    if (!a) return SV_OK;
    if (!cJSON_IsArray(a)) return sv_fail(pc->err, SV_ERR_PARSE, "glTF '%s' is not an array", key);
    *arr = a;
    *n = cJSON_GetArraySize(a);
    return SV_OK;
}

static int hexval(int c)
{
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    return -1;
}

/* Percent-decodes a URI reference into a new string (caller frees); NULL on a
 * bad escape, an encoded NUL, or allocation failure. */
static char *uri_decode(const char *s)
{
    size_t n = strlen(s);
    char *o = malloc(n + 1), *w = o;
    if (!o) return NULL;
    for (size_t i = 0; i < n; i++) {
        if (s[i] == '%') {
            int a = i + 2 < n ? hexval((unsigned char)s[i + 1]) : -1;
            int b = a >= 0 ? hexval((unsigned char)s[i + 2]) : -1;
            if (a < 0 || b < 0 || (a == 0 && b == 0)) {
                free(o);
                return NULL;
            }
            *w++ = (char)(a * 16 + b);
            i += 2;
        } else {
            *w++ = s[i];
        }
    }
    *w = 0;
    return o;
}

static int b64val(int c)
{
    if (c >= 'A' && c <= 'Z') return c - 'A';
    if (c >= 'a' && c <= 'z') return c - 'a' + 26;
    if (c >= '0' && c <= '9') return c - '0' + 52;
    if (c == '+' || c == '-') return 62;
    if (c == '/' || c == '_') return 63;
    return -1;
}

/* Decodes base64 (padding optional). Returns false on a bad character. When out
 * is NULL only counts. */
static bool b64_decode(const char *s, size_t n, uint8_t *out, size_t *out_n)
{
    while (n && s[n - 1] == '=') n--;
    uint32_t acc = 0;
    int bits = 0;
    size_t k = 0;
    for (size_t i = 0; i < n; i++) {
        int v = b64val((unsigned char)s[i]);
        if (v < 0) return false;
        acc = (acc << 6) | (uint32_t)v;
        bits += 6;
        if (bits >= 8) {
            bits -= 8;
            if (out) out[k] = (uint8_t)(acc >> bits);
            k++;
        }
    }
    *out_n = k;
    return true;
}

/* Resolves a uri (buffer or image) to bytes. For data: URIs the decoded bytes are
 * returned in *owned. Unsafe references fail with SV_ERR_REFUSED; a safe name
 * that was not uploaded gives SV_ERR_IO (the caller decides). */
static sv_status resolve_uri(precheck *pc, const char *uri, const char *what, int idx,
                             const uint8_t **data, size_t *size, uint8_t **owned)
{
    *data = NULL;
    *size = 0;
    *owned = NULL;
    if (strncmp(uri, "data:", 5) == 0) {
        const char *comma = strchr(uri, ',');
        if (!comma || comma - uri < 12 || strncmp(comma - 7, ";base64", 7) != 0)
            return sv_fail(pc->err, SV_ERR_PARSE, "glTF %s %d: data: URI is not base64", what, idx);
        size_t n = strlen(comma + 1), k = 0;
        if (!b64_decode(comma + 1, n, NULL, &k))
            return sv_fail(pc->err, SV_ERR_PARSE, "glTF %s %d: data: URI is not valid base64", what,
                           idx);
        uint8_t *o = malloc(k ? k : 1);
        if (!o)
            return sv_fail(pc->err, SV_ERR_NOMEM, "glTF %s %d: cannot decode data: URI", what, idx);
        b64_decode(comma + 1, n, o, &k);
        *data = *owned = o;
        *size = k;
        return SV_OK;
    }
    char *dec = uri_decode(uri);
    if (!dec)
        return sv_fail(pc->err, SV_ERR_REFUSED, "glTF %s %d: refused uri '%.200s': bad %%-escape",
                       what, idx, uri);
    size_t fi = 0;
    sv_error e = {0};
    sv_status st = sv_upload_find(pc->files, pc->count, dec, &fi, &e);
    free(dec);
    if (st != SV_OK) {
        sv_fail(pc->err, st, "glTF %s %d: %s", what, idx, e.message);
        return st;
    }
    *data = pc->files[fi].data;
    *size = pc->files[fi].size;
    return SV_OK;
}

static sv_status check_glb(precheck *pc, const uint8_t *d, size_t size, const uint8_t **json,
                           size_t *json_len, const uint8_t **bin, size_t *bin_len)
{
    *bin = NULL;
    *bin_len = 0;
    if (size < 12)
        return sv_fail(pc->err, SV_ERR_PARSE, "GLB truncated: %zu bytes, the header alone is 12",
                       size);
    if (rd32(d) != GLB_MAGIC) return sv_fail(pc->err, SV_ERR_FORMAT, "not a GLB: bad magic");
    uint32_t version = rd32(d + 4), length = rd32(d + 8);
    if (version != 2)
        return sv_fail(pc->err, SV_ERR_FORMAT, "GLB version %u is not supported (2 only)", version);
    if (length > size)
        return sv_fail(pc->err, SV_ERR_PARSE,
                       "GLB truncated: header says %u bytes but the file has %zu", length, size);
    if (length < size)
        return sv_fail(pc->err, SV_ERR_PARSE,
                       "GLB header length lies: it says %u bytes but the file has %zu", length,
                       size);
    size_t off = 12;
    int chunk = 0;
    while (off < size) {
        if (size - off < 8)
            return sv_fail(
                pc->err, SV_ERR_PARSE,
                "GLB chunk %d truncated: %zu bytes left at offset %zu, a chunk header is 8", chunk,
                size - off, off);
        uint32_t clen = rd32(d + off), ctype = rd32(d + off + 4);
        if ((uint64_t)clen > size - off - 8)
            return sv_fail(pc->err, SV_ERR_PARSE,
                           "GLB chunk %d says %u bytes but only %zu remain (truncated or lying)",
                           chunk, clen, size - off - 8);
        if (chunk == 0) {
            if (ctype != GLB_JSON)
                return sv_fail(pc->err, SV_ERR_PARSE, "GLB first chunk is not JSON");
            *json = d + off + 8;
            *json_len = clen;
        } else if (chunk == 1 && ctype == GLB_BIN) {
            *bin = d + off + 8;
            *bin_len = clen;
        }
        off += 8 + (size_t)clen;
        chunk++;
    }
    if (chunk == 0) return sv_fail(pc->err, SV_ERR_PARSE, "GLB has no JSON chunk");
    return SV_OK;
}

static sv_status check_buffers(precheck *pc, bool is_glb, const uint8_t *bin, size_t bin_len)
{
    for (int i = 0; i < pc->n_buffers; i++) {
        const cJSON *b = cJSON_GetArrayItem(pc->buffers, i);
        bool present;
        sv_status st = get_uint(pc, b, "byteLength", "buffer", i, &pc->buf[i].declared, &present);
        if (st != SV_OK) return st;
        if (!present) return sv_fail(pc->err, SV_ERR_PARSE, "glTF buffer %d has no byteLength", i);
        const cJSON *uri = cJSON_GetObjectItemCaseSensitive(b, "uri");
        if (!uri) {
            if (!(is_glb && i == 0 && bin))
                return sv_fail(pc->err, SV_ERR_PARSE,
                               "glTF buffer %d has no uri and no GLB BIN chunk", i);
            pc->buf[i].data = bin;
            pc->buf[i].size = bin_len;
        } else {
            if (!cJSON_IsString(uri))
                return sv_fail(pc->err, SV_ERR_PARSE, "glTF buffer %d: uri is not a string", i);
            st = resolve_uri(pc, uri->valuestring, "buffer", i, &pc->buf[i].data, &pc->buf[i].size,
                             &pc->buf[i].owned);
            if (st == SV_ERR_IO)
                return sv_fail(pc->err, SV_ERR_REFUSED,
                               "glTF buffer %d: uri '%.200s' is not among the uploaded files", i,
                               uri->valuestring);
            if (st != SV_OK) return st;
        }
        if (pc->buf[i].declared > pc->buf[i].size)
            return sv_fail(pc->err, SV_ERR_PARSE,
                           "glTF buffer %d declares %llu bytes but its data has %zu", i,
                           (unsigned long long)pc->buf[i].declared, pc->buf[i].size);
    }
    for (int i = 0; i < pc->n_views; i++) {
        const cJSON *v = cJSON_GetArrayItem(pc->views, i);
        int64_t bi;
        uint64_t off = 0, len = 0, stride = 0;
        bool present;
        sv_status st = get_index(pc, v, "buffer", "bufferView", i, pc->n_buffers, "buffer", &bi);
        if (st == SV_OK && bi < 0)
            st = sv_fail(pc->err, SV_ERR_PARSE, "glTF bufferView %d has no buffer", i);
        if (st == SV_OK) st = get_uint(pc, v, "byteOffset", "bufferView", i, &off, &present);
        if (st == SV_OK) st = get_uint(pc, v, "byteLength", "bufferView", i, &len, &present);
        if (st == SV_OK) st = get_uint(pc, v, "byteStride", "bufferView", i, &stride, &present);
        if (st != SV_OK) return st;
        if (present && (stride < 4 || stride > 252))
            return sv_fail(pc->err, SV_ERR_PARSE,
                           "glTF bufferView %d: byteStride %llu is not in 4..252", i,
                           (unsigned long long)stride);
        if (off > pc->buf[bi].declared || len > pc->buf[bi].declared - off)
            return sv_fail(
                pc->err, SV_ERR_PARSE,
                "glTF bufferView %d (offset %llu, length %llu) overruns buffer %lld of %llu bytes",
                i, (unsigned long long)off, (unsigned long long)len, (long long)bi,
                (unsigned long long)pc->buf[bi].declared);
    }
    return SV_OK;
}

static int component_size(uint64_t ct)
{
    switch (ct) {
    case 5120:
    case 5121:
        return 1;
    case 5122:
    case 5123:
        return 2;
    case 5125:
    case 5126:
        return 4;
    default:
        return 0;
    }
}

static int type_components(const char *t)
{
    static const struct {
        const char *name;
        int n;
    } types[] = {{"SCALAR", 1}, {"VEC2", 2}, {"VEC3", 3}, {"VEC4", 4},
                 {"MAT2", 4},   {"MAT3", 9}, {"MAT4", 16}};
    for (size_t i = 0; i < sizeof types / sizeof types[0]; i++)
        if (strcmp(t, types[i].name) == 0) return types[i].n;
    return 0;
}

/* The bytes [off, off + count × stride) (the last element only `elem` long)
 * that `what` (NULL: the accessor's own data) reads from bufferView vi: they must lie inside the view, whose
 * own range was checked against its buffer in check_buffers. */
static sv_status check_view_range(precheck *pc, int acc, const char *what, int64_t vi,
                                  uint64_t off, uint64_t count, uint64_t elem, uint64_t stride)
{
    const cJSON *v = cJSON_GetArrayItem(pc->views, (int)vi);
    uint64_t vlen = 0;
    bool present;
    get_uint(pc, v, "byteLength", "bufferView", (int)vi, &vlen, &present);
    /* off < 2^53, count < 2^32, stride and elem <= 252: no overflow */
    uint64_t need = count ? off + (count - 1) * stride + elem : off;
    if (off > vlen || need > vlen)
        return sv_fail(pc->err, SV_ERR_PARSE,
                       "glTF accessor %d%s%s needs %llu bytes (offset %llu, count %llu × stride "
                       "%llu) but bufferView %lld has %llu",
                       acc, what ? ": " : "", what ? what : "", (unsigned long long)need, (unsigned long long)off,
                       (unsigned long long)count, (unsigned long long)stride, (long long)vi,
                       (unsigned long long)vlen);
    return SV_OK;
}

/* Reads one little-endian unsigned integer of cs bytes (1, 2 or 4). */
static uint32_t rd_uint(const uint8_t *p, int cs)
{
    return cs == 1 ? p[0] : cs == 2 ? (uint32_t)(p[0] | p[1] << 8) : rd32(p);
}

/* The in-memory bytes of bufferView vi from offset off on, or NULL when its
 * buffer is not in memory; *avail is how many bytes follow. */
static const uint8_t *view_bytes(precheck *pc, int64_t vi, uint64_t off, uint64_t *avail)
{
    const cJSON *v = cJSON_GetArrayItem(pc->views, (int)vi);
    uint64_t voff = 0;
    bool present;
    get_uint(pc, v, "byteOffset", "bufferView", (int)vi, &voff, &present);
    int bi = (int)cJSON_GetObjectItemCaseSensitive(v, "buffer")->valuedouble;
    const buffer_info *b = &pc->buf[bi];
    if (!b->data || voff + off > b->size) return NULL;
    *avail = b->size - (voff + off);
    return b->data + voff + off;
}

/* The `sparse` member of accessor i (count elements of elem bytes, components
 * of cs bytes): its count, its indices (an unsigned integer type, no
 * byteStride, every index < the accessor's count and increasing) and its
 * values (count elements, no byteStride) inside their buffer views. */
static sv_status check_sparse(precheck *pc, int i, const cJSON *sp, uint64_t count, uint64_t elem)
{
    if (!cJSON_IsObject(sp))
        return sv_fail(pc->err, SV_ERR_PARSE, "glTF accessor %d: sparse is not an object", i);
    uint64_t n = 0;
    bool present;
    sv_status st = get_uint(pc, sp, "count", "accessor sparse", i, &n, &present);
    if (st != SV_OK) return st;
    if (!present || n == 0 || n > count)
        return sv_fail(pc->err, SV_ERR_PARSE,
                       "glTF accessor %d: sparse count must be 1..%llu (the accessor's count)", i,
                       (unsigned long long)count);
    const cJSON *ind = cJSON_GetObjectItemCaseSensitive(sp, "indices");
    const cJSON *val = cJSON_GetObjectItemCaseSensitive(sp, "values");
    if (!cJSON_IsObject(ind) || !cJSON_IsObject(val))
        return sv_fail(pc->err, SV_ERR_PARSE,
                       "glTF accessor %d: sparse needs indices and values objects", i);
    int64_t ivi, vvi;
    uint64_t ioff = 0, voff = 0, ict = 0;
    bool has_ict;
    st = get_index(pc, ind, "bufferView", "accessor sparse indices", i, pc->n_views,
                   "bufferView", &ivi);
    if (st == SV_OK)
        st = get_uint(pc, ind, "byteOffset", "accessor sparse indices", i, &ioff, &present);
    if (st == SV_OK)
        st = get_uint(pc, ind, "componentType", "accessor sparse indices", i, &ict, &has_ict);
    if (st == SV_OK)
        st = get_index(pc, val, "bufferView", "accessor sparse values", i, pc->n_views,
                       "bufferView", &vvi);
    if (st == SV_OK)
        st = get_uint(pc, val, "byteOffset", "accessor sparse values", i, &voff, &present);
    if (st != SV_OK) return st;
    if (ivi < 0 || vvi < 0)
        return sv_fail(pc->err, SV_ERR_PARSE,
                       "glTF accessor %d: sparse indices and values need a bufferView", i);
    if (!has_ict || (ict != 5121 && ict != 5123 && ict != 5125))
        return sv_fail(pc->err, SV_ERR_PARSE,
                       "glTF accessor %d: sparse indices componentType must be 5121, 5123 or 5125",
                       i);
    int ics = component_size(ict);
    for (int k = 0; k < 2; k++) {
        const cJSON *v = cJSON_GetArrayItem(pc->views, (int)(k ? vvi : ivi));
        if (cJSON_GetObjectItemCaseSensitive(v, "byteStride"))
            return sv_fail(pc->err, SV_ERR_PARSE,
                           "glTF accessor %d: sparse %s bufferView %lld has a byteStride", i,
                           k ? "values" : "indices", (long long)(k ? vvi : ivi));
    }
    if (ioff % (uint64_t)ics)
        return sv_fail(pc->err, SV_ERR_PARSE,
                       "glTF accessor %d: sparse indices byteOffset %llu is not a multiple of %d",
                       i, (unsigned long long)ioff, ics);
    st = check_view_range(pc, i, "sparse indices", ivi, ioff, n, (uint64_t)ics, (uint64_t)ics);
    if (st == SV_OK) st = check_view_range(pc, i, "sparse values", vvi, voff, n, elem, elem);
    if (st != SV_OK) return st;
    uint64_t avail = 0;
    const uint8_t *p = view_bytes(pc, ivi, ioff, &avail);
    if (!p || avail < n * (uint64_t)ics) return SV_OK; /* declared sizes checked above */
    uint64_t prev = 0;
    for (uint64_t k = 0; k < n; k++) {
        uint64_t ix = rd_uint(p + k * (uint64_t)ics, ics);
        if (ix >= count || (k && ix <= prev))
            return sv_fail(pc->err, SV_ERR_PARSE,
                           "glTF accessor %d: sparse index %llu is %llu (indices must increase "
                           "and be below the count %llu)",
                           i, (unsigned long long)k, (unsigned long long)ix,
                           (unsigned long long)count);
        prev = ix;
    }
    return SV_OK;
}

/* min and max, when present: arrays of exactly nc finite numbers. */
static sv_status check_min_max(precheck *pc, int i, const cJSON *a, int nc)
{
    static const char *const keys[2] = {"min", "max"};
    for (int k = 0; k < 2; k++) {
        const cJSON *m = cJSON_GetObjectItemCaseSensitive(a, keys[k]);
        if (!m) continue;
        if (!cJSON_IsArray(m) || cJSON_GetArraySize(m) != nc)
            return sv_fail(pc->err, SV_ERR_PARSE,
                           "glTF accessor %d: %s is not an array of %d numbers", i, keys[k], nc);
        for (const cJSON *x = m->child; x; x = x->next)
            if (!cJSON_IsNumber(x) || !isfinite(x->valuedouble))
                return sv_fail(pc->err, SV_ERR_PARSE,
                               "glTF accessor %d: %s holds something not a finite number", i,
                               keys[k]);
    }
    return SV_OK;
}

/* Every accessor form against its buffer view: the element range (byteOffset,
 * count, byteStride), component alignment, normalized, min/max and sparse. */
static sv_status check_accessors(precheck *pc)
{
    for (int i = 0; i < pc->n_accessors; i++) {
        const cJSON *a = cJSON_GetArrayItem(pc->accessors, i);
        uint64_t ct = 0, count = 0, off = 0;
        bool has_ct, has_count, has_off;
        int64_t vi;
        if (!cJSON_IsObject(a))
            return sv_fail(pc->err, SV_ERR_PARSE, "glTF accessor %d is not an object", i);
        sv_status st = get_uint(pc, a, "componentType", "accessor", i, &ct, &has_ct);
        if (st == SV_OK) st = get_uint(pc, a, "count", "accessor", i, &count, &has_count);
        if (st == SV_OK) st = get_uint(pc, a, "byteOffset", "accessor", i, &off, &has_off);
        if (st == SV_OK)
            st = get_index(pc, a, "bufferView", "accessor", i, pc->n_views, "bufferView", &vi);
        if (st != SV_OK) return st;
        const cJSON *type = cJSON_GetObjectItemCaseSensitive(a, "type");
        int cs = component_size(ct);
        int nc = cJSON_IsString(type) ? type_components(type->valuestring) : 0;
        if (!has_ct || !cs)
            return sv_fail(pc->err, SV_ERR_PARSE, "glTF accessor %d has no valid componentType", i);
        if (!nc) return sv_fail(pc->err, SV_ERR_PARSE, "glTF accessor %d has no valid type", i);
        if (!has_count || count == 0)
            return sv_fail(pc->err, SV_ERR_PARSE, "glTF accessor %d has no count", i);
        if (count > UINT32_MAX)
            return sv_fail(pc->err, SV_ERR_LIMIT, "glTF accessor %d declares %llu elements", i,
                           (unsigned long long)count);
        const cJSON *norm = cJSON_GetObjectItemCaseSensitive(a, "normalized");
        if (norm && !cJSON_IsBool(norm))
            return sv_fail(pc->err, SV_ERR_PARSE, "glTF accessor %d: normalized is not a boolean",
                           i);
        if (cJSON_IsTrue(norm) && (ct == 5125 || ct == 5126))
            return sv_fail(pc->err, SV_ERR_PARSE,
                           "glTF accessor %d: normalized is only for 8- and 16-bit components", i);
        st = check_min_max(pc, i, a, nc);
        if (st != SV_OK) return st;
        uint64_t elem = (uint64_t)cs * (uint64_t)nc;
        const cJSON *sp = cJSON_GetObjectItemCaseSensitive(a, "sparse");
        if (sp && (st = check_sparse(pc, i, sp, count, elem)) != SV_OK) return st;
        if (vi < 0) {
            if (has_off)
                return sv_fail(pc->err, SV_ERR_PARSE,
                               "glTF accessor %d has a byteOffset but no bufferView", i);
            continue; /* all zeros (or sparse only) */
        }
        const cJSON *v = cJSON_GetArrayItem(pc->views, (int)vi);
        uint64_t stride = 0;
        bool has_stride;
        get_uint(pc, v, "byteStride", "bufferView", (int)vi, &stride, &has_stride);
        if (!has_stride || stride == 0) stride = elem;
        if (stride < elem)
            return sv_fail(pc->err, SV_ERR_PARSE,
                           "glTF accessor %d: bufferView %lld byteStride %llu is shorter than "
                           "its %llu-byte element",
                           i, (long long)vi, (unsigned long long)stride, (unsigned long long)elem);
        if (off % (uint64_t)cs || stride % (uint64_t)cs)
            return sv_fail(pc->err, SV_ERR_PARSE,
                           "glTF accessor %d: byteOffset %llu or byteStride %llu is not a "
                           "multiple of its %d-byte component",
                           i, (unsigned long long)off, (unsigned long long)stride, cs);
        st = check_view_range(pc, i, NULL, vi, off, count, elem, stride);
        if (st != SV_OK) return st;
    }
    return SV_OK;
}

/* Reads the accessor's element count (validated above). */
static uint64_t accessor_count(precheck *pc, int64_t ai)
{
    const cJSON *c = cJSON_GetObjectItemCaseSensitive(cJSON_GetArrayItem(pc->accessors, (int)ai),
                                                      "count");
    return (uint64_t)c->valuedouble;
}

/* Checks every index of an index accessor against the vertex count, when its
 * bytes are in memory (GLB BIN, data: URI, uploaded .bin). */
static sv_status check_index_values(precheck *pc, int mesh, int prim, int64_t ai, uint64_t nverts)
{
    const cJSON *a = cJSON_GetArrayItem(pc->accessors, (int)ai);
    uint64_t ct = (uint64_t)cJSON_GetObjectItemCaseSensitive(a, "componentType")->valuedouble;
    int cs = component_size(ct);
    if (ct != 5121 && ct != 5123 && ct != 5125)
        return sv_fail(pc->err, SV_ERR_PARSE,
                       "glTF mesh %d primitive %d: index accessor %lld has componentType %llu",
                       mesh, prim, (long long)ai, (unsigned long long)ct);
    const cJSON *sp = cJSON_GetObjectItemCaseSensitive(a, "sparse");
    if (sp) { /* the substituted values are indices too (ranges checked in check_sparse) */
        const cJSON *val = cJSON_GetObjectItemCaseSensitive(sp, "values");
        uint64_t n = (uint64_t)cJSON_GetObjectItemCaseSensitive(sp, "count")->valuedouble;
        uint64_t voff = 0, avail = 0;
        bool has;
        get_uint(pc, val, "byteOffset", "accessor sparse values", (int)ai, &voff, &has);
        int64_t vvi = (int64_t)cJSON_GetObjectItemCaseSensitive(val, "bufferView")->valuedouble;
        const uint8_t *p = view_bytes(pc, vvi, voff, &avail);
        for (uint64_t k = 0; p && k < n && (k + 1) * (uint64_t)cs <= avail; k++) {
            uint32_t ix = rd_uint(p + k * (uint64_t)cs, cs);
            if ((uint64_t)ix >= nverts)
                return sv_fail(pc->err, SV_ERR_INVALID,
                               "glTF mesh %d primitive %d: sparse index value %u is past vertex "
                               "%llu",
                               mesh, prim, ix, (unsigned long long)nverts);
        }
    }
    const cJSON *bv = cJSON_GetObjectItemCaseSensitive(a, "bufferView");
    if (!bv) return SV_OK;
    const cJSON *v = cJSON_GetArrayItem(pc->views, (int)bv->valuedouble);
    uint64_t aoff = 0, voff = 0, stride = 0, count = accessor_count(pc, ai);
    bool present;
    get_uint(pc, a, "byteOffset", "accessor", (int)ai, &aoff, &present);
    get_uint(pc, v, "byteOffset", "bufferView", 0, &voff, &present);
    get_uint(pc, v, "byteStride", "bufferView", 0, &stride, &present);
    if (!stride) stride = (uint64_t)cs;
    int bi = (int)cJSON_GetObjectItemCaseSensitive(v, "buffer")->valuedouble;
    const buffer_info *b = &pc->buf[bi];
    if (!b->data) return SV_OK;
    uint64_t base = voff + aoff;
    for (uint64_t k = 0; k < count; k++) {
        uint64_t o = base + k * stride;
        if (o + (uint64_t)cs > b->size) break; /* checked above against declared sizes */
        const uint8_t *p = b->data + o;
        uint32_t ix = cs == 1 ? p[0] : cs == 2 ? (uint32_t)(p[0] | p[1] << 8) : rd32(p);
        if ((uint64_t)ix >= nverts)
            return sv_fail(pc->err, SV_ERR_INVALID,
                           "glTF mesh %d primitive %d: triangle %llu refers to vertex %u of %llu",
                           mesh, prim, (unsigned long long)(k / 3), ix, (unsigned long long)nverts);
    }
    return SV_OK;
}

static sv_status check_meshes(precheck *pc)
{
    for (int m = 0; m < pc->n_meshes; m++) {
        const cJSON *mesh = cJSON_GetArrayItem(pc->meshes, m);
        const cJSON *prims = cJSON_GetObjectItemCaseSensitive(mesh, "primitives");
        if (!cJSON_IsArray(prims))
            return sv_fail(pc->err, SV_ERR_PARSE, "glTF mesh %d has no primitives array", m);
        int np = cJSON_GetArraySize(prims);
        for (int p = 0; p < np; p++) {
            const cJSON *pr = cJSON_GetArrayItem(prims, p);
            const cJSON *attrs = cJSON_GetObjectItemCaseSensitive(pr, "attributes");
            if (!cJSON_IsObject(attrs))
                return sv_fail(pc->err, SV_ERR_PARSE, "glTF mesh %d primitive %d has no attributes",
                               m, p);
            int64_t pos, ind, mat;
            uint64_t mode = 4;
            bool present;
            sv_status st = SV_OK;
            for (const cJSON *at = attrs->child; at && st == SV_OK; at = at->next) {
                int64_t ai;
                st = get_index(pc, attrs, at->string, "mesh primitive attribute", m,
                               pc->n_accessors, "accessor", &ai);
            }
            if (st == SV_OK)
                st = get_index(pc, attrs, "POSITION", "mesh", m, pc->n_accessors, "accessor", &pos);
            if (st == SV_OK)
                st = get_index(pc, pr, "indices", "mesh", m, pc->n_accessors, "accessor", &ind);
            if (st == SV_OK)
                st = get_index(pc, pr, "material", "mesh", m, pc->n_materials, "material", &mat);
            if (st == SV_OK) st = get_uint(pc, pr, "mode", "mesh", m, &mode, &present);
            if (st != SV_OK) return st;
            if (pos < 0)
                return sv_fail(pc->err, SV_ERR_PARSE, "glTF mesh %d primitive %d has no POSITION",
                               m, p);
            /* what assimp reads as positions and indices must be what they
             * are (glTF 2.0 §3.7.2.1: POSITION is float VEC3, indices SCALAR) */
            const cJSON *pa = cJSON_GetArrayItem(pc->accessors, (int)pos);
            const cJSON *pt = cJSON_GetObjectItemCaseSensitive(pa, "type");
            if (strcmp(pt->valuestring, "VEC3") != 0 ||
                cJSON_GetObjectItemCaseSensitive(pa, "componentType")->valuedouble != 5126)
                return sv_fail(pc->err, SV_ERR_PARSE,
                               "glTF mesh %d primitive %d: POSITION accessor %lld is not a float "
                               "VEC3",
                               m, p, (long long)pos);
            if (ind >= 0) {
                const cJSON *it = cJSON_GetObjectItemCaseSensitive(
                    cJSON_GetArrayItem(pc->accessors, (int)ind), "type");
                if (strcmp(it->valuestring, "SCALAR") != 0)
                    return sv_fail(pc->err, SV_ERR_PARSE,
                                   "glTF mesh %d primitive %d: index accessor %lld is not SCALAR",
                                   m, p, (long long)ind);
            }
            uint64_t nv = accessor_count(pc, pos);
            uint64_t ni = ind >= 0 ? accessor_count(pc, ind) : nv;
            /* a primitive too short for its mode: assimp computes its face
             * count as count - 2 unsigned (a strip of 1 vertex: 2^32 - 1
             * faces allocated) */
            static const uint64_t min_of_mode[7] = {1, 2, 2, 2, 3, 3, 3};
            if (mode > 6)
                return sv_fail(pc->err, SV_ERR_PARSE, "glTF mesh %d primitive %d: mode %llu", m,
                               p, (unsigned long long)mode);
            if (ni < min_of_mode[mode])
                return sv_fail(pc->err, SV_ERR_PARSE,
                               "glTF mesh %d primitive %d: %llu %s, mode %llu needs at least %llu",
                               m, p, (unsigned long long)ni, ind >= 0 ? "indices" : "vertices",
                               (unsigned long long)mode,
                               (unsigned long long)min_of_mode[mode]);
            uint64_t tris = mode == 4                  ? ni / 3
                            : (mode == 5 || mode == 6) ? (ni >= 3 ? ni - 2 : 0)
                                                       : 0;
            pc->mesh_tris[m] += tris;
            pc->mesh_verts[m] += nv;
            if (ind >= 0) {
                st = check_index_values(pc, m, p, ind, nv);
                if (st != SV_OK) return st;
            }
        }
    }
    return SV_OK;
}

static sv_status check_nodes(precheck *pc, const cJSON *root)
{
    int n = pc->n_nodes;
    for (int i = 0; i < n; i++) pc->parent[i] = -1;
    uint64_t tris = 0, verts = 0;
    for (int i = 0; i < n; i++) {
        const cJSON *node = cJSON_GetArrayItem(pc->nodes, i);
        int64_t mesh;
        sv_status st = get_index(pc, node, "mesh", "node", i, pc->n_meshes, "mesh", &mesh);
        if (st != SV_OK) return st;
        if (mesh >= 0) {
            tris += pc->mesh_tris[mesh];
            verts += pc->mesh_verts[mesh];
            if (tris > pc->lim.max_triangles)
                return sv_fail(
                    pc->err, SV_ERR_LIMIT,
                    "glTF declares more than %llu triangles (node %d instances mesh %lld)",
                    (unsigned long long)pc->lim.max_triangles, i, (long long)mesh);
            if (verts > pc->lim.max_vertices)
                return sv_fail(pc->err, SV_ERR_LIMIT, "glTF declares more than %llu vertices",
                               (unsigned long long)pc->lim.max_vertices);
        }
        const cJSON *ch = cJSON_GetObjectItemCaseSensitive(node, "children");
        if (!ch) continue;
        if (!cJSON_IsArray(ch))
            return sv_fail(pc->err, SV_ERR_PARSE, "glTF node %d: children is not an array", i);
        for (const cJSON *c = ch->child; c; c = c->next) {
            double d = c->valuedouble;
            if (!cJSON_IsNumber(c) || !(d >= 0) || d >= n || floor(d) != d)
                return sv_fail(pc->err, SV_ERR_PARSE,
                               "glTF node %d has a child that is not a node index", i);
            int k = (int)d;
            if (pc->parent[k] >= 0)
                return sv_fail(pc->err, SV_ERR_PARSE,
                               "glTF node %d is a child of both node %d and node %d (the node "
                               "graph must be a tree)",
                               k, pc->parent[k], i);
            pc->parent[k] = i;
        }
    }
    if (n == 0) {
        for (int m = 0; m < pc->n_meshes; m++) {
            tris += pc->mesh_tris[m];
            verts += pc->mesh_verts[m];
        }
        if (tris > pc->lim.max_triangles || verts > pc->lim.max_vertices)
            return sv_fail(pc->err, SV_ERR_LIMIT,
                           "glTF declares %llu triangles, %llu vertices (limits %llu, %llu)",
                           (unsigned long long)tris, (unsigned long long)verts,
                           (unsigned long long)pc->lim.max_triangles,
                           (unsigned long long)pc->lim.max_vertices);
    }
    /* Iterative depth-first walk from the roots. Every node has at most one
     * parent, so each is pushed at most once; a node never reached lies on (or
     * under) a cycle. The stack holds node and depth pairs. */
    uint32_t *stack = pc->stack, sp = 0;
    uint32_t visited = 0;
    for (int r = 0; r < n; r++) {
        if (pc->parent[r] >= 0) continue;
        stack[sp++] = (uint32_t)r;
        stack[sp++] = 1;
        while (sp) {
            uint32_t depth = stack[--sp], node = stack[--sp];
            visited++;
            if (depth > pc->lim.max_node_depth)
                return sv_fail(pc->err, SV_ERR_LIMIT,
                               "glTF node graph is deeper than %u levels (node %u is at depth %u)",
                               pc->lim.max_node_depth, node, depth);
            const cJSON *ch = cJSON_GetObjectItemCaseSensitive(
                cJSON_GetArrayItem(pc->nodes, (int)node), "children");
            for (const cJSON *c = ch ? ch->child : NULL; c; c = c->next) {
                stack[sp++] = (uint32_t)c->valuedouble;
                stack[sp++] = depth + 1;
            }
        }
    }
    if (visited != (uint32_t)n) {
        for (int i = 0; i < n; i++) {
            /* the first node whose ancestor chain does not end at a root */
            int j = i, steps = 0;
            while (j >= 0 && steps <= n) {
                j = pc->parent[j];
                steps++;
            }
            if (j >= 0)
                return sv_fail(pc->err, SV_ERR_PARSE, "glTF node graph has a cycle through node %d",
                               i);
        }
        return sv_fail(pc->err, SV_ERR_PARSE, "glTF node graph has a cycle");
    }
    const cJSON *scenes = cJSON_GetObjectItemCaseSensitive(root, "scenes");
    if (scenes && !cJSON_IsArray(scenes))
        return sv_fail(pc->err, SV_ERR_PARSE, "glTF 'scenes' is not an array");
    int si = 0;
    for (const cJSON *s = scenes ? scenes->child : NULL; s; s = s->next, si++) {
        const cJSON *sn = cJSON_GetObjectItemCaseSensitive(s, "nodes");
        if (sn && !cJSON_IsArray(sn))
            return sv_fail(pc->err, SV_ERR_PARSE, "glTF scene %d: nodes is not an array", si);
        for (const cJSON *c = sn ? sn->child : NULL; c; c = c->next) {
            double d = c->valuedouble;
            if (!cJSON_IsNumber(c) || !(d >= 0) || d >= n || floor(d) != d)
                return sv_fail(pc->err, SV_ERR_PARSE,
                               "glTF scene %d refers to a node that does not exist", si);
        }
    }
    return SV_OK;
}

static sv_status check_images(precheck *pc)
{
    for (int i = 0; i < pc->n_images; i++) {
        const cJSON *im = cJSON_GetArrayItem(pc->images, i);
        int64_t bv;
        sv_status st = get_index(pc, im, "bufferView", "image", i, pc->n_views, "bufferView", &bv);
        if (st != SV_OK) return st;
        const cJSON *uri = cJSON_GetObjectItemCaseSensitive(im, "uri");
        if (!uri) continue;
        if (!cJSON_IsString(uri))
            return sv_fail(pc->err, SV_ERR_PARSE, "glTF image %d: uri is not a string", i);
        if (strncmp(uri->valuestring, "data:", 5) == 0) continue; /* decoded by the importer */
        const uint8_t *d;
        size_t sz;
        uint8_t *owned;
        st = resolve_uri(pc, uri->valuestring, "image", i, &d, &sz, &owned);
        free(owned);
        /* A texture that was not uploaded is a warning at import, not an error. */
        if (st != SV_OK && st != SV_ERR_IO) return st;
    }
    return SV_OK;
}

sv_status sv_gltf_precheck(const uint8_t *data, size_t size, bool is_glb, const sv_file *files,
                           size_t count, const sv_limits *limits, sv_error *err)
{
    precheck pc = {0};
    pc.files = files;
    pc.count = count;
    pc.lim = sv_limits_resolve(limits ? *limits : (sv_limits){0});
    pc.err = err;
    if (!data && size) return sv_fail(err, SV_ERR_INTERNAL, "sv_gltf_precheck: data is NULL");
    if (size == 0) return sv_fail(err, SV_ERR_PARSE, "glTF file is empty");
    if (size > pc.lim.max_file_bytes)
        return sv_fail(err, SV_ERR_LIMIT, "glTF file is %zu bytes (limit %llu)", size,
                       (unsigned long long)pc.lim.max_file_bytes);
    const uint8_t *json = data, *bin = NULL;
    size_t json_len = size, bin_len = 0;
    sv_status st = SV_OK;
    if (is_glb) {
        st = check_glb(&pc, data, size, &json, &json_len, &bin, &bin_len);
        if (st != SV_OK) return st;
    }
    /* A GLB's JSON chunk is padded to 4 bytes with spaces; some writers pad
     * with NULs, which end the text for assimp's parser as well. */
    if (is_glb)
        for (int k = 0; k < 3 && json_len && json[json_len - 1] == 0; k++) json_len--;
    /* The document assimp reads must be the one checked here: no duplicate
     * key, no NUL in a string, nothing after the value. */
    cJSON *root = sv_json_parse_strict((const char *)json, json_len, "glTF JSON", SV_ERR_PARSE,
                                       err);
    if (!root) return err && err->status ? err->status : SV_ERR_PARSE;
    if (!cJSON_IsObject(root)) {
        st = sv_fail(err, SV_ERR_PARSE, "glTF JSON is not an object");
        goto out;
    }
    const cJSON *asset = cJSON_GetObjectItemCaseSensitive(root, "asset");
    const cJSON *ver = cJSON_GetObjectItemCaseSensitive(asset, "version");
    if (!cJSON_IsString(ver)) {
        st = sv_fail(err, SV_ERR_PARSE, "glTF has no asset.version");
        goto out;
    }
    if (ver->valuestring[0] != '2' || ver->valuestring[1] != '.') {
        st = sv_fail(err, SV_ERR_FORMAT, "glTF version '%.20s' is not supported (2.x only)",
                     ver->valuestring);
        goto out;
    }
    if ((st = get_array(&pc, root, "nodes", &pc.nodes, &pc.n_nodes)) != SV_OK ||
        (st = get_array(&pc, root, "meshes", &pc.meshes, &pc.n_meshes)) != SV_OK ||
        (st = get_array(&pc, root, "accessors", &pc.accessors, &pc.n_accessors)) != SV_OK ||
        (st = get_array(&pc, root, "bufferViews", &pc.views, &pc.n_views)) != SV_OK ||
        (st = get_array(&pc, root, "buffers", &pc.buffers, &pc.n_buffers)) != SV_OK ||
        (st = get_array(&pc, root, "images", &pc.images, &pc.n_images)) != SV_OK ||
        (st = get_array(&pc, root, "materials", &pc.materials, &pc.n_materials)) != SV_OK)
        goto out;
    if ((uint64_t)pc.n_nodes > pc.lim.max_nodes) {
        st = sv_fail(err, SV_ERR_LIMIT, "glTF has %d nodes (limit %u)", pc.n_nodes,
                     pc.lim.max_nodes);
        goto out;
    }
    if ((uint64_t)pc.n_meshes > pc.lim.max_nodes) {
        st = sv_fail(err, SV_ERR_LIMIT, "glTF has %d meshes (limit %u)", pc.n_meshes,
                     pc.lim.max_nodes);
        goto out;
    }
    if ((uint64_t)pc.n_materials > pc.lim.max_materials) {
        st = sv_fail(err, SV_ERR_LIMIT, "glTF has %d materials (limit %u)", pc.n_materials,
                     pc.lim.max_materials);
        goto out;
    }
    pc.buf = sv_calloc((size_t)pc.n_buffers, sizeof *pc.buf);
    pc.parent = sv_calloc((size_t)pc.n_nodes, sizeof *pc.parent);
    pc.stack = sv_calloc((size_t)pc.n_nodes, 2 * sizeof *pc.stack);
    pc.mesh_tris = sv_calloc((size_t)pc.n_meshes, sizeof *pc.mesh_tris);
    pc.mesh_verts = sv_calloc((size_t)pc.n_meshes, sizeof *pc.mesh_verts);
    if (!pc.buf || !pc.parent || !pc.stack || !pc.mesh_tris || !pc.mesh_verts) {
        st = sv_fail(err, SV_ERR_NOMEM, "glTF precheck: out of memory");
        goto out;
    }
    if ((st = check_buffers(&pc, is_glb, bin, bin_len)) != SV_OK) goto out;
    if ((st = check_accessors(&pc)) != SV_OK) goto out;
    if ((st = check_meshes(&pc)) != SV_OK) goto out;
    if ((st = check_nodes(&pc, root)) != SV_OK) goto out;
    if ((st = check_images(&pc)) != SV_OK) goto out;
out:
    if (pc.buf)
        for (int i = 0; i < pc.n_buffers; i++) free(pc.buf[i].owned);
    free(pc.buf);
    free(pc.parent);
    free(pc.stack);
    free(pc.mesh_tris);
    free(pc.mesh_verts);
    cJSON_Delete(root);
    return st;
}
