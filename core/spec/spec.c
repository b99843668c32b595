/* spec.c — strict parsing of the bake spec (spec.h, docs/spec.md). */
#include "spec.h"

#include <ctype.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "json_strict.h"
#include "method.h"

static const char *const top_keys[] = {"method", "scene",  "import", "classify", "bake", "evaluate",
                                       "lod",    "output", "target", "seed",     NULL};

static sv_status parse_enum(const cJSON *obj, const char *section, const char *key,
                            const char *const *names, int *out, sv_error *err)
{
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(obj, key);
    if (!v) return SV_OK;
    if (cJSON_IsString(v))
        for (int i = 0; names[i]; i++)
            if (strcmp(v->valuestring, names[i]) == 0) {
                *out = i;
                return SV_OK;
            }
    char list[160] = "";
    for (int i = 0; names[i]; i++) {
        strncat(list, i ? ", " : "", sizeof list - strlen(list) - 1);
        strncat(list, names[i], sizeof list - strlen(list) - 1);
    }
    return sv_fail(err, SV_ERR_SPEC, "%s.%s: expected one of %s", section, key, list);
}

static sv_status parse_vec3(const cJSON *obj, const char *section, const char *key, double out[3],
                            bool normalise, sv_error *err)
{
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(obj, key);
    if (!v) return SV_OK;
    if (!cJSON_IsArray(v) || cJSON_GetArraySize(v) != 3)
        return sv_fail(err, SV_ERR_SPEC, "%s.%s: expected an array of 3 numbers", section, key);
    double t[3], len = 0;
    for (int i = 0; i < 3; i++) {
        const cJSON *e = cJSON_GetArrayItem(v, i);
        if (!cJSON_IsNumber(e) || !isfinite(e->valuedouble) || fabs(e->valuedouble) > 1e6)
            return sv_fail(err, SV_ERR_SPEC, "%s.%s: expected an array of 3 finite numbers",
                           section, key);
        t[i] = e->valuedouble;
        len += t[i] * t[i];
    }
    len = sqrt(len);
    if (normalise) {
        if (len < 1e-9)
            return sv_fail(err, SV_ERR_SPEC, "%s.%s: direction must not be zero", section, key);
        for (int i = 0; i < 3; i++) t[i] /= len;
    }
    memcpy(out, t, sizeof t);
    return SV_OK;
}

static sv_status parse_names(const cJSON *obj, const char *section, const char *key,
                             const char ***out, size_t *count, sv_error *err)
{
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(obj, key);
    if (!v) return SV_OK;
    if (!cJSON_IsArray(v))
        return sv_fail(err, SV_ERR_SPEC, "%s.%s: expected an array of material names", section,
                       key);
    int n = cJSON_GetArraySize(v);
    if (n > 1024) return sv_fail(err, SV_ERR_SPEC, "%s.%s: at most 1024 names", section, key);
    const char **names = sv_calloc((size_t)n + 1, sizeof *names);
    if (!names) return sv_fail(err, SV_ERR_NOMEM, "out of memory");
    int i = 0;
    const cJSON *e;
    cJSON_ArrayForEach(e, v)
    {
        if (!cJSON_IsString(e) || strlen(e->valuestring) == 0 || strlen(e->valuestring) > 127) {
            free(names);
            return sv_fail(err, SV_ERR_SPEC, "%s.%s[%d]: expected a non-empty name (≤127 bytes)",
                           section, key, i);
        }
        names[i++] = e->valuestring;
    }
    *out = names;
    *count = (size_t)n;
    return SV_OK;
}

static sv_status parse_u32(const cJSON *obj, const char *section, const char *key, long lo, long hi,
                           uint32_t *out, sv_error *err)
{
    long v = (long)*out;
    sv_status st = sv_setting_int(obj, section, key, lo, hi, &v, err);
    if (st == SV_OK) *out = (uint32_t)v;
    return st;
}

