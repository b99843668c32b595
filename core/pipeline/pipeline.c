/* pipeline.c — the whole offline bake as a sequence of stages (docs/design.md
 * "The core pipeline"): import → validate → classify (prepare, once per
 * request) then, per bake, compose the chain (chain.c) → bake → calibrate
 * (calibrate.c) → evaluate → plan switches (chain.c) → write (outputs.c,
 * report.c); a spec's target runs that bake once per try (target.c).
 *
 * Outputs (docs/outputs.md): model.glb, lod<i>_<name>.glb, planes.json, report.json, preview.png,
 * atlas_<lod>_<map>.png. All but report.json's "times" are deterministic.
 */
#include "pipeline.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "pipeline_internal.h"
#include "trunk.h"
#include "image_io.h"

const char *const svp_stage_names[ST_COUNT] = {"import", "validate", "classify", "method",
                                               "bake",   "pack",     "evaluate", "write"};
/* The renderer's largest target side (render.h max_size): the pipeline's
 * renders (bake tiles, evaluation views, impostor frames) stay below it. */
#define SVP_RENDER_MAX 8192u
/* The largest screen size a level is drawn at when none was evaluated. */
#define SVP_DEFAULT_LARGEST_PIXELS 256u
/* Texels a side of a quad level's kept trunk textures: the next power of
 * two above the largest evaluated size, within these bounds. */
#define SVP_KEPT_TEXTURE_MIN 64u
#define SVP_KEPT_TEXTURE_MAX 16384u
/* Overall progress at the start of each stage (rough shares of a typical bake). */
static const double stage_start[ST_COUNT + 1] = {0.0, 0.08, 0.1, 0.15, 0.3, 0.65, 0.7, 0.95, 1.0};

sv_status svp_progress(run *r, int stage, double within)
{
    double now = sv_now();
    if (r->stage >= 0) r->times[r->stage] += now - r->t0;
    r->t0 = now;
    r->stage = stage;
    double f = stage_start[stage] + within * (stage_start[stage + 1] - stage_start[stage]);
    f = r->pa + f * (r->pb - r->pa);
    if (r->req->progress && !r->req->progress(r->req->user, svp_stage_names[stage], f))
        return SV_ERR_CANCELLED;
    return SV_OK;
}

static void prepared_free(prepared *p)
{
    sv_leaves_free(&p->leaves);
    sv_classification_free(&p->cls);
    sv_mesh_destroy(p->mesh);
    memset(p, 0, sizeof *p);
}

/* import → validate → classify → leaves, shared by bake and info. */
static sv_status prepare(const sv_file *files, size_t count, const sv_spec *spec, prepared *p,
                         run *r, sv_error *err)
{
    memset(p, 0, sizeof *p);
    sv_status st;
    sv_import_options io = {0};
    io.unit_scale = spec->unit_scale;
    io.up_axis = spec->up_axis == 'A' ? 'Y' : spec->up_axis; /* "auto": decided below */
    io.missing_files_warn = spec->missing_files_warn;
    if (r && (st = svp_progress(r, ST_IMPORT, 0))) return sv_fail(err, st, "cancelled");
    if ((st = sv_import(files, count, &io, &p->mesh, &p->info, err))) return st;
    if (r && (st = svp_progress(r, ST_VALIDATE, 0))) return sv_fail(err, st, "cancelled");
    if ((st = sv_validate(p->mesh, &io.limits, &p->repairs, err))) return st;
    if (r && (st = svp_progress(r, ST_CLASSIFY, 0))) return sv_fail(err, st, "cancelled");
    sv_classify_options co = {spec->foliage, spec->foliage_count, spec->trunk, spec->trunk_count};
    if ((st = sv_classify(p->mesh, &co, &p->cls, err))) return st;
    /* Plausibility: lying down or in the wrong units, said in
     * input.warnings; import.up "auto" turns a Z-up tree upright here. */
    sv_detect_up(p->mesh, p->cls.tri_part, &p->up);
    if (spec->up_axis == 'A' && p->up.z_up) {
        sv_mesh_rotate_up(p->mesh, p->up.z_up);
        sv_point_rotate_up(p->info.origin, p->up.z_up); /* the local frame turns with it */
        p->up_rotated = true;
    }
    /* the size is judged by the units check below, from more than the height */
    sv_plausibility_warnings(&p->up, NAN, p->up_rotated, p->info.warnings, sizeof p->info.warnings);
    if ((st = sv_leaves_build(p->mesh, &p->cls, &p->leaves, err))) return st;
    {
        double mn[3], mx[3];
        sv_mesh_bounds(p->mesh, mn, mx);
        double height = p->up.z_up && !p->up_rotated ? p->up.height : mx[1] - mn[1];
        /* a tree lying down is measured as it lies: its height is along Z */
        sv_check_units(p->up.z_up && !p->up_rotated ? NULL : p->mesh, p->cls.tri_part, &p->leaves,
                       p->info.unit_scale, height, &p->units);
        sv_units_warning(&p->units, p->info.warnings, sizeof p->info.warnings);
    }
    sv_mesh_sphere(p->mesh, p->centre, &p->radius);
    if (!(p->radius > 0) || !isfinite(p->radius))
        return sv_fail(err, SV_ERR_UNBAKEABLE, "the mesh has no extent (all vertices coincide)");
    return SV_OK;
}

