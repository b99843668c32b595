/* octahedral_level.c — an octahedral level's hooks for the pipeline
 * (level.h, sv_octa_level_ops). The level's payload is its sv_octa_grid (octahedral.h); the technique
 * is R. Brucks, "Octahedral Impostors" (2018), its mips I. Castaño,
 * "Computing Alpha Mipmaps" (2010), docs/methods/octahedral.md. Apart from
 * octahedral.c, like octahedral_bake.c: these hooks render, which the
 * daemon (it links the methods' schema halves) must not link. The pipeline
 * reads and writes their files. */
#include <cjson/cJSON.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "level.h"
#include "octahedral.h"

/* level.h bake: frames sized for the largest evaluated size unless the spec
 * set them (the atlas shrinking lowers them for a level drawn only smaller),
 * then every frame rendered (sv_octa_bake). */
static sv_status octa_level_bake(sv_lod_plan *lod, const sv_level_bake_in *in, sv_baked_lod *out,
                                 sv_error *err)
{
    sv_octa_grid *g = lod->payload;
    if (!g->frame_pixels)
        g->frame_pixels = sv_octa_frame_pixels(g->n, in->largest_pixels, in->texels_per_pixel,
                                               in->max_atlas);
    return sv_octa_bake(in->ren, in->gsrc, in->src, g, in->opt, 0, out, err);
}

/* level.h draw: the C reference runtime (sv_octa_render) on the baked
 * albedo and depth atlases. */
static sv_status octa_level_draw(const sv_lod_plan *lod, const sv_baked_lod *b,
                                 const sv_camera *cam, uint32_t w, uint32_t h, sv_image *color,
                                 float *depth, sv_error *err)
{
    return sv_octa_render(lod->payload, &b->albedo, b->depth.data ? &b->depth : NULL, cam, w, h,
                          color, depth, err);
}

/* level.h shrink: frames stay whole, at least SV_OCTA_MIN_FRAME_PIXELS a side. */
static int octa_level_shrink(sv_lod_plan *lod, int halvings)
{
    sv_octa_grid *g = lod->payload;
    int k = 0;
    while (k < halvings && (g->frame_pixels >> (k + 1)) >= SV_OCTA_MIN_FRAME_PIXELS) k++;
    g->frame_pixels >>= k;
    return k;
}

/* level.h images: the albedo's Castaño mips atlas_<lod>_albedo_mip<k>.png,
 * k = 1.., while frames keep at least 4 texels (sv_octa_mip from the albedo,
 * level 0), counted in the grid for impostor.json. */
static sv_status octa_level_images(sv_lod_plan *lod, const sv_baked_lod *b, sv_level_images *out,
                                   sv_error *err)
{
    sv_octa_grid *g = lod->payload;
    g->mip_count = 0;
    for (;;) {
        /* mip k + 1 from mip k (level 0: the albedo) */
        uint32_t k = out->count;
        if ((k ? out->items[k - 1].image.width : b->albedo.width) / g->n < 8) break;
        sv_level_image *items = realloc(out->items, (k + 1) * sizeof *items);
        if (!items) return sv_fail(err, SV_ERR_NOMEM, "octahedral: no memory for a mip");
        out->items = items;
        memset(&items[k], 0, sizeof items[k]);
        const sv_image *src = k ? &items[k - 1].image : &b->albedo;
        sv_status st = sv_octa_mip(g, &b->albedo, src, &items[k].image, err);
        if (st) return st;
        out->count = k + 1;
        snprintf(items[k].name, sizeof items[k].name, "atlas_%s_albedo_mip%u.png", lod->name,
                 k + 1);
    }
    g->mip_count = out->count;
    return SV_OK;
}

/* level.h doc_entry: the level's impostor.json entry (sv_octa_impostor_json). */
static cJSON *octa_level_doc(const sv_lod_plan *lod, const sv_level_names *names)
{
    const sv_octa_grid *g = lod->payload;
    return sv_octa_impostor_json(g, names->lod, names->node, names->maps, g->mip_count);
}

