/* pipeline_internal.h — the state the pipeline's files share (private to
 * core/pipeline*.c, chain.c, calibrate.c, target.c, report.c, outputs.c,
 * textures.c;
 * docs/design.md "The core pipeline" has the map).
 *
 * One bake is a sequence of stages over a `run` (what lives for the whole
 * request: the spec, the prepared mesh, the renderer and evaluators kept
 * across a target search's tries) and a `bake_state` (what one bake of the
 * chain makes: plans, bakes, measures). Each stage function below says what
 * it reads and what it fills. Names with the svp_ prefix cross files.
 */
#ifndef SV_PIPELINE_INTERNAL_H
#define SV_PIPELINE_INTERNAL_H

#include <cjson/cJSON.h>

#include "bake.h"
#include "classify.h"
#include "evaluate.h"
#include "import.h"
#include "level.h"
#include "pipeline.h"
#include "plausibility.h"
#include "render.h"
#include "spec.h"
#include "method_ops.h"
#include "validate.h"

enum {
    ST_IMPORT,
    ST_VALIDATE,
    ST_CLASSIFY,
    ST_METHOD,
    ST_BAKE,
    ST_PACK,
    ST_EVALUATE,
    ST_WRITE,
    ST_COUNT
};
/* The source's base-colour textures used only with alpha (MASK, BLEND)
 * get colour in their transparent texels (atlas.h, sv_texture_dilate, with
 * `passes` rings) when that changes what a mipmapping engine draws; other
 * textures are left as they are (textures.c). In: the imported mesh, before
 * it is uploaded or baked. SV_ERR_NOMEM on allocation failure. */
sv_status svp_dilate_textures(sv_mesh *m, uint32_t passes, sv_error *err);

/* "import", "validate", ...: progress reports and report.json "times" */
extern const char *const svp_stage_names[ST_COUNT];

typedef struct prepared {
    sv_mesh *mesh;
    sv_import_info info;
    sv_validate_report repairs;
    sv_classification cls;
    sv_leaves leaves;
    sv_up_guess up;       /* the up-axis check (plausibility.h) */
    bool up_rotated;      /* import.up "auto" found the tree Z-up and rotated it */
    sv_units_guess units; /* the units check (plausibility.h) */
    double centre[3], radius;
} prepared;

/* What a trial bake (the target search) measured on the method's finest LOD. */
typedef struct trial_out {
    uint32_t quads, triangles;
    double texels;
    double iou; /* at spec.target_pixels (mean or worst), -1 = not measured */
} trial_out;

struct bake_state;

typedef struct run {
    const sv_bake_request *req;
    sv_spec spec;
    prepared p;
    double times[ST_COUNT];
    double t0;
    int stage;
    double pa, pb;   /* progress is mapped into [pa, pb] (the target search) */
    int search_most; /* the target search's bound on tries (sv_search_fn) */
    bool trial;      /* stop after evaluation, write nothing, fill tout */
    trial_out tout;
    /* A try's bake kept for the final bake of a target search (target.c):
     * with `keep` set, a trial's state is moved into it instead of being
     * freed; with `reuse` set, the next bake takes that state (owned) in
     * place of its compose and texture bake, and measures and writes it.
     * Only where the final spec bakes exactly what the try did (the user's
     * chain off: the try's spec differs by the ignored lod.coarsest). */
    struct bake_state *keep;
    struct bake_state *reuse;
    sv_memo *memo; /* what methods keep across the bakes of this request (method_ops.h) */
    cJSON *target_json;  /* report "target" (deterministic part), owned */
    cJSON *target_times; /* report times.target: seconds per try, owned */
    /* Kept across the bakes of one run (a target search bakes once per
     * try): the renderer, the original on it, and the evaluator
     * with its reference renders, reused while its options stay the same. */
    sv_renderer *ren;
    sv_gpu_mesh *gsrc;
    sv_evaluator *ev; /* sizes above evaluate.small_render / 4 (or all sizes) */
    sv_eval_options ev_opt;
    sv_evaluator *ev_small; /* sizes at or below it, from their own render (NULL: none) */
    sv_eval_options ev_small_opt;
    sv_evaluator *calib_ev; /* the alpha calibration's (calibrate.c) */
    sv_eval_options calib_opt;
} run;

