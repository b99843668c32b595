/* method_ops.c — the build registry of stand-in methods (method_ops.h) and
 * of their per-level hooks (level.h), made of registry.h. Kept out of
 * methods.c, which sylvad links to check settings: these run the methods,
 * render and write files. */
#include "level.h"
#include "method_ops.h"

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define SV_METHOD(n) extern const sv_method_ops sv_method_##n##_ops;
#include "registry.h"
#undef SV_METHOD

static const sv_method_ops *const registry[] = {
#define SV_METHOD(n) &sv_method_##n##_ops,
#include "registry.h"
#undef SV_METHOD
};
#define REGISTRY_COUNT (sizeof registry / sizeof registry[0])

const sv_method_ops *const *sv_method_ops_list(size_t *count)
{
    *count = REGISTRY_COUNT;
    return registry;
}

const sv_method_ops *sv_method_ops_find(const char *name)
{
    if (!name) return NULL;
    for (size_t i = 0; i < REGISTRY_COUNT; i++)
        if (strcmp(registry[i]->method->name, name) == 0) return registry[i];
    return NULL;
}

const sv_level_ops *sv_level_ops_find(const char *method)
{
    const sv_method_ops *m = sv_method_ops_find(method);
    return m ? m->levels : NULL;
}

void sv_chain_out_free(sv_chain_out *o)
{
    sv_stand_in_free(&o->levels);
    free(o->place);
    cJSON_Delete(o->skipped);
    cJSON_Delete(o->report);
    memset(o, 0, sizeof *o);
}

cJSON *sv_chain_skip_note(cJSON *skipped, const char *name, const char *stage, const char *fmt, ...)
{
    char why[400];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(why, sizeof why, fmt, ap);
    va_end(ap);
    cJSON *o = cJSON_CreateObject();
    cJSON_AddStringToObject(o, "name", name);
    cJSON_AddStringToObject(o, "stage", stage);
    cJSON_AddStringToObject(o, "reason", why);
    cJSON_AddItemToArray(skipped, o);
    return o;
}

/* ---- the request's memo (method_ops.h) ---- */

typedef struct memo_slot {
    char key[32];
    void *data;
    void (*free_fn)(void *);
} memo_slot;

struct sv_memo {
    memo_slot *slots;
    size_t n, cap;
};

sv_memo *sv_memo_create(void) { return calloc(1, sizeof(sv_memo)); }

void sv_memo_free(sv_memo *m)
{
    if (!m) return;
    for (size_t i = 0; i < m->n; i++)
        if (m->slots[i].free_fn) m->slots[i].free_fn(m->slots[i].data);
    free(m->slots);
    free(m);
}

void *sv_memo_slot(sv_memo *m, const char *key, void *(*make)(void), void (*free_fn)(void *))
{
    if (!m || strlen(key) >= sizeof m->slots[0].key) return NULL;
    for (size_t i = 0; i < m->n; i++)
        if (!strcmp(m->slots[i].key, key)) return m->slots[i].data;
    if (m->n == m->cap) {
        size_t cap = m->cap ? 2 * m->cap : 4;
        memo_slot *s = realloc(m->slots, cap * sizeof *s);
        if (!s) return NULL;
        m->slots = s;
        m->cap = cap;
    }
    void *data = make();
    if (!data) return NULL;
    memo_slot *s = &m->slots[m->n++];
    snprintf(s->key, sizeof s->key, "%s", key);
    s->data = data;
    s->free_fn = free_fn;
    return data;
}
