/* stochastic.h — stochastic simplification of the foliage (spec method
 * "stochastic"), after Cook, Halstead, Planck, Ryu, "Stochastic simplification
 * of aggregate detail" (SIGGRAPH 2007) as presented by Fichtner, "GPU Based
 * Stochastic Foliage Simplification" (papers/stochastic-foliage-simplification.txt).
 *
 * A level λ ∈ (0, 1] draws the first ⌈λN⌉ of the N leaves in a fixed order
 * (§3.2), each scaled about its centre by √s (§3.3, §4.3.1) and colour-adjusted
 * towards the mean leaf colour (§3.4). The order is a seeded random permutation
 * (optionally weighted by leaf area, see sv_stochastic_order), so any prefix is
 * a random sample of the leaves. docs/methods/stochastic.md describes the
 * settings and the outputs.
 *
 * The pure formulas are exposed for tests. Nothing here needs GL: the visible
 * area ratio r is measured through a caller-supplied coverage function (the
 * pipeline renders with render.h; see sv_stochastic_measure_ratio).
 */
#ifndef SV_STOCHASTIC_H
#define SV_STOCHASTIC_H

#include <cjson/cJSON.h>

#include "method_ops.h"

#define SV_STOCH_MAX_LEVELS 8

/* ---- pure formulas -------------------------------------------------------- */

/* §3.1 eq. 1: the image-area fraction b = d0²/d² (1 when d <= d0 or d <= 0). */
double sv_stochastic_b(double d0, double d);

/* §3.1 eq. 2: λ = b^log_h(1/2), clamped to [0, 1]; b >= 1 gives 1, b <= 0 gives
 * 0. h ∈ (0, 1) is the value of b at which half of the leaves are drawn
 * (h = 1/2: λ = b). */
double sv_stochastic_lambda(double b, double h);

/* The motion term (Cook et al. 2007 reduce detail where motion blur hides it;
 * Fichtner §3.1 leaves it out). Our form: a blur of m pixels smears a feature
 * over 1 + m pixels along the motion, so the effective image area shrinks by
 * b_motion = 1/(1 + m), multiplied into b before eq. 2. Returns 1 for m <= 0. */
double sv_stochastic_motion_b(double blur_pixels);

/* §3.3 eq. 3: area scale s = (1 − (1 − r)^{1/λ}) / r, computed as
 * −expm1(log1p(−r)/λ)/r so it is exact for tiny r. Limits: λ >= 1 → 1;
 * r <= 0 → 1/λ (no overlap); r >= 1 → 1; λ → 0 → 1/r. Always finite and in
 * [1, min(1/λ, 1/r)] (λ is floored at 1e-9). */
double sv_stochastic_area_scale(double r, double lambda);

/* §3.4 eq. 4 with α = √λ: c' = c̄ + √λ (c − c̄) (λ clamped to [0, 1]). */
double sv_stochastic_contrast(double c, double mean, double lambda);

/* §3.5/§4.3.3 fade window in order position (fraction of N): leaves whose
 * position lies in [lo, hi] fade, with radius R = min(1 − λ, radius) (the
 * paper's choice, so λ = 1 shows every leaf fully): lo = max(0, λ − R),
 * hi = min(1, λ + R). */
void sv_stochastic_fade(double lambda, double radius, double *lo, double *hi);

/* Importance used to order leaves (§3.2). */
typedef enum sv_stoch_order_mode {
    SV_STOCH_ORDER_RANDOM = 0, /* uniform seeded permutation (Fisher–Yates, splitmix64) */
    SV_STOCH_ORDER_AREA        /* weighted random permutation (Efraimidis–Spirakis keys
                                  u^(1/w)), w = leaf area: a leaf twice as large is twice
                                  as likely to come first; still random, so any prefix is a
                                  sample, but prefixes favour the leaves that cover more */
} sv_stoch_order_mode;

/* order[0..leaves->count) receives a permutation of the leaf indices. Same
 * seed, same order. */
sv_status sv_stochastic_order(const sv_leaves *leaves, uint64_t seed, sv_stoch_order_mode mode,
                              uint32_t *order, sv_error *err);