/* One impostor.json entry into g (the fields the runtime reads). */
static sv_status grid_of(const cJSON *e, const char *lod, sv_octa_grid *g, sv_error *err)
{
    const cJSON *n = cJSON_GetObjectItemCaseSensitive(e, "grid");
    const cJSON *fp = cJSON_GetObjectItemCaseSensitive(e, "frame_pixels");
    const cJSON *half = cJSON_GetObjectItemCaseSensitive(e, "half");
    const cJSON *cut = cJSON_GetObjectItemCaseSensitive(e, "alpha_cutoff");
    memset(g, 0, sizeof *g);
    if (!cJSON_IsNumber(n) || !cJSON_IsNumber(fp) || !cJSON_IsNumber(half) ||
        !sv_level_json_vec3(cJSON_GetObjectItemCaseSensitive(e, "centre"), g->centre))
        return sv_fail(err, SV_ERR_PARSE, "view: impostor.json: level %s lacks a field", lod);
    g->n = (uint32_t)n->valuedouble;
    g->frame_pixels = (uint32_t)fp->valuedouble;
    g->half = half->valuedouble;
    g->hemi = cJSON_IsTrue(cJSON_GetObjectItemCaseSensitive(e, "hemi"));
    g->cutoff = cJSON_IsNumber(cut) ? cut->valuedouble : 0.5;
    /* absent: Brucks' layout (files written before the scale existed) */
    const cJSON *es = cJSON_GetObjectItemCaseSensitive(e, "elevation_scale");
    g->elev_scale = cJSON_IsNumber(es) ? es->valuedouble : 1.0;
    if (!(g->elev_scale > 0 && g->elev_scale <= 1))
        return sv_fail(err, SV_ERR_PARSE,
                       "view: impostor.json: level %s: elevation_scale %g outside (0, 1]", lod,
                       g->elev_scale);
    return SV_OK;
}

/* level.h view: level lod of impostor.json (absent file or level: not
 * found), drawn by the reference runtime from its atlases. */
static sv_status octa_level_view(const sv_level_files *files, const char *lod, const sv_camera *cam,
                                 uint32_t size, sv_image *out, bool *found, sv_error *err)
{
    *found = false;
    bool missing = false;
    cJSON *j = files->json(files->user, "impostor.json", &missing, err);
    if (!j) return missing ? SV_OK : err ? err->status : SV_ERR_IO;
    sv_status st = SV_OK;
    sv_octa_grid g;
    sv_image albedo = {0}, depth = {0};
    const cJSON *e;
    cJSON_ArrayForEach(e, cJSON_GetObjectItemCaseSensitive(j, "lods"))
    {
        const cJSON *name = cJSON_GetObjectItemCaseSensitive(e, "lod");
        if (!cJSON_IsString(name) || strcmp(name->valuestring, lod) != 0) continue;
        *found = true;
        const cJSON *maps = cJSON_GetObjectItemCaseSensitive(e, "maps");
        const cJSON *alb = cJSON_GetObjectItemCaseSensitive(maps, "albedo");
        const cJSON *dep = cJSON_GetObjectItemCaseSensitive(maps, "depth");
        if ((st = grid_of(e, lod, &g, err))) break;
        if (!cJSON_IsString(alb)) {
            st = sv_fail(err, SV_ERR_PARSE, "view: impostor.json: level %s lacks a field", lod);
            break;
        }
        if ((st = files->image(files->user, alb->valuestring, false, &albedo, err))) break;
        if (cJSON_IsString(dep) &&
            (st = files->image(files->user, dep->valuestring, true, &depth, err)))
            break;
        st = sv_octa_render(&g, &albedo, depth.data ? &depth : NULL, cam, size, size, out, NULL,
                            err);
        break;
    }
    cJSON_Delete(j);
    sv_image_free(&albedo);
    sv_image_free(&depth);
    return st;
}

const sv_level_ops sv_octa_level_ops = {
    .method = SV_OCTA_METHOD,
    .bake = octa_level_bake,
    .draw = octa_level_draw,
    .shrink = octa_level_shrink,
    .images = octa_level_images,
    .doc_file = "impostor.json",
    .doc_schema = "sylva.impostor/1",
    .doc_entry = octa_level_doc,
    .view = octa_level_view,
};
