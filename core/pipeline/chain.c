/* chain.c — the LOD chain (issue 6; docs/lod.md): which levels are built
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

#include "method.h"
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
        if (r->p.leaves.count == 0 && !is_stoch)
            skip_note(c, name, "plan", "the tree has no leaves");
        else if (i < fine && !is_stoch)
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
        if (c->info[i].stochastic && isfinite(c->info[i].distance) && c->info[i].distance > d_after)
            d_after = c->info[i].distance;
    d_after = fmin(d_after, sc->distance_max);
    c->required = -1;
    c->required_first = 0;
    if (is_stoch) c->required = (int)si->lod_count - 1;
    for (int k = 0; k < 2; k++) {
        if (!names[k]) continue;
        const sv_method *m = sv_method_find(names[k]);
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

/* Switch sizes from measured error (issue 6). Each LOD's own limit is the
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
        if (x->stochastic && !l->evaluated)
            best = x->distance > 0 ? sv_scene_pixels(&s->scene, tree_h, x->distance) : INFINITY;
        if (l->evaluated) {
            double top = l->eval.sizes[0].pixels;
            best = sv_eval_max_pixels_scaled(&l->eval, s->lod_tolerance, s->lod_tolerance_pixels);
            l->meets_tolerance = best > 0;
            if (x->stochastic && best >= top) {
                double sched = x->distance > 0 ? sv_scene_pixels(&s->scene, tree_h, x->distance)
                                               : INFINITY;
                best = sched > top ? sched : top;
            } else if (best > top) {
                best = top; /* nothing was measured above */
            }
        }
        if (x->stochastic && x->lambda >= 1) {
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

/* Chooses the LODs drawn (after evaluation). At a screen size S the renderer
 * should draw the cheapest LOD — the latest in the chain — whose own limit is
 * >= S, so LOD i is drawn for S in (max over later LODs of their limits, its
 * own limit] and never when that interval is empty (a later, cheaper LOD is
 * good wherever it would be). Then LODs whose interval misses the scene's
 * [pixels at distance_max, pixels at distance_min] are dropped as well. The
 * last LOD left is drawn down to 0 px. */
#define SV_LOD_MIN_BAND 1.25

/* Dominated LODs: drop[i] when a later, cheaper LOD is good up to at least
 * its own limit. When that leaves nothing, the finest stays (the best there is). */
static void drop_dominated(const run *r, chain *c, lod_out *lods, const sv_stand_in *si, bool *drop)
{
    uint32_t n = si->lod_count;
    double later = 0;
    for (uint32_t i = n; i-- > 0;) {
        drop[i] = !(lods[i].own_pixels > later);
        if (drop[i]) {
            cJSON *note = lods[i].meets_tolerance
                              ? skip_note(
                                    c, si->lods[i].name, "switch",
                                    "never drawn: a cheaper LOD later in the chain meets the "
                                    "tolerance (%g at %g px) up to %.4g px, this one only up to "
                                    "%.4g px",
                                    r->spec.lod_tolerance, r->spec.lod_tolerance_pixels, later,
                                    lods[i].own_pixels)
                              : skip_note(c, si->lods[i].name, "switch",
                                          "fails the tolerance (%g at %g px) at every size",
                                          r->spec.lod_tolerance, r->spec.lod_tolerance_pixels);
            note_lod(note, &lods[i]);
        } else {
            later = lods[i].own_pixels;
        }
    }
    bool any = false;
    for (uint32_t i = 0; i < n; i++) any = any || !drop[i];
    if (!any && n > 0) { /* nothing meets the tolerance: the finest is the best there is */
        drop[0] = false;
        cJSON_DeleteItemFromArray(c->skipped, cJSON_GetArraySize(c->skipped) - 1);
    }
}

/* Thin bands: a LOD drawn over less than a factor SV_LOD_MIN_BAND of
 * screen sizes (its own limit over the next kept LOD's) costs a switch and
 * a set of buffers for almost nothing; the finer LOD before it takes its
 * band. Walked from the far end so the coarse LODs, which the far scene
 * needs, stay; the last LOD and the last kept LOD of the spec's method are
 * never dropped here. */
static void drop_thin_bands(chain *c, lod_out *lods, const sv_stand_in *si, bool *drop)
{
    uint32_t n = si->lod_count;
    double next_lim = -1;
    for (uint32_t i = n; i-- > 0;) {
        if (drop[i]) continue;
        if (next_lim < 0 || i == 0) {
            next_lim = lods[i].own_pixels;
            continue;
        }
        bool last_of_method = false;
        if (c->required >= 0 && (int)i >= c->required_first && (int)i <= c->required) {
            last_of_method = true;
            for (int j = c->required_first; j <= c->required; j++)
                if (j != (int)i && !drop[j]) last_of_method = false;
        }
        if (!last_of_method && lods[i].own_pixels < SV_LOD_MIN_BAND * next_lim) {
            drop[i] = true;
            note_lod(skip_note(c, si->lods[i].name, "switch",
                               "band too thin: drawn only from %.4g to %.4g px (less than a "
                               "factor %g); the finer LOD before it takes the band",
                               next_lim, lods[i].own_pixels, SV_LOD_MIN_BAND),
                     &lods[i]);
            continue;
        }
        next_lim = lods[i].own_pixels;
    }
}

/* The scene's range, on the LODs left: a LOD drawn only above the tree's
 * size at the nearest distance, or only below its size at the farthest
 * (but the first kept), is dropped. Then the kept LODs switch at their own
 * limits. */
static void drop_out_of_scene(const run *r, chain *c, lod_out *lods, const sv_stand_in *si,
                              double tree_h, bool *drop)
{
    const sv_scene *sc = &r->spec.scene;
    double pmin = sv_scene_pixels(sc, tree_h, sc->distance_max);
    double pmax = sv_scene_pixels(sc, tree_h, sc->distance_min);
    uint32_t n = si->lod_count;
    uint32_t kept = 0;
    for (uint32_t i = 0; i < n; i++) {
        if (drop[i]) continue;
        double hi = lods[i].own_pixels, lo = 0;
        for (uint32_t j = i + 1; j < n; j++)
            if (!drop[j]) {
                lo = lods[j].own_pixels;
                break;
            }
        cJSON *note = NULL;
        if (lo >= pmax)
            note = skip_note(c, si->lods[i].name, "switch",
                             "never drawn in the scene: used above %.4g px, but at the nearest "
                             "distance (%g m) the tree is %.4g px",
                             lo, sc->distance_min, pmax);
        else if (hi <= pmin && kept > 0)
            note = skip_note(c, si->lods[i].name, "switch",
                             "never drawn in the scene: used below %.4g px, but at the farthest "
                             "distance (%g m) the tree is %.4g px",
                             hi, sc->distance_max, pmin);
        if (note) {
            note_lod(note, &lods[i]);
            drop[i] = true;
        } else {
            kept++;
        }
    }
    for (uint32_t i = 0; i < n; i++)
        if (!drop[i]) lods[i].switch_pixels = lods[i].own_pixels;
}

/* The method the spec names always yields a LOD, at the far end of the
 * chain when the plan left nothing of it and nothing after it: its most
 * accurate one (mean IoU at the smallest measured size; a coarser one
 * only when it is as good), not blindly its coarsest, which may be
 * dominated (issue 19). Its skip note is withdrawn. */
static void keep_required(chain *c, lod_out *lods, const sv_stand_in *si, bool *drop)
{
    uint32_t n = si->lod_count;
    int q = c->required;
    if (q >= 0 && (uint32_t)q < n && drop[q]) {
        bool any_kept = false;
        for (int j = c->required_first; j <= q; j++) any_kept = any_kept || !drop[j];
        double best = -1;
        for (int j = c->required_first; j <= q && !any_kept; j++) {
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
    drop_dominated(r, c, lods, si, drop);
    drop_thin_bands(c, lods, si, drop);
    drop_out_of_scene(r, c, lods, si, tree_h, drop);
    keep_required(c, lods, si, drop);
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