/* Number of leaves drawn at λ: ⌈λN⌉ (at least 1 when N > 0, at most N). */
uint32_t sv_stochastic_count(double lambda, uint32_t n);

/* The r of eq. 3 from two coverage measurements (the paper's §6 suggestion:
 * count covered pixels offscreen). With Cook's model — leaves placed at random
 * over the tree's image, each covering a fraction r of it — n leaves cover
 * A·(1 − (1 − r)^n). Given the covered area of the first `n_sub` leaves and of
 * all `n` leaves, q = covered_sub / covered_all = (1 − (1 − r)^n_sub) /
 * (1 − (1 − r)^n), which increases monotonically from n_sub/n (r → 0) to 1
 * (r → 1); solved for r by bisection on log r. Returns 0 for q <= n_sub/n
 * and 1 for q >= 1; 0 for invalid counts. */
double sv_stochastic_ratio_from_coverage(double q, uint32_t n_sub, uint32_t n);

/* ---- measuring r ---------------------------------------------------------- */

/* Covered area (e.g. pixels summed over several views) when triangles
 * tris[0..count) of the source mesh are drawn alone (in the chain: the
 * pipeline's cover callback, method_ops.h). */
typedef sv_chain_cover_fn sv_coverage_fn;

typedef struct sv_stoch_ratio {
    double r;           /* the measured ratio */
    double covered_all; /* coverage of every leaf */
    double covered_sub; /* coverage of the first n_sub leaves of the order */
    uint32_t n_sub, n;
} sv_stoch_ratio;

/* Measures r for the tree: draws all leaves and the prefix of `order` holding
 * a fraction `fraction` (default 0.1 when <= 0) of them, through fn, and solves
 * with sv_stochastic_ratio_from_coverage. SV_ERR_UNBAKEABLE when the tree has
 * no leaves or nothing is covered. */
sv_status sv_stochastic_measure_ratio(const sv_leaves *leaves, const uint32_t *order,
                                      double fraction, sv_coverage_fn fn, void *user,
                                      sv_stoch_ratio *out, sv_error *err);

/* ---- settings and the levels ---------------------------------------------- */

typedef struct sv_stochastic_settings {
    double levels[SV_STOCH_MAX_LEVELS]; /* "levels": λ values, strictly decreasing in (0, 1];
                                           default 1, 0.5, 0.25, 0.1 (1 = the full reordered mesh);
                                           0 until resolved for a level given by triangles */
    uint32_t level_triangles[SV_STOCH_MAX_LEVELS]; /* {"triangles": N} entries (0 = given as λ):
                                           the level draws at most N triangles, trunk included */
    uint32_t level_count;
    double h;  /* "h": in (0, 1), default 0.5 */
    double d0; /* "d0": metres where simplification starts; 0 = scene.distance_min */
    sv_stoch_order_mode order;  /* "order": "random" (default) | "area" */
    double fade;                /* "fade": fade radius, [0, 0.5], default 0.1 (Cook) */
    bool area_preservation;     /* "area_preservation": default true */
    bool contrast_preservation; /* "contrast_preservation": default true */
    double shutter;        /* "shutter": seconds of exposure for the motion term, default 1/60 */
    double ratio_fraction; /* "ratio_fraction": leaf fraction drawn to measure r, default 0.1 */
    bool simplify_leaves;  /* "simplify_leaves": default true: below λ = 1 a leaf modelled
                                  with several triangles is simplified to the level's error
                                  (sv_stochastic_level_error) before leaves are dropped */
    double visible_ratio;  /* "visible_ratio": r given by the user, in (0, 1]; 0 (default) =
                                  the pipeline measures it by rendering. The method's run()
                                  (without a renderer) needs it given. */
} sv_stochastic_settings;

/* Parses the spec's "stochastic" object (NULL = defaults) strictly. A level
 * is a number λ in (0, 1] or {"triangles": N}; the latter is resolved by
 * sv_stochastic_resolve once the tree is known. */
sv_status sv_stochastic_parse(const cJSON *settings, sv_stochastic_settings *out, sv_error *err);

/* Turns every {"triangles": N} level into λ = min(1, N / triangles) (the
 * tree's triangle count) and checks that all levels are strictly decreasing
 * (SV_ERR_SPEC naming the level and the tree's count otherwise). */