sv_status sv_pipeline_info(const sv_file *files, size_t count, const char *spec_json,
                           size_t spec_len, char **json_out, sv_error *err)
{
    *json_out = NULL;
    sv_spec spec;
    sv_status st = sv_spec_parse(spec_json, spec_json ? spec_len : 0, &spec, err);
    if (st) return st;
    prepared p;
    st = prepare(files, count, &spec, &p, NULL, err);
    if (st == SV_OK) {
        cJSON *j = svp_describe(&p);
        *json_out = cJSON_PrintUnformatted(j);
        cJSON_Delete(j);
        if (!*json_out) st = sv_fail(err, SV_ERR_NOMEM, "out of memory");
    }
    prepared_free(&p);
    sv_spec_free(&spec);
    return st;
}

/* ---- levels drawn by their own hook (level.h: an octahedral impostor) ---- */

bool svp_drawn_by_hook(const sv_lod_plan *lod)
{
    return lod->ops && lod->ops->draw;
}

/* sv_eval_draw_fn on a level_draw_ctx: the level's draw hook. */
sv_status svp_level_draw(void *user, const sv_camera *cam, uint32_t w, uint32_t h, sv_image *color,
                         float *depth, sv_error *err)
{
    const level_draw_ctx *c = user;
    return c->lod->ops->draw(c->lod, c->baked, cam, w, h, color, depth, err);
}

/* ---- view-dependent levels, for the evaluator and the preview ---- */

sv_status svp_select_subsets(void *user, const double view_dir[3],
                             sv_eval_subset subsets[SV_EVAL_MAX_SUBSETS], uint32_t *count,
                             sv_error *err)
{
    view_sets *v = user;
    uint32_t counts[SV_MAX_VIEW_SETS] = {0};
    double weights[SV_MAX_VIEW_SETS] = {0};
    uint32_t n = v->lod->select(v->lod, view_dir, v->quads, counts, weights);
    if (n == 0) {
        subsets[0] = (sv_eval_subset){NULL, 0, 1.0};
        *count = 1;
        return SV_OK;
    }
    if (n > SV_MAX_VIEW_SETS || n > SV_EVAL_MAX_SUBSETS)
        return sv_fail(err, SV_ERR_INTERNAL, "view selector returned %u sets", n);
    uint32_t q_total = v->baked->quad_count, all = v->baked->mesh->triangle_count;
    for (uint32_t k = 0; k < n; k++) {
        uint32_t m = 0;
        for (uint32_t i = 0; i < counts[k]; i++) {
            uint32_t q = v->quads[k][i];
            if (q >= q_total) return sv_fail(err, SV_ERR_INTERNAL, "view selector: quad %u", q);
            v->tris[k][m++] = 2 * q;
            v->tris[k][m++] = 2 * q + 1;
        }
        for (uint32_t t = 2 * q_total; t < all; t++) v->tris[k][m++] = t;
        subsets[k] = (sv_eval_subset){v->tris[k], m, weights[k]};
    }
    *count = n;
    return SV_OK;
}

void svp_view_sets_free(view_sets *v)
{
    for (int k = 0; k < SV_MAX_VIEW_SETS; k++) {
        free(v->quads[k]);
        free(v->tris[k]);
        v->quads[k] = v->tris[k] = NULL;
    }
}

sv_status svp_view_sets_init(view_sets *v, const sv_lod_plan *lod, const sv_baked_lod *b,
                             sv_error *err)
{
    memset(v, 0, sizeof *v);
    v->lod = lod;
    v->baked = b;
    for (int k = 0; k < SV_MAX_VIEW_SETS; k++) {
        v->quads[k] = sv_calloc((size_t)lod->quad_count + 1, sizeof(uint32_t));
        v->tris[k] = sv_calloc((size_t)b->mesh->triangle_count + 1, sizeof(uint32_t));
        if (!v->quads[k] || !v->tris[k]) {
            svp_view_sets_free(v);
            return sv_fail(err, SV_ERR_NOMEM, "out of memory");
        }
    }
    return SV_OK;
}

/* ---- the stages of one bake ---- */

/* svp_progress, with err set when the caller cancels. */
static sv_status stage(run *r, int which, double within, sv_error *err)
{
    sv_status st = svp_progress(r, which, within);
    return st ? sv_fail(err, st, "cancelled") : SV_OK;
}

/* The evaluator's framing sphere (evaluate.h): screen sizes are diameters of it. */
static void frame_sphere(const prepared *p, double fc[3], double *fr)
{
    *fr = 0;
    sv_mesh_frame_sphere(p->mesh, fc, fr);
}

/* Method stage. In: r->spec, r->p. Out: b->si, b->ch (the chain's plans);
 * r->spec.scene's distances resolved; r->ren and r->gsrc made once per run. */
