/* lod_plan.c — the kept LODs and their switch sizes, chosen by cost
 * (lod_plan.h has the rule; docs/lod.md "Which level is drawn").
 *
 * The switch sizes follow from measured error, as in Fichtner's chain
 * (LOD i drawn where it is within the tolerance) and Cook et al. 2007 §5
 * (a level is used from the distance where its error becomes invisible);
 * what level is drawn at a size is the cheapest one that is good enough
 * there, so no band is ever drawn by a dearer level than needed.
 */
#include <math.h>
#include <string.h>

#include "lod_plan.h"

/* Sizes are swept in steps of 1/64 of an octave, each switch then bisected. */
#define PLAN_STEPS_PER_OCTAVE 64.0
#define PLAN_BISECT 40

double sv_plan_level_error(const sv_plan_level *l, double S)
{
    if (!l->eval) return S <= l->own_pixels ? 0.0 : 1.0;
    return sv_eval_error_at(l->eval, S);
}

static double tolerance_at(const sv_plan_rules *ru, double S)
{
    return ru->tolerance_pixels > 0 ? ru->tolerance * ru->tolerance_pixels / S : ru->tolerance;
}

/* a is cheaper than b: fewer triangles, then fewer texels, then later. */
static bool cheaper(const sv_plan_level *lv, uint32_t a, uint32_t b)
{
    if (lv[a].triangles != lv[b].triangles) return lv[a].triangles < lv[b].triangles;
    if (lv[a].texels != lv[b].texels) return lv[a].texels < lv[b].texels;
    return a > b;
}

static bool allowed(const sv_plan_level *lv, uint32_t n, const sv_plan_rules *ru, uint32_t i,
                    double S)
{
    return i + 1 == n || !(ru->triangles_per_pixel > 0) ||
           lv[i].triangles <= ru->triangles_per_pixel * S * S;
}

static void note(int *why_not, uint32_t i, int why)
{
    if (why_not && !why_not[i]) why_not[i] = why;
}

uint32_t sv_lod_plan_drawn_at(const sv_plan_level *lv, uint32_t n, const sv_plan_rules *ru,
                              double S, uint32_t from, int *why_not)
{
    if (from >= n) return n ? n - 1 : 0;
    double T = tolerance_at(ru, S);
    int64_t a = -1;
    for (uint32_t i = from; i < n; i++) {
        if (!(S <= lv[i].own_pixels)) continue;
        if (!allowed(lv, n, ru, i, S)) {
            note(why_not, i, SV_PLAN_DENSE);
            continue;
        }
        if (a < 0 || cheaper(lv, i, (uint32_t)a)) a = i;
    }
    if (a < 0) { /* none within the tolerance: the most accurate allowed */
        double best = INFINITY;
        for (uint32_t i = from; i < n; i++) {
            if (!allowed(lv, n, ru, i, S)) continue;
            double e = sv_plan_level_error(&lv[i], S);
            if (e < best || (e == best && a >= 0 && cheaper(lv, i, (uint32_t)a))) best = e, a = i;
        }
    }
    if (a < 0) a = n - 1; /* cannot happen: the last is always allowed */
    /* rule 2's switch saving: while `from` (the level drawn at the larger
     * sizes) is within the tolerance and allowed, a level replaces it only
     * with at most (1 - min_saving) of its triangles */
    if ((uint32_t)a != from && ru->min_saving > 0 && S <= lv[from].own_pixels &&
        allowed(lv, n, ru, from, S)) {
        double most = (1 - ru->min_saving) * lv[from].triangles;
        if (!(lv[a].triangles <= most)) {
            for (uint32_t i = from + 1; i < n; i++)
                if (S <= lv[i].own_pixels && allowed(lv, n, ru, i, S) && !(lv[i].triangles <= most))
                    note(why_not, i, SV_PLAN_SAVES_LITTLE);
            a = from;
        }
    }
    for (uint32_t i = from; i < n; i++)
        if (i != (uint32_t)a && S <= lv[i].own_pixels && allowed(lv, n, ru, i, S))
            note(why_not, i, SV_PLAN_CHEAPER);
    /* rule 3: a level cost_ratio times cheaper within the slack */
    for (;;) {
        if (!(ru->cost_ratio > 0)) break;
        double ea = sv_plan_level_error(&lv[a], S);
        double bound = (ea > T ? ea : T) + ru->slack;
        int64_t b = -1;
        for (uint32_t j = from; j < n; j++) {
            if (j == (uint32_t)a || !allowed(lv, n, ru, j, S)) continue;
            if (!(lv[j].triangles * ru->cost_ratio < lv[a].triangles)) continue;
            if (!(S <= lv[j].top_pixels || S <= lv[j].own_pixels)) continue;
            if (sv_plan_level_error(&lv[j], S) > bound) continue;
            if (b < 0 || cheaper(lv, j, (uint32_t)b)) b = j;
        }
        if (b < 0) break;
        note(why_not, (uint32_t)a, SV_PLAN_WORTH);
        a = b;
    }
    return (uint32_t)a;
}