sv_status sv_stochastic_resolve(sv_stochastic_settings *s, uint32_t triangles, sv_error *err);

/* λ at distance d in `scene`: eq. 1 and 2, with b multiplied by the motion
 * term when scene->camera_speed > 0 (blur = camera_speed × shutter × pixels
 * per metre at d, the camera moving across the view). d0 = 0 in s means
 * scene->distance_min. */
double sv_stochastic_lambda_at(const sv_stochastic_settings *s, const sv_scene *scene, double d);

/* The nearest distance at which λ(d) <= lambda (bisection; λ(d) decreases
 * with d). Returns 0 for lambda >= 1 and INFINITY when never reached below 1e7 m. */
double sv_stochastic_distance_for_lambda(const sv_stochastic_settings *s, const sv_scene *scene,
                                         double lambda);

/* The height in pixels above which a tree needs its full mesh: a tree drawn
 * taller than this at d0 is treated as if drawn this tall there. */
#define SV_STOCH_FULL_PIXELS 512.0

/* The smallest fraction of its triangles a level's trunk is simplified
 * towards (the error bound usually stops it first). */
#define SV_STOCH_TRUNK_FLOOR 0.05

/* A leaf element simplified to a level's error is drawn simplified only while
 * its coverage (area times opacity, scaled by its area gain) stays at least
 * this fraction of its modelled coverage; below, it is drawn whole (as
 * modelled) or not at all, and the budget drops more leaves instead. */
#define SV_STOCH_MIN_COVER 0.5

/* A min_cover no simplified leaf reaches: every leaf drawn whole. */
#define SV_STOCH_WHOLE 1e9

/* The geometric error a level may have, in metres: one pixel at the nearest
 * distance d it is drawn by Cook's schedule (sv_stochastic_distance_for_lambda,
 * clamped to the scene's distance range), or, when larger, one pixel of the
 * tree (bounding diameter 2·radius) drawn SV_STOCH_FULL_PIXELS × d0/d tall
 * (a tree too large for the scene's d0 is not kept finer than one of 512 px);
 * 0 for λ >= 1 (the full mesh) or when the scene gives no pixel size. */
double sv_stochastic_level_error(const sv_stochastic_settings *s, const sv_scene *scene,
                                 double radius, double lambda);

typedef struct sv_stoch_level {
    double lambda;                /* the level: its foliage triangles are about λ of the tree's */
    double leaf_fraction;         /* μ = leaves / N: λ, or more when simplified leaves fit more */
    double leaf_error;            /* metres each kept leaf's outline may move (0 = as modelled) */
    uint64_t leaf_triangles;      /* foliage triangles drawn */
    double area_scale;            /* s(r, μ) (1 when area preservation is off) */
    double area_gamma;            /* leaves scaled by (s × gain)^(γ/2): 1 (the paper) unless the
                                  scorer found 0.85 or 0.7 closer to the original */
    double contrast_alpha;        /* √μ (1 when contrast preservation is off) */
    uint32_t leaves;              /* ⌈μN⌉ */
    double fade_lo, fade_hi;      /* sv_stochastic_fade at μ */
    sv_mesh *geometry;            /* the drawn leaves (owned until moved out) */
    float *leaf_centre;           /* 3 per geometry vertex: its leaf's centre */
    float *leaf_order;            /* 1 per geometry vertex: (order position + 0.5) / N */
    bool trunk_in_geometry;       /* the trunk was built first and leads the geometry */
    double trunk_error;           /* when trunk_in_geometry: the bound its trunk was built to (m) */
    uint32_t trunk_vertices;      /* when trunk_in_geometry: the geometry's first vertices */
    uint32_t trunk_triangles;     /* when trunk_in_geometry: the geometry's first triangles */
    uint32_t contrast_materials;  /* material copies added for contrast bins */
    uint32_t contrast_capped;     /* leaves whose brightening was capped (factor 1 on an
                                    untextured material, 4 on a brightened texture) */
    uint32_t brightened_textures; /* images added: a texture brightened for leaves whose
                                     factor would pass 1 */
    double colour_gain;           /* mean luminance factor restoring simplified leaves'
                                    modelled colour (1: none simplified) */
    uint32_t leaves_simplified;   /* drawn leaves with a simplified shape */
    uint32_t leaves_whole;        /* drawn leaves kept as modelled because their simplified
                                    shape lost coverage (below min_cover) */
    double min_cover;             /* the coverage ratio a simplified leaf needed (>= 1e9: every
                                    leaf whole, the paper's rule) */
    double leaf_cover_min;        /* the least coverage ratio among drawn simplified leaves
                                    (1 when none) */
    bool spread;                  /* every leaf kept, the foliage simplified as one mesh
                                    to the level's budget whatever the error (the
                                    candidate for trees of few large elements) */
    double score;                 /* the scorer's figure of the kept candidate (NAN unscored) */
    int same_as;                  /* >= 0: a copy of that coarser level, which scored higher
                                    than every candidate of this one; -1 otherwise */
} sv_stoch_level;

