/* spec_flags.h — the spec a bake runs with, from a --spec file and the
 * command-line flags both tools take (sylva-bake bake and sylva bake;
 * docs/client.md "Options"), so the two read --method and --set alike:
 *
 *   --method NAME        spec "method"
 *   --set key=value      value as JSON when it parses, else a string; an
 *                        undotted key is a setting of the method
 *                        (spec[method][key]), a dotted key a path from the
 *                        root (billboard_cloud.lods=[20]); "seed", "method"
 *                        and ".name" are root keys
 *   --units U            the same as --set import.units=U
 *   --up Y|Z|auto        the same as --set import.up=...
 *
 * Flags override the --spec file. Header-only (static): the client links
 * nothing of core.
 */
#ifndef SYLVA_SPEC_FLAGS_H
#define SYLVA_SPEC_FLAGS_H

#include <cjson/cJSON.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Formats a message into err (errlen bytes; nothing when err is NULL). */
static inline void sylva_spec_err_(char *err, size_t errlen, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));
static inline void sylva_spec_err_(char *err, size_t errlen, const char *fmt, ...)
{
    if (!err || !errlen) return;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(err, errlen, fmt, ap);
    va_end(ap);
}

/* Builds the spec to bake with. base (may be NULL: none) is the --spec file's
 * bytes. Without method and sets the spec is base exactly (or NULL when base
 * is NULL: the caller then uses "{}"). Otherwise base (or {}) is parsed,
 * "method" is set, and each "key=value" of sets is applied as the top of this
 * file says. *out (free()) receives the bytes, *out_len their length.
 * Returns 0, or -1 with a one-line message in err (a usage error). */
static inline int sylva_spec_build(const char *base, size_t base_len, const char *method,
                         const char *const *sets, size_t set_count, char **out, size_t *out_len,
                         char *err, size_t errlen)
{
    *out = NULL;
    *out_len = 0;
    if (!method && set_count == 0) {
        if (!base) return 0;
        char *copy = malloc(base_len + 1);
        if (!copy) {
            sylva_spec_err_(err, errlen, "out of memory");
            return -1;
        }
        memcpy(copy, base, base_len);
        copy[base_len] = '\0';
        *out = copy;
        *out_len = base_len;
        return 0;
    }
    int rc = -1;
    cJSON *root = base ? cJSON_ParseWithLength(base, base_len) : cJSON_CreateObject();
    if (!cJSON_IsObject(root)) {
        sylva_spec_err_(err, errlen, "the spec file is not a JSON object");
        goto out;
    }
    if (method) {
        cJSON *m = cJSON_CreateString(method);
        if (!m || (cJSON_HasObjectItem(root, "method")
                       ? !cJSON_ReplaceItemInObjectCaseSensitive(root, "method", m)
                       : !cJSON_AddItemToObject(root, "method", m))) {
            cJSON_Delete(m);
            sylva_spec_err_(err, errlen, "out of memory");
            goto out;
        }
    }
    const cJSON *jm = cJSON_GetObjectItemCaseSensitive(root, "method");
    const char *mname = cJSON_IsString(jm) ? jm->valuestring : NULL;
    for (size_t i = 0; i < set_count; i++) {
        const char *eq = strchr(sets[i], '=');
        if (!eq || eq == sets[i]) {
            sylva_spec_err_(err, errlen, "--set expects key=value, got \"%.60s\"", sets[i]);
            goto out;
        }
        char key[512];
        size_t kl = (size_t)(eq - sets[i]);
        if (kl >= sizeof key) {
            sylva_spec_err_(err, errlen, "--set key too long");
            goto out;
        }
        memcpy(key, sets[i], kl);
        key[kl] = '\0';
        const char *value = eq + 1;
        cJSON *v = cJSON_ParseWithOpts(value, NULL, 1);
        if (!v) v = cJSON_CreateString(value);
        if (!v) {
            sylva_spec_err_(err, errlen, "out of memory");
            goto out;
        }
        cJSON *obj = root;
        char *path = key;
        /* The root: a leading dot (".lod={...}"), or an undotted key naming one
         * of the spec's top-level scalars (docs/spec.md). */
        bool at_root = key[0] == '.' || strcmp(key, "seed") == 0 || strcmp(key, "method") == 0;
        if (key[0] == '.') path = key + 1;
        if (at_root && (!path[0] || strchr(path, '.'))) {
            cJSON_Delete(v);
            sylva_spec_err_(err, errlen, "--set %.*s: a root key is one name after the dot", (int)kl,
                    sets[i]);
            goto out;
        }
        if (at_root) {
            /* obj stays the root */
        } else if (!strchr(key, '.')) {
            if (!mname) {
                cJSON_Delete(v);
                sylva_spec_err_(err, errlen, "--set %s needs --method (or a spec naming the method)", key);
                goto out;
            }
            cJSON *mo = cJSON_GetObjectItemCaseSensitive(root, mname);
            if (!mo) mo = cJSON_AddObjectToObject(root, mname);
            if (!cJSON_IsObject(mo)) {
                cJSON_Delete(v);
                sylva_spec_err_(err, errlen, "--set %s: spec key \"%s\" is not an object", key, mname);
                goto out;
            }
            obj = mo;
        } else {
            char *dot;
            while ((dot = strchr(path, '.')) != NULL) {
                *dot = '\0';
                if (!path[0]) {
                    cJSON_Delete(v);
                    sylva_spec_err_(err, errlen, "--set: empty component in key \"%.*s\"", (int)kl,
                            sets[i]);
                    goto out;
                }
                cJSON *next = cJSON_GetObjectItemCaseSensitive(obj, path);
                if (!next) next = cJSON_AddObjectToObject(obj, path);
                if (!cJSON_IsObject(next)) {
                    cJSON_Delete(v);
                    sylva_spec_err_(err, errlen, "--set %.*s: \"%s\" is not an object", (int)kl, sets[i],
                            path);
                    goto out;
                }
                obj = next;
                path = dot + 1;
            }
            if (!path[0]) {
                cJSON_Delete(v);
                sylva_spec_err_(err, errlen, "--set: key \"%.*s\" ends with a dot", (int)kl, sets[i]);
                goto out;
            }
        }
        bool ok = cJSON_HasObjectItem(obj, path)
                      ? cJSON_ReplaceItemInObjectCaseSensitive(obj, path, v)
                      : cJSON_AddItemToObject(obj, path, v);
        if (!ok) {
            cJSON_Delete(v);
            sylva_spec_err_(err, errlen, "out of memory");
            goto out;
        }
        jm = cJSON_GetObjectItemCaseSensitive(root, "method");
        mname = cJSON_IsString(jm) ? jm->valuestring : NULL;
    }
    char *text = cJSON_PrintUnformatted(root);
    if (!text) {
        sylva_spec_err_(err, errlen, "out of memory");
        goto out;
    }
    *out = text;
    *out_len = strlen(text);
    rc = 0;
out:
    cJSON_Delete(root);
    return rc;
}

#endif