static sv_status parse_scene(const cJSON *o, sv_spec *s, sv_error *err)
{
    static const char *const keys[] = {
        "lighting", "light_dir",     "shadows", "ambient_occlusion", "viewer",
        "distance", "screen_height", "fov_deg", "camera_speed",      NULL};
    static const char *const lightings[] = {"static", "dynamic", "unlit", NULL};
    static const char *const viewers[] = {"orbit", "ground", "aerial", "side", NULL};
    sv_scene *sc = &s->scene;
    sv_status st;
    int e;
    if ((st = sv_setting_only(o, "scene", keys, err))) return st;
    e = (int)sc->lighting;
    if ((st = parse_enum(o, "scene", "lighting", lightings, &e, err))) return st;
    sc->lighting = (sv_lighting)e;
    e = (int)sc->viewer;
    if ((st = parse_enum(o, "scene", "viewer", viewers, &e, err))) return st;
    sc->viewer = (sv_viewer)e;
    if ((st = parse_vec3(o, "scene", "light_dir", sc->light_dir, true, err))) return st;
    if ((st = sv_setting_bool(o, "scene", "shadows", &sc->shadows, err))) return st;
    if ((st = sv_setting_bool(o, "scene", "ambient_occlusion", &sc->ambient_occlusion, err)))
        return st;
    if ((st = parse_u32(o, "scene", "screen_height", 16, 16384, &sc->screen_height, err)))
        return st;
    if ((st = sv_setting_number(o, "scene", "fov_deg", 1, 170, &sc->fov_y_deg, err))) return st;
    if ((st = sv_setting_number(o, "scene", "camera_speed", 0, 1e4, &sc->camera_speed, err)))
        return st;
    const cJSON *d = cJSON_GetObjectItemCaseSensitive(o, "distance");
    if (cJSON_IsString(d) && strcmp(d->valuestring, "auto") == 0) {
        sc->distance_auto = true;
    } else if (d) {
        const cJSON *a = cJSON_GetArrayItem(d, 0), *b = cJSON_GetArrayItem(d, 1);
        if (!cJSON_IsArray(d) || cJSON_GetArraySize(d) != 2 || !cJSON_IsNumber(a) ||
            !cJSON_IsNumber(b) || !(a->valuedouble > 0) || !(b->valuedouble >= a->valuedouble) ||
            !(b->valuedouble <= 1e7))
            return sv_fail(err, SV_ERR_SPEC,
                           "scene.distance: expected [min, max] in metres with 0 < min <= max "
                           "<= 1e7, or \"auto\"");
        sc->distance_min = a->valuedouble;
        sc->distance_max = b->valuedouble;
        sc->distance_auto = false;
    }
    if (sc->ambient_occlusion && sc->lighting != SV_LIGHTING_DYNAMIC)
        return sv_fail(err, SV_ERR_SPEC,
                       "scene.ambient_occlusion: needs \"lighting\": \"dynamic\" (static lighting "
                       "bakes light into the albedo)");
    return SV_OK;
}