/* scene.distance "auto" (the default): the range follows the tree's size,
 * the framing sphere's diameter that every screen size is measured on. */
static void resolve_distance(run *r)
{
    double fc[3], fr;
    frame_sphere(&r->p, fc, &fr);
    sv_scene_resolve_distance(&r->spec.scene, 2.0 * (fr > 0 ? fr : r->p.radius));
}

static sv_status stage_compose(run *r, bake_state *b, sv_error *err)
{
    const prepared *p = &r->p;
    sv_status st;
    resolve_distance(r);
    if ((st = stage(r, ST_METHOD, 0, err))) return st;
    /* the renderer first: the chain's own levels measure and score by rendering */
    if (!r->ren) {
        if ((st = sv_renderer_create(SVP_RENDER_MAX, &r->ren, err))) return st;
        if ((st = sv_gpu_mesh_upload(r->ren, p->mesh, &r->gsrc, err))) return st;
    }
    if ((st = svp_chain_compose(r, r->ren, r->gsrc, &b->si, &b->ch, err))) return st;
    if (b->si.lod_count == 0)
        return sv_fail(err, SV_ERR_UNBAKEABLE, "method %s produced no level of detail",
                       r->spec.method);
    return SV_OK;
}

/* The texture bake's options, from the spec (docs/spec.md "bake", "scene"). */
static void bake_options(const run *r, sv_bake_options *bo)
{
    const sv_spec *spec = &r->spec;
    sv_bake_options_init(bo);
    bo->max_atlas = spec->max_atlas;
    bo->max_supersample = spec->max_supersample;
    bo->texel_size = spec->texel_size;
    bo->alpha_threshold = spec->alpha_threshold > 0 ? spec->alpha_threshold : 0.3;
    bo->coverage_alpha = !(spec->alpha_threshold > 0);
    bo->texel_floor = spec->texel_pixels ? 2.0 * r->p.radius / spec->texel_pixels : 0;
    bo->padding = spec->padding;
    bo->dilate = spec->dilate;
    bo->lit = spec->scene.lighting == SV_LIGHTING_STATIC;
    bo->normal_map = spec->scene.lighting == SV_LIGHTING_DYNAMIC;
    bo->ao_map = bo->normal_map && spec->scene.ambient_occlusion;
    bo->depth_map = spec->scene.shadows;
    memcpy(bo->light_dir, spec->scene.light_dir, sizeof bo->light_dir);
    bo->tri_part = r->p.cls.tri_part;
    bo->viewer = spec->scene.viewer;
}

/* Bakes LOD i of b into b->lods[i].baked: through the level's own bake
 * hook (level.h; an impostor's frames), or the quads with the geometry the
 * level keeps (trunk, a chain level's own leaves). */
static sv_status bake_level(run *r, bake_state *b, uint32_t i, sv_error *err)
{
    const sv_spec *spec = &r->spec;
    const prepared *p = &r->p;
    sv_lod_plan *lp = &b->si.lods[i];
    sv_status st;
    if (lp->ops && lp->ops->bake) {
        sv_level_bake_in in = {.ren = r->ren, .gsrc = r->gsrc, .src = p->mesh, .opt = &b->bo};
        in.largest_pixels = spec->eval_size_count ? spec->eval_sizes[0]
                                                  : SVP_DEFAULT_LARGEST_PIXELS;
        in.texels_per_pixel = SV_ATLAS_TEXELS_PER_PIXEL;
        in.max_atlas = spec->max_atlas;
        return lp->ops->bake(lp, &in, &b->lods[i].baked, err);
    }
    sv_mesh *keep = NULL;
    if (lp->trunk != SV_TRUNK_NONE) {
        double ratio = lp->trunk == SV_TRUNK_MESH ? 1.0 : lp->trunk_ratio;
        if ((st = sv_trunk_mesh_budget(p->mesh, p->cls.tri_part, ratio, lp->trunk_max_triangles,
                                       b->ch.info[i].trunk_error, &keep, err)))
            return st;
    }
    if (lp->geometry) {
        /* explicit geometry (a chain level's leaves) is drawn as is, with the trunk */
        sv_mesh *merged = NULL;
        st = sv_mesh_merge(keep, lp->geometry, &merged, err);
        sv_mesh_destroy(keep);
        keep = merged;
        if (st) return st;
    }
    /* A quad LOD is never drawn taller than the largest evaluated size
     * (svp_plan_switches caps its limit there), so the textures of the trunk
     * it keeps need no more texels a side than the next power of two
     * above it: the bark of the original (2048² and more) was copied
     * into every level's file. */
    if (keep && !b->ch.info[i].scheduled) {
        uint32_t cap = SVP_KEPT_TEXTURE_MIN;
        while (cap < spec->eval_sizes[0] && cap < SVP_KEPT_TEXTURE_MAX) cap *= 2;
        for (uint32_t k = 0; k < keep->image_count && !st; k++)
            st = sv_image_reduce(&keep->images[k], cap, err);
        if (st) {
            sv_mesh_destroy(keep);
            return st;
        }
    }
    st = sv_bake_lod(r->ren, r->gsrc, p->mesh, lp, keep, &b->bo, &b->lods[i].baked, err);
    sv_mesh_destroy(keep);
    if (st) return st;
    r->times[ST_PACK] += b->lods[i].baked.seconds_pack;
    r->times[ST_BAKE] -= b->lods[i].baked.seconds_pack;
    return SV_OK;
}

