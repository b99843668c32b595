/* bake.h — texture baking of quads (billboard-cloud paper §3.3.7), atlas packing
 * (stb_rect_pack) and the textured result mesh of one level of detail.
 *
 * For each quad: render the faces valid for it orthographically along -normal,
 * supersampled so the smallest leaf covers at least one sample (capped), then
 * downsample with an alpha threshold (binary alpha) — colour the per-channel
 * median of the covered samples scaled to their mean luminance in linear
 * light, normals the per-channel median — and render the colour from the
 * other side as well, the two blended per texel in linear light by the
 * views of the scene's viewer that see each side's surface on its face (a
 * leaf modelled as an upper-side and an underside card shows each from its
 * side; the quad shows one texture; docs/outputs.md "Two sides"), and
 * dilate colour into transparent texels so mipmaps do not bleed. The albedo
 * atlas is glTF base colour (sRGB-encoded, factor 1): the source's linear
 * factor × its decoded texels.
 * One texel density (world units per texel) for all quads of a LOD, chosen so
 * the atlas fits max_atlas; power-of-two atlas sizes; padding between charts.
 */
#ifndef SV_BAKE_H
#define SV_BAKE_H

#include "render.h"
#include "scene.h"
#include "stand_in.h"

typedef struct sv_bake_options {
    uint32_t max_atlas;       /* max atlas side in texels, default 2048 */
    uint32_t max_supersample; /* cap on the supersampling factor, default 8 */
    double texel_size;        /* world units per texel; 0 = the finest that fits max_atlas */
    double alpha_threshold;   /* default 0.3 (binary alpha) */
    bool coverage_alpha;      /* alpha = covered fraction of the texel instead of binary;
                                 supersampling at least 4; the atlas material's cutoff
                                 is left at 0.5 for the caller to calibrate */
    double texel_floor;       /* with texel_size 0: the texel is never finer than this
                                 (world units; 0 = no floor) */
    uint32_t padding;         /* texels between charts, default 4 */
    uint32_t dilate;          /* texels of colour dilation, default 8 */
    bool normal_map;          /* scene: dynamic lighting */
    bool ao_map;              /* scene: dynamic lighting + ambient occlusion */
    bool depth_map;           /* scene: shadows/parallax */
    bool lit;                 /* scene: static lighting — bake lit albedo */
    double light_dir[3];      /* unit, towards the light (lit); zero = from above-front */
    const uint8_t *tri_part;  /* sv_part (classify.h) of each triangle of src, for quads
                                 that select faces by q->parts; NULL = every face is trunk */
    sv_viewer viewer;         /* where the quads are seen from (scene.h): weighs the colour
                                 each side of a quad shows (sv_bake_front_weight); zero is
                                 ORBIT, sv_bake_options_init sets the scene's default, SIDE */
} sv_bake_options;

typedef struct sv_baked_lod {
    sv_mesh *mesh;        /* the stand-in as drawn: 2 triangles per quad (atlas
                                 material, alpha MASK, double-sided) followed by the
                                 kept geometry (trunk, explicit geometry) with its
                                 own materials. Images: the atlases and kept textures. */
    uint32_t quad_count;  /* quad i is triangles 2i and 2i+1 of mesh */
    float *uv_rects;      /* 4 per quad: u0, v0, u1, v1 in atlas UV (glTF: v down) */
    sv_image albedo;      /* RGBA8 atlas, sRGB-encoded colour, binary alpha */
    sv_image normal;      /* RGB8 tangent-space normal atlas (data NULL when not baked) */
    sv_image ao;          /* 8-bit AO atlas, 1 channel, 255 = open sky: fraction of 12 fixed
                                 upper-hemisphere directions from which the texel's surface
                                 point is not occluded (data NULL when not baked) */
    sv_image depth;       /* 16-bit, 1 channel: |distance of the surface from the quad plane|
                                 / quad slab (the baked faces' largest distance when slab
                                 is 0), clamped to 1, × 65535; 0 = on the plane
                                 (data NULL when not baked) */
    double texel_size;    /* world units per texel used */
    uint32_t supersample; /* factor used */
    double seconds_render, seconds_pack;
} sv_baked_lod;

/* Bakes the quads of lod (faces of `src`, uploaded as `gsrc`) and builds the
 * result mesh. keep (may be NULL) is geometry appended as is (trunk, explicit
 * LOD geometry), already in world space. */
sv_status sv_bake_lod(sv_renderer *r, const sv_gpu_mesh *gsrc, const sv_mesh *src,
                      const sv_lod_plan *lod, const sv_mesh *keep, const sv_bake_options *opt,
                      sv_baked_lod *out, sv_error *err);

void sv_baked_lod_free(sv_baked_lod *b);

/* The share, in [0, 1], of a two-sided quad's view on its +normal side:
 * over view directions d spread as `viewer` spreads them (scene.h: SIDE
 * elevations uniform in angle over [-10°, 40°], GROUND, AERIAL and ORBIT
 * uniform in sin(elevation) over their bands; 64 azimuths × 32 elevations),
 * Σ max(0, d·n) / Σ |d·n|, the share of a surface's projected area seen on
 * its +n side: the weight of the front's colour for a texel whose front
 * capture sees a surface of normal n (turned towards the front) when the
 * bake's depth maps find no view that sees either side's surface (the
 * colour closest, in least squares over those views, to what the source
 * shows there, occlusion left out). 0.5 for a normal of zero length. */
double sv_bake_front_weight(sv_viewer viewer, const double normal[3]);

/* Sets opt to the defaults above. Zero fields of an options struct also mean
 * "the default" (alpha_threshold 0 → 0.3, padding 0 → 4, dilate 0 → 8). */
void sv_bake_options_init(sv_bake_options *opt);

#endif