static sv_status parse_import(const cJSON *o, sv_spec *s, sv_error *err)
{
    static const char *const keys[] = {"units", "up", "missing_files", NULL};
    static const char *const ups[] = {"Y", "Z", "auto", NULL};
    static const char *const missing[] = {"error", "warn", NULL};
    static const struct {
        const char *name;
        double scale;
    } units[] = {{"m", 1.0}, {"cm", 0.01}, {"mm", 0.001}, {"in", 0.0254}, {"ft", 0.3048}};
    sv_status st;
    if ((st = sv_setting_only(o, "import", keys, err))) return st;
    const cJSON *u = cJSON_GetObjectItemCaseSensitive(o, "units");
    if (u) {
        bool ok = false;
        if (cJSON_IsNumber(u) && u->valuedouble >= 1e-6 && u->valuedouble <= 1e6) {
            s->unit_scale = u->valuedouble;
            ok = true;
        } else if (cJSON_IsString(u)) {
            for (size_t i = 0; i < sizeof units / sizeof units[0]; i++)
                if (strcmp(u->valuestring, units[i].name) == 0) {
                    s->unit_scale = units[i].scale;
                    ok = true;
                }
        }
        if (!ok)
            return sv_fail(err, SV_ERR_SPEC,
                           "import.units: expected m, cm, mm, in, ft or metres per unit "
                           "(a number in [1e-6, 1e6])");
    }
    int e = s->up_axis == 'Z' ? 1 : s->up_axis == 'A' ? 2 : 0;
    if ((st = parse_enum(o, "import", "up", ups, &e, err))) return st;
    s->up_axis = e == 1 ? 'Z' : e == 2 ? 'A' : 'Y';
    e = s->missing_files_warn ? 1 : 0;
    if ((st = parse_enum(o, "import", "missing_files", missing, &e, err))) return st;
    s->missing_files_warn = e == 1;
    return SV_OK;
}

static sv_status parse_bake(const cJSON *o, sv_spec *s, sv_error *err)
{
    static const char *const keys[] = {
        "max_atlas",    "max_supersample", "texel_size", "alpha_threshold",
        "texel_pixels", "padding",         "dilate",     NULL};
    sv_status st;
    if ((st = sv_setting_only(o, "bake", keys, err))) return st;
    if ((st = parse_u32(o, "bake", "max_atlas", 64, 16384, &s->max_atlas, err))) return st;
    if (s->max_atlas & (s->max_atlas - 1))
        return sv_fail(err, SV_ERR_SPEC, "bake.max_atlas: must be a power of two");
    if ((st = parse_u32(o, "bake", "max_supersample", 1, 16, &s->max_supersample, err))) return st;
    if ((st = sv_setting_number(o, "bake", "texel_size", 0, 1e6, &s->texel_size, err))) return st;
    const cJSON *at = o ? cJSON_GetObjectItemCaseSensitive(o, "alpha_threshold") : NULL;
    if (cJSON_IsString(at)) {
        if (strcmp(at->valuestring, "calibrated"))
            return sv_fail(
                err, SV_ERR_SPEC,
                "bake.alpha_threshold: expected \"calibrated\" or a number in [0.01, 0.99]");
        s->alpha_threshold = 0;
    } else if ((st = sv_setting_number(o, "bake", "alpha_threshold", 0.01, 0.99,
                                       &s->alpha_threshold, err))) {
        return st;
    }
    if ((st = parse_u32(o, "bake", "texel_pixels", 0, 8192, &s->texel_pixels, err))) return st;
    if ((st = parse_u32(o, "bake", "padding", 0, 64, &s->padding, err))) return st;
    return parse_u32(o, "bake", "dilate", 0, 64, &s->dilate, err);
}

