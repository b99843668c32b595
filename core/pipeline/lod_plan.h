/* lod_plan.h — which measured LODs a chain keeps, and the screen sizes at
 * which each is drawn (docs/lod.md "Which level is drawn").
 *
 * Pure: no GL, no files. The input is each level's cost and its measured
 * coverage error against the original at the evaluator's screen sizes
 * (evaluate.h); the output is the kept levels and their switch sizes.
 *
 * The rule, at every screen size S (pixels: the tree's framing sphere S px
 * tall), walking from the largest size down:
 *   1. Allowed: a level of t triangles is drawn only where t <= k·S², k =
 *      rules.triangles_per_pixel (more triangles than that per pixel of the
 *      tree's square are lost to sub-pixel slivers); the last level is
 *      always allowed.
 *   2. Drawn: the cheapest allowed level (fewest triangles, then fewest
 *      texels, then the later in the chain) whose error at S is within the
 *      tolerance T(S) = tolerance · tolerance_pixels / S (its own limit,
 *      `own_pixels`, is >= S); when none is, the most accurate allowed one.
 *      A switch saves: while the level drawn at the sizes above S is within
 *      the tolerance and allowed at S, another replaces it only when it has
 *      at most (1 - min_saving) of its triangles (a switch is a visible pop
 *      and one more asset to hold; a level a tenth cheaper is worth
 *      neither).
 *   3. Worth its cost: while an allowed level at least `cost_ratio` times
 *      cheaper has an error at S within `slack` of max(T(S), the drawn
 *      level's error), that level is drawn instead.
 *   4. Order: the chain is drawn in order (MSFT_lod), so once a level is
 *      drawn at S, no level before it in the chain is drawn at a smaller S.
 * A band is never handed to a dearer level because it is thin.
 */
#ifndef SV_LOD_PLAN_H
#define SV_LOD_PLAN_H

#include <stdbool.h>
#include <stdint.h>

#include "evaluate.h"

/* sv_lod_plan_choose plans at most this many levels (the rest are dropped). */
#define SV_PLAN_MAX_LEVELS 64

typedef struct sv_plan_level {
    /* input */
    double triangles;           /* cost, first */
    double texels;              /* cost, then */
    double own_pixels;          /* largest size at which it meets the tolerance (0: nowhere) */
    double top_pixels;          /* its measured error holds up to here (INFINITY: any size) */
    const sv_eval_result *eval; /* measured error; NULL: draws as the original (error 0) */
} sv_plan_level;

typedef struct sv_plan_rules {
    double tolerance;           /* max 1 - IoU at tolerance_pixels */
    double tolerance_pixels;    /* the tolerance scales as 1/S; 0: the same at every size */
    double slack;               /* rule 3's error slack (default 0.02) */
    double cost_ratio;          /* rule 3's cost ratio (default 10; 0: rule 3 off) */
    double triangles_per_pixel; /* rule 1's k (default 2; 0: no cap) */
    double pixels_min;          /* the tree's size at the scene's farthest distance */
    double pixels_max;          /* ... and at its nearest */
    double min_saving;          /* rule 2's switch saving (default 0.25; 0: off) */
} sv_plan_rules;

/* Why a level is not kept (sv_plan_out.why). */
enum {
    SV_PLAN_KEPT = 0,
    SV_PLAN_FAILS,       /* within the tolerance at no size */
    SV_PLAN_CHEAPER,     /* wherever it meets the tolerance, a cheaper level does too */
    SV_PLAN_WORTH,       /* rule 3: a far cheaper level within the slack */
    SV_PLAN_DENSE,       /* rule 1: too many triangles where it would be drawn */
    SV_PLAN_ORDER,       /* a later level is already drawn at larger sizes */
    SV_PLAN_OUT_OF_SCENE, /* drawn only above the scene's nearest size */
    SV_PLAN_SAVES_LITTLE  /* rule 2: saves too little on the level drawn before it */
};

typedef struct sv_plan_out {
    bool kept;
    int why;              /* SV_PLAN_*: the first reason met, for a dropped level */
    double switch_pixels; /* kept: the largest size at which it is drawn */
    double drawn_min;     /* kept: the smallest (0 for the last kept level) */
} sv_plan_out;

/* The rule above on levels lv[0..n) in chain order (lv[0] the original: it
 * is always kept, switching at its own_pixels). Fills out[0..n). The sizes
 * swept run from max(pixels_max, lv[0].own_pixels) down to pixels_min. */
void sv_lod_plan_choose(const sv_plan_level *lv, uint32_t n, const sv_plan_rules *rules,
                        sv_plan_out *out);

/* The level drawn at size S when levels before `from` can no longer be
 * (rules 1–3 on lv[from..n)); *why_not[i], when why_not is not NULL, gets a
 * reason for each level it passed over. */
uint32_t sv_lod_plan_drawn_at(const sv_plan_level *lv, uint32_t n, const sv_plan_rules *rules,
                              double S, uint32_t from, int *why_not);

/* The error (1 - mean IoU) a level measures at size S (0 without measures). */
double sv_plan_level_error(const sv_plan_level *l, double S);

#endif
