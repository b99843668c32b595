/* levels.c — the bake's half of the method registry: each method's
 * per-level hooks (level.h). Kept out of methods.c, which sylvad links to
 * check settings: these hooks render and write files. */
#include "level.h"

#include <string.h>

static const sv_level_ops *const registry[] = {
    &sv_octa_level_ops,
};

const sv_level_ops *const *sv_level_ops_list(size_t *count)
{
    *count = sizeof registry / sizeof registry[0];
    return registry;
}

const sv_level_ops *sv_level_ops_find(const char *method)
{
    if (!method) return NULL;
    for (size_t i = 0; i < sizeof registry / sizeof registry[0]; i++)
        if (strcmp(registry[i]->method, method) == 0) return registry[i];
    return NULL;
}
