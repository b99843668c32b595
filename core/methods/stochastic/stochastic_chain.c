/* stochastic_chain.c — the LOD chain's stochastic levels (stochastic.h
 * sv_stochastic_chain, sv_method_ops chain; docs/lod.md) and their outputs
 * (sv_stochastic_level_ops, level.h).
 *
 * Levels are placed by Cook's schedule (Fichtner eq. 1–2 after Cook et al.
 * 2007: λ(d), stochastic.h); the levels finer or coarser than the scene's
 * distance range needs are not built, each noted with why. r (§3.3) is
 * measured by rendering (§6) through the pipeline's cover callback, and
 * candidates are scored through its score callback: the method itself draws
 * nothing and writes no file. A level's payload keeps what its glTF node and
 * its report.json entry carry.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "level.h"
#include "stochastic.h"
#include "trunk.h"

/* The levels of ss the scene needs (by λ at its nearest and farthest
 * distance) into *keep; the others get a note in `notes`. The spec's own
 * method (own) keeps every level it was asked for. */
static void keep_levels(const sv_stochastic_settings *ss, const sv_scene *sc, bool own,
                        cJSON *notes, sv_stochastic_settings *keep)
{
    *keep = *ss;
    keep->level_count = 0;
    double ln = sv_stochastic_lambda_at(ss, sc, sc->distance_min);
    double lf = sv_stochastic_lambda_at(ss, sc, sc->distance_max);
    /* the finest level needed: the smallest level >= λ(distance_min);
     * the coarsest: the smallest level >= λ(distance_max) */
    int fine = 0, coarse = (int)ss->level_count - 1;
    for (int i = 0; i < (int)ss->level_count; i++) {
        if (ss->levels[i] >= ln) fine = i;
        if (ss->levels[i] >= lf) coarse = i;
    }
    for (int i = 0; i < (int)ss->level_count; i++) {
        char name[32];
        sv_stochastic_level_name(ss->levels[i], name);
        if (i < fine && !own && ss->levels[i] < 1)
            sv_chain_skip_note(notes, name, "plan",
                               "finer than needed: at the nearest scene distance (%g m) lambda is "
                               "%.3g, so level %g suffices",
                               sc->distance_min, ln, ss->levels[fine]);
        else if (i > coarse && !own)
            sv_chain_skip_note(
                notes, name, "plan",
                "never reached: at the farthest scene distance (%g m) lambda is still "
                "%.3g (level %g)",
                sc->distance_max, lf, ss->levels[coarse]);
        else {
            keep->level_triangles[keep->level_count] = ss->level_triangles[i];
            keep->levels[keep->level_count++] = ss->levels[i];
        }
    }
}

/* r for area preservation: the spec's, or measured by rendering (paper §6)
 * through in->cover when it gives none (*measured, *m filled). */
static sv_status visible_ratio(const sv_chain_in *ci, const sv_stochastic_settings *keep,
                               double *ratio, bool *measured, sv_stoch_ratio *m, sv_error *err)
{
    const sv_leaves *lv = ci->in->leaves;
    *ratio = keep->visible_ratio;
    *measured = false;
    if (*ratio > 0 || !keep->area_preservation) return SV_OK;
    uint32_t *order = sv_calloc(lv->count ? lv->count : 1, sizeof *order);
    if (!order) return sv_fail(err, SV_ERR_NOMEM, "out of memory");
    sv_status st = sv_stochastic_order(lv, ci->in->seed, keep->order, order, err);
    if (!st)
        st = sv_stochastic_measure_ratio(lv, order, keep->ratio_fraction, ci->cover, ci->cover_user,
                                         m, err);
    free(order);
    if (st) return st;
    *ratio = m->r;
    *measured = true;
    return SV_OK;
}

/* Appends an empty level named `name` made by `source` to out; NULL when
 * out of memory. */
