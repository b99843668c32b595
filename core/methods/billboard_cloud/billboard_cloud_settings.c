/* billboard_cloud_settings.c — the schema half of the billboard clouds
 * (method.h): their settings (billboard_cloud.c's header comment lists
 * them), their check and the target search's ladder. Linked by sylvad. */
#include "billboard_cloud.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

static const char *const bc_keys[] = {"epsilon",
                                      "max_planes",
                                      "lods",
                                      "grid",
                                      "horizontal_penalty",
                                      "cardboard",
                                      "tweak",
                                      "weld",
                                      "threads",
                                      "miss_penalty",
                                      "max_angle_deg",
                                      "refine",
                                      "trunk",
                                      "trunk_max_triangles",
                                      NULL};

static sv_status parse_lods(const cJSON *arr, bc_settings *o, bool *given, sv_error *err)
{
    *given = false;
    if (!arr) return SV_OK;
    if (!cJSON_IsArray(arr)) return sv_fail(err, SV_ERR_SPEC, BC_NAME ".lods: expected an array");
    int n = cJSON_GetArraySize(arr);
    if (n < 1 || n > BC_MAX_LODS)
        return sv_fail(err, SV_ERR_SPEC, BC_NAME ".lods: expected 1 to %d levels, got %d",
                       BC_MAX_LODS, n);
    int i = 0;
    for (const cJSON *it = arr->child; it; it = it->next, i++) {
        bc_lod *l = &o->lods[i];
        l->epsilon = 0;
        l->max_planes = 0;
        char where[64];
        snprintf(where, sizeof where, BC_NAME ".lods[%d]", i);
        if (cJSON_IsNumber(it)) {
            double v = it->valuedouble;
            if (!isfinite(v) || v != floor(v) || v < 2 || v > 4096)
                return sv_fail(err, SV_ERR_SPEC, "%s: expected a plane count in [2, 4096]", where);
            l->max_planes = (long)v;
            continue;
        }
        if (!cJSON_IsObject(it))
            return sv_fail(err, SV_ERR_SPEC, "%s: expected a plane count or an object", where);
        static const char *const keys[] = {"epsilon", "max_planes", NULL};
        sv_status st;
        if ((st = sv_setting_only(it, where, keys, err))) return st;
        if ((st = sv_setting_number(it, where, "epsilon", 1e-6, 2.0, &l->epsilon, err))) return st;
        if ((st = sv_setting_int(it, where, "max_planes", 2, 4096, &l->max_planes, err))) return st;
        if (l->epsilon == 0 && l->max_planes == 0)
            return sv_fail(err, SV_ERR_SPEC, "%s: needs \"epsilon\" or \"max_planes\"", where);
    }
    o->lod_count = n;
    *given = true;
    return SV_OK;
}