/* Bake stage. In: b->si, b->ch. Out: b->bo, b->lods (baked; coverage alpha's
 * cutoffs calibrated). */
static sv_status stage_bake(run *r, bake_state *b, sv_error *err)
{
    sv_status st;
    if ((st = stage(r, ST_BAKE, 0, err))) return st;
    bake_options(r, &b->bo);
    b->lods = sv_calloc(b->si.lod_count, sizeof *b->lods);
    if (!b->lods) return sv_fail(err, SV_ERR_NOMEM, "out of memory");
    for (uint32_t i = 0; i < b->si.lod_count; i++) {
        if ((st = stage(r, ST_BAKE, (double)i / b->si.lod_count, err))) return st;
        if ((st = bake_level(r, b, i, err))) return st;
    }
    if (b->bo.coverage_alpha &&
        (st = svp_calibrate_cutoffs(r, r->ren, r->gsrc, &b->si, b->lods, err)))
        return st;
    return SV_OK;
}

/* One evaluator kept in r (*ev, *opt), made again only when eo changes;
 * destroyed when eo has no sizes. */
static sv_status keep_evaluator(run *r, const sv_eval_options *eo, sv_evaluator **ev,
                                sv_eval_options *opt, sv_error *err)
{
    if (*ev && memcmp(opt, eo, sizeof *eo) != 0) {
        sv_evaluator_destroy(*ev);
        *ev = NULL;
    }
    if (!*ev && eo->size_count) {
        sv_status st = sv_evaluator_create(r->ren, r->p.mesh, r->gsrc, eo, ev, err);
        if (st) return st;
        *opt = *eo;
    }
    return SV_OK;
}

/* A target search's try judges one size, the goal's: o keeps only `px`,
 * rendered as tall as before (supersample raised by the factor the size was
 * boxed down from the largest), so the figure is the one the full
 * evaluation gives, up to float rounding of a box of boxes; o without px
 * keeps no size (has_size: whether o judges px so). A try renders a quarter or less
 * of the pixels (the 512² renders of 256 and 128 px are not made). */
static bool has_size(const sv_eval_options *o, uint32_t px)
{
    for (uint32_t i = 0; i < o->size_count; i++)
        if (o->sizes[i] == px && (o->sizes[0] * o->supersample) % px == 0) return true;
    return false;
}

static void trial_size(sv_eval_options *o, uint32_t px)
{
    if (has_size(o, px)) {
        o->supersample = o->sizes[0] * o->supersample / px;
        o->sizes[0] = px;
        o->size_count = 1;
    } else {
        o->size_count = 0;
    }
}

/* The accuracy evaluators for the spec's evaluate settings, kept in r. The
 * sizes at or below evaluate.small_render / 4 (64 px by default) are judged
 * from a render small_render tall of their own (r->ev_small: 4x4 samples a
 * pixel at 64 px, 8x8 at 32, as sveval judges), the larger ones from the
 * largest size × evaluate.supersample (r->ev). With small_render 0, no
 * size on one side, or both renders small_render tall, one evaluator judges
 * every size (r->ev). */
static sv_status evaluator(run *r, const sv_bake_options *bo, sv_error *err)
{
    const sv_spec *spec = &r->spec;
    sv_eval_options eo, es;
    memset(&eo, 0, sizeof eo);
    eo.view_count = spec->eval_views;
    eo.viewer = spec->scene.viewer;
    /* Judge what a viewer sees: with static lighting the original is lit
     * and the stand-in shows its baked light (unlit atlas material). */
    if (bo->lit) {
        eo.render.shade = SV_SHADE_LIT;
        memcpy(eo.render.light_dir, bo->light_dir, sizeof eo.render.light_dir);
    }
    eo.supersample = spec->eval_supersample;
    es = eo;
    uint32_t lim = spec->eval_small_render / 4;
    for (uint32_t i = 0; i < spec->eval_size_count; i++) {
        uint32_t px = spec->eval_sizes[i]; /* largest first */
        if (px <= lim) es.sizes[es.size_count++] = px;
        else eo.sizes[eo.size_count++] = px;
    }
    if (es.size_count) es.supersample = spec->eval_small_render / es.sizes[0];
    if (!eo.size_count) { /* every size is small: one evaluator */
        eo = es;
        es.size_count = 0;
    } else if (es.size_count && eo.sizes[0] * eo.supersample == spec->eval_small_render) {
        /* both render small_render tall (e.g. 128, 64 and 32 px at
         * supersample 2): one render per view serves every size, each a box
         * of the render by an integer factor (box of box: the same figures
         * up to float rounding), a render fewer per view and level */
        for (uint32_t i = 0; i < es.size_count; i++) eo.sizes[eo.size_count++] = es.sizes[i];
        es.size_count = 0;
    }
    if (r->trial && (has_size(&eo, spec->target_pixels) || has_size(&es, spec->target_pixels))) {
        trial_size(&eo, spec->target_pixels);
        trial_size(&es, spec->target_pixels);
        if (!eo.size_count) {
            eo = es;
            es.size_count = 0;
        }
    }
    sv_status st = keep_evaluator(r, &eo, &r->ev, &r->ev_opt, err);
    if (!st) st = keep_evaluator(r, &es, &r->ev_small, &r->ev_small_opt, err);
    return st;
}

