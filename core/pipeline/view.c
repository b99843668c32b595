/* view.c — one evaluation view of a finished bake's level (view.h). */
#include "view.h"

#include <cjson/cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "evaluate.h"
#include "image.h"
#include "import.h"
#include "octahedral.h"
#include "render.h"
#include "vec3.h"

/* The whole file dir/name (malloc'd), or NULL with err set. */
static uint8_t *read_file(const char *dir, const char *name, size_t *size, sv_error *err)
{
    char path[4096];
    if (strchr(name, '/') || strcmp(name, "..") == 0) {
        sv_fail(err, SV_ERR_INVALID, "view: bad file name '%s'", name);
        return NULL;
    }
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *f = fopen(path, "rb");
    if (!f) {
        sv_fail(err, SV_ERR_INVALID, "view: cannot read %s", path);
        return NULL;
    }
    uint8_t *b = NULL;
    long n = fseek(f, 0, SEEK_END) == 0 ? ftell(f) : -1;
    if (n >= 0 && fseek(f, 0, SEEK_SET) == 0 && (b = malloc(n ? (size_t)n : 1)) &&
        fread(b, 1, (size_t)n, f) != (size_t)n) {
        free(b);
        b = NULL;
    }
    fclose(f);
    if (!b) sv_fail(err, SV_ERR_IO, "view: cannot read %s", path);
    *size = n > 0 ? (size_t)n : 0;
    return b;
}

static cJSON *read_json(const char *dir, const char *name, sv_error *err)
{
    size_t n = 0;
    uint8_t *b = read_file(dir, name, &n, err);
    if (!b) return NULL;
    cJSON *j = cJSON_ParseWithLength((const char *)b, n);
    free(b);
    if (!j) sv_fail(err, SV_ERR_PARSE, "view: %s/%s is not JSON", dir, name);
    return j;
}

static bool vec3_of(const cJSON *a, double v[3])
{
    if (!cJSON_IsArray(a) || cJSON_GetArraySize(a) != 3) return false;
    for (int k = 0; k < 3; k++) {
        const cJSON *e = cJSON_GetArrayItem(a, k);
        if (!cJSON_IsNumber(e)) return false;
        v[k] = e->valuedouble;
    }
    return true;
}

static sv_status decode(const char *dir, const char *name, bool gray16, sv_image *img,
                        sv_error *err)
{
    size_t n = 0;
    uint8_t *b = read_file(dir, name, &n, err);
    if (!b) return err ? err->status : SV_ERR_IO;
    sv_status st = gray16 ? sv_image_decode_gray16(b, n, name, 0, img, err)
                          : sv_image_decode_rgba8(b, n, name, 0, img, err);
    free(b);
    return st;
}

/* The impostor.json entry of level lod into g and its atlases. *found false
 * when the level is not an impostor. */
static sv_status load_impostor(const char *dir, const char *lod, sv_octa_grid *g, sv_image *albedo,
                               sv_image *depth, bool *found, sv_error *err)
{
    *found = false;
    char path[4096];
    snprintf(path, sizeof path, "%s/impostor.json", dir);
    FILE *f = fopen(path, "rb");
    if (!f) return SV_OK;
    fclose(f);
    cJSON *j = read_json(dir, "impostor.json", err);
    if (!j) return err ? err->status : SV_ERR_PARSE;
    sv_status st = SV_OK;
    const cJSON *e;
    cJSON_ArrayForEach(e, cJSON_GetObjectItemCaseSensitive(j, "lods"))
    {
        const cJSON *name = cJSON_GetObjectItemCaseSensitive(e, "lod");
        if (!cJSON_IsString(name) || strcmp(name->valuestring, lod) != 0) continue;
        *found = true;
        const cJSON *n = cJSON_GetObjectItemCaseSensitive(e, "grid");
        const cJSON *fp = cJSON_GetObjectItemCaseSensitive(e, "frame_pixels");
        const cJSON *half = cJSON_GetObjectItemCaseSensitive(e, "half");
        const cJSON *cut = cJSON_GetObjectItemCaseSensitive(e, "alpha_cutoff");
        const cJSON *maps = cJSON_GetObjectItemCaseSensitive(e, "maps");
        const cJSON *alb = cJSON_GetObjectItemCaseSensitive(maps, "albedo");
        const cJSON *dep = cJSON_GetObjectItemCaseSensitive(maps, "depth");
        memset(g, 0, sizeof *g);
        if (!cJSON_IsNumber(n) || !cJSON_IsNumber(fp) || !cJSON_IsNumber(half) ||
            !cJSON_IsString(alb) ||
            !vec3_of(cJSON_GetObjectItemCaseSensitive(e, "centre"), g->centre)) {
            st = sv_fail(err, SV_ERR_PARSE, "view: impostor.json: level %s lacks a field", lod);
            break;
        }
        g->n = (uint32_t)n->valuedouble;
        g->frame_pixels = (uint32_t)fp->valuedouble;
        g->half = half->valuedouble;
        g->hemi = cJSON_IsTrue(cJSON_GetObjectItemCaseSensitive(e, "hemi"));
        g->cutoff = cJSON_IsNumber(cut) ? cut->valuedouble : 0.5;
        /* absent: Brucks' layout (files written before the scale existed) */
        const cJSON *es = cJSON_GetObjectItemCaseSensitive(e, "elevation_scale");
        g->elev_scale = cJSON_IsNumber(es) ? es->valuedouble : 1.0;
        if (!(g->elev_scale > 0 && g->elev_scale <= 1)) {
            st = sv_fail(err, SV_ERR_PARSE,
                         "view: impostor.json: level %s: elevation_scale %g "
                         "outside (0, 1]",
                         lod, g->elev_scale);
            break;
        }
        if ((st = decode(dir, alb->valuestring, false, albedo, err))) break;
        if (cJSON_IsString(dep)) st = decode(dir, dep->valuestring, true, depth, err);
        break;
    }
    cJSON_Delete(j);
    return st;
}

