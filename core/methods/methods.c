/* methods.c — the schema registry of stand-in methods (method.h), made of
 * registry.h. Links no method's build half. */
#include "method.h"

#include <string.h>

#define SV_METHOD(n) extern const sv_method sv_method_##n;
#include "registry.h"
#undef SV_METHOD

static const sv_method *const registry[] = {
#define SV_METHOD(n) &sv_method_##n,
#include "registry.h"
#undef SV_METHOD
};

const sv_method *const *sv_method_list(size_t *count)
{
    *count = sizeof registry / sizeof registry[0];
    return registry;
}

const sv_method *sv_method_find(const char *name)
{
    if (!name) return NULL;
    for (size_t i = 0; i < sizeof registry / sizeof registry[0]; i++)
        if (strcmp(registry[i]->name, name) == 0) return registry[i];
    return NULL;
}

const sv_method *sv_method_chain_levels(void)
{
    for (size_t i = 0; i < sizeof registry / sizeof registry[0]; i++)
        if (registry[i]->chain_levels) return registry[i];
    return NULL;
}
