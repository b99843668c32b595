/* chain.c — the LOD chain (docs/lod.md): which levels are built
 * (svp_chain_compose: full mesh → stochastic levels → the spec's method →
 * the coarsest method) and, once measured, where each is drawn
 * (svp_plan_switches, svp_plan_visibility, svp_compact_lods).
 *
 * Stochastic levels finer or coarser than the scene's distance range needs
 * (by λ(d), Fichtner eq. 1–2 after Cook et al. 2007, stochastic.h) are not
 * built; after evaluation, LODs whose planned screen-size interval misses the
 * scene's range are dropped. Every skip is noted in report.json with why.
 */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "lod_plan.h"
#include "method_ops.h"
#include "trunk.h"
#include "pipeline_internal.h"

void svp_chain_free(chain *c)
{
    sv_stoch_result_free(&c->sres);
    free(c->info);
    cJSON_Delete(c->skipped);
    memset(c, 0, sizeof *c);
}

static cJSON *skip_note(chain *c, const char *name, const char *stage, const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));
static cJSON *skip_note(chain *c, const char *name, const char *stage, const char *fmt, ...)
{
    char why[400];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(why, sizeof why, fmt, ap);
    va_end(ap);
    cJSON *o = cJSON_CreateObject();
    cJSON_AddStringToObject(o, "name", name);
    cJSON_AddStringToObject(o, "stage", stage);
    cJSON_AddStringToObject(o, "reason", why);
    cJSON_AddItemToArray(c->skipped, o);
    return o;
}

/* World size of one pixel at distance d. */
static double metres_per_pixel(const sv_scene *sc, double d)
{
    double px = sv_scene_pixels(sc, 1.0, d);
    return px > 0 && isfinite(px) ? 1.0 / px : 0.0;
}

/* Coverage for measuring r (paper §6): foliage triangles drawn alone from six
 * views placed as the scene's viewer says, covered pixels summed. */
typedef struct cover_ctx {
    sv_renderer *ren;
    const sv_gpu_mesh *g;
    const prepared *p;
    sv_viewer viewer;
} cover_ctx;

static sv_status count_cover(void *user, const uint32_t *tris, uint32_t count, double *covered,
                             sv_error *err)
{
    cover_ctx *c = user;
    double dirs[3 * COVER_VIEWS];
    sv_eval_place_views(c->viewer, COVER_VIEWS, dirs);
    *covered = 0;
    for (int v = 0; v < COVER_VIEWS; v++) {
        sv_camera cam;
        sv_eval_camera(c->p->centre, c->p->radius, &dirs[3 * v], &cam);
        sv_render_options ro;
        memset(&ro, 0, sizeof ro);
        sv_image img = {0};
        if (count == 0) return SV_OK;
        sv_status st = sv_render(c->ren, c->g, tris, count, &cam, &ro, COVER_SIZE, COVER_SIZE, &img,
                                 NULL, err);
        if (st) return st;
        const uint8_t *px = img.data;
        for (size_t i = 0; i < (size_t)COVER_SIZE * COVER_SIZE; i++)
            *covered += px[4 * i + 3] >= 128;
        sv_image_free(&img);
    }
    return SV_OK;
}

/* Moves src's LODs to the end of dst (names made unique), each with its
 * c->info made by method `source`; a LOD with a payload gets that method's
 * level hooks (level.h). src is freed, also on failure. */
static sv_status append_lods(sv_stand_in *dst, chain *c, sv_stand_in *src, const char *source,
                             sv_error *err)
{
    for (uint32_t i = 0; i < src->lod_count; i++) {
        char name[32];
        memcpy(name, src->lods[i].name, sizeof name);
        for (uint32_t j = 0, k = 2; j < dst->lod_count; j++) /* unique node/atlas names */
            if (strcmp(dst->lods[j].name, name) == 0) {
                snprintf(name, sizeof name, "%.24s_%u", src->lods[i].name, k++);
                j = (uint32_t)-1;
            }
        chain_lod *ci = realloc(c->info, ((size_t)dst->lod_count + 1) * sizeof *ci);
        if (ci) c->info = ci;
        sv_lod_plan *l = ci ? sv_stand_in_add_lod(dst, name) : NULL;
        if (!l) {
            sv_stand_in_free(src);
            return sv_fail(err, SV_ERR_NOMEM, "out of memory");
        }
        *l = src->lods[i];
        memcpy(l->name, name, sizeof l->name);
        if (l->payload && !l->ops) l->ops = sv_level_ops_find(source); /* level.h */
        memset(&src->lods[i], 0, sizeof src->lods[i]);
        chain_lod *x = &ci[dst->lod_count - 1];
        memset(x, 0, sizeof *x);
        snprintf(x->source, sizeof x->source, "%s", source);
        x->level = -1;
    }
    sv_stand_in_free(src);
    return SV_OK;
}

