/* evaluate.h — how close a stand-in looks to the original (docs/accuracy.md).
 *
 * The original and the result are rendered (render.h, albedo unless the options
 * say otherwise) from V views placed as the scene's viewer says, with the same
 * orthographic camera framing the original's bounding sphere (sv_mesh_sphere):
 * the image is square and its height spans the sphere's diameter 2·radius.
 * Renders are supersampled: base resolution = largest size × supersample.
 *
 * A stand-in is judged as a viewer at a distance sees it. For each screen size
 * S (the bounding sphere S pixels tall; convert a scene distance d with
 * sv_scene_pixels(scene, 2·radius, d)) the supersampled render is box-filtered
 * to S×S: per pixel, coverage a ∈ [0,1] (fraction of its samples covered),
 * premultiplied colour (mean of rgb × covered) and coverage-weighted depth.
 * Then, per view and size:
 *   iou         = Σ min(a,b) / Σ max(a,b)            (1 when both are empty)
 *   color_error = mean over pixels with max(a,b) > 0 of the mean absolute
 *                 difference of premultiplied r,g,b, in [0,1]
 *   depth_error = Σ min(a,b)·|za − zb| / Σ min(a,b), divided by radius
 *                 (0 when the coverages do not intersect)
 * and per size over all views (sveval's brightness figure):
 *   lum_ratio   = Σ min(a,b)·Y(result) / Σ min(a,b)·Y(original), Y the mean
 *                 over a pixel's covered samples of their Rec. 709 luminance,
 *                 each decoded from sRGB first (linear light, as sveval's
 *                 lum_ratio; 1 when no pixel overlaps). Averaging the encoded
 *                 colours first, as before, darkened varied pixels (decoding is
 *                 convex), lacy originals most: the crossed quads of the
 *                 acacia read 1.239 at 64 px where sveval says 1.081.
 * Colour is what a glTF engine shows (render.h): the linear factor × the
 * texel decoded from sRGB, encoded to sRGB, as ../shared/tools/sveval's
 * default colour; the box filter then averages the encoded values.
 * Point-sampled IoU at a high resolution punishes a leaf moved by a fraction of
 * its width as hard as a missing leaf; the box filter does not.
 *
 * The pure parts (view placement, cameras, filtering, metrics) need no GL and
 * are exposed for tests. Everything is deterministic.
 */
#ifndef SV_EVALUATE_H
#define SV_EVALUATE_H

#include "render.h"
#include "scene.h"

#define SV_EVAL_MAX_SIZES 8
#define SV_EVAL_MAX_SUBSETS 4

/* ---- options and results ------------------------------------------------ */

typedef struct sv_eval_options {
    sv_viewer viewer;                  /* view placement (default ORBIT, the zero value) */
    uint32_t view_count;               /* 0 = 24 */
    uint32_t sizes[SV_EVAL_MAX_SIZES]; /* screen sizes in pixels, any order; */
    uint32_t size_count;               /* 0 = {256, 128, 64, 32} */
    uint32_t supersample;              /* 0 = 4; base = max(sizes) × supersample, capped
                                  by the renderer's maximum size */
    sv_render_options render;          /* shading of both renders (zero = albedo) */
} sv_eval_options;

typedef struct sv_eval_metrics {
    double iou;         /* 1 = same silhouette */
    double color_error; /* 0 = same premultiplied colour */
    double depth_error; /* relative to the bounding radius */
} sv_eval_metrics;

typedef struct sv_eval_size {
    uint32_t pixels;       /* screen size (sphere diameter in pixels) */
    sv_eval_metrics mean;  /* mean over views */
    sv_eval_metrics worst; /* lowest iou, highest errors over views (each on its own) */
    double lum_ratio;      /* over all views (see top): < 1 the result is darker */
} sv_eval_size;

typedef struct sv_eval_result {
    uint32_t view_count;
    uint32_t size_count;
    sv_eval_size sizes[SV_EVAL_MAX_SIZES]; /* largest first */
    sv_eval_metrics *per_view; /* view_count × size_count, [view * size_count + size]; owned */
    double seconds;            /* wall time of the evaluation */
} sv_eval_result;

/* Frees per_view and zeroes the struct. NULL is fine. */
void sv_eval_result_free(sv_eval_result *r);

/* Per-view triangle subsets of the result, for stand-ins whose renderer picks
 * geometry by view (slicings: the two slicings nearest the view direction,
 * blended). Called once per view with the unit direction from the centre
 * towards the viewer; fills subsets[0..*count) (1 ≤ *count ≤ SV_EVAL_MAX_SUBSETS)
 * with triangles of the result mesh (owned by the caller, valid until the next
 * call) and weights that sum to 1. Each subset is rendered on its own and the
 * filtered images are blended with the weights (coverage, premultiplied colour
 * and depth all blend linearly). Returns SV_OK or an error that aborts. */
