/* view.c — one evaluation view of a finished bake's level (view.h). */
#include "view.h"

#include <cjson/cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "evaluate.h"
#include "image.h"
#include "image_io.h"
#include "import.h"
#include "level.h"
#include "method_ops.h"
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

/* sv_level_files json on the bake's folder (user: its path). */
static cJSON *files_json(void *user, const char *name, bool *missing, sv_error *err)
{
    const char *dir = user;
    char path[4096];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *f = fopen(path, "rb");
    *missing = f == NULL;
    if (!f) return NULL;
    fclose(f);
    return read_json(dir, name, err);
}

/* sv_level_files image: the PNG decoded (16-bit grey or RGBA8). */
static sv_status files_image(void *user, const char *name, bool gray16, sv_image *img,
                             sv_error *err)
{
    size_t n = 0;
    uint8_t *b = read_file(user, name, &n, err);
    if (!b) return err ? err->status : SV_ERR_IO;
    sv_status st = gray16 ? sv_image_decode_gray16(b, n, name, 0, img, err)
                          : sv_image_decode_rgba8(b, n, name, 0, img, err);
    free(b);
    return st;
}

/* Level lod drawn by the first registered level hooks that know it
 * (level.h view: an impostor.json level); *drawn false when none does. */
static sv_status view_by_hook(const char *dir, const char *lod, const sv_camera *cam, uint32_t size,
                              sv_image *out, bool *drawn, sv_error *err)
{
    size_t n = 0;
    const sv_method_ops *const *ms = sv_method_ops_list(&n);
    sv_level_files files = {(void *)dir, files_json, files_image};
    *drawn = false;
    for (size_t i = 0; i < n && !*drawn; i++) {
        const sv_level_ops *ops = ms[i]->levels;
        if (!ops || !ops->view) continue;
        sv_status st = ops->view(&files, lod, cam, size, out, drawn, err);
        if (st) return st;
    }
    return SV_OK;
}

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
    if (!sv_level_json_vec3(cJSON_GetObjectItemCaseSensitive(fr, "centre"), centre) ||
        !cJSON_IsNumber(rad) || !((radius = rad->valuedouble) > 0)) {
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
    sv_image out = {0};
    bool drawn = false;
    sv_renderer *r = NULL;
    sv_gpu_mesh *gm = NULL;
    sv_mesh *m = NULL;
    uint8_t *bytes = NULL;
    if ((st = view_by_hook(out_dir, lod, &cam, size, &out, &drawn, err))) goto done;
    if (!drawn) {
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
    cJSON_Delete(rep);
    return st;
}