/* out = a's sizes then b's (both largest first, a's larger), with their
 * per-view measures; a and b are consumed. */
static sv_status merge_eval(sv_eval_result *a, sv_eval_result *b, sv_eval_result *out,
                            sv_error *err)
{
    sv_eval_result m = *a;
    m.size_count = a->size_count + b->size_count;
    m.seconds = a->seconds + b->seconds;
    if (m.size_count > SV_EVAL_MAX_SIZES || a->view_count != b->view_count) {
        sv_eval_result_free(a);
        sv_eval_result_free(b);
        return sv_fail(err, SV_ERR_INTERNAL, "evaluate: cannot merge the two evaluations");
    }
    for (uint32_t k = 0; k < b->size_count; k++) m.sizes[a->size_count + k] = b->sizes[k];
    m.per_view = sv_calloc((size_t)m.view_count * m.size_count + 1, sizeof *m.per_view);
    if (!m.per_view) {
        sv_eval_result_free(a);
        sv_eval_result_free(b);
        return sv_fail(err, SV_ERR_NOMEM, "out of memory");
    }
    for (uint32_t v = 0; v < m.view_count; v++) {
        for (uint32_t k = 0; k < a->size_count; k++)
            m.per_view[v * m.size_count + k] = a->per_view[v * a->size_count + k];
        for (uint32_t k = 0; k < b->size_count; k++)
            m.per_view[v * m.size_count + a->size_count + k] = b->per_view[v * b->size_count + k];
    }
    sv_eval_result_free(a);
    sv_eval_result_free(b);
    *out = m;
    return SV_OK;
}

/* How one level is measured, by either evaluator. */
typedef struct eval_call {
    enum { EC_IDENTITY, EC_MESH, EC_DRAWN, EC_SUBSETS } kind;
    const sv_gpu_mesh *g;
    level_draw_ctx *dc;
    view_sets *vs;
} eval_call;

static sv_status eval_one(sv_evaluator *ev, const eval_call *c, sv_eval_result *out, sv_error *err)
{
    switch (c->kind) {
    case EC_IDENTITY:
        return sv_eval_identity(ev, out, err);
    case EC_DRAWN:
        return sv_evaluate_drawn(ev, svp_level_draw, c->dc, out, err);
    case EC_SUBSETS:
        return sv_evaluate_subsets(ev, c->g, svp_select_subsets, c->vs, out, err);
    default:
        return sv_evaluate(ev, c->g, out, err);
    }
}

/* c measured at every size of the spec: by r->ev, and r->ev_small when
 * there is one, merged. */
static sv_status eval_sizes(run *r, const eval_call *c, sv_eval_result *out, sv_error *err)
{
    sv_status st = eval_one(r->ev, c, out, err);
    if (st || !r->ev_small) return st;
    sv_eval_result small;
    if ((st = eval_one(r->ev_small, c, &small, err))) {
        sv_eval_result_free(out);
        return st;
    }
    sv_eval_result big = *out;
    return merge_eval(&big, &small, out, err);
}

/* An earlier measured level that draws as level i does (sv_mesh_draws_same;
 * neither drawn by its own hook nor view-dependent), or -1. A tree without foliage
 * makes every quad level its trunk, one mesh measured three times. */
static int drawn_as_earlier(const bake_state *b, uint32_t i)
{
    const sv_lod_plan *lp = &b->si.lods[i];
    if (svp_drawn_by_hook(lp) || lp->select) return -1;
    for (uint32_t j = 0; j < i; j++) {
        const sv_lod_plan *lq = &b->si.lods[j];
        if (b->lods[j].evaluated && !svp_drawn_by_hook(lq) && !lq->select &&
            sv_mesh_draws_same(b->lods[j].baked.mesh, b->lods[i].baked.mesh))
            return (int)j;
    }
    return -1;
}

/* dst = src's measures (dst's own seconds: 0, nothing was rendered). */
static sv_status copy_eval(const sv_eval_result *src, sv_eval_result *dst, sv_error *err)
{
    *dst = *src;
    dst->seconds = 0;
    size_t n = (size_t)src->view_count * src->size_count;
    dst->per_view = sv_calloc(n ? n : 1, sizeof *dst->per_view);
    if (!dst->per_view) return sv_fail(err, SV_ERR_NOMEM, "out of memory");
    if (n) memcpy(dst->per_view, src->per_view, n * sizeof *dst->per_view);
    return SV_OK;
}

/* Measures LOD i against the original as it is drawn: the full level, or any
 * that draws as the original does, is the original (nothing to measure),
 * a level drawn as an earlier one has its measures, a level
 * with a draw hook (an impostor: the reference runtime) is drawn by it, a
 * view-dependent level by its per-view subsets. */
