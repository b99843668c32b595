/* outputs.c — the files of a bake that are not JSON (docs/outputs.md): the
 * atlases (and an octahedral level's albedo mips, Castaño's alpha-scaled
 * mips), model.glb with every level as MSFT_lod alternates, one
 * lod<i>_<name>.glb per level, and preview.png.
 */
#include <ctype.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "gltf.h"
#include "pipeline_internal.h"
#include "preview.h"

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

/* Per-vertex attributes and node extras of a stochastic LOD in model.glb:
 * _LEAF_CENTRE (VEC3) and _LEAF_ORDER (SCALAR, (position + 0.5)/N) let a
 * renderer draw any prefix and scale leaves about their centres (Fichtner
 * §4.3.1, §4.3.3); trunk vertices (first in the baked mesh) carry their own
 * position and order 0, so the same shader leaves them alone. */
typedef struct gltf_extra {
    float *centre, *order;
    sv_gltf_attribute attr[2];
    cJSON *extras;
} gltf_extra;

static void gltf_extra_free(gltf_extra *g)
{
    free(g->centre);
    free(g->order);
    cJSON_Delete(g->extras);
    memset(g, 0, sizeof *g);
}

static sv_status stochastic_gltf(const chain *c, const chain_lod *x, const sv_mesh *m,
                                 gltf_extra *g, sv_gltf_lod *gl, sv_error *err)
{
    const sv_stoch_level *L = &c->sres.levels[x->level];
    uint32_t nv = m->vertex_count;
    if (x->geom_vertices > nv)
        return sv_fail(err, SV_ERR_INTERNAL, "stochastic LOD: %u vertices, geometry has %u", nv,
                       x->geom_vertices);
    uint32_t t0 = nv - x->geom_vertices;
    g->centre = sv_calloc(nv ? nv : 1, 3 * sizeof(float));
    g->order = sv_calloc(nv ? nv : 1, sizeof(float));
    g->extras = cJSON_CreateObject();
    if (!g->centre || !g->order || !g->extras) return sv_fail(err, SV_ERR_NOMEM, "out of memory");
    memcpy(g->centre, m->positions, 3 * sizeof(float) * (size_t)t0);
    memcpy(g->centre + 3 * (size_t)t0, L->leaf_centre, 3 * sizeof(float) * x->geom_vertices);
    memcpy(g->order + t0, L->leaf_order, sizeof(float) * x->geom_vertices);
    g->attr[0] = (sv_gltf_attribute){"_LEAF_CENTRE", g->centre, 3};
    g->attr[1] = (sv_gltf_attribute){"_LEAF_ORDER", g->order, 1};
    gl->attributes = g->attr;
    gl->attribute_count = 2;
    cJSON *o = cJSON_AddObjectToObject(g->extras, "sylva_stochastic");
    cJSON_AddNumberToObject(o, "lambda", L->lambda);
    cJSON_AddNumberToObject(o, "leaves", L->leaves);
    cJSON_AddNumberToObject(o, "leaf_fraction", L->leaf_fraction);
    cJSON_AddNumberToObject(o, "leaf_total", c->sres.leaf_count);
    cJSON_AddNumberToObject(o, "area_scale", L->area_scale);
    cJSON_AddNumberToObject(o, "area_gamma", L->area_gamma);
    cJSON_AddNumberToObject(o, "contrast_alpha", L->contrast_alpha);
    double fw[2] = {L->fade_lo, L->fade_hi};
    cJSON_AddItemToObject(o, "fade_window", cJSON_CreateDoubleArray(fw, 2));
    cJSON_AddNumberToObject(o, "fade_radius", c->ss.fade);
    cJSON_AddNumberToObject(o, "visible_ratio", c->sres.r);
    cJSON_AddNumberToObject(o, "h", c->ss.h);
    cJSON_AddNumberToObject(o, "d0", c->ss.d0);
    cJSON_AddStringToObject(o, "order_attribute", "_LEAF_ORDER");
    cJSON_AddStringToObject(o, "centre_attribute", "_LEAF_CENTRE");
    gl->extras = g->extras;
    return SV_OK;
}

/* Writes atlas_<name>_albedo_mip<k>.png for k = 1.. while frames keep at
 * least 4 texels (Castaño-scaled alpha, sv_octa_mip). */