static sv_status parse_evaluate(const cJSON *o, sv_spec *s, sv_error *err)
{
    static const char *const keys[] = {
        "enabled", "views", "supersample", "sizes", "small_render", "flattening_bound", NULL};
    sv_status st;
    if ((st = sv_setting_only(o, "evaluate", keys, err))) return st;
    if ((st = sv_setting_bool(o, "evaluate", "enabled", &s->evaluate, err))) return st;
    if ((st = sv_setting_bool(o, "evaluate", "flattening_bound", &s->eval_flattening_bound, err)))
        return st;
    if ((st = parse_u32(o, "evaluate", "views", 1, 256, &s->eval_views, err))) return st;
    if ((st = parse_u32(o, "evaluate", "supersample", 1, 8, &s->eval_supersample, err))) return st;
    if ((st = parse_u32(o, "evaluate", "small_render", 0, 4096, &s->eval_small_render, err)))
        return st;
    const cJSON *z = cJSON_GetObjectItemCaseSensitive(o, "sizes");
    if (z) {
        int n = cJSON_IsArray(z) ? cJSON_GetArraySize(z) : -1;
        if (n < 1 || n > SV_MAX_EVAL_SIZES)
            return sv_fail(err, SV_ERR_SPEC,
                           "evaluate.sizes: expected 1 to %d screen heights in pixels",
                           SV_MAX_EVAL_SIZES);
        for (int i = 0; i < n; i++) {
            const cJSON *e = cJSON_GetArrayItem(z, i);
            if (!cJSON_IsNumber(e) || e->valuedouble != floor(e->valuedouble) ||
                e->valuedouble < 8 || e->valuedouble > 1024)
                return sv_fail(err, SV_ERR_SPEC,
                               "evaluate.sizes[%d]: expected an integer in [8, 1024]", i);
            s->eval_sizes[i] = (uint32_t)e->valuedouble;
        }
        s->eval_size_count = (uint32_t)n;
        /* largest first, for filtering from the finest */
        for (uint32_t i = 0; i < s->eval_size_count; i++)
            for (uint32_t j = i + 1; j < s->eval_size_count; j++)
                if (s->eval_sizes[j] > s->eval_sizes[i]) {
                    uint32_t t = s->eval_sizes[i];
                    s->eval_sizes[i] = s->eval_sizes[j];
                    s->eval_sizes[j] = t;
                }
    }
    return SV_OK;
}

static void spec_defaults(sv_spec *s)
{
    memset(s, 0, sizeof *s);
    snprintf(s->method, sizeof s->method, "%s", SV_DEFAULT_METHOD);
    sv_scene_defaults(&s->scene);
    s->seed = 1;
    s->up_axis = 'Y';
    s->max_atlas = 2048;
    s->max_supersample = 8;
    s->alpha_threshold = 0; /* calibrated */
    s->texel_pixels = 256;
    s->padding = 4;
    s->dilate = 8;
    s->evaluate = true;
    s->eval_views = 24;
    s->eval_supersample = 2; /* 512² for 256 px (docs/benchmarks.md: 4 costs more for no IoU) */
    s->eval_small_render = 256;
    s->eval_sizes[0] = 256;
    s->eval_sizes[1] = 128;
    s->eval_sizes[2] = 64;
    s->eval_sizes[3] = 32;
    s->eval_size_count = 4;
    s->lod_tolerance = 0.1;
    s->lod_tolerance_pixels = 64;
    s->lod_slack = 0.02;
    s->lod_cost_ratio = 10;
    s->lod_triangles_per_pixel = 2;
    s->lod_min_saving = 0.25;
    s->lod_chain = true;
    s->output_fbx = true;
    snprintf(s->lod_coarsest, sizeof s->lod_coarsest, "%s", "crossed_quads");
}

/* "target": an accuracy to reach and/or budgets not to exceed (docs/spec.md).
 * Needs the evaluate section already parsed (pixels must be an evaluate size). */