typedef struct sv_stoch_result {
    sv_stoch_level levels[SV_STOCH_MAX_LEVELS];
    uint32_t level_count;
    uint32_t *order;         /* N leaf indices */
    uint32_t leaf_count;     /* N */
    double mean_color[3];    /* c̄, area-weighted mean leaf colour (0..1) */
    uint32_t layered_leaves; /* leaves drawn as a layer of another (an underside) */
    double r;
} sv_stoch_result;

/* Scores a candidate level (its whole geometry, trunk included) against the
 * original, higher = closer (the pipeline: mean coverage IoU at 64 px from 8
 * views, the alpha calibration's evaluator). */
typedef sv_chain_score_fn sv_stoch_score_fn;
typedef struct sv_stoch_scorer {
    sv_stoch_score_fn fn;
    void *user;
} sv_stoch_scorer;

/* Builds every level of s from in->leaves (in->mesh, in->seed) with the ratio
 * r (must be in (0, 1] when s->area_preservation).
 *
 * Below λ = 1, with s->simplify_leaves and a scene giving a level error e(λ)
 * (sv_stochastic_level_error) > 0, the budget is spent where coverage comes
 * from: the trunk (in->cls->tri_part) is built first, simplified within e(λ)
 * towards SV_STOCH_TRUNK_FLOOR of its triangles (sv_trunk_mesh_budget), never
 * above the trunk's share of the whole tree's triangles times the level's
 * budget (capped there, the budget winning over the bound), and leads the
 * level's geometry (trunk_in_geometry). Where thin parts (stems, twigs) carry
 * coverage that a pixel's error removes, a finer trunk is worth its
 * triangles; where they hide in the crown, the leaves are: with a scorer the
 * trunk is also built at e/2 and e/4 and the candidate that scores highest is
 * kept (the coarser one unless another is better by more than 1e-4), and
 * then scaling the leaves by (s × gain)^(γ/2) with
 * γ = 0.85 and 0.7 competes with the paper's γ = 1 (√s-scaled leaves at the
 * crown's edge widen the silhouette, which Cook's model ignores; the
 * original's coverage decides), then leaves drawn whole where their
 * simplified silhouette keeps less than 0.8 of the modelled one, then every
 * leaf whole (the paper's rule: the budget drops leaves), then every
 * simplified leaf however thin, then every leaf kept with the foliage
 * simplified as one mesh (vertex clustering, one- and two-triangle leaves
 * as modelled) so that the leaves fill the budget whatever the error
 * (spread: where the elements are few foliage masses, dropping any drops
 * part of the crown); without one, e and γ = 1. Every leaf is
 * simplified (meshoptimizer, per leaf) to e(λ), and drawn so only while its
 * silhouette at the level's pixel e(λ) (the simplified shape scaled by its
 * area gain against the modelled leaf, soft IoU in the leaf's plane where
 * opaque) keeps SV_STOCH_MIN_COVER, else as modelled (min_cover,
 * leaves_whole, leaves_simplified); the leaves drawn are the longest prefix
 * of the order whose triangles fit λ × all the tree's triangles (or N for a
 * {"triangles": N} level) minus the trunk's, at least one. A {"triangles": N}
 * level whose trunk and leaves exceed N gets its trunk capped at what the
 * leaves leave. Otherwise (the paper's method) the budget is λ × the foliage
 * triangles, never fewer than ⌈λN⌉ leaves, and the geometry holds leaves only.
 *
 * The leaves of a level are its prefix, in order, every leaf with its own
 * vertices scaled by √(s(r, μ) × its simplified-area gain) about its centre
 * (μ = leaves / N), with the source's materials and images plus one copy of a
 * leaf material per contrast bin (contrast: each leaf's luminance Y is moved
 * to Ȳ + √μ (Y − Ȳ) by a base-colour factor, quantised in steps of 2^(1/16);
 * factors are capped where the base colour would exceed 1). With a scorer,
 * a level whose kept candidate scores below a coarser (cheaper) level's
 * becomes a copy of the best such level (same_as; its λ kept), so no level
 * is worse than one after it. On failure out is freed. */