static sv_status evaluate_level(run *r, bake_state *b, uint32_t i, sv_error *err)
{
    const sv_lod_plan *lp = &b->si.lods[i];
    lod_out *l = &b->lods[i];
    sv_status st = sv_gpu_mesh_upload(r->ren, l->baked.mesh, &l->gpu, err);
    if (st) return st;
    int same = drawn_as_earlier(b, i);
    eval_call c = {EC_MESH, l->gpu, NULL, NULL};
    level_draw_ctx dc = {lp, &l->baked};
    view_sets vs;
    if (same < 0 && !svp_drawn_by_hook(lp) && !lp->select &&
        sv_mesh_draws_same(r->p.mesh, l->baked.mesh)) {
        c.kind = EC_IDENTITY; /* it is the original */
        st = eval_sizes(r, &c, &l->eval, err);
    } else if (same >= 0) {
        st = copy_eval(&b->lods[same].eval, &l->eval, err);
    } else if (b->ch.info[i].scheduled && b->ch.info[i].lambda >= 1 && !lp->quad_count) {
        c.kind = EC_IDENTITY;
        st = eval_sizes(r, &c, &l->eval, err);
    } else if (svp_drawn_by_hook(lp)) {
        c.kind = EC_DRAWN;
        c.dc = &dc;
        st = eval_sizes(r, &c, &l->eval, err);
    } else if (lp->select) {
        if ((st = svp_view_sets_init(&vs, lp, &l->baked, err))) return st;
        c.kind = EC_SUBSETS;
        c.vs = &vs;
        st = eval_sizes(r, &c, &l->eval, err);
        svp_view_sets_free(&vs);
    } else {
        st = eval_sizes(r, &c, &l->eval, err);
    }
    if (st) return st;
    l->evaluated = true;
    return SV_OK;
}

/* The flattening bound of quad level i (docs/accuracy.md): its quads' faces
 * projected onto their planes, as geometry, with the geometry the level
 * keeps (the baked mesh's triangles after its quads), measured like the
 * level. Levels drawn by a hook or per view, and levels without quads, have
 * none. */
static sv_status measure_bound(run *r, bake_state *b, uint32_t i, sv_error *err)
{
    const sv_lod_plan *lp = &b->si.lods[i];
    lod_out *l = &b->lods[i];
    if (!lp->quad_count || svp_drawn_by_hook(lp) || lp->select) return SV_OK;
    const sv_mesh *bm = l->baked.mesh;
    uint32_t first = 2 * l->baked.quad_count, kept = bm->triangle_count - first;
    sv_mesh *flat = NULL, *keep = NULL, *both = NULL;
    sv_gpu_mesh *g = NULL;
    uint32_t *tris = sv_calloc(kept ? kept : 1, sizeof *tris);
    if (!tris) return sv_fail(err, SV_ERR_NOMEM, "out of memory");
    for (uint32_t t = 0; t < kept; t++) tris[t] = first + t;
    sv_status st = sv_lod_flatten(r->p.mesh, lp, &flat, err);
    if (!st && kept) st = sv_mesh_subset(bm, tris, kept, &keep, err);
    if (!st) st = sv_mesh_merge(keep, flat, &both, err);
    if (!st) st = sv_gpu_mesh_upload(r->ren, both, &g, err);
    eval_call c = {EC_MESH, g, NULL, NULL};
    if (!st) st = eval_sizes(r, &c, &l->bound, err);
    if (!st) l->bound_measured = true;
    sv_gpu_mesh_free(g);
    sv_mesh_destroy(both);
    sv_mesh_destroy(keep);
    sv_mesh_destroy(flat);
    free(tris);
    return st;
}

/* The lum_ratio of level i's evaluation at the size nearest 64 px (the
 * sveval-equivalent render), or 0 when it has none. */
static double level_lum(const lod_out *l)
{
    double best = 0;
    uint32_t d = UINT32_MAX;
    for (uint32_t k = 0; k < l->eval.size_count; k++) {
        uint32_t px = l->eval.sizes[k].pixels, dk = px > 64 ? px - 64 : 64 - px;
        if (dk < d) d = dk, best = l->eval.sizes[k].lum_ratio;
    }
    return best;
}

/* Brightness match (docs/accuracy.md "Brightness"): a level measured on
 * its own whose light differs from the original's where both cover by more
 * than SV_BRIGHTNESS_BAND (lum_ratio, sveval's figure, over the
 * evaluation's views; SV_BRIGHTNESS_BAND_MESH for a mesh level) has its
 * colour scaled by the inverse (a quad level's atlas; a mesh level's
 * materials: svp_scale_mesh_colour), then is
 * measured again; twice at most (a quad level's kept trunk and texels
 * clamped at white keep their light). A level's colour is the views' average of what
 * its texels stand for, the cutoff's counterpart for light: no pop in
 * brightness where the chain switches to it. */