static sv_status octa_write_mips(const char *dir, const char *name, const sv_octa_grid *g,
                                 const sv_image *albedo, uint32_t *count, sv_error *err)
{
    sv_image prev = {0}, next = {0};
    const sv_image *src = albedo;
    sv_status st = SV_OK;
    *count = 0;
    char path[4096];
    while (st == SV_OK && src->width / g->n >= 8) {
        if ((st = sv_octa_mip(g, albedo, src, &next, err))) break;
        snprintf(path, sizeof path, "%s/atlas_%s_albedo_mip%u.png", dir, name, *count + 1);
        st = sv_image_write_png(&next, path, err);
        sv_image_free(&prev);
        prev = next;
        memset(&next, 0, sizeof next);
        src = &prev;
        if (st == SV_OK) (*count)++;
    }
    sv_image_free(&prev);
    sv_image_free(&next);
    return st;
}

const char *const svp_map_names[4] = {"albedo", "normal", "ao", "depth"};

const sv_image *svp_lod_map(const sv_baked_lod *b, int i)
{
    switch (i) {
    case 0: return &b->albedo;
    case 1: return &b->normal;
    case 2: return &b->ao;
    default: return &b->depth;
    }
}

sv_status svp_write_atlases(const run *r, const bake_state *b, sv_error *err)
{
    const sv_stand_in *si = &b->si;
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
    for (uint32_t i = 0; i < si->lod_count; i++)
        if (si->lods[i].octa &&
            (st = octa_write_mips(r->req->out_dir, si->lods[i].name, si->lods[i].octa,
                                  &lods[i].baked.albedo, &lods[i].mip_count, err)))
            return st;
    return SV_OK;
}

sv_status svp_write_gltf(const run *r, bake_state *b, sv_error *err)
{
    const sv_stand_in *si = &b->si;
    lod_out *lods = b->lods;
    const chain *ch = &b->ch;
    sv_status st = SV_OK;
    char path[4096];
    sv_gltf_lod *gl = sv_calloc(si->lod_count, sizeof *gl);
    if (!gl) return sv_fail(err, SV_ERR_NOMEM, "out of memory");
    gltf_extra *gx = sv_calloc(si->lod_count, sizeof *gx);
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
        if (ch->info[i].stochastic)
            st = stochastic_gltf(ch, &ch->info[i], lods[i].baked.mesh, &gx[i], &gl[i], err);
    }
    snprintf(path, sizeof path, "%s/model.glb", r->req->out_dir);
    if (st == SV_OK) st = sv_gltf_write_glb(path, gl, si->lod_count, err);
    /* one standalone file per kept level, for importers that ignore MSFT_lod */
    for (uint32_t i = 0; i < si->lod_count && st == SV_OK; i++) {
        snprintf(path, sizeof path, "%s/%s", r->req->out_dir, lods[i].file);
        st = sv_gltf_write_level_glb(path, &gl[i], err);
    }
    for (uint32_t i = 0; i < si->lod_count; i++) gltf_extra_free(&gx[i]);
    free(gx);
    free(gl);
    return st;
}

/* preview.h's description of level i: how it is drawn, its switch size,
 * cost, and the mean IoU at the measured size nearest its switch size. */
static sv_status preview_level(const bake_state *b, uint32_t i, sv_preview_level *pv,
                               view_sets *vs, bool *vs_ok, octa_draw_ctx *oc, sv_error *err)
{
    const sv_lod_plan *lp = &b->si.lods[i];
    const lod_out *l = &b->lods[i];
    const sv_baked_lod *bk = &l->baked;
    pv->gpu = l->gpu;
    if (lp->octa) {
        *oc = (octa_draw_ctx){lp->octa, bk};
        pv->draw = svp_octa_draw;
        pv->user = oc;
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
    octa_draw_ctx *oc = sv_calloc(n, sizeof *oc);
    if (!pv || !vs || !vs_ok || !oc) st = sv_fail(err, SV_ERR_NOMEM, "out of memory");
    for (uint32_t i = 0; i < n && st == SV_OK; i++)
        st = preview_level(b, i, &pv[i], &vs[i], &vs_ok[i], &oc[i], err);
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
        st = sv_preview_chain(r->ren, r->gsrc, pv, n, &cam, dir, &ro, 256, path, err);
    }
    for (uint32_t i = 0; vs_ok && i < n; i++)
        if (vs_ok[i]) svp_view_sets_free(&vs[i]);
    free(oc);
    free(vs_ok);
    free(vs);
    free(pv);
    return st;
}
