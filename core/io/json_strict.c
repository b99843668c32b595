/* json_strict.c — cJSON with the checks that make it read the same document
 * as any other conforming parser (RFC 8259 §4: "names within an object SHOULD
 * be unique"; §7: control characters must be escaped; §2: one value). */
#include "json_strict.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

/* The strings of text: no raw control byte inside one, no \u0000 escape.
 * Returns the offset of the first bad string's opening quote, or -1. *is_key
 * says whether it is an object key. Syntax is cJSON's to judge. */
static long bad_string(const char *text, size_t len, int *is_key, int *raw)
{
    size_t i = 0;
    while (i < len) {
        if (text[i] != '"') {
            i++;
            continue;
        }
        size_t start = i++;
        int bad = 0;
        *raw = 0;
        while (i < len && text[i] != '"') {
            unsigned char c = (unsigned char)text[i];
            if (c < 0x20) {
                bad = 1;
                *raw = 1;
                i++;
            } else if (c == '\\' && i + 1 < len) {
                if (text[i + 1] == 'u' && i + 5 < len && text[i + 2] == '0' &&
                    text[i + 3] == '0' && text[i + 4] == '0' && text[i + 5] == '0')
                    bad = 1;
                i += 2;
            } else {
                i++;
            }
        }
        i++; /* the closing quote */
        if (bad) {
            size_t k = i;
            while (k < len && (text[k] == ' ' || text[k] == '\t' || text[k] == '\n' ||
                               text[k] == '\r'))
                k++;
            *is_key = k < len && text[k] == ':';
            return (long)start;
        }
    }
    return -1;
}

static int cmp_keys(const void *a, const void *b)
{
    return strcmp(*(const char *const *)a, *(const char *const *)b);
}

/* The first key that appears twice in one object of the tree, or NULL.
 * Iterative; keys are compared after sorting each object's names. */
static const char *duplicate_key(const cJSON *root, int *nomem)
{
    size_t cap = 64, sp = 0, kcap = 0;
    const cJSON **stack = malloc(cap * sizeof *stack);
    const char **keys = NULL, *dup = NULL;
    *nomem = 0;
    if (!stack) {
        *nomem = 1;
        return NULL;
    }
    stack[sp++] = root;
    while (sp && !dup) {
        const cJSON *n = stack[--sp];
        size_t nk = 0;
        for (const cJSON *c = n->child; c; c = c->next) {
            if (cJSON_IsArray(c) || cJSON_IsObject(c)) {
                if (sp == cap) {
                    const cJSON **ns = realloc(stack, 2 * cap * sizeof *ns);
                    if (!ns) goto oom;
                    stack = ns;
                    cap *= 2;
                }
                stack[sp++] = c;
            }
            if (cJSON_IsObject(n)) {
                if (nk == kcap) {
                    size_t nc = kcap ? 2 * kcap : 64;
                    const char **nkeys = realloc(keys, nc * sizeof *nkeys);
                    if (!nkeys) goto oom;
                    keys = nkeys;
                    kcap = nc;
                }
                keys[nk++] = c->string ? c->string : "";
            }
        }
        if (nk > 1) {
            qsort(keys, nk, sizeof *keys, cmp_keys);
            for (size_t i = 1; i < nk && !dup; i++)
                if (strcmp(keys[i - 1], keys[i]) == 0) dup = keys[i];
        }
    }
    free(stack);
    free(keys);
    return dup;
oom:
    *nomem = 1;
    free(stack);
    free(keys);
    return NULL;
}

cJSON *sv_json_parse_strict(const char *text, size_t len, const char *what, sv_status st,
                            sv_error *err)
{
    int is_key = 0, raw = 0;
    long at = bad_string(text, len, &is_key, &raw);
    if (at >= 0) {
        sv_fail(err, st, "%s: the %s at byte %ld holds %s", what, is_key ? "key" : "string", at,
                raw ? "a raw control character (NUL, newline ...)" : "a NUL (\\u0000)");
        return NULL;
    }
    const char *end = NULL;
    cJSON *root = cJSON_ParseWithLengthOpts(text, len, &end, 0);
    if (!root) {
        size_t off = end ? (size_t)(end - text) : 0;
        sv_fail(err, st, "%s: JSON syntax error at byte %zu of %zu", what, off, len);
        return NULL;
    }
    size_t off = (size_t)(end - text);
    while (off < len &&
           (text[off] == ' ' || text[off] == '\t' || text[off] == '\n' || text[off] == '\r'))
        off++;
    if (off < len) {
        sv_fail(err, st, "%s: content after the JSON value at byte %zu of %zu (one value only)",
                what, off, len);
        cJSON_Delete(root);
        return NULL;
    }
    int nomem = 0;
    const char *dup = duplicate_key(root, &nomem);
    if (dup || nomem) {
        if (nomem)
            sv_fail(err, SV_ERR_NOMEM, "%s: out of memory checking keys", what);
        else
            sv_fail(err, st, "%s: the key \"%.100s\" appears twice in one object", what, dup);
        cJSON_Delete(root);
        return NULL;
    }
    return root;
}
