/* slicing_settings.c — the schema half of the slicings (method.h): their
 * settings (slicing.c's header comment lists them), their check and the
 * target search's ladder. Linked by sylvad. */
#include "slicing.h"

#include <stdio.h>
#include <string.h>

#include "method.h"

static const char *const sl_keys[] = {"slicings", "slices", "spacing", "top", "trunk_ratio", NULL};

sv_status sl_parse(const cJSON *s, sl_settings *o, sv_error *err)
{
    o->slicings = 6;
    o->slices = 5;
    o->spacing = SL_DEFAULT_SPACING;
    o->top = -1;
    o->trunk_ratio = 0.25;
    sv_status st;
    if ((st = sv_setting_only(s, SL_NAME, sl_keys, err))) return st;
    if ((st = sv_setting_int(s, SL_NAME, "slicings", 1, SV_SLICING_MAX_SLICINGS, &o->slicings,
                             err)))
        return st;
    if ((st = sv_setting_int(s, SL_NAME, "slices", 1, SV_SLICING_MAX_SLICES, &o->slices, err)))
        return st;
    const cJSON *sp = s ? cJSON_GetObjectItemCaseSensitive(s, "spacing") : NULL;
    if (sp) {
        if (cJSON_IsString(sp) && strcmp(sp->valuestring, "uniform") == 0)
            o->spacing = SV_SPACING_UNIFORM;
        else if (cJSON_IsString(sp) && strcmp(sp->valuestring, "foliage") == 0)
            o->spacing = SV_SPACING_FOLIAGE;
        else
            return sv_fail(err, SV_ERR_SPEC,
                           SL_NAME ".spacing: expected \"uniform\" or \"foliage\"");
    }
    const cJSON *tp = s ? cJSON_GetObjectItemCaseSensitive(s, "top") : NULL;
    if (tp && !cJSON_IsNull(tp)) {
        bool b = false;
        if ((st = sv_setting_bool(s, SL_NAME, "top", &b, err)))
            return sv_fail(err, SV_ERR_SPEC, SL_NAME ".top: expected null, true or false");
        o->top = b ? 1 : 0;
    }
    if ((st = sv_setting_number(s, SL_NAME, "trunk_ratio", 0, 1, &o->trunk_ratio, err))) return st;
    if (!(o->trunk_ratio > 0))
        return sv_fail(err, SV_ERR_SPEC, SL_NAME ".trunk_ratio: expected a number in (0, 1]");
    return SV_OK;
}

static sv_status sl_check(const cJSON *settings, sv_error *err)
{
    sl_settings s;
    return sl_parse(settings, &s, err);
}

/* method.h ladder: slicings x slices, 2x2 .. 12x8. */
static int sl_ladder(int step, uint32_t max_triangles, cJSON *set)
{
    (void)max_triangles; /* its trunk is not a per-level budget of its own */
    static const int steps[][2] = {{2, 2}, {3, 3}, {4, 3}, {4, 4},  {6, 4},
                                   {6, 5}, {8, 5}, {8, 6}, {12, 6}, {12, 8}};
    if (step < 0 || step >= (int)(sizeof steps / sizeof steps[0])) return SV_LADDER_END;
    cJSON_DeleteItemFromObjectCaseSensitive(set, "slicings");
    cJSON_DeleteItemFromObjectCaseSensitive(set, "slices");
    cJSON_AddNumberToObject(set, "slicings", steps[step][0]);
    cJSON_AddNumberToObject(set, "slices", steps[step][1]);
    return SV_LADDER_STEP;
}

const sv_method sv_method_slicing = {
    .name = SL_NAME,
    .summary = "slicings (Jakulin): S sets of K parallel textured slices through the crown, "
               "the two nearest the view blended; trunk kept as a mesh",
    .check = sl_check,
    .ladder = sl_ladder,
};
