/* leaf_clusters_settings.c — the schema half of the leaf clusters
 * (method.h): their settings (leaf_clusters.c's header comment lists them),
 * their check and the target search's ladder. Linked by sylvad. */
#include "leaf_clusters.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

static const char *const lc_keys[] = {
    "clusters",    "alpha_rel",           "area_weighted", "iterations", "seed_tries",
    "trunk_ratio", "trunk_max_triangles", "twigs",         NULL};

static double default_trunk_ratio(uint32_t level)
{
    static const double table[3] = {0.5, 0.25, 0.1};
    return level < 3 ? table[level] : 0.05;
}

static sv_status parse_levels(const cJSON *s, lc_settings *o, sv_error *err)
{
    const cJSON *a = cJSON_GetObjectItemCaseSensitive(s, "clusters");
    if (!a) return SV_OK;
    /* One integer is a one-level list: `--set clusters=16` means [16]. */
    bool one = cJSON_IsNumber(a);
    int n = one ? 1 : cJSON_IsArray(a) ? cJSON_GetArraySize(a) : -1;
    if (n < 1 || n > LC_MAX_LEVELS)
        return sv_fail(err, SV_ERR_SPEC,
                       LC_NAME ".clusters: expected an integer or an array of 1 to %d integers",
                       LC_MAX_LEVELS);
    int i = 0;
    for (const cJSON *it = one ? a : a->child; it; it = one ? NULL : it->next, i++) {
        double v = cJSON_IsNumber(it) ? it->valuedouble : NAN;
        if (!isfinite(v) || v != floor(v) || v < 1 || v > LC_MAX_CLUSTERS)
            return sv_fail(err, SV_ERR_SPEC,
                           LC_NAME ".clusters[%d]: expected an integer in [1, %d]", i,
                           LC_MAX_CLUSTERS);
        o->levels[i] = (uint32_t)v;
        if (i > 0 && o->levels[i] >= o->levels[i - 1])
            return sv_fail(err, SV_ERR_SPEC,
                           LC_NAME ".clusters[%d]: counts must strictly decrease (%u after %u)", i,
                           o->levels[i], o->levels[i - 1]);
    }
    o->level_count = (uint32_t)n;
    return SV_OK;
}

static sv_status parse_trunk(const cJSON *s, lc_settings *o, sv_error *err)
{
    for (uint32_t l = 0; l < LC_MAX_LEVELS; l++) o->trunk_ratio[l] = default_trunk_ratio(l);
    const cJSON *a = cJSON_GetObjectItemCaseSensitive(s, "trunk_ratio");
    if (!a) return SV_OK;
    if (!cJSON_IsArray(a) || cJSON_GetArraySize(a) != (int)o->level_count)
        return sv_fail(err, SV_ERR_SPEC,
                       LC_NAME ".trunk_ratio: expected an array of %u numbers (one per level)",
                       o->level_count);
    int i = 0;
    for (const cJSON *it = a->child; it; it = it->next, i++) {
        double v = cJSON_IsNumber(it) ? it->valuedouble : NAN;
        if (!(v > 0 && v <= 1))
            return sv_fail(err, SV_ERR_SPEC,
                           LC_NAME ".trunk_ratio[%d]: expected a number in (0, 1]", i);
        o->trunk_ratio[i] = v;
    }
    return SV_OK;
}

sv_status lc_parse(const cJSON *s, lc_settings *o, sv_error *err)
{
    memset(o, 0, sizeof *o);
    o->levels[0] = 32, o->levels[1] = 16, o->levels[2] = 8;
    o->level_count = 3;
    o->alpha_rel = 0.0007; /* docs/methods/leaf_clusters.md, "Measured again" */
    o->area_weighted = true;
    o->iterations = 50;
    o->seed_tries = 4;
    for (int i = 0; i < LC_MAX_LEVELS; i++) o->trunk_max[i] = LC_TRUNK_MAX_DEFAULT;
    o->twigs = true;
    sv_status st;
    if ((st = sv_setting_only(s, LC_NAME, lc_keys, err))) return st;
    if ((st = parse_levels(s, o, err))) return st;
    if ((st = sv_setting_number(s, LC_NAME, "alpha_rel", 0, 100, &o->alpha_rel, err))) return st;
    if ((st = sv_setting_bool(s, LC_NAME, "area_weighted", &o->area_weighted, err))) return st;
    if ((st = sv_setting_int(s, LC_NAME, "iterations", 1, 1000, &o->iterations, err))) return st;
    if ((st = sv_setting_int(s, LC_NAME, "seed_tries", 1, 64, &o->seed_tries, err))) return st;
    if ((st = sv_setting_int_per_level(s, LC_NAME, "trunk_max_triangles", 1, 10000000, o->trunk_max,
                                       LC_MAX_LEVELS, err)))
        return st;
    if ((st = sv_setting_bool(s, LC_NAME, "twigs", &o->twigs, err))) return st;
    return parse_trunk(s, o, err);
}

static sv_status lc_check(const cJSON *settings, sv_error *err)
{
    lc_settings s;
    return lc_parse(settings, &s, err);
}

/* method.h ladder: clusters [K], K = 4 .. 128 (a given trunk_ratio is
 * dropped: it is one per level); under a triangle budget the kept trunk
 * yields to the quads (sv_ladder_trunk_share). */
static int lc_ladder(int step, uint32_t max_triangles, cJSON *set)
{
    static const int counts[] = {4, 6, 8, 12, 16, 24, 32, 48, 64, 96, 128};
    if (step < 0 || step >= (int)(sizeof counts / sizeof counts[0])) return SV_LADDER_END;
    cJSON_DeleteItemFromObjectCaseSensitive(set, "clusters");
    cJSON_DeleteItemFromObjectCaseSensitive(set, "trunk_ratio"); /* one per level */
    cJSON *a = cJSON_CreateArray();
    cJSON_AddItemToArray(a, cJSON_CreateNumber(counts[step]));
    cJSON_AddItemToObject(set, "clusters", a);
    return sv_ladder_trunk_share(set, max_triangles, counts[step], LC_TRUNK_MAX_DEFAULT);
}

const sv_method sv_method_leaf_clusters = {
    .name = LC_NAME,
    .summary = "leaf-cluster impostors (Garcia et al.): k-means planes over leaves, "
               "levels 32/16/8 with parent links",
    .check = lc_check,
    .ladder = lc_ladder,
};