static sv_lod_plan *add_level(sv_chain_out *out, const char *name, const char *source,
                              sv_chain_place **place)
{
    sv_chain_place *p = realloc(out->place, ((size_t)out->levels.lod_count + 1) * sizeof *p);
    if (!p) return NULL;
    out->place = p;
    sv_lod_plan *l = sv_stand_in_add_lod(&out->levels, name);
    if (!l) return NULL;
    *place = &p[out->levels.lod_count - 1];
    memset(*place, 0, sizeof **place);
    snprintf((*place)->source, sizeof(*place)->source, "%s", source);
    return l;
}

/* A tree without leaves (a winter tree, a trunk alone) has no stochastic
 * levels: its own mesh, then its trunk simplified with meshopt_simplify
 * (topology kept) within a quarter of the error the schedule allows at each
 * level's λ (one pixel where λ(d) reaches it; sv_stochastic_level_error),
 * named trunk<λ%>, placed by the same schedule (docs/lod.md). The quarter:
 * meshoptimizer's error is a distance, and a branch thinner than it
 * collapses and leaves the silhouette; at the whole pixel the aspen's
 * branches lost 0.30 of the coverage at 256 px, at a quarter 0.02. The
 * quad levels come after these. */
#define TRUNK_LEVEL_ERROR 0.25
static sv_status trunk_levels(const sv_method_input *in, const sv_stochastic_settings *keep,
                              sv_chain_out *out, sv_error *err)
{
    for (uint32_t k = 0; k < keep->level_count; k++) {
        double lambda = keep->levels[k];
        char name[32];
        if (lambda >= 1) snprintf(name, sizeof name, "full");
        else snprintf(name, sizeof name, "trunk%d", (int)lround(lambda * 100));
        sv_chain_place *x;
        sv_lod_plan *l = add_level(out, name, "trunk", &x);
        if (!l) return sv_fail(err, SV_ERR_NOMEM, "out of memory");
        double e = lambda >= 1 ? 0 : sv_stochastic_level_error(keep, in->scene, in->radius, lambda);
        if (lambda >= 1) {
            l->trunk = SV_TRUNK_MESH;
        } else {
            l->trunk = SV_TRUNK_NONE; /* the simplified trunk is the level's geometry */
            sv_status st = sv_trunk_mesh(in->mesh, in->cls->tri_part, SV_STOCH_TRUNK_FLOOR,
                                         e * TRUNK_LEVEL_ERROR, &l->geometry, err);
            if (st) return st;
        }
        x->lambda = lambda;
        x->distance = sv_stochastic_distance_for_lambda(keep, in->scene, lambda);
        x->trunk_error = e;
    }
    return SV_OK;
}

/* ---- a level's payload and hooks ------------------------------------------ */

/* What a built level's outputs need (one block, freed with free()): its
 * figures, the chain's, and 4 floats per leaf vertex after the struct
 * (3 of its leaf's centre each, then 1 of its order position each). */
typedef struct st_level {
    sv_stoch_level L; /* its figures (pointers cleared) */
    uint32_t triangles_asked;
    double copy_of_lambda; /* λ of the level it copies (L.same_as >= 0) */
    uint32_t leaf_total, layered_leaves;
    double r, h, d0, fade, distance;
    uint32_t leaf_vertices; /* the baked mesh ends with them */
} st_level;

static float *st_centres(const st_level *p)
{
    return (float *)(p + 1);
}
static float *st_orders(const st_level *p)
{
    return st_centres(p) + 3 * (size_t)p->leaf_vertices;
}

