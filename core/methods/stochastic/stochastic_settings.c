/* stochastic_settings.c — the schema half of the stochastic
 * simplification (method.h): its settings (stochastic.h,
 * sv_stochastic_settings), their check and the target search's ladder.
 * Linked by sylvad. */
#include "stochastic.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#define ST_NAME "stochastic"

/* ---- settings ----------------------------------------------------------- */

static const char *const st_keys[] = {"levels",
                                      "h",
                                      "d0",
                                      "order",
                                      "fade",
                                      "area_preservation",
                                      "contrast_preservation",
                                      "shutter",
                                      "ratio_fraction",
                                      "visible_ratio",
                                      "simplify_leaves",
                                      NULL};

sv_status sv_stochastic_parse(const cJSON *o, sv_stochastic_settings *s, sv_error *err)
{
    memset(s, 0, sizeof *s);
    static const double def[4] = {1, 0.5, 0.25, 0.1};
    memcpy(s->levels, def, sizeof def);
    s->level_count = 4;
    s->h = 0.5;
    s->fade = 0.1;
    s->area_preservation = true;
    s->contrast_preservation = true;
    s->simplify_leaves = true;
    s->shutter = 1.0 / 60.0;
    s->ratio_fraction = 0.1;
    sv_status st;
    if ((st = sv_setting_only(o, ST_NAME, st_keys, err))) return st;
    const cJSON *lv = cJSON_GetObjectItemCaseSensitive(o, "levels");
    if (lv) {
        int n = cJSON_IsArray(lv) ? cJSON_GetArraySize(lv) : -1;
        if (n < 1 || n > SV_STOCH_MAX_LEVELS)
            return sv_fail(err, SV_ERR_SPEC,
                           ST_NAME ".levels: expected an array of 1 to %d numbers in (0, 1]",
                           SV_STOCH_MAX_LEVELS);
        for (int i = 0; i < n; i++) {
            const cJSON *e = cJSON_GetArrayItem(lv, i);
            if (cJSON_IsObject(e)) {
                /* {"triangles": N}: resolved to λ by sv_stochastic_resolve */
                const cJSON *t = cJSON_GetObjectItemCaseSensitive(e, "triangles");
                if (!cJSON_IsNumber(t) || cJSON_GetArraySize(e) != 1 || !(t->valuedouble >= 1) ||
                    t->valuedouble > 4e9 || t->valuedouble != floor(t->valuedouble))
                    return sv_fail(err, SV_ERR_SPEC,
                                   ST_NAME ".levels[%d]: expected {\"triangles\": N} with N a "
                                           "whole number >= 1 and no other key",
                                   i);
                s->level_triangles[i] = (uint32_t)t->valuedouble;
                s->levels[i] = 0;
                continue;
            }
            if (!cJSON_IsNumber(e) || !(e->valuedouble > 0) || e->valuedouble > 1)
                return sv_fail(err, SV_ERR_SPEC,
                               ST_NAME ".levels[%d]: expected a number in (0, 1] or "
                                       "{\"triangles\": N}",
                               i);
            if (i > 0 && !s->level_triangles[i - 1] && !(e->valuedouble < s->levels[i - 1]))
                return sv_fail(err, SV_ERR_SPEC,
                               ST_NAME ".levels[%d]: levels must be strictly decreasing", i);
            s->levels[i] = e->valuedouble;
        }
        s->level_count = (uint32_t)n;
    }
    if ((st = sv_setting_number(o, ST_NAME, "h", 0.01, 0.99, &s->h, err))) return st;
    if ((st = sv_setting_number(o, ST_NAME, "d0", 0, 1e7, &s->d0, err))) return st;
    if ((st = sv_setting_number(o, ST_NAME, "fade", 0, 0.5, &s->fade, err))) return st;
    if ((st = sv_setting_bool(o, ST_NAME, "area_preservation", &s->area_preservation, err)))
        return st;
    if ((st = sv_setting_bool(o, ST_NAME, "contrast_preservation", &s->contrast_preservation, err)))
        return st;
    if ((st = sv_setting_bool(o, ST_NAME, "simplify_leaves", &s->simplify_leaves, err))) return st;
    if ((st = sv_setting_number(o, ST_NAME, "shutter", 0, 1, &s->shutter, err))) return st;
    if ((st = sv_setting_number(o, ST_NAME, "ratio_fraction", 0.01, 0.5, &s->ratio_fraction, err)))
        return st;
    if ((st = sv_setting_number(o, ST_NAME, "visible_ratio", 0, 1, &s->visible_ratio, err)))
        return st;
    const cJSON *ord = cJSON_GetObjectItemCaseSensitive(o, "order");
    if (ord) {
        if (cJSON_IsString(ord) && strcmp(ord->valuestring, "random") == 0)
            s->order = SV_STOCH_ORDER_RANDOM;
        else if (cJSON_IsString(ord) && strcmp(ord->valuestring, "area") == 0)
            s->order = SV_STOCH_ORDER_AREA;
        else return sv_fail(err, SV_ERR_SPEC, ST_NAME ".order: expected one of random, area");
    }
    return SV_OK;
}

static sv_status st_check(const cJSON *settings, sv_error *err)
{
    sv_stochastic_settings s;
    return sv_stochastic_parse(settings, &s, err);
}

/* method.h ladder: levels [lambda], lambda = 0.02 .. 1. */
static int st_ladder(int step, uint32_t max_triangles, cJSON *set)
{
    (void)max_triangles; /* its trunk is not a per-level budget of its own */
    static const double lambdas[] = {0.02, 0.05, 0.1, 0.2, 0.3, 0.5, 0.75, 1.0};
    if (step < 0 || step >= (int)(sizeof lambdas / sizeof lambdas[0])) return SV_LADDER_END;
    cJSON_DeleteItemFromObjectCaseSensitive(set, "levels");
    cJSON *a = cJSON_CreateArray();
    cJSON_AddItemToArray(a, cJSON_CreateNumber(lambdas[step]));
    cJSON_AddItemToObject(set, "levels", a);
    return SV_LADDER_STEP;
}

const sv_method sv_method_stochastic = {
    .name = ST_NAME,
    .summary = "stochastic simplification of the foliage (Cook et al. 2007): random leaf "
               "subsets, area- and contrast-preserving, as meshes",
    .check = st_check,
    .ladder = st_ladder,
    .chain_levels = true,
};