/* ---- the LOD chain (chain.c; docs/lod.md) ---- */

typedef struct chain_lod {
    bool scheduled;     /* placed by the chain hook's schedule (sv_method_ops chain) */
    double lambda;      /* scheduled: its share of the detail (1: the full mesh, exact) */
    double distance;    /* scheduled: the nearest distance it is drawn from */
    double trunk_error; /* metres: meshoptimizer bound, one pixel at `distance` */
    char source[32];    /* method that made it */
} chain_lod;

typedef struct chain {
    cJSON *levels_report;    /* report.json lod_chain.<levels_name> from the chain hook; owned */
    const char *levels_name; /* the method that built the chain's own levels */
    chain_lod *info;         /* one per si LOD */
    cJSON *skipped;          /* [{name, stage, reason}] */
    int required;            /* the spec method's last LOD (-1: none) */
    int required_first;      /* the spec method's first LOD */
    int coarsest;            /* lod.coarsest's last LOD (-1: none) */
    int coarsest_first;      /* ... and its first */
} chain;

/* The chain's cover callback (sv_chain_in cover: a visible ratio's input)
 * sums covered pixels of COVER_VIEWS renders of COVER_SIZE² (report.json
 * says so) */
#define COVER_VIEWS 6
#define COVER_SIZE 512

/* What one LOD became: its bake, its measure, its place in the chain. */
typedef struct lod_out {
    sv_baked_lod baked;
    sv_gpu_mesh *gpu;
    sv_eval_result eval;
    bool evaluated;
    sv_eval_result bound; /* the flattening bound's measure (evaluate.flattening_bound) */
    bool bound_measured;
    double switch_pixels; /* largest screen height at which this LOD meets the tolerance */
    double own_pixels;    /* the same before the chain made it non-increasing */
    double coverage;      /* MSFT_screencoverage threshold below which the next LOD is used */
    bool meets_tolerance;
    char maps[4][64];    /* atlas file names: albedo, normal, ao, depth */
    char file[96];       /* standalone glTF of this level: lod<i>_<name>.glb */
    char node[96];       /* its node name (also in model.glb): <asset>_LOD<i> */
    double alpha_cutoff; /* calibrated atlas cutoff (0 = not calibrated) */
    double calib_iou;    /* mean IoU at SV_CALIB_PIXELS with that cutoff */
    bool reduced;        /* its atlas was reduced after it was measured (measure again) */
    double colour_scale; /* its atlas colour × this in linear light (0: untouched; svp_scale_atlas) */
} lod_out;

/* One bake of the chain (svp_bake_all): filled stage by stage. */
typedef struct bake_state {
    sv_stand_in si;     /* the chain's plans (compose) */
    chain ch;           /* how each LOD was made (compose) */
    lod_out *lods;      /* one per si LOD (bake, evaluate, plan, write) */
    sv_bake_options bo; /* from the spec (bake) */
    double fc[3], fr;   /* the evaluator's framing sphere (plan) */
    double tree_h;      /* its diameter: screen sizes are measured on it (plan) */
} bake_state;

/* Texels per screen pixel a level's atlas keeps (a level's own bake hook,
 * svp_shrink_atlases). */
#define SV_ATLAS_TEXELS_PER_PIXEL 4.0

/* ---- pipeline.c ---- */

/* Closes the open stage's time, opens `stage` and reports progress `within`
 * it (mapped into [r->pa, r->pb]). SV_ERR_CANCELLED when the caller cancels. */
sv_status svp_progress(run *r, int stage, double within);
/* One bake of the chain with r->spec (r prepared): the outputs into
 * r->req->out_dir, or (r->trial) only r->tout. */