static sv_status parse_target(const cJSON *o, sv_spec *s, sv_error *err)
{
    static const char *const keys[] = {"iou",        "pixels",        "worst",
                                       "max_planes", "max_triangles", NULL};
    if (!cJSON_IsObject(o)) return sv_fail(err, SV_ERR_SPEC, "target: expected an object");
    sv_status st;
    if ((st = sv_setting_only(o, "target", keys, err))) return st;
    if ((st = sv_setting_number(o, "target", "iou", 0.01, 1, &s->target_iou, err))) return st;
    if ((st = sv_setting_bool(o, "target", "worst", &s->target_worst, err))) return st;
    if ((st = parse_u32(o, "target", "max_planes", 1, 4096, &s->target_max_planes, err))) return st;
    if ((st = parse_u32(o, "target", "max_triangles", 1, 100000000, &s->target_max_triangles, err)))
        return st;
    if (s->target_iou == 0 && !s->target_max_planes && !s->target_max_triangles)
        return sv_fail(err, SV_ERR_SPEC,
                       "target: expected \"iou\", \"max_planes\" or \"max_triangles\"");
    bool need_eval = s->target_iou > 0;
    if (need_eval && !s->evaluate)
        return sv_fail(err, SV_ERR_SPEC, "target.iou: needs evaluate.enabled (it is measured)");
    /* default pixels: 64 when it is an evaluate size, else the smallest one */
    s->target_pixels = 0;
    for (uint32_t i = 0; i < s->eval_size_count; i++)
        if (s->eval_sizes[i] == 64) s->target_pixels = 64;
    if (!s->target_pixels) s->target_pixels = s->eval_sizes[s->eval_size_count - 1];
    if (cJSON_GetObjectItemCaseSensitive(o, "pixels")) {
        if ((st = parse_u32(o, "target", "pixels", 1, 8192, &s->target_pixels, err))) return st;
        bool found = false;
        for (uint32_t i = 0; i < s->eval_size_count; i++)
            if (s->eval_sizes[i] == s->target_pixels) found = true;
        if (!found)
            return sv_fail(err, SV_ERR_SPEC, "target.pixels: %u is not one of evaluate.sizes",
                           s->target_pixels);
    }
    s->has_target = true;
    return SV_OK;
}

/* The error for a spec that is not JSON, guessing at a file name sent in
 * its place: curl's -F spec=FILE sends the name itself; -F spec=@FILE sends
 * the file. end: where cJSON stopped. */
static sv_status invalid_json(const char *json, size_t len, const char *end, sv_error *err)
{
    size_t off = end ? (size_t)(end - json) : 0;
    size_t k = 0, e = len;
    while (k < len && isspace((unsigned char)json[k])) k++;
    while (e > k && isspace((unsigned char)json[e - 1])) e--;
    bool named = e - k >= 5 && e - k < 256 && json[k] != '{' && json[k] != '[' &&
                 memchr(json + k, '\n', e - k) == NULL && memcmp(json + e - 5, ".json", 5) == 0;
    if (named)
        return sv_fail(err, SV_ERR_SPEC,
                       "spec: invalid JSON near byte %zu: the spec part holds '%.*s', a "
                       "file name? (curl -F spec=@FILE sends the file, -F spec=FILE the "
                       "name)",
                       off, (int)(e - k < 80 ? e - k : 80), json + k);
    return sv_fail(err, SV_ERR_SPEC, "spec: invalid JSON near byte %zu", off);
}

/* "classify": material names forced to foliage or trunk. */
static sv_status parse_classify(const cJSON *cl, sv_spec *s, sv_error *err)
{
    static const char *const keys[] = {"foliage", "trunk", NULL};
    sv_status st = sv_setting_only(cl, "classify", keys, err);
    if (!st) st = parse_names(cl, "classify", "foliage", &s->foliage, &s->foliage_count, err);
    if (!st) st = parse_names(cl, "classify", "trunk", &s->trunk, &s->trunk_count, err);
    return st;
}

/* "output": which files beyond the glTF ones a bake writes, and how the glTF
 * geometry is encoded. */
static sv_status parse_output(const cJSON *o, sv_spec *s, sv_error *err)
{
    static const char *const keys[] = {"fbx", "compress", NULL};
    static const char *const compress[] = {"none", "quantize", "meshopt", NULL};
    sv_status st = sv_setting_only(o, "output", keys, err);
    if (!st) st = sv_setting_bool(o, "output", "fbx", &s->output_fbx, err);
    int e = (int)s->output_compress;
    if (!st) st = parse_enum(o, "output", "compress", compress, &e, err);
    s->output_compress = (sv_compress)e;
    return st;
}

