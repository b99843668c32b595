/* companions.h — the files a mesh names, shared by sylva-bake (core/cli),
 * the importer's reference check (core/io/sniff.c) and the `sylva` client
 * (client/sylva.c), so the offline tool, the client and the daemon agree on
 * which references are safe and which files a mesh needs:
 *
 *   - an OBJ's `mtllib` lines; a .mtl's `map_*` lines (the last word: the
 *     options before it are skipped);
 *   - a glTF's (JSON or GLB) buffers[].uri and images[].uri, data: URIs
 *     excepted, percent-decoded.
 *
 * A reference is followed only when it is safe (sylva_ref_unsafe): a plain
 * name or a relative path without `..`, looked for in the folder of the file
 * that names it (the mesh's folder, or a subfolder of it). Nothing absolute,
 * no scheme, no drive letter, no `..` is ever opened.
 *
 * Header-only (static): the client links nothing of core, and each program
 * includes it from one file.
 */
#ifndef SYLVA_COMPANIONS_H
#define SYLVA_COMPANIONS_H

#include <cjson/cJSON.h>
#include <ctype.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>

#define SYLVA_COMPANIONS_MAX 256 /* files found for one mesh, at most */

/* NULL when ref may be followed: non-empty, not absolute (/x, \x), no scheme
 * or drive letter before a ':' (file:, http:, C:), no `..` component (with /
 * or \ as separators), no control character. Otherwise a short reason
 * ("absolute paths are not allowed", ...). Pure. */
static inline const char *sylva_ref_unsafe(const char *ref)
{
    if (!ref || !ref[0]) return "an empty file reference";
    if (ref[0] == '/' || ref[0] == '\\') return "absolute paths are not allowed";
    if (isalpha((unsigned char)ref[0])) {
        const char *c = ref + 1;
        while (isalnum((unsigned char)*c) || *c == '+' || *c == '-' || *c == '.') c++;
        if (*c == ':') return "URI schemes and drive letters are not allowed";
    }
    for (const char *c = ref; *c; c++) {
        if ((unsigned char)*c < 0x20 || *c == 0x7f) return "control characters in a file name";
        bool start = (c == ref) || c[-1] == '/' || c[-1] == '\\';
        if (start && c[0] == '.' && c[1] == '.' && (c[2] == 0 || c[2] == '/' || c[2] == '\\'))
            return "'..' leaves the upload";
    }
    return NULL;
}

/* Called for each reference found, as written (glTF URIs percent-decoded). */
typedef void (*sylva_ref_fn)(void *user, const char *ref);

/* The value of one hex digit, -1 for another character. */
static inline int sylva_hex_(int c)
{
    return c >= '0' && c <= '9'   ? c - '0'
           : c >= 'a' && c <= 'f' ? c - 'a' + 10
           : c >= 'A' && c <= 'F' ? c - 'A' + 10
                                  : -1;
}

/* Percent-decodes s in place; false (s unchanged in meaning) on a bad escape. */
static inline bool sylva_uri_decode_(char *s)
{
    char *o = s;
    for (const char *c = s; *c; c++) {
        if (*c == '%') {
            int a = sylva_hex_((unsigned char)c[1]), b = a >= 0 ? sylva_hex_((unsigned char)c[2]) : -1;
            if (a < 0 || b < 0 || (a == 0 && b == 0)) return false;
            *o++ = (char)(a * 16 + b);
            c += 2;
        } else {
            *o++ = *c;
        }
    }
    *o = 0;
    return true;
}

/* The references of OBJ or MTL text: `mtllib NAME` (obj) and `map_* [opts] NAME`
 * (mtl), one per line, the name being the rest of the line (mtllib) or its
 * last word (map_*), trailing blanks and CR removed. */
