/* chain.c — the LOD chain (docs/lod.md): which levels are built
 * (svp_chain_compose: full mesh → the chain's own levels → the spec's method
 * → the coarsest method) and, once measured, where each is drawn
 * (svp_plan_switches, svp_plan_visibility, svp_compact_lods).
 *
 * The chain's own levels, placed by a schedule of distances, come from the
 * method whose schema says chain_levels (its sv_method_ops chain hook), with
 * the renderer lent as a cover and a score callback; it notes the levels the
 * scene's distance range does not need. After evaluation, LODs whose planned
 * screen-size interval misses the scene's range are dropped. Every skip is
 * noted in report.json with why.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "lod_plan.h"
#include "method_ops.h"
#include "trunk.h"
#include "pipeline_internal.h"

void svp_chain_free(chain *c)
{
    cJSON_Delete(c->levels_report);
    free(c->info);
    cJSON_Delete(c->skipped);
    memset(c, 0, sizeof *c);
}

/* World size of one pixel at distance d. */
static double metres_per_pixel(const sv_scene *sc, double d)
{
    double px = sv_scene_pixels(sc, 1.0, d);
    return px > 0 && isfinite(px) ? 1.0 / px : 0.0;
}

/* The chain's cover callback (sv_chain_cover_fn): triangles of the original
 * drawn alone from COVER_VIEWS views placed as the scene's viewer says,
 * covered pixels summed. */
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
    }
    sv_stand_in_free(src);
    return SV_OK;
}

/* The chain's own levels (the sv_method_ops chain hook of method m), built
 * by m with the renderer lent as callbacks (ren, gsrc: the original) and
 * appended to si finest first with their place in its schedule; its notes
 * of levels not built go to c->skipped, its report.json part to
 * c->levels_report. own: the spec's method is m. */
static sv_status compose_levels(run *r, sv_renderer *ren, const sv_gpu_mesh *gsrc,
                                const sv_method_input *in, const sv_method_ops *m, bool own,
                                sv_stand_in *si, chain *c, sv_error *err)
{
    cover_ctx cc = {ren, gsrc, &r->p, r->spec.scene.viewer};
    score_ctx sc = {r, ren, gsrc};
    sv_chain_in ci = {in,
                      cJSON_GetObjectItemCaseSensitive(r->spec.root, m->method->name),
                      own,
                      own || r->spec.lod_chain,
                      count_cover,
                      &cc,
                      COVER_VIEWS,
                      COVER_SIZE,
                      svp_chain_score,
                      &sc};
    sv_chain_out out = {0};
    sv_status st = m->chain(&ci, &out, err);
    cJSON *note;
    while (!st && out.skipped && (note = cJSON_DetachItemFromArray(out.skipped, 0)))
        cJSON_AddItemToArray(c->skipped, note);
    for (uint32_t k = 0; !st && k < out.levels.lod_count; k++) {
        sv_stand_in one = {0};
        sv_lod_plan *l = sv_stand_in_add_lod(&one, NULL);
        if (!l) {
            st = sv_fail(err, SV_ERR_NOMEM, "out of memory");
            break;
        }
        *l = out.levels.lods[k];
        memset(&out.levels.lods[k], 0, sizeof out.levels.lods[k]);
        if ((st = append_lods(si, c, &one, out.place[k].source, err))) break;
        chain_lod *x = &c->info[si->lod_count - 1];
        x->scheduled = true;
        x->lambda = out.place[k].lambda;
        x->distance = out.place[k].distance;
        x->trunk_error = out.place[k].trunk_error;
    }
    if (!st) {
        c->levels_report = out.report;
        c->levels_name = m->method->name;
        out.report = NULL;
    }
    sv_chain_out_free(&out);
    return st;
}

/* The quad methods after the chain's own levels: the spec's (its LODs are
 * the chain's required ones; none when own, the spec's method made the
 * chain's levels), then the coarsest. */
