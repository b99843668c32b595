/* method_settings.c — strict parsing helpers for method settings (method.h).
 *
 * Every helper names the offending key as "section.key" so a spec error points
 * at the exact place. A missing object or key is not an error: the caller's
 * default stays in *out.
 */
#include "method.h"

#include <math.h>
#include <string.h>

static const cJSON *item_of(const cJSON *obj, const char *key)
{
    if (!obj || !cJSON_IsObject(obj)) return NULL;
    return cJSON_GetObjectItemCaseSensitive(obj, key);
}

sv_status sv_setting_number(const cJSON *obj, const char *method, const char *key, double lo,
                            double hi, double *out, sv_error *err)
{
    const cJSON *it = item_of(obj, key);
    if (!it) return SV_OK;
    if (!cJSON_IsNumber(it) || !isfinite(it->valuedouble))
        return sv_fail(err, SV_ERR_SPEC, "%s.%s: expected a number", method, key);
    double v = it->valuedouble;
    if (!(v >= lo && v <= hi))
        return sv_fail(err, SV_ERR_SPEC, "%s.%s: %g is outside [%g, %g]", method, key, v, lo, hi);
    *out = v;
    return SV_OK;
}

sv_status sv_setting_int(const cJSON *obj, const char *method, const char *key, long lo, long hi,
                         long *out, sv_error *err)
{
    const cJSON *it = item_of(obj, key);
    if (!it) return SV_OK;
    if (!cJSON_IsNumber(it) || !isfinite(it->valuedouble) ||
        it->valuedouble != floor(it->valuedouble))
        return sv_fail(err, SV_ERR_SPEC, "%s.%s: expected an integer", method, key);
    double v = it->valuedouble;
    /* Compare in double first so huge values cannot overflow the conversion. */
    if (!(v >= (double)lo && v <= (double)hi))
        return sv_fail(err, SV_ERR_SPEC, "%s.%s: %g is outside [%ld, %ld]", method, key, v, lo, hi);
    *out = (long)v;
    return SV_OK;
}

sv_status sv_setting_bool(const cJSON *obj, const char *method, const char *key, bool *out,
                          sv_error *err)
{
    const cJSON *it = item_of(obj, key);
    if (!it) return SV_OK;
    if (!cJSON_IsBool(it))
        return sv_fail(err, SV_ERR_SPEC, "%s.%s: expected true or false", method, key);
    *out = cJSON_IsTrue(it);
    return SV_OK;
}

sv_status sv_setting_only(const cJSON *obj, const char *method, const char *const *known,
                          sv_error *err)
{
    if (!obj) return SV_OK;
    if (!cJSON_IsObject(obj)) return sv_fail(err, SV_ERR_SPEC, "%s: expected an object", method);
    for (const cJSON *it = obj->child; it; it = it->next) {
        bool found = false;
        for (size_t i = 0; known && known[i]; i++)
            if (it->string && strcmp(it->string, known[i]) == 0) {
                found = true;
                break;
            }
        if (!found)
            return sv_fail(err, SV_ERR_SPEC, "%s.%.64s: unknown setting", method,
                           it->string ? it->string : "?");
    }
    return SV_OK;
}

sv_status sv_setting_int_per_level(const cJSON *obj, const char *method, const char *key, long lo,
                                   long hi, long *out, int n, sv_error *err)
{
    const cJSON *a = item_of(obj, key);
    if (!a) return SV_OK;
    if (!cJSON_IsArray(a)) {
        long v = out[0];
        sv_status st = sv_setting_int(obj, method, key, lo, hi, &v, err);
        if (st) return st;
        for (int i = 0; i < n; i++) out[i] = v;
        return SV_OK;
    }
    int count = cJSON_GetArraySize(a), i = 0;
    if (count < 1 || count > n)
        return sv_fail(err, SV_ERR_SPEC, "%s.%s: expected a number or 1 to %d numbers", method, key,
                       n);
    for (const cJSON *it = a->child; it; it = it->next, i++) {
        double v = cJSON_IsNumber(it) ? it->valuedouble : NAN;
        if (!isfinite(v) || v != floor(v) || v < (double)lo || v > (double)hi)
            return sv_fail(err, SV_ERR_SPEC, "%s.%s[%d]: expected an integer in [%ld, %ld]", method,
                           key, i, lo, hi);
        out[i] = (long)v;
    }
    for (; i < n; i++) out[i] = out[i - 1];
    return SV_OK;
}

int sv_ladder_trunk_share(cJSON *settings, uint32_t max_triangles, int quads, long trunk_default)
{
    if (!max_triangles || !settings ||
        cJSON_GetObjectItemCaseSensitive(settings, "trunk_max_triangles"))
        return SV_LADDER_STEP;
    long floor = (long)max_triangles / 4, left = (long)max_triangles - 2L * quads;
    long trunk = left < trunk_default ? left : trunk_default;
    bool over = left < floor;
    if (trunk < floor) trunk = floor;
    if (trunk < 1) trunk = 1;
    cJSON_AddNumberToObject(settings, "trunk_max_triangles", (double)trunk);
    return over ? SV_LADDER_OVER : SV_LADDER_STEP;
}
