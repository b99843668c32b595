/* outputs.c — the files of a bake that are not JSON (docs/outputs.md): the
 * atlases (and the images a level adds through its own hook, level.h: an
 * octahedral level's albedo mips), model.glb with every level as MSFT_lod alternates, one
 * lod<i>_<name>.glb per level, the LOD group files (lods.glb, lods.fbx, one
 * lod<i>_<name>.fbx per level, textures beside them) and preview.png.
 */
#include <ctype.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fbx.h"
#include "gltf.h"
#include "pipeline_internal.h"
#include "preview.h"
#include "image_io.h"

/* The asset's name for node names (`<asset>_LOD<i>`, the convention Unity,
 * Unreal and Godot importers group into LOD sets): the main file's base name
 * without its extension, every byte outside [A-Za-z0-9_-] replaced by '_',
 * at most cap - 1 bytes; "tree" when nothing is left. */
static void asset_name(const char *file, char *out, size_t cap)
{
    const char *b = file ? file : "";
    for (const char *c = b; *c; c++)
        if (*c == '/' || *c == '\\') b = c + 1;
    const char *dot = strrchr(b, '.');
    size_t n = dot && dot != b ? (size_t)(dot - b) : strlen(b);
    if (n > cap - 1) n = cap - 1;
    for (size_t i = 0; i < n; i++) {
        unsigned char ch = (unsigned char)b[i];
        out[i] = (isalnum(ch) || ch == '_' || ch == '-') ? (char)ch : '_';
    }
    out[n] = 0;
    if (n == 0) snprintf(out, cap, "tree");
}

/* preview.png's tile side per level (preview.h: in [64, 1024]). */
#define SVP_PREVIEW_TILE 256u

const char *const svp_map_names[4] = {"albedo", "normal", "ao", "depth"};

const sv_image *svp_lod_map(const sv_baked_lod *b, int i)
{
    switch (i) {
    case 0:
        return &b->albedo;
    case 1:
        return &b->normal;
    case 2:
        return &b->ao;
    default:
        return &b->depth;
    }
}

sv_status svp_write_atlases(const run *r, bake_state *b, sv_error *err)
{
    sv_stand_in *si = &b->si;
    lod_out *lods = b->lods;
    char path[4096];
    sv_status st;
    for (uint32_t i = 0; i < si->lod_count; i++)
        for (int k = 0; k < 4; k++) {
            const sv_image *img = svp_lod_map(&lods[i].baked, k);
            if (!img->data) continue;
            snprintf(lods[i].maps[k], sizeof lods[i].maps[k], "atlas_%s_%s.png", si->lods[i].name,
                     svp_map_names[k]);
            snprintf(path, sizeof path, "%s/%s", r->req->out_dir, lods[i].maps[k]);
            if ((st = sv_image_write_png(img, path, err))) return st;
        }
    for (uint32_t i = 0; i < si->lod_count; i++) {
        sv_lod_plan *lp = &si->lods[i];
        if (!lp->ops || !lp->ops->images) continue;
        sv_level_images extra = {0};
        st = lp->ops->images(lp, &lods[i].baked, &extra, err);
        for (uint32_t k = 0; k < extra.count && st == SV_OK; k++) {
            snprintf(path, sizeof path, "%s/%s", r->req->out_dir, extra.items[k].name);
            st = sv_image_write_png(&extra.items[k].image, path, err);
        }
        sv_level_images_free(&extra);
        if (st) return st;
    }
    return SV_OK;
}

/* Level i's switch sizes as report.json gives them (docs/outputs.md "LOD
 * groups"), into o. */
static bool add_switch(const run *r, const bake_state *b, uint32_t i, cJSON *o)
{
    const lod_out *l = &b->lods[i];
    double d = sv_scene_distance_for_pixels(&r->spec.scene, b->tree_h, l->switch_pixels);
    return cJSON_AddNumberToObject(o, "lod", i) &&
           cJSON_AddNumberToObject(o, "screen_coverage", l->coverage) &&
           cJSON_AddNumberToObject(o, "switch_pixels", l->switch_pixels) &&
           cJSON_AddNumberToObject(o, "switch_distance", d);
}