/* "lod": the chain's tolerance, whether there is a chain, its coarsest level. */
static sv_status parse_lod(const cJSON *lod, sv_spec *s, sv_error *err)
{
    static const char *const keys[] = {
        "tolerance", "tolerance_pixels", "slack", "cost_ratio", "min_saving", "triangles_per_pixel",
        "chain",     "coarsest",         NULL};
    sv_status st = sv_setting_only(lod, "lod", keys, err);
    if (!st) st = sv_setting_number(lod, "lod", "tolerance", 0.001, 1, &s->lod_tolerance, err);
    if (!st)
        st = sv_setting_number(lod, "lod", "tolerance_pixels", 0, 16384, &s->lod_tolerance_pixels,
                               err);
    if (!st) st = sv_setting_number(lod, "lod", "slack", 0, 1, &s->lod_slack, err);
    if (!st) st = sv_setting_number(lod, "lod", "cost_ratio", 0, 1e6, &s->lod_cost_ratio, err);
    if (!st) st = sv_setting_number(lod, "lod", "min_saving", 0, 0.99, &s->lod_min_saving, err);
    if (!st)
        st = sv_setting_number(lod, "lod", "triangles_per_pixel", 0, 1e6,
                               &s->lod_triangles_per_pixel, err);
    if (!st) st = sv_setting_bool(lod, "lod", "chain", &s->lod_chain, err);
    const cJSON *co = cJSON_GetObjectItemCaseSensitive(lod, "coarsest");
    if (st || !co) return st;
    const sv_method *cm = cJSON_IsString(co) ? sv_method_find(co->valuestring) : NULL;
    bool none = cJSON_IsString(co) && strcmp(co->valuestring, "none") == 0;
    if ((!cm && !none) || (cm && cm->chain_levels))
        return sv_fail(err, SV_ERR_SPEC, "lod.coarsest: expected \"none\" or a quad method name");
    snprintf(s->lod_coarsest, sizeof s->lod_coarsest, "%s", none ? "" : cm->name);
    return SV_OK;
}

