/* sniff.c — what an upload holds: the mesh format from its bytes (never its
 * name), and resolution of file names written inside an upload to the uploaded
 * files, refusing anything that could reach outside the upload.
 *
 * Why sniff: assimp 5.2.5 picks its parser from the name's extension and, when
 * that fails, tries ~40 parsers by signature. sylva decides the format itself
 * from magic bytes and passes only GLB/glTF/OBJ/PLY/FBX/COLLADA on.
 */
#include "import.h"
#include "companions.h"

#include <ctype.h>
#include <stdio.h>
#include <string.h>

const char *sv_format_name(sv_format f)
{
    switch (f) {
    case SV_FORMAT_GLB:
        return "glb";
    case SV_FORMAT_GLTF:
        return "gltf";
    case SV_FORMAT_OBJ:
        return "obj";
    case SV_FORMAT_PLY:
        return "ply";
    case SV_FORMAT_FBX:
        return "fbx";
    case SV_FORMAT_COLLADA:
        return "dae";
    case SV_FORMAT_UNKNOWN:
        break;
    }
    return "unknown";
}

static bool has_prefix(const uint8_t *d, size_t n, const char *p)
{
    size_t m = strlen(p);
    return n >= m && memcmp(d, p, m) == 0;
}

/* Offset of the first byte after a UTF-8 BOM and ASCII whitespace. */
static size_t skip_bom_ws(const uint8_t *d, size_t n)
{
    size_t i = 0;
    if (n >= 3 && d[0] == 0xEF && d[1] == 0xBB && d[2] == 0xBF) i = 3;
    while (i < n && (d[i] == ' ' || d[i] == '\t' || d[i] == '\r' || d[i] == '\n')) i++;
    return i;
}

static bool contains(const uint8_t *d, size_t n, const char *needle)
{
    size_t m = strlen(needle);
    if (m == 0 || n < m) return false;
    for (size_t i = 0; i + m <= n; i++) {
        const uint8_t *p = memchr(d + i, needle[0], n - m + 1 - i);
        if (!p) return false;
        i = (size_t)(p - d);
        if (memcmp(p, needle, m) == 0) return true;
    }
    return false;
}

/* OBJ has no magic. Accept text whose non-blank, non-comment lines start with OBJ
 * keywords, up to and including a first vertex line ("v "), within 64 KiB. */
static bool looks_like_obj(const uint8_t *d, size_t n)
{
    static const char *const keywords[] = {
        "v",    "vt",         "vn",        "vp",     "f",      "l",      "p",        "o",
        "g",    "s",          "mtllib",    "usemtl", "usemap", "maplib", "cstype",   "deg",
        "bmat", "step",       "curv",      "curv2",  "surf",   "parm",   "trim",     "hole",
        "scrv", "sp",         "end",       "con",    "mg",     "bevel",  "c_interp", "d_interp",
        "lod",  "shadow_obj", "trace_obj", "ctech",  "stech",  "call",   "csh"};
    size_t lim = n < 65536 ? n : 65536;
    if (memchr(d, 0, lim)) return false;
    size_t i = 0;
    while (i < lim) {
        while (i < lim && (d[i] == ' ' || d[i] == '\t' || d[i] == '\r')) i++;
        size_t eol = i;
        while (eol < lim && d[eol] != '\n') eol++;
        if (i < eol && d[i] != '#') {
            size_t t = i;
            while (t < eol && !isspace(d[t])) t++;
            size_t len = t - i;
            bool known = false;
            for (size_t k = 0; k < sizeof keywords / sizeof keywords[0]; k++)
                if (strlen(keywords[k]) == len && memcmp(d + i, keywords[k], len) == 0) {
                    known = true;
                    break;
                }
            if (!known) return false;
            if (len == 1 && d[i] == 'v' && t < eol) return true;
        }
        i = eol + 1;
    }
    return false;
}

sv_format sv_sniff_format(const uint8_t *data, size_t size)
{
    if (!data || size == 0) return SV_FORMAT_UNKNOWN;
    if (has_prefix(data, size, "glTF")) return SV_FORMAT_GLB;
    if (has_prefix(data, size, "Kaydara FBX Binary")) return SV_FORMAT_FBX;
    if (has_prefix(data, size, "ply\n") || has_prefix(data, size, "ply\r\n")) {
        size_t i = data[3] == '\n' ? 4 : 5;
        if (has_prefix(data + i, size - i, "format ")) return SV_FORMAT_PLY;
        return SV_FORMAT_UNKNOWN;
    }
    size_t s = skip_bom_ws(data, size);
    const uint8_t *t = data + s;
    size_t tn = size - s;
    if (tn && t[0] == '{') {
        /* glTF JSON: an object with an "asset" member somewhere (precheck verifies). */
        size_t head = tn < 1024 ? tn : 1024;
        if (!memchr(t, 0, head) && contains(t, tn, "\"asset\"")) return SV_FORMAT_GLTF;
        return SV_FORMAT_UNKNOWN;
    }
    if (tn && t[0] == '<') {
        size_t head = tn < 4096 ? tn : 4096;
        if (contains(t, head, "<COLLADA")) return SV_FORMAT_COLLADA;
        return SV_FORMAT_UNKNOWN;
    }
    if (has_prefix(t, tn, "; FBX")) return SV_FORMAT_FBX;
    if (looks_like_obj(data, size)) return SV_FORMAT_OBJ;
    return SV_FORMAT_UNKNOWN;
}