/* lods.glb (every level a child of one root node, switch sizes in extras),
 * lods.fbx (the same nodes through assimp, textures beside) and one
 * lod<i>_<name>.fbx per level (Unreal imports each as a LOD of one static
 * mesh): the shapes engines group into LODs. */
static sv_status write_lod_group(const run *r, bake_state *b, const sv_gltf_lod *gl,
                                 const char *asset, sv_error *err)
{
    uint32_t n = b->si.lod_count;
    sv_status st = SV_OK;
    char path[4096];
    sv_gltf_lod *gg = sv_calloc(n, sizeof *gg);
    cJSON **ex = sv_calloc(n, sizeof *ex);
    cJSON *root = cJSON_CreateObject();
    cJSON *list = root ? cJSON_AddArrayToObject(root, "lods") : NULL;
    bool ok = gg && ex && list && cJSON_AddStringToObject(root, "units", "m") &&
              cJSON_AddNumberToObject(root, "screen_height", r->spec.scene.screen_height) &&
              cJSON_AddNumberToObject(root, "fov_deg", r->spec.scene.fov_y_deg);
    for (uint32_t i = 0; ok && i < n; i++) {
        gg[i] = gl[i];
        /* the level's own extras (its gltf hook's) and its switch sizes */
        ex[i] = gl[i].extras ? cJSON_Duplicate(gl[i].extras, true) : cJSON_CreateObject();
        cJSON *e = cJSON_CreateObject();
        ok = ex[i] && e && add_switch(r, b, i, ex[i]) &&
             cJSON_AddStringToObject(e, "node", gl[i].name) && add_switch(r, b, i, e);
        if (e) cJSON_AddItemToArray(list, e);
        gg[i].extras = ex[i];
    }
    if (!ok) st = sv_fail(err, SV_ERR_NOMEM, "out of memory");
    sv_gltf_group g = {asset, root};
    snprintf(path, sizeof path, "%s/lods.glb", r->req->out_dir);
    if (st == SV_OK) st = sv_gltf_write_group_glb(path, &g, gg, n, err);
    /* the FBX files refer to the atlases already written beside them */
    sv_fbx_file *known = sv_calloc(4 * (size_t)n, sizeof *known);
    uint32_t nk = 0;
    if (!known && st == SV_OK) st = sv_fail(err, SV_ERR_NOMEM, "out of memory");
    for (uint32_t i = 0; known && i < n; i++)
        for (int k = 0; k < 4; k++)
            if (svp_lod_map(&b->lods[i].baked, k)->data && b->lods[i].maps[k][0])
                known[nk++] = (sv_fbx_file){svp_lod_map(&b->lods[i].baked, k), b->lods[i].maps[k]};
    bool fbx = r->spec.output_fbx;
    if (st == SV_OK && fbx)
        st = sv_fbx_write(r->req->out_dir, "lods.fbx", asset, gl, n, known, nk, err);
    for (uint32_t i = 0; fbx && i < n && st == SV_OK; i++) {
        char file[128];
        snprintf(file, sizeof file, "lod%u_%s.fbx", i, b->si.lods[i].name);
        st = sv_fbx_write(r->req->out_dir, file, asset, &gl[i], 1, known, nk, err);
    }
    free(known);
    for (uint32_t i = 0; ex && i < n; i++) cJSON_Delete(ex[i]);
    free(ex);
    free(gg);
    cJSON_Delete(root);
    return st;
}

/* Deletes from the objects in extras (one level down: a method's own
 * object) every member whose value is the name of one of l's extra
 * attributes. */
static void drop_attribute_names(cJSON *extras, const sv_gltf_lod *l)
{
    cJSON *o;
    cJSON_ArrayForEach(o, extras)
    {
        if (!cJSON_IsObject(o)) continue;
        for (cJSON *m = o->child, *next; m; m = next) {
            next = m->next;
            for (uint32_t a = 0; cJSON_IsString(m) && a < l->attribute_count; a++)
                if (strcmp(m->valuestring, l->attributes[a].name) == 0) {
                    cJSON_Delete(cJSON_DetachItemViaPointer(o, m));
                    break;
                }
        }
    }
}