static sv_status compose_methods(const run *r, const sv_method_input *in, bool own, sv_stand_in *si,
                                 chain *c, sv_error *err)
{
    const sv_spec *spec = &r->spec;
    const sv_scene *sc = &spec->scene;
    const char *names[2] = {own ? NULL : spec->method, NULL};
    if (spec->lod_chain && spec->lod_coarsest[0] && strcmp(spec->lod_coarsest, spec->method) != 0)
        names[1] = spec->lod_coarsest;
    double d_after = sc->distance_min; /* quads come after the last scheduled level */
    for (uint32_t i = 0; i < si->lod_count; i++)
        if (c->info[i].scheduled && isfinite(c->info[i].distance) && c->info[i].distance > d_after)
            d_after = c->info[i].distance;
    d_after = fmin(d_after, sc->distance_max);
    c->required = c->coarsest = -1;
    c->required_first = c->coarsest_first = 0;
    if (own) c->required = (int)si->lod_count - 1;
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
    /* the chain's own levels are the levels of the method that says so
     * (sv_method chain_levels), built by its chain hook */
    const sv_method *levels = sv_method_chain_levels(), *m = sv_method_find(spec->method);
    const sv_method_ops *lo = levels ? sv_method_ops_find(levels->name) : NULL;
    if (!lo || !lo->chain)
        return sv_fail(err, SV_ERR_INTERNAL, "no method makes the chain's levels");
    bool own = m == levels;
    sv_method_input in = {
        p->mesh,   &p->cls,      &p->leaves, {p->centre[0], p->centre[1], p->centre[2]},
        p->radius, &spec->scene, spec->seed, r->memo};
    snprintf(si->method, sizeof si->method, "%s", spec->method);
    if ((st = compose_levels(r, ren, gsrc, &in, lo, own, si, c, err))) return st;
    return compose_methods(r, &in, own, si, c, err);
}

/* Switch sizes from measured error. Each LOD's own limit is the
 * largest screen size S (pixels: sv_eval_max_pixels_scaled) at which its mean
 * coverage error is within lod.tolerance × lod.tolerance_pixels / S (one
 * tolerance at every size dropped every quad level of most trees), at most
 * the largest measured size for a quad LOD, 0 when it fails everywhere. The
 * full mesh is the original: it is good at any size (its limit is the tree's size at the nearest scene distance). A scheduled level
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
                        sv_scene_pixels(sc, tree_h, sc->distance_min),
                        s->lod_min_saving};
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
            why = sv_chain_skip_note(c->skipped, nm, "switch",
                                     "fails the tolerance (%g at %g px) at every size",
                                     s->lod_tolerance, s->lod_tolerance_pixels);
            break;
        case SV_PLAN_CHEAPER:
            why = sv_chain_skip_note(
                c->skipped, nm, "switch",
                "never drawn: wherever it meets the tolerance (%g at %g px; here up "
                "to %.4g px) a cheaper level does too",
                s->lod_tolerance, s->lod_tolerance_pixels, lods[i].own_pixels);
            break;
        case SV_PLAN_WORTH:
            why = sv_chain_skip_note(
                c->skipped, nm, "switch",
                "never drawn: a level %g times cheaper is within %g of the tolerance "
                "where this one would be drawn",
                s->lod_cost_ratio, s->lod_slack);
            break;
        case SV_PLAN_DENSE:
            why = sv_chain_skip_note(
                c->skipped, nm, "switch",
                "never drawn: where it meets the tolerance (up to %.4g px) it has more "
                "than %g triangles per pixel of the tree's square",
                lods[i].own_pixels, s->lod_triangles_per_pixel);
            break;
        case SV_PLAN_SAVES_LITTLE:
            why = sv_chain_skip_note(
                c->skipped, nm, "switch",
                "never drawn: where it meets the tolerance, the level drawn before it does "
                "too and this one saves less than %g of its triangles (lod.min_saving)",
                s->lod_min_saving);
            break;
        case SV_PLAN_OUT_OF_SCENE:
            why = sv_chain_skip_note(
                c->skipped, nm, "switch",
                "never drawn in the scene: chosen only above %.4g px, but at the "
                "nearest distance (%g m) the tree is %.4g px",
                ru.pixels_max, sc->distance_min, ru.pixels_max);
            break;
        default:
            why = sv_chain_skip_note(
                c->skipped, nm, "switch",
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
