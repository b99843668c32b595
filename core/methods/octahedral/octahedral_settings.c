/* octahedral_settings.c — the schema half of the octahedral impostor
 * (method.h): its settings (docs/methods/octahedral.md), their check and
 * the target search's ladder. Linked by sylvad. */
#include "octahedral.h"

#include <stdio.h>
#include <string.h>

#include "method.h"

#define OCTA_NAME SV_OCTA_METHOD

static const char *const octa_keys[] = {
    "grid", "hemi", "frame_pixels", "proxy_quads", "elevation_scale", NULL};

sv_status octa_parse(const cJSON *s, octa_settings *o, sv_error *err)
{
    memset(o, 0, sizeof *o);
    o->proxy_quads = SV_OCTA_PROXY_QUADS;
    sv_status st;
    if ((st = sv_setting_only(s, OCTA_NAME, octa_keys, err))) return st;
    if ((st = sv_setting_int(s, OCTA_NAME, "proxy_quads", 1, 8, &o->proxy_quads, err))) return st;
    if ((st = sv_setting_number(s, OCTA_NAME, "elevation_scale", 0.1, 1, &o->elev_scale, err)))
        return st;
    if ((st = sv_setting_int(s, OCTA_NAME, "grid", 2, SV_OCTA_MAX_GRID, &o->grid, err))) return st;
    if (cJSON_GetObjectItemCaseSensitive(s, "hemi")) {
        if ((st = sv_setting_bool(s, OCTA_NAME, "hemi", &o->hemi, err))) return st;
        o->hemi_set = true;
    }
    if ((st = sv_setting_int(s, OCTA_NAME, "frame_pixels", 0, 2048, &o->frame_pixels, err)))
        return st;
    if (o->frame_pixels && (o->frame_pixels < 8 || (o->frame_pixels & (o->frame_pixels - 1))))
        return sv_fail(err, SV_ERR_SPEC,
                       "octahedral.frame_pixels: %ld is not a power of two in [8, 2048] (or 0)",
                       o->frame_pixels);
    return SV_OK;
}

static sv_status octa_check(const cJSON *settings, sv_error *err)
{
    octa_settings s;
    return octa_parse(settings, &s, err);
}

/* method.h ladder: grid N = 4 .. 16 (frames keep their size, so
 * texels grow as N^2; every step has the same proxy of proxy_quads quads). */
static int octa_ladder(int step, uint32_t max_triangles, cJSON *set)
{
    (void)max_triangles; /* its trunk is not a per-level budget of its own */
    static const int grids[] = {4, 6, 8, 12, 16};
    if (step < 0 || step >= (int)(sizeof grids / sizeof grids[0])) return SV_LADDER_END;
    cJSON_DeleteItemFromObjectCaseSensitive(set, "grid");
    cJSON_AddNumberToObject(set, "grid", grids[step]);
    return SV_LADDER_STEP;
}

const sv_method sv_method_octahedral = {
    .name = OCTA_NAME,
    .summary = "octahedral impostor: N×N views on an octahedron (or hemi), three blended per view",
    .check = octa_check,
    .ladder = octa_ladder,
};