sv_status svp_write_gltf(const run *r, bake_state *b, sv_error *err)
{
    const sv_stand_in *si = &b->si;
    lod_out *lods = b->lods;
    sv_status st = SV_OK;
    char path[4096];
    sv_gltf_lod *gl = sv_calloc(si->lod_count, sizeof *gl);
    if (!gl) return sv_fail(err, SV_ERR_NOMEM, "out of memory");
    sv_level_gltf *gx = sv_calloc(si->lod_count, sizeof *gx);
    if (!gx) {
        free(gl);
        return sv_fail(err, SV_ERR_NOMEM, "out of memory");
    }
    char asset[64];
    asset_name(r->req->files[0].name, asset, sizeof asset);
    for (uint32_t i = 0; i < si->lod_count && st == SV_OK; i++) {
        snprintf(lods[i].node, sizeof lods[i].node, "%s_LOD%u", asset, i);
        snprintf(lods[i].file, sizeof lods[i].file, "lod%u_%s.glb", i, si->lods[i].name);
        gl[i].name = lods[i].node;
        gl[i].mesh_name = si->lods[i].name;
        gl[i].mesh = lods[i].baked.mesh;
        gl[i].screen_coverage = lods[i].coverage;
        memcpy(gl[i].translation, r->p.info.origin, sizeof gl[i].translation);
        gl[i].compress = r->spec.output_compress == SV_COMPRESS_MESHOPT    ? SV_GLTF_MESHOPT
                         : r->spec.output_compress == SV_COMPRESS_QUANTIZE ? SV_GLTF_QUANTIZE
                                                                           : SV_GLTF_FLOAT;
        const sv_lod_plan *lp = &si->lods[i];
        /* a mesh level (full, stochastic, trunk) of a source without
         * normals: no normals in its files either (docs/outputs.md "Sizes") */
        gl[i].no_normals = r->p.info.no_normals && lp->quad_count == 0 && !lp->select &&
                           !svp_drawn_by_hook(lp);
        if (lp->ops && lp->ops->gltf) { /* the level's own attributes and extras */
            st = lp->ops->gltf(lp, &lods[i].baked, &gx[i], err);
            gl[i].attributes = gx[i].attr;
            gl[i].attribute_count = gx[i].attr_count;
            gl[i].extras = gx[i].extras;
        }
    }
    snprintf(path, sizeof path, "%s/model.glb", r->req->out_dir);
    if (st == SV_OK) st = sv_gltf_write_glb(path, gl, si->lod_count, err);
    /* The other files are for engines that draw each level as it is: no
     * extra vertex attributes (a stochastic level's fade attributes,
     * docs/outputs.md "Sizes"); their extras keep the level's description
     * without the members that name those attributes. */
    cJSON **plain = sv_calloc(si->lod_count, sizeof *plain);
    if (!plain && st == SV_OK) st = sv_fail(err, SV_ERR_NOMEM, "out of memory");
    for (uint32_t i = 0; plain && i < si->lod_count && st == SV_OK; i++) {
        if (!gl[i].attribute_count) continue;
        if (!(plain[i] = cJSON_Duplicate(gl[i].extras, true))) {
            st = sv_fail(err, SV_ERR_NOMEM, "out of memory");
            break;
        }
        drop_attribute_names(plain[i], &gl[i]);
        gl[i].attributes = NULL;
        gl[i].attribute_count = 0;
        gl[i].extras = plain[i];
    }
    /* one standalone file per kept level, for importers that ignore MSFT_lod */
    for (uint32_t i = 0; i < si->lod_count && st == SV_OK; i++) {
        snprintf(path, sizeof path, "%s/%s", r->req->out_dir, lods[i].file);
        st = sv_gltf_write_level_glb(path, &gl[i], err);
    }
    if (st == SV_OK) st = write_lod_group(r, b, gl, asset, err);
    for (uint32_t i = 0; plain && i < si->lod_count; i++) cJSON_Delete(plain[i]);
    free(plain);
    for (uint32_t i = 0; i < si->lod_count; i++) sv_level_gltf_free(&gx[i]);
    free(gx);
    free(gl);
    return st;
}