/* Copies ref into out with non-printable bytes as '?', for messages. */
static const char *printable(const char *ref, char *out, size_t cap)
{
    size_t i = 0;
    for (; ref[i] && i + 1 < cap; i++) out[i] = (ref[i] >= 0x20 && ref[i] < 0x7f) ? ref[i] : '?';
    out[i] = 0;
    return out;
}

static const char *base_name(const char *p)
{
    const char *b = p;
    for (const char *c = p; *c; c++)
        if (*c == '/' || *c == '\\') b = c + 1;
    return b;
}

static bool name_eq(const char *a, const char *b, bool fold_case)
{
    for (;; a++, b++) {
        char x = *a == '\\' ? '/' : *a, y = *b == '\\' ? '/' : *b;
        if (fold_case) {
            x = (char)tolower((unsigned char)x);
            y = (char)tolower((unsigned char)y);
        }
        if (x != y) return false;
        if (!x) return true;
    }
}

/* Refuses a reference that could leave the upload; SV_OK when it is safe.
 * The rule is companions.h's, shared with sylva-bake's and the client's
 * search for companions beside a mesh. */
static sv_status check_safe(const char *ref, const char *shown, sv_error *err)
{
    const char *why = sylva_ref_unsafe(ref);
    if (!why) return SV_OK;
    if (!ref[0]) return sv_fail(err, SV_ERR_REFUSED, "refused %s", why);
    return sv_fail(err, SV_ERR_REFUSED, "refused '%s': %s", shown, why);
}

static int hexdigit(int c)
{
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    return -1;
}

/* Percent-decodes src into dst (cap bytes). False when there is nothing to
 * decode, an escape is malformed or encodes NUL, or it does not fit. */
static bool percent_decode(const char *src, char *dst, size_t cap)
{
    if (!strchr(src, '%')) return false;
    size_t o = 0;
    for (const char *c = src; *c; c++) {
        if (o + 1 >= cap) return false;
        if (*c == '%') {
            int a = hexdigit((unsigned char)c[1]), b = a >= 0 ? hexdigit((unsigned char)c[2]) : -1;
            if (a < 0 || b < 0 || (a == 0 && b == 0)) return false;
            dst[o++] = (char)(a * 16 + b);
            c += 2;
        } else {
            dst[o++] = *c;
        }
    }
    dst[o] = 0;
    return true;
}

static bool lookup(const sv_file *files, size_t count, const char *ref, size_t *index)
{
    const char *rb = base_name(ref);
    if (!rb[0]) return false;
    for (int pass = 0; pass < 3; pass++) {
        for (size_t i = 0; i < count; i++) {
            if (!files[i].name) continue;
            bool hit = pass == 0   ? name_eq(files[i].name, ref, false)
                       : pass == 1 ? name_eq(base_name(files[i].name), rb, false)
                                   : name_eq(base_name(files[i].name), rb, true);
            if (hit) {
                *index = i;
                return true;
            }
        }
    }
    return false;
}

sv_status sv_upload_find(const sv_file *files, size_t count, const char *ref, size_t *index,
                         sv_error *err)
{
    char shown[200], decoded[1024], shown_dec[200];
    if (!ref || !ref[0]) return sv_fail(err, SV_ERR_REFUSED, "refused an empty file reference");
    printable(ref, shown, sizeof shown);
    sv_status st = check_safe(ref, shown, err);
    if (st != SV_OK) return st;
    /* glTF URIs are percent-encoded ("my%20leaf.png", "%2e%2e/x"); assimp passes
     * them on undecoded. The decoded form must be safe too. */
    bool has_decoded = percent_decode(ref, decoded, sizeof decoded);
    if (has_decoded) {
        printable(decoded, shown_dec, sizeof shown_dec);
        st = check_safe(decoded, shown_dec, err);
        if (st != SV_OK) return st;
    }
    if (lookup(files, count, ref, index)) return SV_OK;
    if (has_decoded && lookup(files, count, decoded, index)) return SV_OK;
    return sv_fail(err, SV_ERR_IO, "'%s' is not among the uploaded files", shown);
}