/* The stochastic levels the scene needs (by λ at its nearest and farthest
 * distance) into *keep; the others get a skip note. The stochastic method
 * itself keeps every level it was asked for. */
static void stochastic_levels(const run *r, chain *c, bool is_stoch, sv_stochastic_settings *keep)
{
    const sv_scene *sc = &r->spec.scene;
    *keep = c->ss;
    keep->level_count = 0;
    double ln = sv_stochastic_lambda_at(&c->ss, sc, sc->distance_min);
    double lf = sv_stochastic_lambda_at(&c->ss, sc, sc->distance_max);
    /* the finest level needed: the smallest level >= λ(distance_min);
     * the coarsest: the smallest level >= λ(distance_max) */
    int fine = 0, coarse = (int)c->ss.level_count - 1;
    for (int i = 0; i < (int)c->ss.level_count; i++) {
        if (c->ss.levels[i] >= ln) fine = i;
        if (c->ss.levels[i] >= lf) coarse = i;
    }
    for (int i = 0; i < (int)c->ss.level_count; i++) {
        char name[32];
        sv_stochastic_level_name(c->ss.levels[i], name);
        if (i < fine && !is_stoch && c->ss.levels[i] < 1)
            skip_note(c, name, "plan",
                      "finer than needed: at the nearest scene distance (%g m) lambda is "
                      "%.3g, so level %g suffices",
                      sc->distance_min, ln, c->ss.levels[fine]);
        else if (i > coarse && !is_stoch)
            skip_note(c, name, "plan",
                      "never reached: at the farthest scene distance (%g m) lambda is still "
                      "%.3g (level %g)",
                      sc->distance_max, lf, c->ss.levels[coarse]);
        else {
            keep->level_triangles[keep->level_count] = c->ss.level_triangles[i];
            keep->levels[keep->level_count++] = c->ss.levels[i];
        }
    }
}

/* r for area preservation: the spec's, or measured by rendering (paper §6)
 * when it gives none (c->ratio, c->ratio_measured). */