static st_level *st_level_new(const sv_stoch_result *res, const sv_stochastic_settings *ss,
                              uint32_t k, uint32_t leaf_vertices, double distance)
{
    const sv_stoch_level *L = &res->levels[k];
    st_level *p = malloc(sizeof *p + 4 * sizeof(float) * (size_t)leaf_vertices);
    if (!p) return NULL;
    memset(p, 0, sizeof *p);
    p->L = *L;
    p->L.geometry = NULL;
    p->L.leaf_centre = p->L.leaf_order = NULL;
    p->triangles_asked = ss->level_triangles[k];
    p->copy_of_lambda = L->same_as >= 0 ? res->levels[L->same_as].lambda : 0;
    p->leaf_total = res->leaf_count;
    p->layered_leaves = res->layered_leaves;
    p->r = res->r;
    p->h = ss->h;
    p->d0 = ss->d0;
    p->fade = ss->fade;
    p->distance = distance;
    p->leaf_vertices = leaf_vertices;
    memcpy(st_centres(p), L->leaf_centre, 3 * sizeof(float) * leaf_vertices);
    memcpy(st_orders(p), L->leaf_order, sizeof(float) * leaf_vertices);
    return p;
}

/* level.h gltf: trunk vertices (the first of the baked mesh) are their own
 * centre with order 0; the leaves' come from the build. */
static sv_status st_level_gltf(const sv_lod_plan *lod, const sv_baked_lod *baked, sv_level_gltf *g,
                               sv_error *err)
{
    const st_level *p = lod->payload;
    const sv_stoch_level *L = &p->L;
    const sv_mesh *m = baked->mesh;
    uint32_t nv = m->vertex_count, lv = p->leaf_vertices;
    if (lv > nv)
        return sv_fail(err, SV_ERR_INTERNAL, "stochastic LOD: %u vertices, geometry has %u", nv,
                       lv);
    uint32_t t0 = nv - lv;
    g->data = sv_calloc(nv ? nv : 1, 4 * sizeof(float));
    g->extras = cJSON_CreateObject();
    if (!g->data || !g->extras) return sv_fail(err, SV_ERR_NOMEM, "out of memory");
    float *centre = g->data, *order = g->data + 3 * (size_t)(nv ? nv : 1);
    memcpy(centre, m->positions, 3 * sizeof(float) * (size_t)t0);
    memcpy(centre + 3 * (size_t)t0, st_centres(p), 3 * sizeof(float) * lv);
    memcpy(order + t0, st_orders(p), sizeof(float) * lv);
    g->attr[0] = (sv_vertex_attribute){"_LEAF_CENTRE", centre, 3};
    g->attr[1] = (sv_vertex_attribute){"_LEAF_ORDER", order, 1};
    g->attr_count = 2;
    cJSON *o = cJSON_AddObjectToObject(g->extras, "sylva_stochastic");
    cJSON_AddNumberToObject(o, "lambda", L->lambda);
    cJSON_AddNumberToObject(o, "leaves", L->leaves);
    cJSON_AddNumberToObject(o, "leaf_fraction", L->leaf_fraction);
    cJSON_AddNumberToObject(o, "leaf_total", p->leaf_total);
    cJSON_AddNumberToObject(o, "area_scale", L->area_scale);
    cJSON_AddNumberToObject(o, "area_gamma", L->area_gamma);
    cJSON_AddNumberToObject(o, "contrast_alpha", L->contrast_alpha);
    double fw[2] = {L->fade_lo, L->fade_hi};
    cJSON_AddItemToObject(o, "fade_window", cJSON_CreateDoubleArray(fw, 2));
    cJSON_AddNumberToObject(o, "fade_radius", p->fade);
    cJSON_AddNumberToObject(o, "visible_ratio", p->r);
    cJSON_AddNumberToObject(o, "h", p->h);
    cJSON_AddNumberToObject(o, "d0", p->d0);
    cJSON_AddStringToObject(o, "order_attribute", "_LEAF_ORDER");
    cJSON_AddStringToObject(o, "centre_attribute", "_LEAF_CENTRE");
    return SV_OK;
}