static sv_status match_brightness(run *r, bake_state *b, uint32_t i, sv_error *err)
{
    const sv_lod_plan *lp = &b->si.lods[i];
    lod_out *l = &b->lods[i];
    if (svp_drawn_by_hook(lp) || lp->select || drawn_as_earlier(b, i) >= 0 || !l->evaluated ||
        (lp->quad_count && !l->baked.albedo.data))
        return SV_OK;
    for (int pass = 0; pass < 2; pass++) {
        double q = level_lum(l);
        if (!(q > 0) ||
            fabs(q - 1.0) <= (lp->quad_count ? SV_BRIGHTNESS_BAND : SV_BRIGHTNESS_BAND_MESH))
            break;
        /* a pass moves the light by a quarter at most: a level several times
         * too dark or bright is a fault to see (the 8-bit colour-space error
         * that made the bush's atlases 2-4x darker), not a mean to match; the
         * largest factor measured on both sets is 1.092 (the bonsai's
         * crossed quads, over four passes) */
        double f = 1.0 / q;
        f = f < 0.8 ? 0.8 : f > 1.25 ? 1.25 : f;
        sv_status st = lp->quad_count ? svp_scale_atlas(&l->baked, f, err)
                                      : svp_scale_mesh_colour(l->baked.mesh, f, err);
        if (st) return st;
        l->colour_scale = (l->colour_scale > 0 ? l->colour_scale : 1.0) * f;
        sv_gpu_mesh_free(l->gpu);
        l->gpu = NULL;
        sv_eval_result_free(&l->eval);
        l->evaluated = false;
        if ((st = evaluate_level(r, b, i, err))) return st;
    }
    return SV_OK;
}

/* Evaluate stage (when the spec asks). In: b->lods baked. Out: their eval. */
static sv_status stage_evaluate(run *r, bake_state *b, sv_error *err)
{
    sv_status st;
    if ((st = stage(r, ST_EVALUATE, 0, err))) return st;
    if (!r->spec.evaluate) return SV_OK;
    if ((st = evaluator(r, &b->bo, err))) return st;
    for (uint32_t i = 0; i < b->si.lod_count; i++) {
        if ((st = stage(r, ST_EVALUATE, (double)i / b->si.lod_count, err))) return st;
        if ((st = evaluate_level(r, b, i, err))) return st;
        /* a try judges coverage only: its colour is matched if it is baked */
        if (!r->trial && (st = match_brightness(r, b, i, err))) return st;
        if (r->spec.eval_flattening_bound && !r->trial && (st = measure_bound(r, b, i, err)))
            return st;
    }
    return SV_OK;
}

/* A target search's try: what the method's finest LOD costs and reached
 * (r->tout); nothing is written. */
static void trial_result(run *r, const bake_state *b)
{
    const lod_out *l = &b->lods[0];
    trial_out *o = &r->tout;
    o->quads = l->baked.quad_count;
    o->triangles = l->baked.mesh->triangle_count;
    o->texels = (double)l->baked.albedo.width * l->baked.albedo.height;
    o->iou = -1;
    if (l->evaluated)
        for (uint32_t k = 0; k < l->eval.size_count; k++)
            if (l->eval.sizes[k].pixels == r->spec.target_pixels)
                o->iou = r->spec.target_worst ? l->eval.sizes[k].worst.iou
                                              : l->eval.sizes[k].mean.iou;
}

/* Plan stage. In: b->lods measured. Out: switch sizes and coverages, the
 * LODs never drawn removed (b->si, b->lods, b->ch compacted, notes in
 * b->ch.skipped), later levels' atlases shrunk; b->fc, b->fr, b->tree_h. */
static sv_status stage_plan(run *r, bake_state *b, sv_error *err)
{
    const sv_spec *spec = &r->spec;
    frame_sphere(&r->p, b->fc, &b->fr);
    b->tree_h = 2.0 * (b->fr > 0 ? b->fr : r->p.radius);
    svp_plan_switches(r, &b->ch, b->lods, b->si.lod_count, b->tree_h);
    if (!spec->evaluate || b->si.lod_count <= 1) return SV_OK;
    bool *drop = sv_calloc(b->si.lod_count, sizeof *drop);
    if (!drop) return sv_fail(err, SV_ERR_NOMEM, "out of memory");
    svp_plan_visibility(r, &b->ch, b->lods, &b->si, b->tree_h, drop);
    svp_compact_lods(&b->si, b->lods, &b->ch, drop);
    free(drop);
    for (uint32_t i = 0; i < b->si.lod_count; i++) {
        double next = (i + 1 < b->si.lod_count) ? b->lods[i + 1].switch_pixels : 0;
        double cov = next / (double)spec->scene.screen_height;
        b->lods[i].coverage = cov > 1 ? 1 : cov;
    }
    sv_status st = svp_shrink_atlases(r, r->ren, r->gsrc, &b->si, b->lods, b->tree_h,
                                      b->bo.coverage_alpha, err);
    /* a reduced atlas draws otherwise: the report gives what is written */
    for (uint32_t i = 0; i < b->si.lod_count && !st; i++) {
        lod_out *l = &b->lods[i];
        if (!l->reduced || !l->evaluated) continue;
        sv_gpu_mesh_free(l->gpu);
        l->gpu = NULL;
        sv_eval_result_free(&l->eval);
        l->evaluated = false;
        st = evaluate_level(r, b, i, err);
        /* a reduced atlas shows other light (the Sapling quaking aspen's
         * billboard clouds: lum_ratio 1.000 at full size, 0.942 reduced) */
        if (!st) st = match_brightness(r, b, i, err);
    }
    return st;
}

