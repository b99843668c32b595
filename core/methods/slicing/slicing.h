/* slicing.h — the pure geometry of Jakulin's slicings (core/methods/slicing/slicing.c): slab
 * boundaries, clipping of triangles at slab planes, and the blending rule that
 * picks and weights slicings for a view direction.
 *
 * A slicing is a set of parallel slabs through the crown along a direction n;
 * slab k holds the foliage with bounds[k] <= n·p <= bounds[k+1] and is drawn as
 * one textured quad on its mid-plane. Azimuthal slicing j of S has
 *   n_j = (sin θ_j, 0, cos θ_j),  θ_j = j·180°/S,
 * so slicing 0 faces +Z (the crossed-quads convention). A slicing and its
 * opposite direction share their planes, so S slicings cover 180° of azimuth
 * and each quad is seen from both sides (double-sided material). The optional
 * top slicing has n = +Y. Units and axes: sv.h.
 */
#ifndef SV_SLICING_H
#define SV_SLICING_H

#include <cjson/cJSON.h>

#include "stand_in.h"

#define SV_SLICING_MAX_SLICINGS 32u /* azimuthal slicings */
#define SV_SLICING_MAX_SLICES 64u   /* slices per slicing */
#define SV_SLICING_FOLIAGE_BINS 4096u

typedef enum sv_slice_spacing {
    SV_SPACING_UNIFORM = 0, /* slabs of equal thickness */
    SV_SPACING_FOLIAGE      /* slabs holding equal foliage area */
} sv_slice_spacing;

/* Unit direction of azimuthal slicing j of `count` (see above). 0° and 90° are
 * exact (no sin/cos rounding). */
void sv_slicing_direction(uint32_t j, uint32_t count, double n[3]);

/* Clips triangle tri to the slab lo <= n·p <= hi (n need not be unit; lo <= hi).
 * out receives the clipped convex polygon (at most 5 vertices, in the
 * triangle's winding); returns its vertex count, 0 when nothing is left (a
 * piece of zero width is dropped). */
uint32_t sv_slab_clip_triangle(const double tri[3][3], const double n[3], double lo, double hi,
                               double out[5][3]);

/* Area of a planar polygon of n vertices (0 for n < 3). */
double sv_polygon_area(const double (*poly)[3], uint32_t n);

/* bounds[0..k] = lo + i·(hi − lo)/k, with bounds[0] = lo and bounds[k] = hi exactly. */
void sv_slab_bounds_uniform(double lo, double hi, uint32_t k, double *bounds);

/* Boundaries that give each of the k slabs of [lo, hi] an equal share of the
 * foliage area along the direction: proj holds, per triangle, the three
 * projections n·p of its vertices (3·count values), area its area. The
 * cumulative area below s is computed exactly per triangle (its area density
 * along n is a tent between its extreme projections) into
 * SV_SLICING_FOLIAGE_BINS bins and interpolated linearly inside a bin, so a
 * boundary is exact to 1/4096 of hi − lo. Boundaries then keep a gap of at
 * least (hi − lo)/(100·k) (foliage concentrated in one plane would otherwise
 * give slabs of zero thickness). bounds[0] = lo, bounds[k] = hi.
 * Fails with SV_ERR_NOMEM, or SV_ERR_INVALID when lo >= hi or k == 0.
 * With no foliage area at all the bounds are uniform. */
sv_status sv_slab_bounds_foliage(const double *proj, const double *area, size_t count, double lo,
                                 double hi, uint32_t k, double *bounds, sv_error *err);

/* The blending rule (docs/methods/slicing.md). For a unit view direction v
 * (either sign: the rule is symmetric, v and −v give the same answer):
 *   φ = atan2(v.x, v.z) taken modulo 180° (0 when v is vertical),
 *   t = φ / (180°/S), j = ⌊t⌋, f = t − j:
 *   slicing j gets weight 1 − f, slicing (j + 1) mod S gets f;
 *   with top, e = asin(|v.y|) ∈ [0°, 90°]: both are scaled by 1 − e/90° and
 *   the top slicing (index S) gets e/90°.
 * Zero weights are dropped and a slicing named twice (S = 1) is merged.
 * idx/w receive up to 3 entries (slicing indices ascending), weights sum to 1;
 * returns their number (>= 1). slicings must be >= 1. */
uint32_t sv_slicing_blend(uint32_t slicings, bool top, const double view_dir[3], uint32_t idx[3],
                          double w[3]);

/* For a LOD made by the slicing method: a JSON object with each slicing's
 * direction and quads and the blending rule as data (written to planes.json as
 * the LOD's "slicing"). NULL for any other LOD, or on out-of-memory. */
cJSON *sv_slicing_describe(const sv_lod_plan *lod);

/* The method's own: its settings, shared by the schema half
 * (slicing_settings.c) and the build half (slicing.c). */
#define SL_NAME "slicing"
#define SL_DEFAULT_SPACING SV_SPACING_UNIFORM

typedef struct sl_settings {
    long slicings, slices;
    sv_slice_spacing spacing;
    int top; /* -1 auto, 0, 1 */
    double trunk_ratio;
} sl_settings;

/* The settings object s (NULL: defaults) into o; SV_ERR_SPEC naming the key. */
sv_status sl_parse(const cJSON *s, sl_settings *o, sv_error *err);

struct sv_method;
struct sv_method_ops;
extern const struct sv_method sv_method_slicing;
extern const struct sv_method_ops sv_method_slicing_ops;

#endif