/* level.h report: the level's fields of report.json (docs/outputs.md). */
static void st_level_report(const sv_lod_plan *lod, cJSON *o)
{
    const st_level *p = lod->payload;
    const sv_stoch_level *L = &p->L;
    cJSON_AddNumberToObject(o, "lambda", L->lambda);
    cJSON_AddNumberToObject(o, "leaves", L->leaves);
    if (p->triangles_asked) cJSON_AddNumberToObject(o, "triangles_asked", p->triangles_asked);
    cJSON_AddNumberToObject(o, "leaf_fraction", L->leaf_fraction);
    cJSON_AddNumberToObject(o, "leaf_triangles", (double)L->leaf_triangles);
    cJSON_AddNumberToObject(o, "leaf_error", L->leaf_error);
    cJSON_AddNumberToObject(o, "area_scale", L->area_scale);
    cJSON_AddNumberToObject(o, "area_gamma", L->area_gamma);
    cJSON_AddNumberToObject(o, "contrast_alpha", L->contrast_alpha);
    cJSON_AddNumberToObject(o, "contrast_materials", L->contrast_materials);
    cJSON_AddNumberToObject(o, "contrast_capped_leaves", L->contrast_capped);
    cJSON_AddNumberToObject(o, "colour_gain", L->colour_gain);
    cJSON_AddNumberToObject(o, "layered_leaves", p->layered_leaves);
    cJSON_AddNumberToObject(o, "brightened_textures", L->brightened_textures);
    cJSON_AddNumberToObject(o, "leaves_simplified", L->leaves_simplified);
    cJSON_AddNumberToObject(o, "leaves_whole", L->leaves_whole);
    if (L->spread) cJSON_AddStringToObject(o, "min_cover", "spread");
    else if (L->min_cover < SV_STOCH_WHOLE) cJSON_AddNumberToObject(o, "min_cover", L->min_cover);
    else cJSON_AddStringToObject(o, "min_cover", "whole");
    cJSON_AddNumberToObject(o, "leaf_cover_min", L->leaf_cover_min);
    if (!isnan(L->score)) cJSON_AddNumberToObject(o, "candidate_iou", L->score);
    if (L->same_as >= 0) cJSON_AddNumberToObject(o, "copy_of_lambda", p->copy_of_lambda);
    if (isfinite(p->distance)) cJSON_AddNumberToObject(o, "lambda_distance", p->distance);
}

const sv_level_ops sv_stochastic_level_ops = {
    .method = "stochastic",
    .gltf = st_level_gltf,
    .report = st_level_report,
};

/* ---- the chain ----------------------------------------------------------- */

/* report.json lod_chain.stochastic: the leaves, the schedule's terms and r. */
static cJSON *chain_report(const sv_chain_in *ci, const sv_stochastic_settings *ss,
                           const sv_stoch_result *res, bool measured, const sv_stoch_ratio *m)
{
    const sv_scene *sc = ci->in->scene;
    cJSON *st = cJSON_CreateObject();
    if (!st) return NULL;
    cJSON_AddNumberToObject(st, "leaves", res->leaf_count);
    cJSON_AddNumberToObject(st, "h", ss->h);
    cJSON_AddNumberToObject(st, "d0", ss->d0 > 0 ? ss->d0 : sc->distance_min);
    cJSON_AddStringToObject(st, "order", ss->order == SV_STOCH_ORDER_AREA ? "area" : "random");
    cJSON_AddItemToObject(st, "mean_leaf_color", cJSON_CreateDoubleArray(res->mean_color, 3));
    cJSON *vr = cJSON_AddObjectToObject(st, "visible_ratio");
    cJSON_AddNumberToObject(vr, "r", res->r);
    if (measured) {
        cJSON_AddStringToObject(vr, "source",
                                "measured by rendering (covered pixels of a "
                                "leaf prefix vs all leaves)");
        cJSON_AddNumberToObject(vr, "views", ci->cover_views);
        cJSON_AddNumberToObject(vr, "pixels", ci->cover_pixels);
        cJSON_AddNumberToObject(vr, "covered_all", m->covered_all);
        cJSON_AddNumberToObject(vr, "covered_prefix", m->covered_sub);
        cJSON_AddNumberToObject(vr, "prefix_leaves", m->n_sub);
    } else {
        cJSON_AddStringToObject(vr, "source",
                                ss->area_preservation
                                    ? "given in the spec (stochastic.visible_ratio)"
                                    : "not used (area_preservation is off)");
    }
    cJSON *terms = cJSON_AddArrayToObject(st, "lambda_terms");
    cJSON *t = cJSON_CreateObject();
    cJSON_AddStringToObject(t, "term", "size");
    cJSON_AddStringToObject(t, "status", "done");
    cJSON_AddStringToObject(t, "reason", "b = d0^2/d^2 (Fichtner eq. 1)");
    cJSON_AddItemToArray(terms, t);
    t = cJSON_CreateObject();
    bool mv = sc->camera_speed > 0;
    cJSON_AddStringToObject(t, "term", "motion");
    cJSON_AddStringToObject(t, "status", mv ? "done" : "skipped");
    cJSON_AddStringToObject(t, "reason",
                            mv ? "scene.camera_speed > 0: b /= 1 + blur pixels"
                               : "no camera motion in the scene");
    cJSON_AddItemToArray(terms, t);
    return st;
}