sv_status sv_stochastic_build(const sv_method_input *in, const sv_stochastic_settings *s, double r,
                              const sv_stoch_scorer *scorer, sv_stoch_result *out, sv_error *err);

/* The trunk cap of level i built as L: for a level given as {"triangles": N},
 * N minus the leaf triangles drawn (at least 1), so leaves and trunk together
 * stay within N (sv_trunk_mesh_budget); 0 = no cap (a level given as λ). */
uint32_t sv_stochastic_trunk_cap(const sv_stochastic_settings *s, uint32_t i,
                                 const sv_stoch_level *L);

/* Moves level i of a build (settings s) into lod: its geometry (L->geometry
 * becomes NULL), and how the pipeline adds the trunk: none when the level
 * leads with its own, the whole trunk at λ = 1, else simplified to
 * max(λ, SV_STOCH_TRUNK_FLOOR) within sv_stochastic_trunk_cap. */
void sv_stochastic_plan(const sv_stochastic_settings *s, uint32_t i, sv_stoch_level *L,
                        sv_lod_plan *lod);

/* Frees geometry, attributes and order. NULL is fine. */
void sv_stoch_result_free(sv_stoch_result *res);

/* The LOD name used for level λ: "full" for 1, else "stochastic<λ·100>". */
void sv_stochastic_level_name(double lambda, char name[32]);

/* ---- the chain's levels (stochastic_chain.c) ------------------------------- */

/* sv_method_ops chain (method_ops.h): the levels the scene's distances need
 * (by λ at the nearest and farthest distance; the others are noted as
 * skipped, unless the spec's method is this one, which keeps every level
 * asked for), r measured through in->cover when the spec gives none, every
 * level built with in->score as its scorer (sv_stochastic_build) and placed
 * by Cook's schedule (sv_stochastic_distance_for_lambda). A tree without
 * leaves gets its own mesh and its trunk simplified at each level's error
 * instead (source "trunk"). Each stochastic level's payload carries what
 * sv_stochastic_level_ops writes for it. */
sv_status sv_stochastic_chain(const sv_chain_in *in, sv_chain_out *out, sv_error *err);

/* The hooks of a chain's stochastic level (level.h): gltf gives model.glb
 * per-vertex _LEAF_CENTRE (VEC3) and _LEAF_ORDER (SCALAR, (position + 0.5)/N)
 * so a renderer can draw any prefix and scale leaves about their centres
 * (Fichtner §4.3.1, §4.3.3; trunk vertices, first in the baked mesh, carry
 * their own position and order 0, so the same shader leaves them alone), and
 * the node extras "sylva_stochastic" (the level's λ, leaves, scales, fade
 * window and the chain's r, h, d0); report adds report.json's fields
 * (docs/outputs.md): lambda, leaves, triangles_asked (when given as a count),
 * leaf_fraction, leaf_triangles, leaf_error, the area and contrast terms, the
 * leaf shapes, the candidate's score and lambda_distance. */
struct sv_level_ops;
extern const struct sv_level_ops sv_stochastic_level_ops;

extern const sv_method sv_method_stochastic;         /* stochastic_settings.c */
extern const sv_method_ops sv_method_stochastic_ops; /* stochastic.c */

#endif