typedef struct sv_eval_subset {
    const uint32_t *tris; /* NULL = every triangle */
    uint32_t tri_count;
    double weight;
} sv_eval_subset;
typedef sv_status (*sv_eval_subset_fn)(void *user, const double view_dir[3],
                                       sv_eval_subset subsets[SV_EVAL_MAX_SUBSETS], uint32_t *count,
                                       sv_error *err);

/* Draws a stand-in that is not drawn as triangles (octahedral impostors:
 * the CPU reference runtime) with camera cam into a w × h RGBA8 image
 * (allocated by the call; alpha >= 128 = covered) and depth[w·h] (distance
 * along forward from the camera's origin plane, INFINITY where nothing is
 * drawn); the same contract as sv_render. */
typedef sv_status (*sv_eval_draw_fn)(void *user, const sv_camera *cam, uint32_t w, uint32_t h,
                                     sv_image *color, float *depth, sv_error *err);

/* ---- the evaluator ------------------------------------------------------- */

typedef struct sv_evaluator sv_evaluator;

/* Places the views, frames `original` (its bounding sphere), renders it (`g`,
 * uploaded to r) once per view at the base resolution and keeps the filtered
 * images of every size (docs/benchmarks.md, "Figures moved out of the code",
 * has their memory per view).
 * opt may be NULL (all defaults). r, original and g must outlive the evaluator.
 * Fails with SV_ERR_INVALID for an empty original or bad options (a size of 0,
 * too many sizes), SV_ERR_RENDER when rendering fails. */
sv_status sv_evaluator_create(sv_renderer *r, const sv_mesh *original, const sv_gpu_mesh *g,
                              const sv_eval_options *opt, sv_evaluator **out, sv_error *err);

void sv_evaluator_destroy(sv_evaluator *e);

/* Renders `result` (uploaded to the same renderer, whole) from the evaluator's
 * views and compares it with the original at every size. On success *out owns
 * per_view (sv_eval_result_free); on failure *out is zeroed. */
sv_status sv_evaluate(sv_evaluator *e, const sv_gpu_mesh *result, sv_eval_result *out,
                      sv_error *err);

/* sv_evaluate for a stand-in drawn by `draw` (called once per view at the
 * base resolution). SV_ERR_INTERNAL when draw is NULL. */
sv_status sv_evaluate_drawn(sv_evaluator *e, sv_eval_draw_fn draw, void *user, sv_eval_result *out,
                            sv_error *err);

/* Mean IoU (over views, at the evaluator's largest size) of `result` drawn
 * with its swept materials' cutoff at (k + 0.5) / 255, for every k in
 * [0, 255) at once: iou[k]. The swept materials are its MASK materials whose
 * alpha_cutoff is 0 (render.h, SV_SHADE_ALPHA_MAX); one render per view
 * instead of one per cutoff, each cutoff's value equal to sv_evaluate's for
 * that cutoff (to rounding). SV_ERR_RENDER / SV_ERR_NOMEM. */
sv_status sv_evaluate_cutoffs(sv_evaluator *e, const sv_gpu_mesh *result, double iou[255],
                              sv_error *err);

/* The result of evaluating the original against itself (IoU 1, errors 0 at
 * every view and size) without rendering: for a level that is the original
 * mesh (the chain's full level). SV_ERR_NOMEM only. */
sv_status sv_eval_identity(const sv_evaluator *e, sv_eval_result *out, sv_error *err);
/* sv_evaluate with a per-view choice of triangles (see sv_eval_subset_fn);
 * fn NULL = every triangle. SV_ERR_INVALID when the callback's weights are
 * negative or do not sum to 1. */
sv_status sv_evaluate_subsets(sv_evaluator *e, const sv_gpu_mesh *result, sv_eval_subset_fn fn,
                              void *user, sv_eval_result *out, sv_error *err);

/* Writes preview.png: four views (evenly spaced through the view list), one
 * row each: original | result | error heat map, at the largest size, over a
 * neutral grey. Heat: black = same, red = coverage differs, yellow = colour
 * differs where both are covered. fn/user as in sv_evaluate_subsets (NULL = whole result).
 * Uses sv_image_write_png. */
sv_status sv_evaluator_preview(sv_evaluator *e, const sv_gpu_mesh *result, sv_eval_subset_fn fn,
                               void *user, const char *png_path, sv_error *err);

/* Number of views and their unit directions (towards the viewer), for callers
 * that want to report them. */
