/* crossed_quads_settings.c — the schema half of the crossed quads
 * (method.h): its settings (crossed_quads.c's header comment lists them),
 * their check and the target search's ladder. Linked by sylvad. */
#include "crossed_quads.h"

static const char *const cq_keys[] = {"planes", "horizontal", NULL};

sv_status cq_parse(const cJSON *s, cq_settings *o, sv_error *err)
{
    o->planes = 2;
    o->horizontal = false;
    sv_status st;
    if ((st = sv_setting_only(s, CQ_NAME, cq_keys, err))) return st;
    if ((st = sv_setting_int(s, CQ_NAME, "planes", 2, 3, &o->planes, err))) return st;
    return sv_setting_bool(s, CQ_NAME, "horizontal", &o->horizontal, err);
}

static sv_status cq_check(const cJSON *settings, sv_error *err)
{
    cq_settings s;
    return cq_parse(settings, &s, err);
}

/* method.h ladder: planes 2, 2 + horizontal, 3, 3 + horizontal. */
static int cq_ladder(int step, uint32_t max_triangles, cJSON *set)
{
    (void)max_triangles; /* its trunk is not a per-level budget of its own */
    if (step < 0 || step >= 4) return SV_LADDER_END;
    cJSON_DeleteItemFromObjectCaseSensitive(set, "planes");
    cJSON_DeleteItemFromObjectCaseSensitive(set, "horizontal");
    cJSON_AddNumberToObject(set, "planes", step < 2 ? 2 : 3);
    cJSON_AddBoolToObject(set, "horizontal", step % 2 == 1);
    return SV_LADDER_STEP;
}

const sv_method sv_method_crossed_quads = {
    .name = CQ_NAME,
    .summary = "2 or 3 vertical quads crossing on the trunk axis (+ optional horizontal): "
               "the cardboard baseline",
    .check = cq_check,
    .ladder = cq_ladder,
};