void svp_bake_state_free(bake_state *b)
{
    if (b->lods)
        for (uint32_t i = 0; i < b->si.lod_count; i++) {
            sv_gpu_mesh_free(b->lods[i].gpu);
            sv_eval_result_free(&b->lods[i].eval);
            sv_eval_result_free(&b->lods[i].bound);
            sv_baked_lod_free(&b->lods[i].baked);
        }
    free(b->lods);
    sv_stand_in_free(&b->si);
    svp_chain_free(&b->ch);
}

/* A target try's state in place of compose and bake (r->reuse, taken):
 * what the try measured is measured again with the final bake's evaluators
 * (a try judges one size). report.json's method and bake times stay 0. */
static void stage_reuse(run *r, bake_state *b)
{
    *b = *r->reuse;
    free(r->reuse);
    r->reuse = NULL;
    resolve_distance(r);
    /* no method or bake stage is opened: their times stay 0 in the report */
    for (uint32_t i = 0; i < b->si.lod_count; i++) {
        lod_out *l = &b->lods[i];
        sv_gpu_mesh_free(l->gpu);
        l->gpu = NULL;
        sv_eval_result_free(&l->eval);
        sv_eval_result_free(&l->bound);
        l->evaluated = l->bound_measured = false;
        l->colour_scale = 0; /* a try's colour is never matched (stage_evaluate) */
    }
}

/* One bake: compose → bake → evaluate → (a try stops here) plan → write.
 * The renderer, the original on it and the evaluators belong to r. */
sv_status svp_bake_all(run *r, sv_error *err)
{
    bake_state b;
    memset(&b, 0, sizeof b);
    sv_status st = SV_OK;
    if (r->reuse) {
        stage_reuse(r, &b);
    } else {
        st = stage_compose(r, &b, err);
        if (!st) st = stage_bake(r, &b, err);
    }
    if (!st) st = stage_evaluate(r, &b, err);
    if (!st && r->trial) {
        trial_result(r, &b);
        if (r->keep) *r->keep = b; /* the target search keeps it */
        else svp_bake_state_free(&b);
        return SV_OK;
    }
    if (!st) st = stage_plan(r, &b, err);
    if (!st) st = stage(r, ST_WRITE, 0, err);
    /* each atlas goes into its file, model.glb and its level's glb: encoded
     * once (image.h) */
    sv_png_memo *memo = st ? NULL : sv_png_memo_create();
    sv_png_memo *prev_memo = sv_png_memo_use(memo);
    if (!st) st = svp_write_atlases(r, &b, err);
    if (!st) st = svp_write_gltf(r, &b, err);
    sv_png_memo_use(prev_memo);
    sv_png_memo_free(memo);
    if (!st) st = svp_write_preview(r, &b, r->spec.evaluate ? r->ev : NULL, err);
    if (!st) st = svp_write_planes(r, &b, err);
    if (!st) st = svp_write_report(r, &b, err);
    svp_bake_state_free(&b);
    return st;
}

sv_status sv_pipeline_run(const sv_bake_request *req, sv_error *err)
{
    run r;
    memset(&r, 0, sizeof r);
    r.req = req;
    r.stage = -1;
    r.t0 = sv_now();
    r.pa = 0;
    r.pb = 1;
    sv_status st = sv_spec_parse(req->spec_json, req->spec_json ? req->spec_len : 0, &r.spec, err);
    if (st) return st;
    if (req->file_count == 0) {
        st = sv_fail(err, SV_ERR_FORMAT, "no mesh file given");
        goto out;
    }
    if (!(r.memo = sv_memo_create())) {
        st = sv_fail(err, SV_ERR_NOMEM, "out of memory");
        goto out;
    }
    if ((st = prepare(req->files, req->file_count, &r.spec, &r.p, &r, err))) goto out;
    if ((st = svp_dilate_textures(r.p.mesh, r.spec.dilate ? r.spec.dilate : 8, err))) goto out;
    st = r.spec.has_target ? svp_target_search(&r, err) : svp_bake_all(&r, err);
out:
    sv_memo_free(r.memo);
    if (r.reuse) {
        svp_bake_state_free(r.reuse);
        free(r.reuse);
    }
    cJSON_Delete(r.target_json);
    cJSON_Delete(r.target_times);
    sv_evaluator_destroy(r.ev);
    sv_evaluator_destroy(r.ev_small);
    sv_evaluator_destroy(r.calib_ev);
    sv_gpu_mesh_free(r.gsrc);
    sv_renderer_destroy(r.ren);
    prepared_free(&r.p);
    sv_spec_free(&r.spec);
    return st;
}