static inline void sylva_refs_text_(const char *d, size_t n, bool mtl, sylva_ref_fn fn, void *user)
{
    size_t i = 0;
    while (i < n) {
        size_t e = i;
        while (e < n && d[e] != '\n') e++;
        size_t a = i;
        while (a < e && (d[a] == ' ' || d[a] == '\t')) a++;
        const char *kw = mtl ? "map_" : "mtllib";
        size_t kl = strlen(kw);
        if (e - a > kl && strncmp(d + a, kw, kl) == 0) {
            size_t p = a + kl;
            while (p < e && d[p] != ' ' && d[p] != '\t') p++; /* the rest of map_Kd */
            size_t z = e;
            while (z > p && isspace((unsigned char)d[z - 1])) z--;
            if (mtl) { /* the last word */
                size_t w = z;
                while (w > p && d[w - 1] != ' ' && d[w - 1] != '\t') w--;
                p = w;
            } else {
                while (p < z && (d[p] == ' ' || d[p] == '\t')) p++;
            }
            if (z > p && z - p < 1024) {
                char ref[1024];
                memcpy(ref, d + p, z - p);
                ref[z - p] = 0;
                fn(user, ref);
            }
        }
        i = e + 1;
    }
}

/* The external URIs of a glTF JSON document. */
static inline void sylva_refs_gltf_(const char *json, size_t n, sylva_ref_fn fn, void *user)
{
    cJSON *root = cJSON_ParseWithLength(json, n);
    if (!root) return;
    static const char *const arrays[] = {"buffers", "images"};
    for (size_t k = 0; k < 2; k++) {
        const cJSON *arr = cJSON_GetObjectItemCaseSensitive(root, arrays[k]), *it;
        cJSON_ArrayForEach(it, arr)
        {
            const char *uri = cJSON_GetStringValue(cJSON_GetObjectItemCaseSensitive(it, "uri"));
            if (!uri || strncmp(uri, "data:", 5) == 0 || strlen(uri) >= 1024) continue;
            char ref[1024];
            snprintf(ref, sizeof ref, "%s", uri);
            if (sylva_uri_decode_(ref)) fn(user, ref);
            else fn(user, uri);
        }
    }
    cJSON_Delete(root);
}

/* Calls fn for every file the mesh or .mtl file `name` (data, size bytes)
 * names. The kind is told by the bytes (GLB magic, a JSON object) and by the
 * name (.mtl, else OBJ text); other formats name nothing here. Pure. */
static inline void sylva_refs_scan(const char *name, const unsigned char *data, size_t size,
                                   sylva_ref_fn fn, void *user)
{
    size_t nl = strlen(name);
    if (size >= 20 && memcmp(data, "glTF", 4) == 0) {
        uint32_t len = (uint32_t)data[12] | (uint32_t)data[13] << 8 | (uint32_t)data[14] << 16 |
                       (uint32_t)data[15] << 24;
        if (memcmp(data + 16, "JSON", 4) == 0 && len <= size - 20)
            sylva_refs_gltf_((const char *)data + 20, len, fn, user);
        return;
    }
    size_t i = 0;
    if (size >= 3 && memcmp(data, "\xEF\xBB\xBF", 3) == 0) i = 3;
    while (i < size && isspace(data[i])) i++;
    if (i < size && data[i] == '{') {
        sylva_refs_gltf_((const char *)data, size, fn, user);
        return;
    }
    bool mtl = nl >= 4 && strcasecmp(name + nl - 4, ".mtl") == 0;
    bool obj = nl >= 4 && strcasecmp(name + nl - 4, ".obj") == 0;
    if (mtl || obj) sylva_refs_text_((const char *)data, size, mtl, fn, user);
}

/* Companions found for one mesh (sylva_companions_find). */
typedef struct sylva_companions {
    char *paths[SYLVA_COMPANIONS_MAX]; /* found beside the mesh, in the order named */
    size_t count;
} sylva_companions;

/* Frees the paths of c and empties it. */
static inline void sylva_companions_free(sylva_companions *c)
{
    for (size_t i = 0; i < c->count; i++) free(c->paths[i]);
    c->count = 0;
}

/* The base name of p, with / or \ as separators. */
static inline const char *sylva_base_(const char *p)
{
    const char *b = p;
    for (const char *c = p; *c; c++)
        if (*c == '/' || *c == '\\') b = c + 1;
    return b;
}

/* Reads a whole file (NULL when it cannot be read). */
static inline unsigned char *sylva_slurp_(const char *path, size_t *size)
{
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    size_t cap = 1 << 16, n = 0;
    unsigned char *buf = malloc(cap);
    while (buf) {
        n += fread(buf + n, 1, cap - n, f);
        if (n < cap) break;
        unsigned char *nb = cap > ((size_t)1 << 34) ? NULL : realloc(buf, cap * 2);
        if (!nb) {
            free(buf);
            buf = NULL;
            break;
        }
        buf = nb;
        cap *= 2;
    }
    fclose(f);
    *size = n;
    return buf;
}