uint32_t sv_evaluator_view_count(const sv_evaluator *e);
void sv_evaluator_view_dir(const sv_evaluator *e, uint32_t view, double dir[3]);

/* ---- LOD switching from the curve --------------------------------------- */

/* The largest screen size (pixels, interpolated linearly in log2(size) between
 * measured sizes) at which the result's mean IoU is still >= min_iou:
 * a LOD with this curve may be drawn while the tree is at most that many pixels
 * tall. Returns the largest measured size when every size passes, and 0 when
 * even the smallest fails. */
double sv_eval_max_pixels(const sv_eval_result *r, double min_iou);

/* The largest screen size S (pixels) at which the result's mean coverage
 * error 1 − IoU(S) is at most max_error · ref_pixels / S: the tolerance is
 * max_error at ref_pixels and scales as 1/S, so (1 − IoU) · S — about the
 * width in pixels of the band where the two silhouettes differ — stays within
 * max_error · ref_pixels. Between measured sizes the error is interpolated in
 * log2(size); outside them it is held at the nearest measured value.
 * INFINITY when the error is 0 at every measured size; 0 when no size in
 * [2^-8, 2^24] px passes. ref_pixels <= 0 gives sv_eval_max_pixels(r,
 * 1 − max_error) (one tolerance at every size). */
double sv_eval_max_pixels_scaled(const sv_eval_result *r, double max_error, double ref_pixels);

/* The mean coverage error 1 - IoU of r at screen size px: interpolated
 * linearly in log2 size between measured sizes, held at the nearest measured
 * one outside them. 1 when r has no sizes. */
double sv_eval_error_at(const sv_eval_result *r, double px);

/* ---- pure parts (no GL), exposed for tests ------------------------------- */

/* Unit view directions (from the centre towards the viewer, +Y up) for n views:
 *   ORBIT:  a Fibonacci sphere (uniform over the whole sphere);
 *   GROUND: elevations uniform in sin(e) over [0°, 20°], golden-angle azimuths;
 *   AERIAL: elevations uniform in sin(e) over [40°, 90°], golden-angle azimuths.
 * dirs receives 3n doubles. Deterministic. */
void sv_eval_place_views(sv_viewer viewer, uint32_t n, double *dirs);

/* Orthographic camera looking at `centre` from direction dir (unit, towards the
 * viewer), framing the sphere (half extents = radius, near/far = ∓1.01 radius),
 * with image up as close to +Y as possible (+Y views use -Z as up). */
void sv_eval_camera(const double centre[3], double radius, const double dir[3], sv_camera *cam);

/* Linear image planes that box-filter and blend exactly. */
typedef struct sv_eval_image {
    uint32_t width, height;
    float *coverage; /* w*h, [0,1] */
    float *color;    /* 3*w*h, premultiplied rgb in [0,1] */
    float *depth;    /* w*h, coverage × depth (divide by coverage for depth) */
    float *lum;      /* w*h, coverage × linear luminance (each covered sample's
                        Rec. 709 luminance of its colour decoded from sRGB,
                        averaged in linear light) */
} sv_eval_image;

sv_status sv_eval_image_alloc(sv_eval_image *img, uint32_t w, uint32_t h, sv_error *err);
void sv_eval_image_free(sv_eval_image *img); /* NULL is fine; zeroes the struct */

/* Converts a render (RGBA8 colour whose alpha is coverage, and its depth buffer
 * or NULL) into planes of the same size: a sample is covered when alpha >= 128. */
sv_status sv_eval_image_from_render(const sv_image *rgba, const float *depth, sv_eval_image *out,
                                    sv_error *err);

/* sv_eval_image_from_render then sv_eval_image_downsample to w × h, in one
 * pass over the render when w and h divide its size (the evaluator's case),
 * with the same bits as the two steps. out is allocated. */
sv_status sv_eval_image_from_render_filtered(const sv_image *rgba, const float *depth, uint32_t w,
                                             uint32_t h, sv_eval_image *out, sv_error *err);

/* Box-filters src to w × h (each output pixel is the area-weighted mean of the
 * source pixels it covers; sizes need not divide). out is allocated. */
sv_status sv_eval_image_downsample(const sv_eval_image *src, uint32_t w, uint32_t h,
                                   sv_eval_image *out, sv_error *err);

/* dst += weight × src, plane by plane (same sizes). */
void sv_eval_image_accumulate(sv_eval_image *dst, const sv_eval_image *src, double weight);

/* The metrics above for two images of the same size; radius scales depth. */
sv_eval_metrics sv_eval_compare(const sv_eval_image *a, const sv_eval_image *b, double radius);

#endif