sv_status svp_bake_all(run *r, sv_error *err);
/* Frees what b holds (b itself is the caller's). */
void svp_bake_state_free(struct bake_state *b);

/* Adapts a LOD's view selector (stand_in.h) to the evaluator's per-view
 * triangle subsets (an sv_eval_subset_fn on a view_sets): quad q is
 * triangles 2q and 2q+1 of the baked mesh, the kept geometry after the quads
 * is drawn in every subset. */
typedef struct view_sets {
    const sv_lod_plan *lod;
    const sv_baked_lod *baked;
    uint32_t *quads[SV_MAX_VIEW_SETS];
    uint32_t *tris[SV_MAX_VIEW_SETS];
} view_sets;
sv_status svp_view_sets_init(view_sets *v, const sv_lod_plan *lod, const sv_baked_lod *b,
                             sv_error *err);
void svp_view_sets_free(view_sets *v);
sv_status svp_select_subsets(void *user, const double view_dir[3],
                             sv_eval_subset subsets[SV_EVAL_MAX_SUBSETS], uint32_t *count,
                             sv_error *err);
/* A level drawn by its own hook (sv_level_ops draw), adapted to the
 * evaluator's and the preview's sv_eval_draw_fn on a level_draw_ctx. */
typedef struct level_draw_ctx {
    const sv_lod_plan *lod;
    const sv_baked_lod *baked;
} level_draw_ctx;
sv_status svp_level_draw(void *user, const sv_camera *cam, uint32_t w, uint32_t h, sv_image *color,
                         float *depth, sv_error *err);
/* True when lod is drawn by its own hook, not as a triangle mesh. */
bool svp_drawn_by_hook(const sv_lod_plan *lod);

/* ---- chain.c: which LODs, and where each is drawn ---- */

/* Builds the chain into si (and c->info, one per LOD): the chain's own levels
 * the scene needs (sv_method_ops chain), the spec's method, the coarsest
 * method. Lends the renderer (ren, gsrc: the original) to the chain hook as
 * its cover and score callbacks. */
sv_status svp_chain_compose(run *r, sv_renderer *ren, const sv_gpu_mesh *gsrc, sv_stand_in *si,
                            chain *c, sv_error *err);
void svp_chain_free(chain *c);
/* Switch sizes from measured error: fills own_pixels, switch_pixels,
 * meets_tolerance and coverage of lods[0..n). */
void svp_plan_switches(const run *r, const chain *c, lod_out *lods, uint32_t n, double tree_h);
/* Chooses the LODs drawn: drop[i] for each LOD never drawn, each with its
 * note in c->skipped; sets switch_pixels of the kept ones. */
void svp_plan_visibility(const run *r, chain *c, lod_out *lods, const sv_stand_in *si,
                         double tree_h, bool *drop);
/* Removes the dropped LODs from si, lods and c->info (order kept). */
void svp_compact_lods(sv_stand_in *si, lod_out *lods, chain *c, const bool *drop);

/* ---- calibrate.c: alpha cutoffs and atlas sizes ---- */

/* The small evaluator of the alpha calibration and the chain's score
 * callback (64 px, 8 views, rendered at render²), kept in r and made again
 * only when render changes; *out is r's, not the caller's. */
sv_status svp_small_evaluator(run *r, sv_renderer *ren, const sv_gpu_mesh *gsrc, uint32_t render,
                              sv_evaluator **out, sv_error *err);
/* The chain's score callback (sv_chain_score_fn) on a score_ctx: mean IoU of
 * a candidate level at 64 px. */
typedef struct score_ctx {
    run *r;
    sv_renderer *ren;
    const sv_gpu_mesh *gsrc;
} score_ctx;
sv_status svp_chain_score(void *user, const sv_mesh *level, double *score, sv_error *err);
/* Sets the atlas cutoff (lods[i].alpha_cutoff, calib_iou) of every quad level
 * baked with coverage alpha. */
