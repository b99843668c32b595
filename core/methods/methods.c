/* methods.c — the registry of stand-in methods (method.h). */
#include "method.h"

#include <string.h>

static const sv_method *const registry[] = {
    &sv_method_crossed_quads, &sv_method_leaf_clusters,   &sv_method_stochastic,
    &sv_method_slicing,       &sv_method_billboard_cloud, &sv_method_octahedral,
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