sv_status bc_parse(const cJSON *s, bc_settings *o, sv_error *err)
{
    memset(o, 0, sizeof *o);
    o->epsilon = BC_DEFAULT_EPS;
    o->max_planes = BC_DEFAULT_MAX;
    o->grid[0] = 32;
    o->grid[1] = 16;
    o->grid[2] = 32;
    o->hp_enabled = -1;
    o->hp_penalty = 0.6;
    o->hp_angle = 50;
    o->cb_enabled = false;
    o->cb_coverage = 0.8;
    o->tweak = true;
    o->weld = true;
    o->threads = 2;
    o->miss_penalty = 0.5;
    o->max_angle = 75;
    o->refine = 48; /* docs/methods/billboard_cloud.md, k-planes iterations */
    o->trunk_mesh = true;
    for (int i = 0; i < BC_MAX_LODS; i++) o->trunk_max[i] = BC_TRUNK_MAX_DEFAULT;
    sv_status st;
    if ((st = sv_setting_only(s, BC_NAME, bc_keys, err))) return st;
    if ((st = sv_setting_number(s, BC_NAME, "epsilon", 1e-6, 2.0, &o->epsilon, err))) return st;
    if ((st = sv_setting_int(s, BC_NAME, "max_planes", 2, 4096, &o->max_planes, err))) return st;
    if ((st = sv_setting_bool(s, BC_NAME, "tweak", &o->tweak, err))) return st;
    if ((st = sv_setting_bool(s, BC_NAME, "weld", &o->weld, err))) return st;
    if ((st = sv_setting_int(s, BC_NAME, "threads", 1, 16, &o->threads, err))) return st;
    if ((st = sv_setting_number(s, BC_NAME, "miss_penalty", 0, 10, &o->miss_penalty, err)))
        return st;
    if ((st = sv_setting_number(s, BC_NAME, "max_angle_deg", 1, 90, &o->max_angle, err))) return st;
    if ((st = sv_setting_int(s, BC_NAME, "refine", 0, 1000, &o->refine, err))) return st;
    const cJSON *tr = s ? cJSON_GetObjectItemCaseSensitive(s, "trunk") : NULL;
    if (tr) {
        if (!cJSON_IsString(tr) ||
            (strcmp(tr->valuestring, "mesh") && strcmp(tr->valuestring, "planes")))
            return sv_fail(err, SV_ERR_SPEC, BC_NAME ".trunk: expected \"mesh\" or \"planes\"");
        o->trunk_mesh = !strcmp(tr->valuestring, "mesh");
    }
    if ((st = sv_setting_int_per_level(s, BC_NAME, "trunk_max_triangles", 1, 10000000, o->trunk_max,
                                       BC_MAX_LODS, err)))
        return st;

    const cJSON *g = s ? cJSON_GetObjectItemCaseSensitive(s, "grid") : NULL;
    if (g) {
        static const long lo[3] = {8, 4, 8}, hi[3] = {512, 256, 1024};
        static const char *const names[3] = {"θ", "φ", "ρ"};
        if (!cJSON_IsArray(g) || cJSON_GetArraySize(g) != 3)
            return sv_fail(err, SV_ERR_SPEC, BC_NAME ".grid: expected [nθ, nφ, nρ]");
        int i = 0;
        for (const cJSON *it = g->child; it; it = it->next, i++) {
            double v = cJSON_IsNumber(it) ? it->valuedouble : NAN;
            if (!isfinite(v) || v != floor(v) || v < lo[i] || v > hi[i])
                return sv_fail(err, SV_ERR_SPEC,
                               BC_NAME ".grid[%d]: n%s must be an integer in [%ld, %ld]", i,
                               names[i], lo[i], hi[i]);
            o->grid[i] = (long)v;
        }
        if (o->grid[0] % 2)
            return sv_fail(err, SV_ERR_SPEC,
                           BC_NAME ".grid[0]: nθ must be even (antipodal columns)");
    }
    const cJSON *hp = s ? cJSON_GetObjectItemCaseSensitive(s, "horizontal_penalty") : NULL;
    if (hp) {
        static const char *const keys[] = {"enabled", "penalty", "angle_deg", NULL};
        const char *where = BC_NAME ".horizontal_penalty";
        if ((st = sv_setting_only(hp, where, keys, err))) return st;
        const cJSON *en = cJSON_GetObjectItemCaseSensitive(hp, "enabled");
        if (en && !cJSON_IsNull(en)) {
            bool b = false;
            if ((st = sv_setting_bool(hp, where, "enabled", &b, err))) return st;
            o->hp_enabled = b;
        }
        if ((st = sv_setting_number(hp, where, "penalty", 0, 1, &o->hp_penalty, err))) return st;
        if ((st = sv_setting_number(hp, where, "angle_deg", 0, 89, &o->hp_angle, err))) return st;
    }
    const cJSON *cb = s ? cJSON_GetObjectItemCaseSensitive(s, "cardboard") : NULL;
    if (cb) {
        static const char *const keys[] = {"enabled", "coverage", NULL};
        const char *where = BC_NAME ".cardboard";
        if ((st = sv_setting_only(cb, where, keys, err))) return st;
        if ((st = sv_setting_bool(cb, where, "enabled", &o->cb_enabled, err))) return st;
        if ((st = sv_setting_number(cb, where, "coverage", 0, 1, &o->cb_coverage, err))) return st;
    }
    bool given = false;
    if ((st = parse_lods(s ? cJSON_GetObjectItemCaseSensitive(s, "lods") : NULL, o, &given, err)))
        return st;
    if (!given) {
        o->lod_count = 3;
        for (int i = 0; i < 3; i++) {
            long m = o->max_planes >> i;
            o->lods[i].epsilon = 0;
            o->lods[i].max_planes = m < 2 ? 2 : m;
        }
        o->lods[0].epsilon = 0;
    }
    return SV_OK;
}

static sv_status bc_check(const cJSON *settings, sv_error *err)
{
    bc_settings s;
    return bc_parse(settings, &s, err);
}

/* method.h ladder: lods [{epsilon 0.01, max_planes P}] (a small epsilon
 * raised until at most P planes remain: the best P planes), P = 4 .. 128;
 * under a triangle budget the kept trunk yields to the quads
 * (sv_ladder_trunk_share). */
static int bc_ladder(int step, uint32_t max_triangles, cJSON *set)
{
    static const int counts[] = {4, 6, 8, 12, 16, 24, 32, 48, 64, 96, 128};
    if (step < 0 || step >= (int)(sizeof counts / sizeof counts[0])) return SV_LADDER_END;
    cJSON *l = cJSON_CreateObject();
    cJSON_AddNumberToObject(l, "epsilon", 0.01);
    cJSON_AddNumberToObject(l, "max_planes", counts[step]);
    cJSON *a = cJSON_CreateArray();
    cJSON_AddItemToArray(a, l);
    cJSON_DeleteItemFromObjectCaseSensitive(set, "lods");
    cJSON_AddItemToObject(set, "lods", a);
    return sv_ladder_trunk_share(set, max_triangles, counts[step], BC_TRUNK_MAX_DEFAULT);
}

const sv_method sv_method_billboard_cloud = {
    .name = BC_NAME,
    .summary = "billboard clouds (Decoret 2003, Behrendt 2005): greedy dual-space plane "
               "selection, incremental LODs",
    .check = bc_check,
    .ladder = bc_ladder,
};