sv_status svp_calibrate_cutoffs(run *r, sv_renderer *ren, const sv_gpu_mesh *gsrc,
                                const sv_stand_in *si, lod_out *lods, sv_error *err);
/* Shrinks the atlases of levels after the first to their switch size (and
 * calibrates their cutoff again there when `calibrate`). */
sv_status svp_shrink_atlases(run *r, sv_renderer *ren, const sv_gpu_mesh *gsrc, sv_stand_in *si,
                             lod_out *lods, double tree_h, bool calibrate, sv_error *err);

/* Brightness match (docs/accuracy.md "Brightness"): a quad level whose
 * lum_ratio at 64 px is off 1 by more than this gets its colour scaled. */
#define SV_BRIGHTNESS_BAND 0.02
/* ... and a mesh level (stochastic, trunk) by more than this: its light
 * differs where leaves were dropped or grown, not evenly, so a uniform scale
 * trades colour error for mean light, worth it only against a visible pop
 * (the held-out yucca's stochastic25 at 0.907: sveval RGB error at 64 px
 * 5.56 -> 3.90; its stochastic50 at 0.979 would have gone 1.61 -> 2.04) */
#define SV_BRIGHTNESS_BAND_MESH 0.05
/* b's atlas colour × f in linear light: each texel decoded from sRGB,
 * scaled, clamped to 1, encoded again, alpha kept; new pixels for the
 * albedo and for the atlas material's texture (its copy in b->mesh). */
sv_status svp_scale_atlas(sv_baked_lod *b, double f, sv_error *err);
/* A mesh level's colour × f in linear light: each material's base colour
 * factor, or, where the factor would pass 1 (glTF's bound), the texture it
 * samples (decoded from sRGB, scaled, clamped to 1, encoded again, alpha
 * kept; new pixels, so other levels sharing them keep theirs). */
sv_status svp_scale_mesh_colour(sv_mesh *m, double f, sv_error *err);

/* ---- target.c ---- */

/* The spec's target (docs/spec.md "target"): searches the method's ladder
 * cheapest first, then bakes the chosen setting with the user's own LOD
 * settings like svp_bake_all (r->target_json, r->target_times filled). A
 * target that cannot be met is not an error: the best try is baked and the
 * report says "met": false. */
sv_status svp_target_search(run *r, sv_error *err);

/* ---- outputs.c: the files that are not JSON ---- */

extern const char *const svp_map_names[4]; /* albedo, normal, ao, depth */
/* The atlas map i (svp_map_names order) of a bake. */
const sv_image *svp_lod_map(const sv_baked_lod *b, int i);
/* atlas_<lod>_<map>.png (names into lods[i].maps), then each level's own
 * images (sv_level_ops images: an impostor's mips), written as PNG. */
sv_status svp_write_atlases(const run *r, bake_state *b, sv_error *err);
/* model.glb and lod<i>_<name>.glb (names into lods[i].node and .file). */
sv_status svp_write_gltf(const run *r, bake_state *b, sv_error *err);
/* preview.png from ev's first view (ev NULL: nothing). */
sv_status svp_write_preview(const run *r, const bake_state *b, sv_evaluator *ev, sv_error *err);

/* ---- report.c: the JSON documents ---- */

/* The description `sylva-bake info` prints and report.json embeds. */
cJSON *svp_describe(const prepared *p);
/* report.json "accuracy" of one measured LOD. */
cJSON *svp_accuracy_json(const sv_eval_result *e);
/* Writes j (pretty, then a newline) to dir/name. */
sv_status svp_write_json(const char *dir, const char *name, cJSON *j, sv_error *err);
/* planes.json and the documents levels add beside it (sv_level_ops
 * doc_file: impostor.json). */
sv_status svp_write_planes(const run *r, const bake_state *b, sv_error *err);
/* report.json; closes the write stage's time first (times are its last key). */
sv_status svp_write_report(run *r, const bake_state *b, sv_error *err);

#endif