/* preview.h's description of level i: how it is drawn, its switch size,
 * cost, and the mean IoU at the measured size nearest its switch size. */
static sv_status preview_level(const bake_state *b, uint32_t i, sv_preview_level *pv, view_sets *vs,
                               bool *vs_ok, level_draw_ctx *dc, sv_error *err)
{
    const sv_lod_plan *lp = &b->si.lods[i];
    const lod_out *l = &b->lods[i];
    const sv_baked_lod *bk = &l->baked;
    pv->gpu = l->gpu;
    if (svp_drawn_by_hook(lp)) {
        *dc = (level_draw_ctx){lp, bk};
        pv->draw = svp_level_draw;
        pv->user = dc;
    } else if (lp->select) {
        sv_status st = svp_view_sets_init(vs, lp, bk, err);
        if (st) return st;
        *vs_ok = true;
        pv->select = svp_select_subsets;
        pv->user = vs;
    }
    pv->name = lp->name;
    pv->pixels = l->switch_pixels;
    pv->triangles = bk->mesh->triangle_count;
    pv->texels = (double)bk->albedo.width * bk->albedo.height;
    pv->iou = -1;
    double best = INFINITY, px = l->switch_pixels > 0 ? l->switch_pixels : 1;
    for (uint32_t k = 0; l->evaluated && k < l->eval.size_count; k++) {
        const sv_eval_size *z = &l->eval.sizes[k];
        double dist = fabs(log2((double)z->pixels / px));
        if (dist < best) {
            best = dist;
            pv->iou = z->mean.iou;
            pv->iou_pixels = z->pixels;
        }
    }
    return SV_OK;
}

/* preview.png: every kept level beside the original (preview.h), from the
 * first evaluation view */
sv_status svp_write_preview(const run *r, const bake_state *b, sv_evaluator *ev, sv_error *err)
{
    if (!ev) return SV_OK;
    uint32_t n = b->si.lod_count;
    sv_status st = SV_OK;
    char path[4096];
    snprintf(path, sizeof path, "%s/preview.png", r->req->out_dir);
    sv_preview_level *pv = sv_calloc(n, sizeof *pv);
    view_sets *vs = sv_calloc(n, sizeof *vs);
    bool *vs_ok = sv_calloc(n, sizeof *vs_ok);
    level_draw_ctx *dc = sv_calloc(n, sizeof *dc);
    if (!pv || !vs || !vs_ok || !dc) st = sv_fail(err, SV_ERR_NOMEM, "out of memory");
    for (uint32_t i = 0; i < n && st == SV_OK; i++)
        st = preview_level(b, i, &pv[i], &vs[i], &vs_ok[i], &dc[i], err);
    if (st == SV_OK) {
        double dir[3];
        sv_evaluator_view_dir(ev, 0, dir);
        sv_camera cam;
        sv_eval_camera(b->fc, b->fr > 0 ? b->fr : r->p.radius, dir, &cam);
        sv_render_options ro;
        memset(&ro, 0, sizeof ro);
        if (b->bo.lit) {
            ro.shade = SV_SHADE_LIT;
            memcpy(ro.light_dir, b->bo.light_dir, sizeof ro.light_dir);
        }
        st = sv_preview_chain(r->ren, r->gsrc, pv, n, &cam, dir, &ro, SVP_PREVIEW_TILE, path, err);
    }
    for (uint32_t i = 0; vs_ok && i < n; i++)
        if (vs_ok[i]) svp_view_sets_free(&vs[i]);
    free(dc);
    free(vs_ok);
    free(vs);
    free(pv);
    return st;
}