typedef struct sylva_scan_ {
    const char *prog;       /* "sylva-bake", "sylva": the prefix of the lines on log */
    FILE *log;              /* NULL: silent */
    const char *from;       /* the file whose references are scanned */
    char dir[4096];         /* its folder, "" for the current one */
    const char *const *given; /* the mesh and the files listed */
    size_t given_count;
    sylva_companions *out;
} sylva_scan_;

/* Whether a given or found file already has this base name (any case). */
static inline bool sylva_have_(const sylva_scan_ *s, const char *base)
{
    for (size_t i = 0; i < s->given_count; i++)
        if (strcasecmp(sylva_base_(s->given[i]), base) == 0) return true;
    for (size_t i = 0; i < s->out->count; i++)
        if (strcasecmp(sylva_base_(s->out->paths[i]), base) == 0) return true;
    return false;
}

/* sylva_ref_fn of sylva_companions_find: follows one reference if safe, new
 * and there. */
static inline void sylva_on_ref_(void *user, const char *ref)
{
    sylva_scan_ *s = user;
    /* never followed; the importer refuses it, naming it (one line, not two) */
    if (sylva_ref_unsafe(ref)) return;
    const char *base = sylva_base_(ref);
    if (!base[0] || sylva_have_(s, base) || s->out->count >= SYLVA_COMPANIONS_MAX) return;
    size_t need = strlen(s->dir) + strlen(ref) + 2;
    char *path = malloc(need);
    if (!path) return;
    snprintf(path, need, "%s%s", s->dir, ref);
    for (char *c = path + strlen(s->dir); *c; c++)
        if (*c == '\\') *c = '/';
    struct stat st;
    if (stat(path, &st) != 0 || !S_ISREG(st.st_mode)) { /* the importer names what is missing */
        free(path);
        return;
    }
    s->out->paths[s->out->count++] = path;
    if (s->log) fprintf(s->log, "%s: using %s (named by %s)\n", s->prog, path, sylva_base_(s->from));
}

/* Finds the companions `mesh` names that `listed` (n paths) lacks: the files
 * its references name (see the top of this file), looked for beside the file
 * naming them, then the references of those found and of the listed .mtl
 * files, and so on. A reference whose base name a listed file already has is
 * taken as supplied. Each file used is said on log ("PROG: using PATH (named
 * by NAME)"). An unsafe reference is never followed and a safe one that is
 * not there is left out, both silently: the import refuses either, naming
 * it, in its one line. *out receives the paths (sylva_companions_free). Returns false when
 * the mesh cannot be read (nothing found then). */
static inline bool sylva_companions_find(const char *mesh, const char *const *listed, size_t n,
                                         const char *prog, FILE *log, sylva_companions *out)
{
    memset(out, 0, sizeof *out);
    const char **given = calloc(n + 1, sizeof *given);
    if (!given) return false;
    given[0] = mesh;
    for (size_t i = 0; i < n; i++) given[i + 1] = listed[i];
    sylva_scan_ s = {.prog = prog, .log = log, .given = given, .given_count = n + 1, .out = out};
    bool ok = true;
    /* the mesh, the listed .mtl files, then each file found (found ones grow the list) */
    for (size_t k = 0; k < n + 1 + out->count; k++) {
        const char *path = k < n + 1 ? given[k] : out->paths[k - n - 1];
        size_t pl = strlen(path);
        if (k > 0 && !(pl >= 4 && strcasecmp(path + pl - 4, ".mtl") == 0)) continue;
        size_t size = 0;
        unsigned char *d = sylva_slurp_(path, &size);
        if (!d) {
            if (k == 0) ok = false;
            continue;
        }
        s.from = path;
        /* listed files resolve beside the mesh; found ones beside themselves */
        const char *dir_of = k == 0 || k > n ? path : mesh;
        const char *slash = strrchr(dir_of, '/');
        size_t dl = slash ? (size_t)(slash - dir_of) + 1 : 0;
        if (dl >= sizeof s.dir) dl = 0;
        memcpy(s.dir, dir_of, dl);
        s.dir[dl] = 0;
        sylva_refs_scan(sylva_base_(path), d, size, sylva_on_ref_, &s);
        free(d);
    }
    free(given);
    return ok;
}

#endif