/* Moves the built levels of res into out, each with its payload. */
static sv_status place_levels(const sv_chain_in *ci, const sv_stochastic_settings *keep,
                              sv_stoch_result *res, sv_chain_out *out, sv_error *err)
{
    const sv_scene *sc = ci->in->scene;
    for (uint32_t k = 0; k < res->level_count; k++) {
        sv_stoch_level *L = &res->levels[k];
        char name[32];
        sv_stochastic_level_name(L->lambda, name);
        sv_chain_place *x;
        sv_lod_plan *l = add_level(out, name, sv_method_stochastic.name, &x);
        if (!l) return sv_fail(err, SV_ERR_NOMEM, "out of memory");
        uint32_t lv = L->geometry ? L->geometry->vertex_count - L->trunk_vertices : 0;
        x->lambda = L->lambda;
        x->distance = sv_stochastic_distance_for_lambda(keep, sc, L->lambda);
        x->trunk_error = L->trunk_in_geometry
                             ? L->trunk_error
                             : sv_stochastic_level_error(keep, sc, ci->in->radius, L->lambda);
        if (!(l->payload = st_level_new(res, keep, k, lv, x->distance)))
            return sv_fail(err, SV_ERR_NOMEM, "out of memory");
        l->ops = &sv_stochastic_level_ops;
        sv_stochastic_plan(keep, k, L, l);
    }
    return SV_OK;
}

sv_status sv_stochastic_chain(const sv_chain_in *ci, sv_chain_out *out, sv_error *err)
{
    const sv_method_input *in = ci->in;
    sv_stochastic_settings ss, keep;
    sv_status st;
    if ((st = sv_stochastic_parse(ci->settings, &ss, err)) ||
        (st = sv_stochastic_resolve(&ss, in->mesh->triangle_count, err)) || !ci->build)
        return st;
    if (!(out->skipped = cJSON_CreateArray())) return sv_fail(err, SV_ERR_NOMEM, "out of memory");
    keep_levels(&ss, in->scene, ci->own, out->skipped, &keep);
    if (!keep.level_count) return SV_OK;
    if (in->leaves->count == 0 && !ci->own) return trunk_levels(in, &keep, out, err);
    double ratio;
    bool measured;
    sv_stoch_ratio m = {0};
    if ((st = visible_ratio(ci, &keep, &ratio, &measured, &m, err))) return st;
    sv_stoch_scorer scorer = {ci->score, ci->score_user};
    sv_stoch_result res;
    if ((st = sv_stochastic_build(in, &keep, ratio, &scorer, &res, err))) return st;
    st = place_levels(ci, &keep, &res, out, err);
    if (!st && !(out->report = chain_report(ci, &keep, &res, measured, &m)))
        st = sv_fail(err, SV_ERR_NOMEM, "out of memory");
    sv_stoch_result_free(&res);
    return st;
}