sv_status sv_spec_parse(const char *json, size_t len, sv_spec *s, sv_error *err)
{
    spec_defaults(s);
    sv_status st = SV_OK;
    if (len == 0) return SV_OK; /* an empty spec part means {} */
    if (len > (1u << 20)) return sv_fail(err, SV_ERR_SPEC, "spec: larger than 1 MiB");
    const char *end = NULL;
    cJSON *root = cJSON_ParseWithLengthOpts(json, len, &end, false);
    if (!root) return invalid_json(json, len, end, err);
    /* The worker and the daemon must read the same spec: refuse what two
     * parsers could read differently (docs/spec.md). */
    cJSON_Delete(root);
    root = sv_json_parse_strict(json, len, "spec", SV_ERR_SPEC, err);
    if (!root) return err && err->status ? err->status : SV_ERR_SPEC;
    s->root = root;
    if (!cJSON_IsObject(root)) {
        st = sv_fail(err, SV_ERR_SPEC, "spec: expected a JSON object");
        goto out;
    }
    const cJSON *m = cJSON_GetObjectItemCaseSensitive(root, "method");
    if (m) {
        if (!cJSON_IsString(m) || strlen(m->valuestring) >= sizeof s->method) {
            st = sv_fail(err, SV_ERR_SPEC, "method: expected a method name");
            goto out;
        }
        snprintf(s->method, sizeof s->method, "%s", m->valuestring);
    }
    const sv_method *method = sv_method_find(s->method);
    if (!method) {
        size_t n;
        const sv_method *const *all = sv_method_list(&n);
        char list[256] = "";
        for (size_t i = 0; i < n; i++) {
            strncat(list, i ? ", " : "", sizeof list - strlen(list) - 1);
            strncat(list, all[i]->name, sizeof list - strlen(list) - 1);
        }
        st = sv_fail(err, SV_ERR_SPEC, "method: unknown method '%.32s' (known: %s)", s->method,
                     list);
        goto out;
    }
    /* Unknown top-level keys are errors; keys named after a method are that
     * method's settings, validated whether or not it is the chosen one. */
    const cJSON *item;
    cJSON_ArrayForEach(item, root)
    {
        bool known = false;
        for (int i = 0; top_keys[i]; i++)
            if (strcmp(item->string, top_keys[i]) == 0) known = true;
        const sv_method *other = known ? NULL : sv_method_find(item->string);
        if (other) {
            if ((st = other->check(item, err))) goto out;
            known = true;
        }
        if (!known) {
            st = sv_fail(err, SV_ERR_SPEC, "spec: unknown key '%.64s'", item->string);
            goto out;
        }
    }
    s->settings = cJSON_GetObjectItemCaseSensitive(root, s->method);
    if (!s->settings && (st = method->check(NULL, err))) goto out;
#define SECTION(name, fn)                                                   \
    do {                                                                    \
        const cJSON *o = cJSON_GetObjectItemCaseSensitive(root, name);      \
        if (o && !cJSON_IsObject(o)) {                                      \
            st = sv_fail(err, SV_ERR_SPEC, "%s: expected an object", name); \
            goto out;                                                       \
        }                                                                   \
        if (o && (st = fn(o, s, err))) goto out;                            \
    } while (0)
    SECTION("scene", parse_scene);
    SECTION("import", parse_import);
    SECTION("bake", parse_bake);
    SECTION("evaluate", parse_evaluate);
    SECTION("output", parse_output);
#undef SECTION
    const cJSON *cl = cJSON_GetObjectItemCaseSensitive(root, "classify");
    if (cl && (st = parse_classify(cl, s, err))) goto out;
    const cJSON *lod = cJSON_GetObjectItemCaseSensitive(root, "lod");
    if (lod && (st = parse_lod(lod, s, err))) goto out;
    const cJSON *tg = cJSON_GetObjectItemCaseSensitive(root, "target");
    if (tg && (st = parse_target(tg, s, err))) goto out;
    const cJSON *seed = cJSON_GetObjectItemCaseSensitive(root, "seed");
    if (seed) {
        if (!cJSON_IsNumber(seed) || seed->valuedouble < 0 ||
            seed->valuedouble > 9007199254740991.0 ||
            seed->valuedouble != floor(seed->valuedouble)) {
            st = sv_fail(err, SV_ERR_SPEC, "seed: expected an integer in [0, 2^53)");
            goto out;
        }
        s->seed = (uint64_t)seed->valuedouble;
    }
out:
    if (st != SV_OK) sv_spec_free(s);
    return st;
}

void sv_spec_free(sv_spec *s)
{
    if (!s) return;
    free(s->foliage);
    free(s->trunk);
    cJSON_Delete(s->root);
    char method[32];
    memcpy(method, s->method, sizeof method);
    memset(s, 0, sizeof *s);
    memcpy(s->method, method, sizeof method);
}

/* Bytes a copy of the chain's meshes may take per input byte, glTF and FBX:
 * above the largest measured on the shared trees (docs/benchmarks.md
 * "Output sizes": `lods.glb` and the FBX files against the input). */
#define SV_EST_GLTF_CHAIN 6u
#define SV_EST_FBX 18u

uint64_t sv_spec_output_estimate(const sv_spec *spec, uint64_t input_bytes)
{
    uint64_t a = spec && spec->max_atlas ? spec->max_atlas : 2048;
    bool fbx = !spec || spec->output_fbx;
    /* meshes (and the input's textures they embed): model.glb, the
     * lod<i>_<name>.glb files and lods.glb each hold the chain; the FBX files
     * (lods.fbx, lod<i>_<name>.fbx, the textures beside them) */
    uint64_t mesh = (3 * SV_EST_GLTF_CHAIN + (fbx ? SV_EST_FBX : 0)) * input_bytes;
    /* atlases: 4/3 of the first level's a² texels of 8 bytes, four copies
     * (the PNG or JPEG file, model.glb, the level's own file, lods.glb; the
     * FBX files refer to the files beside them) */
    return mesh + 4 * 8 * 4 * a * a / 3;
}