typedef struct imp_ctx {
    const sv_octa_grid *g;
    const sv_image *albedo, *depth;
} imp_ctx;

sv_status sv_view_render(const char *out_dir, const char *lod, const double dir_in[3],
                         uint32_t size, const char *png_path, sv_error *err)
{
    double dir[3] = {dir_in[0], dir_in[1], dir_in[2]};
    if (size < 1 || size > 4096)
        return sv_fail(err, SV_ERR_INVALID, "view: size %u outside [1, 4096]", size);
    if (!(sv_norm3(dir) > 0)) return sv_fail(err, SV_ERR_INVALID, "view: the direction is zero");
    sv_normalize3(dir);
    cJSON *rep = read_json(out_dir, "report.json", err);
    if (!rep) return err ? err->status : SV_ERR_PARSE;
    sv_status st = SV_OK;
    double centre[3], radius = 0;
    const cJSON *fr = cJSON_GetObjectItemCaseSensitive(
        cJSON_GetObjectItemCaseSensitive(rep, "evaluation"), "frame");
    const cJSON *rad = cJSON_GetObjectItemCaseSensitive(fr, "radius");
    if (!vec3_of(cJSON_GetObjectItemCaseSensitive(fr, "centre"), centre) || !cJSON_IsNumber(rad) ||
        !((radius = rad->valuedouble) > 0)) {
        cJSON_Delete(rep);
        return sv_fail(err, SV_ERR_PARSE, "view: %s/report.json has no evaluation.frame", out_dir);
    }
    const char *file = NULL;
    const cJSON *l;
    cJSON_ArrayForEach(l, cJSON_GetObjectItemCaseSensitive(rep, "lods"))
    {
        const cJSON *name = cJSON_GetObjectItemCaseSensitive(l, "name");
        const cJSON *f = cJSON_GetObjectItemCaseSensitive(l, "file");
        if (cJSON_IsString(name) && cJSON_IsString(f) && strcmp(name->valuestring, lod) == 0)
            file = f->valuestring;
    }
    if (!file) {
        cJSON_Delete(rep);
        return sv_fail(err, SV_ERR_INVALID, "view: %s/report.json has no level named '%s'", out_dir,
                       lod);
    }
    sv_camera cam;
    sv_eval_camera(centre, radius, dir, &cam);
    sv_image out = {0}, albedo = {0}, depth = {0};
    sv_octa_grid g;
    bool imp = false;
    sv_renderer *r = NULL;
    sv_gpu_mesh *gm = NULL;
    sv_mesh *m = NULL;
    uint8_t *bytes = NULL;
    if ((st = load_impostor(out_dir, lod, &g, &albedo, &depth, &imp, err))) goto done;
    if (imp) {
        st = sv_octa_render(&g, &albedo, depth.data ? &depth : NULL, &cam, size, size, &out, NULL,
                            err);
    } else {
        size_t n = 0;
        if (!(bytes = read_file(out_dir, file, &n, err))) {
            st = err ? err->status : SV_ERR_IO;
            goto done;
        }
        sv_file in = {file, bytes, n};
        if ((st = sv_import(&in, 1, NULL, &m, NULL, err))) goto done;
        if ((st = sv_renderer_create(size, &r, err))) goto done;
        if ((st = sv_gpu_mesh_upload(r, m, &gm, err))) goto done;
        st = sv_render(r, gm, NULL, 0, &cam, NULL, size, size, &out, NULL, err);
    }
    if (st == SV_OK) {
        uint8_t *p = out.data; /* covered (alpha >= 128, the evaluator's rule) or not */
        for (size_t i = 0; i < (size_t)size * size; i++)
            p[4 * i + 3] = p[4 * i + 3] >= 128 ? 255 : 0;
        st = sv_image_write_png(&out, png_path, err);
    }
done:
    sv_gpu_mesh_free(gm);
    sv_renderer_destroy(r);
    sv_mesh_destroy(m);
    free(bytes);
    sv_image_free(&out);
    sv_image_free(&albedo);
    sv_image_free(&depth);
    cJSON_Delete(rep);
    return st;
}