/* The largest size in [lo, hi) at which the level drawn (from `from`) is no
 * longer `prev`: the switch between two grid sizes, by bisection in log2. */
static double bisect_switch(const sv_plan_level *lv, uint32_t n, const sv_plan_rules *ru,
                            uint32_t from, uint32_t prev, double lo, double hi)
{
    double a = log2(lo), b = log2(hi); /* drawn(lo) != prev, drawn(hi) == prev */
    for (int k = 0; k < PLAN_BISECT; k++) {
        double m = 0.5 * (a + b);
        if (sv_lod_plan_drawn_at(lv, n, ru, exp2(m), from, NULL) == prev) b = m;
        else a = m;
    }
    return exp2(a);
}

void sv_lod_plan_choose(const sv_plan_level *lv, uint32_t n, const sv_plan_rules *ru,
                        sv_plan_out *out)
{
    memset(out, 0, n * sizeof *out);
    if (n == 0) return;
    for (uint32_t i = SV_PLAN_MAX_LEVELS; i < n; i++) out[i].why = SV_PLAN_ORDER;
    if (n > SV_PLAN_MAX_LEVELS) n = SV_PLAN_MAX_LEVELS;
    int why_not[SV_PLAN_MAX_LEVELS] = {0};
    double top = lv[0].own_pixels;
    if (!isfinite(top) || top < ru->pixels_max) top = ru->pixels_max;
    double bottom = ru->pixels_min > 0 ? ru->pixels_min : 1.0;
    if (!(top > bottom)) top = bottom;
    double step = exp2(-1.0 / PLAN_STEPS_PER_OCTAVE);
    uint32_t from = 0, cur = sv_lod_plan_drawn_at(lv, n, ru, top, 0, why_not);
    /* first and last size each level is drawn at: [lo, hi] */
    double hi[SV_PLAN_MAX_LEVELS], lo[SV_PLAN_MAX_LEVELS];
    bool drawn[SV_PLAN_MAX_LEVELS] = {false};
    drawn[cur] = true;
    hi[cur] = top;
    lo[cur] = top;
    from = cur;
    for (double S = top * step, prevS = top;; prevS = S, S *= step) {
        bool last = S <= bottom;
        if (last) S = bottom;
        uint32_t d = sv_lod_plan_drawn_at(lv, n, ru, S, from, why_not);
        if (d != cur) {
            double sw = bisect_switch(lv, n, ru, from, cur, S, prevS);
            lo[cur] = sw;
            cur = d;
            from = d;
            drawn[d] = true;
            hi[d] = sw;
        }
        lo[cur] = S;
        if (last) break;
    }
    for (uint32_t i = 0; i < n; i++) {
        sv_plan_out *o = &out[i];
        bool in_scene = drawn[i] && lo[i] <= ru->pixels_max;
        if (i == 0 || in_scene) {
            o->kept = true;
            o->switch_pixels = i == 0 ? lv[0].own_pixels : fmin(hi[i], lv[0].own_pixels);
            o->drawn_min = drawn[i] ? lo[i] : o->switch_pixels;
            continue;
        }
        if (drawn[i]) o->why = SV_PLAN_OUT_OF_SCENE;
        else if (!(lv[i].own_pixels > 0)) o->why = SV_PLAN_FAILS;
        else if (why_not[i]) o->why = why_not[i];
        else o->why = SV_PLAN_ORDER;
    }
    /* the last kept level is drawn down to 0 px */
    for (uint32_t i = n; i-- > 0;)
        if (out[i].kept) {
            out[i].drawn_min = 0;
            break;
        }
}