static sv_status stochastic_ratio(run *r, sv_renderer *ren, const sv_gpu_mesh *gsrc, chain *c,
                                  const sv_stochastic_settings *keep, double *ratio, sv_error *err)
{
    const prepared *p = &r->p;
    *ratio = c->ss.visible_ratio;
    if (*ratio > 0 || !keep->area_preservation) return SV_OK;
    uint32_t *order = sv_calloc(p->leaves.count ? p->leaves.count : 1, sizeof *order);
    if (!order) return sv_fail(err, SV_ERR_NOMEM, "out of memory");
    sv_status st = sv_stochastic_order(&p->leaves, r->spec.seed, c->ss.order, order, err);
    cover_ctx cc = {ren, gsrc, p, r->spec.scene.viewer};
    if (!st)
        st = sv_stochastic_measure_ratio(&p->leaves, order, c->ss.ratio_fraction, count_cover, &cc,
                                         &c->ratio, err);
    free(order);
    if (st) return st;
    *ratio = c->ratio.r;
    c->ratio_measured = true;
    return SV_OK;
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
static sv_status compose_trunk_levels(run *r, const sv_stochastic_settings *keep, sv_stand_in *si,
                                      chain *c, sv_error *err)
{
    const sv_scene *sc = &r->spec.scene;
    for (uint32_t k = 0; k < keep->level_count; k++) {
        double lambda = keep->levels[k];
        char name[32];
        if (lambda >= 1) snprintf(name, sizeof name, "full");
        else snprintf(name, sizeof name, "trunk%d", (int)lround(lambda * 100));
        sv_stand_in one = {0};
        sv_lod_plan *l = sv_stand_in_add_lod(&one, name);
        if (!l) return sv_fail(err, SV_ERR_NOMEM, "out of memory");
        double e = lambda >= 1 ? 0 : sv_stochastic_level_error(keep, sc, r->p.radius, lambda);
        sv_status st = SV_OK;
        if (lambda >= 1) {
            l->trunk = SV_TRUNK_MESH;
        } else {
            l->trunk = SV_TRUNK_NONE; /* the simplified trunk is the level's geometry */
            st = sv_trunk_mesh(r->p.mesh, r->p.cls.tri_part, SV_STOCH_TRUNK_FLOOR,
                               e * TRUNK_LEVEL_ERROR, &l->geometry, err);
        }
        if (st) {
            sv_stand_in_free(&one);
            return st;
        }
        if ((st = append_lods(si, c, &one, "trunk", err))) return st;
        chain_lod *x = &c->info[si->lod_count - 1];
        x->scheduled = true;
        x->lambda = lambda;
        x->distance = sv_stochastic_distance_for_lambda(keep, sc, lambda);
        x->trunk_error = e;
    }
    return SV_OK;
}

/* Builds the kept stochastic levels (Fichtner §4.3) and appends them to si,
 * finest first, with their λ, schedule distance and trunk error. */
static sv_status compose_stochastic(run *r, sv_renderer *ren, const sv_gpu_mesh *gsrc,
                                    const sv_method_input *in, bool is_stoch, sv_stand_in *si,
                                    chain *c, sv_error *err)
{
    const sv_scene *sc = &r->spec.scene;
    sv_stochastic_settings keep;
    stochastic_levels(r, c, is_stoch, &keep);
    if (!keep.level_count) return SV_OK;
    if (r->p.leaves.count == 0 && !is_stoch) return compose_trunk_levels(r, &keep, si, c, err);
    double ratio;
    sv_status st = stochastic_ratio(r, ren, gsrc, c, &keep, &ratio, err);
    if (st) return st;
    stoch_score_ctx sc_ctx = {r, ren, gsrc};
    sv_stoch_scorer scorer = {svp_stoch_score, &sc_ctx};
    if ((st = sv_stochastic_build(in, &keep, ratio, &scorer, &c->sres, err))) return st;
    c->ss = keep;
    c->has_stochastic = true;
    for (uint32_t k = 0; k < c->sres.level_count; k++) {
        sv_stoch_level *L = &c->sres.levels[k];
        char name[32];
        sv_stochastic_level_name(L->lambda, name);
        sv_stand_in one = {0};
        sv_lod_plan *l = sv_stand_in_add_lod(&one, name);
        if (!l) return sv_fail(err, SV_ERR_NOMEM, "out of memory");
        l->geometry = L->geometry;
        L->geometry = NULL;
        /* below λ = 1 the method built the trunk first (it leads the geometry) */
        l->trunk = L->trunk_in_geometry ? SV_TRUNK_NONE
                   : L->lambda >= 1     ? SV_TRUNK_MESH
                                        : SV_TRUNK_SIMPLIFIED;
        l->trunk_ratio = fmax(L->lambda, SV_STOCH_TRUNK_FLOOR);
        l->trunk_max_triangles = sv_stochastic_trunk_cap(&keep, k, L);
        uint32_t gv = l->geometry ? l->geometry->vertex_count - L->trunk_vertices : 0;
        if ((st = append_lods(si, c, &one, sv_method_chain_levels()->name, err))) return st;
        chain_lod *x = &c->info[si->lod_count - 1];
        x->stochastic = true;
        x->scheduled = true;
        x->level = (int)k;
        x->lambda = L->lambda;
        x->geom_vertices = gv;
        x->distance = sv_stochastic_distance_for_lambda(&c->ss, sc, L->lambda);
        x->trunk_error = L->trunk_in_geometry
                             ? L->trunk_error
                             : sv_stochastic_level_error(&c->ss, sc, r->p.radius, L->lambda);
    }
    return SV_OK;
}

/* The quad methods after the stochastic levels: the spec's (its LODs are the
 * chain's required ones), then the coarsest. */
static sv_status compose_methods(const run *r, const sv_method_input *in, bool is_stoch,
                                 sv_stand_in *si, chain *c, sv_error *err)
{
    const sv_spec *spec = &r->spec;
    const sv_scene *sc = &spec->scene;
    const char *names[2] = {is_stoch ? NULL : spec->method, NULL};
    if (spec->lod_chain && spec->lod_coarsest[0] && strcmp(spec->lod_coarsest, spec->method) != 0)
        names[1] = spec->lod_coarsest;
    double d_after = sc->distance_min; /* quads come after the last stochastic level */
    for (uint32_t i = 0; i < si->lod_count; i++)
        if (c->info[i].scheduled && isfinite(c->info[i].distance) && c->info[i].distance > d_after)
            d_after = c->info[i].distance;
    d_after = fmin(d_after, sc->distance_max);
    c->required = c->coarsest = -1;
    c->required_first = c->coarsest_first = 0;
    if (is_stoch) c->required = (int)si->lod_count - 1;
    for (int k = 0; k < 2; k++) {
        if (!names[k]) continue;
        const sv_method_ops *m = sv_method_ops_find(names[k]);
        if (!m) return sv_fail(err, SV_ERR_SPEC, "lod: unknown method %s", names[k]);
        sv_stand_in part = {0};
        const cJSON *set = cJSON_GetObjectItemCaseSensitive(spec->root, names[k]);
        sv_status st = m->run(in, set, &part, err);
        if (st) return st;
        uint32_t first = si->lod_count;
        if ((st = append_lods(si, c, &part, names[k], err))) return st;
        for (uint32_t i = first; i < si->lod_count; i++)
            c->info[i].trunk_error = metres_per_pixel(sc, d_after);
        if (k == 0 && si->lod_count > first) {
            c->required = (int)si->lod_count - 1;
            c->required_first = (int)first;
        }
        if (k == 1 && si->lod_count > first) {
            c->coarsest = (int)si->lod_count - 1;
            c->coarsest_first = (int)first;
        }
    }
    return SV_OK;
}

sv_status svp_chain_compose(run *r, sv_renderer *ren, const sv_gpu_mesh *gsrc, sv_stand_in *si,
                            chain *c, sv_error *err)
{
    const sv_spec *spec = &r->spec;
    const prepared *p = &r->p;
    sv_status st;
    c->skipped = cJSON_CreateArray();
    if (!c->skipped) return sv_fail(err, SV_ERR_NOMEM, "out of memory");
    /* the chain's stochastic levels are the levels of the method that says
     * so (sv_method chain_levels); its settings are the chain's */
    const sv_method *levels = sv_method_chain_levels(), *m = sv_method_find(spec->method);
    if (!levels) return sv_fail(err, SV_ERR_INTERNAL, "no method makes the chain's levels");
    bool is_stoch = m == levels;
    if ((st = sv_stochastic_parse(cJSON_GetObjectItemCaseSensitive(spec->root, levels->name),
                                  &c->ss, err)) ||
        (st = sv_stochastic_resolve(&c->ss, p->mesh->triangle_count, err)))
        return st;
    sv_method_input in = {
        p->mesh,   &p->cls,      &p->leaves, {p->centre[0], p->centre[1], p->centre[2]},
        p->radius, &spec->scene, spec->seed};
    snprintf(si->method, sizeof si->method, "%s", spec->method);
    if ((is_stoch || spec->lod_chain) &&
        (st = compose_stochastic(r, ren, gsrc, &in, is_stoch, si, c, err)))
        return st;
    return compose_methods(r, &in, is_stoch, si, c, err);
}

/* Switch sizes from measured error. Each LOD's own limit is the
 * largest screen size S (pixels: sv_eval_max_pixels_scaled) at which its mean
 * coverage error is within lod.tolerance × lod.tolerance_pixels / S (issue
 * 19: one tolerance at every size dropped every quad level of most trees), at
 * most the largest measured size for a quad LOD, 0 when it fails everywhere. The full mesh is the original: it is good at any size (its
 * limit is the tree's size at the nearest scene distance). A stochastic level
 * that passes at every measured size is limited by Cook's schedule instead
 * (the size at the nearest distance where λ(d) <= its λ), since nothing was
 * measured above. Without evaluation only the schedule is known: quad LODs
 * get 0 and the limits are made non-increasing along the chain. */
void svp_plan_switches(const run *r, const chain *c, lod_out *lods, uint32_t n, double tree_h)
{
    const sv_spec *s = &r->spec;
    double prev = INFINITY;
    double pnear = sv_scene_pixels(&s->scene, tree_h, s->scene.distance_min);
    for (uint32_t i = 0; i < n; i++) {
        lod_out *l = &lods[i];
        const chain_lod *x = &c->info[i];
        double best = 0;
        l->meets_tolerance = false;
        if (x->scheduled && !l->evaluated)
            best = x->distance > 0 ? sv_scene_pixels(&s->scene, tree_h, x->distance) : INFINITY;
        if (l->evaluated) {
            double top = l->eval.sizes[0].pixels;
            best = sv_eval_max_pixels_scaled(&l->eval, s->lod_tolerance, s->lod_tolerance_pixels);
            l->meets_tolerance = best > 0;
            if (x->scheduled && best >= top) {
                double sched = x->distance > 0 ? sv_scene_pixels(&s->scene, tree_h, x->distance)
                                               : INFINITY;
                best = sched > top ? sched : top;
            } else if (best > top) {
                best = top; /* nothing was measured above */
            }
        }
        if (x->scheduled && x->lambda >= 1) {
            best = INFINITY;
            l->meets_tolerance = true;
        }
        /* drawn up to the nearest distance at least (finite for JSON) */
        if (isinf(best)) best = fmax(pnear, l->evaluated ? l->eval.sizes[0].pixels : 0);
        l->own_pixels = best;
        if (!l->evaluated && best > prev) best = prev;
        l->switch_pixels = best;
        prev = best;
    }
    for (uint32_t i = 0; i < n; i++) {
        double next = (i + 1 < n) ? lods[i + 1].switch_pixels : 0;
        double cov = next / (double)s->scene.screen_height;
        lods[i].coverage = cov > 1 ? 1 : cov;
    }
}

static void note_lod(cJSON *note, const lod_out *l)
{
    cJSON_AddNumberToObject(note, "triangles", l->baked.mesh->triangle_count);
    cJSON_AddNumberToObject(note, "own_limit_pixels", l->own_pixels);
    if (l->evaluated) cJSON_AddItemToObject(note, "accuracy", svp_accuracy_json(&l->eval));
}

/* Chooses the LODs drawn (after evaluation) by cost: at every screen size
 * the cheapest level good enough there (lod_plan.h, docs/lod.md "Which level
 * is drawn"). The original is always LOD0. Levels never drawn in the scene's
 * [pixels at distance_max, pixels at distance_min] are dropped with a note;
 * the last kept level is drawn down to 0 px. */
static void plan_by_cost(const run *r, chain *c, lod_out *lods, const sv_stand_in *si,
                         double tree_h, bool *drop)
{
    const sv_spec *s = &r->spec;
    const sv_scene *sc = &s->scene;
    uint32_t n = si->lod_count;
    sv_plan_level *lv = sv_calloc(n ? n : 1, sizeof *lv);
    sv_plan_out *out = sv_calloc(n ? n : 1, sizeof *out);
    if (!lv || !out) { /* out of memory: keep everything as planned */
        free(lv);
        free(out);
        return;
    }
    for (uint32_t i = 0; i < n; i++) {
        const lod_out *l = &lods[i];
        const chain_lod *x = &c->info[i];
        bool exact = i == 0 || (x->scheduled && x->lambda >= 1);
        lv[i].triangles = l->baked.mesh ? l->baked.mesh->triangle_count : 0;
        lv[i].texels = (double)l->baked.albedo.width * l->baked.albedo.height;
        lv[i].own_pixels = l->own_pixels;
        lv[i].eval = l->evaluated && !exact ? &l->eval : NULL;
        lv[i].top_pixels = lv[i].eval ? l->eval.sizes[0].pixels : INFINITY;
    }
    sv_plan_rules ru = {s->lod_tolerance,
                        s->lod_tolerance_pixels,
                        s->lod_slack,
                        s->lod_cost_ratio,
                        s->lod_triangles_per_pixel,
                        sv_scene_pixels(sc, tree_h, sc->distance_max),
                        sv_scene_pixels(sc, tree_h, sc->distance_min)};
    sv_lod_plan_choose(lv, n, &ru, out);
    for (uint32_t i = 0; i < n; i++) {
        drop[i] = !out[i].kept;
        if (out[i].kept) {
            lods[i].switch_pixels = out[i].switch_pixels;
            continue;
        }
        const char *nm = si->lods[i].name;
        cJSON *why = NULL;
        switch (out[i].why) {
        case SV_PLAN_FAILS:
            why = skip_note(c, nm, "switch", "fails the tolerance (%g at %g px) at every size",
                            s->lod_tolerance, s->lod_tolerance_pixels);
            break;
        case SV_PLAN_CHEAPER:
            why = skip_note(c, nm, "switch",
                            "never drawn: wherever it meets the tolerance (%g at %g px; here up "
                            "to %.4g px) a cheaper level does too",
                            s->lod_tolerance, s->lod_tolerance_pixels, lods[i].own_pixels);
            break;
        case SV_PLAN_WORTH:
            why = skip_note(c, nm, "switch",
                            "never drawn: a level %g times cheaper is within %g of the tolerance "
                            "where this one would be drawn",
                            s->lod_cost_ratio, s->lod_slack);
            break;
        case SV_PLAN_DENSE:
            why = skip_note(c, nm, "switch",
                            "never drawn: where it meets the tolerance (up to %.4g px) it has more "
                            "than %g triangles per pixel of the tree's square",
                            lods[i].own_pixels, s->lod_triangles_per_pixel);
            break;
        case SV_PLAN_OUT_OF_SCENE:
            why = skip_note(c, nm, "switch",
                            "never drawn in the scene: chosen only above %.4g px, but at the "
                            "nearest distance (%g m) the tree is %.4g px",
                            ru.pixels_max, sc->distance_min, ru.pixels_max);
            break;
        default:
            why = skip_note(c, nm, "switch",
                            "never drawn: a later level of the chain is already drawn at larger "
                            "sizes than where this one is good");
        }
        note_lod(why, &lods[i]);
    }
    free(lv);
    free(out);
}

/* A method the spec names (its method, and lod.coarsest) always yields a
 * LOD, at the far end of the chain when the plan left nothing of it and
 * nothing after it: its most accurate one (mean IoU at the smallest
 * measured size; a coarser one only when it is as good), not blindly its
 * coarsest, which may be dominated. Its skip note is withdrawn. The
 * method's LODs are [first, last] of si. */
static void keep_required(chain *c, lod_out *lods, const sv_stand_in *si, bool *drop, int first,
                          int last)
{
    uint32_t n = si->lod_count;
    int q = last;
    if (q >= 0 && (uint32_t)q < n && drop[q]) {
        bool any_kept = false;
        for (int j = first; j <= q; j++) any_kept = any_kept || !drop[j];
        double best = -1;
        for (int j = first; j <= q && !any_kept; j++) {
            const lod_out *l = &lods[j];
            double iou = l->evaluated ? l->eval.sizes[l->eval.size_count - 1].mean.iou : 0;
            if (iou > best + 1e-9) best = iou, q = j;
        }
    }
    if (!(q >= 0 && (uint32_t)q < n && drop[q])) return;
    bool after = false, before = false;
    double prev = INFINITY;
    for (uint32_t j = (uint32_t)q + 1; j < n; j++) after = after || !drop[j];
    for (int j = 0; j < q; j++)
        if (!drop[j]) {
            before = true;
            prev = lods[j].switch_pixels;
        }
    if (after) return;
    drop[q] = false;
    const lod_out *l = &lods[q];
    double smallest = l->evaluated ? l->eval.sizes[l->eval.size_count - 1].pixels : 0;
    lods[q].switch_pixels = before ? fmin(smallest, 0.5 * prev) : lods[q].own_pixels;
    cJSON *it;
    int k = 0;
    cJSON_ArrayForEach(it, c->skipped)
    {
        const cJSON *nm = cJSON_GetObjectItemCaseSensitive(it, "name");
        if (cJSON_IsString(nm) && strcmp(nm->valuestring, si->lods[q].name) == 0) {
            cJSON_DeleteItemFromArray(c->skipped, k);
            break;
        }
        k++;
    }
}

void svp_plan_visibility(const run *r, chain *c, lod_out *lods, const sv_stand_in *si,
                         double tree_h, bool *drop)
{
    plan_by_cost(r, c, lods, si, tree_h, drop);
    keep_required(c, lods, si, drop, c->required_first, c->required);
    keep_required(c, lods, si, drop, c->coarsest_first, c->coarsest);
}

/* Removes the dropped LODs from si, lods and c->info (order kept). */
void svp_compact_lods(sv_stand_in *si, lod_out *lods, chain *c, const bool *drop)
{
    sv_stand_in gone = {0};
    uint32_t w = 0;
    for (uint32_t i = 0; i < si->lod_count; i++) {
        if (drop[i]) {
            sv_lod_plan *g = sv_stand_in_add_lod(&gone, NULL);
            if (g) *g = si->lods[i]; /* (out of memory: the plan leaks, nothing worse) */
            sv_gpu_mesh_free(lods[i].gpu);
            sv_eval_result_free(&lods[i].eval);
            sv_eval_result_free(&lods[i].bound);
            sv_baked_lod_free(&lods[i].baked);
            continue;
        }
        si->lods[w] = si->lods[i];
        lods[w] = lods[i];
        c->info[w] = c->info[i];
        w++;
    }
    si->lod_count = w;
    sv_stand_in_free(&gone);
}
