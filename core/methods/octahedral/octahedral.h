/* octahedral.h — octahedral and hemi-octahedral impostors.
 *
 * Technique: R. Brucks, "Octahedral Impostors" (shaderbits.com, 2018), as
 * shipped in Unreal's ImpostorBaker and Amplify Impostors: the tree is
 * rendered orthographically from N × N directions laid on an octahedron
 * (the whole sphere) or on the upper half of one (hemi), the frames are
 * stored in one grid atlas, and at run time one camera-facing quad samples
 * the three frames nearest the view direction, each through its own frame
 * plane, blends them by barycentric weight and alpha-tests the blend.
 * Alpha mips keep their alpha-tested coverage (I. Castaño, "Computing Alpha
 * Mipmaps", 2010). docs/methods/octahedral.md and docs/runtime.md hold the
 * same rules as prose; server/viewer's GLSL implements them for WebGL2.
 *
 * Conventions (the runtime shader reads exactly these):
 * - Y is up. A direction d is unit, from the tree's centre towards a viewer.
 * - Full octahedron: p = d / (|dx|+|dy|+|dz|); uv = (p.x, p.z) when p.y >= 0,
 *   else ((1-|p.z|)·sgn p.x, (1-|p.x|)·sgn p.z) with sgn 0 = +1.
 *   Hemi: d.y is clamped to >= 0 first; uv = (p.x + p.z, p.x − p.z).
 *   Both give uv in [-1, 1]².
 * - Elevation scale S in (0, 1] (impostor.json "elevation_scale"; 1, or
 *   absent, is Brucks' layout): d is replaced by (d.x, d.y/S, d.z) before
 *   the encoding above, and a decoded direction (x, y, z) becomes
 *   normalize(x, S·y, z). S < 1 spends the rings of frames nearer the
 *   horizon, where a ground viewer looks from: hemi 8×8 with S = 0.5 has
 *   rings at 0°, 11–16°, 34–42° and 72° instead of 0°, 22–29°, 53–61°, 80°.
 * - Grid: g = (uv·0.5 + 0.5)·(N − 1). Frame (i, j) (i along u, j along v) is
 *   the view from the direction that decodes from g = (i, j).
 * - Frame basis for direction d: right = normalize(Y × d), up = d × right;
 *   when |d.y| > 0.9999, up_ref −Z instead of Y for d.y > 0 (+Z for d.y < 0):
 *   right = normalize(up_ref × d).
 * - Atlas: (N·F)² texels, F = frame_pixels. Frame (i, j) covers texel
 *   columns [i·F, (i+1)·F) and rows [j·F, (j+1)·F), row 0 = the image's top
 *   row. In a frame, texel (x, y) shows the world point
 *   centre + half·((2(x+0.5)/F − 1)·right + (1 − 2(y+0.5)/F)·up).
 * - Selection for a view direction: c = min(floor(g), N − 2), f = g − c.
 *   f.x + f.y <= 1: frames c, c+(1,0), c+(0,1) with weights 1−f.x−f.y, f.x, f.y;
 *   else frames c+(1,1), c+(1,0), c+(0,1) with f.x+f.y−1, 1−f.y, 1−f.x.
 * - Sampling frame k from a point q on the camera-facing quad with ray
 *   direction D (towards the viewer; no sample when D·d_k <= 1e-4), with
 *   parallax from the depth map: h = 0; repeat SV_OCTA_PARALLAX_STEPS + 1
 *   times { t = ((q−c)·d_k − h)/(D·d_k); P = q − t·D − h·d_k (the ray's point
 *   at height h over the frame plane, projected onto it);
 *   s = ((P−c)·right_k/half)·0.5 + 0.5, t' = 0.5 − ((P−c)·up_k/half)·0.5;
 *   stop when (s, t') leaves [0,1]² (the frame is empty there) or after
 *   the last step; else h = (depth(s, t') − 0.5)·2·half }, then sample
 *   colour and alpha at the last (s, t'). Without a depth map h stays 0
 *   (Brucks' plain frame-plane projection).
 *   Bilinear on each channel on its own (a GPU's LINEAR filter), texel
 *   centres clamped inside the frame ([0.5, F − 0.5]).
 * - Blend: a = Σ w_k a_k; rgb = Σ w_k a_k rgb_k / a; drawn when a >= cutoff
 *   (impostor.json "alpha_cutoff"; 0.5 unless calibrated).
 * - Depth map (16-bit): value/65535 = 0.5 + 0.5·s/half, s = signed distance
 *   of the surface seen from the frame plane along d_k (towards the viewer).
 *   Normal map: RGB = 0.5 + 0.5·n in the frame basis (right, up, d_k).
 */
#ifndef SV_OCTAHEDRAL_H
#define SV_OCTAHEDRAL_H

#include <cjson/cJSON.h>

#include "bake.h"
#include "render.h"

/* The method's name (spec "method", its settings key, sv_octa_level_ops). */
#define SV_OCTA_METHOD "octahedral"
#define SV_OCTA_MAX_GRID 32
/* The smallest frame side a bake makes or the atlas shrinking leaves. */
#define SV_OCTA_MIN_FRAME_PIXELS 16u
#define SV_OCTA_PARALLAX_STEPS 3
/* Default quads of the glTF proxy: 3 at 60° (sveval soft IoU at 64 px,
 * ficus / aspen: 1 quad 0.519 / 0.420, 2: 0.736 / 0.576, 3: 0.777 / 0.618,
 * 4: 0.794 / 0.606). */
#define SV_OCTA_PROXY_QUADS 3
/* Default elevation scale for a ground viewer (scene.viewer "ground"). */
#define SV_OCTA_GROUND_SCALE 0.5

typedef struct sv_octa_grid {
    uint32_t n;            /* frames per side, 2..SV_OCTA_MAX_GRID */
    bool hemi;             /* upper hemisphere only */
    uint32_t frame_pixels; /* F: texels per frame side */
    double centre[3];      /* frame planes pass through it */
    double half;           /* frame half extent, world units */
    double cutoff;         /* the blend's alpha test (0 = 0.5); the pipeline calibrates it */
    uint32_t proxy_quads;  /* quads of the glTF proxy (plain viewers' fallback), 1..8 */
    double elev_scale;     /* S in (0, 1]: directions squashed towards the horizon (1 = Brucks) */
    uint32_t mip_count;    /* albedo mips after level 0 (sv_octa_level_ops' images) */
} sv_octa_grid;

/* uv in [-1,1]² of unit direction d (conventions above; elev_scale S in
 * (0, 1], 1 = Brucks' layout). */
void sv_octa_encode(bool hemi, double elev_scale, const double d[3], double uv[2]);

/* Unit direction for uv in [-1,1]² (the inverse of sv_octa_encode). */
void sv_octa_decode(bool hemi, double elev_scale, const double uv[2], double d[3]);

/* Direction of frame (i, j) of grid g. */
void sv_octa_frame_dir(const sv_octa_grid *g, uint32_t i, uint32_t j, double d[3]);

/* Frame basis for unit direction d: right and up (unit, orthogonal, right × up = d). */
void sv_octa_frame_basis(const double d[3], double right[3], double up[3]);

/* The three frames and weights (summing to 1) a viewer in unit direction
 * view_dir blends: frames[k] = {i, j}. */
void sv_octa_select(const sv_octa_grid *g, const double view_dir[3], uint32_t frames[3][2],
                    double w[3]);

/* The reference runtime on the CPU: draws the impostor (albedo atlas, and
 * depth atlas or NULL for the frame planes' depth) with the orthographic
 * camera cam into a w × h RGBA8 image (alpha 255 where drawn, 0 elsewhere;
 * transparent black where not drawn) and depth[w·h] (distance along the
 * camera's forward from its origin plane, INFINITY where not drawn; depth
 * may be NULL). One sample per pixel centre. rgba is allocated. */
sv_status sv_octa_render(const sv_octa_grid *g, const sv_image *albedo, const sv_image *depth_map,
                         const sv_camera *cam, uint32_t w, uint32_t h, sv_image *rgba, float *depth,
                         sv_error *err);

/* Fits g for mesh m: n frames a side, hemi or not, elevation scale
 * elev_scale (outside (0, 1]: 1); centre = the bounds'
 * centre, half = the largest extent of any used vertex along any frame's
 * right or up (a square frame holds the tree from every grid direction),
 * with a 1/128 margin; every other field reset (proxy_quads to
 * SV_OCTA_PROXY_QUADS, cutoff 0). frame_pixels (0) is left for the caller.
 * SV_ERR_SPEC for n outside [2, SV_OCTA_MAX_GRID], SV_ERR_UNBAKEABLE for an
 * empty mesh. */
sv_status sv_octa_fit(const sv_mesh *m, uint32_t n, bool hemi, double elev_scale, sv_octa_grid *g,
                      sv_error *err);

/* Renders the n × n frames of g (F = g->frame_pixels texels each,
 * supersample² samples per texel, 0 = 2, lowered to fit the renderer) into
 * out: albedo (coverage alpha error-diffused to binary per frame, straight
 * colour dilated into empty texels;
 * lit with opt->light_dir when opt->lit), normal map when opt->normal_map,
 * and the depth map (always: the runtime's parallax reads it), and the proxy
 * mesh: one quad through the centre facing the frame nearest the +Z side
 * view, textured with that frame (a plain glTF viewer shows the tree; a
 * runtime replaces the material). */
sv_status sv_octa_bake(sv_renderer *r, const sv_gpu_mesh *gsrc, const sv_mesh *src,
                       const sv_octa_grid *g, const sv_bake_options *opt, uint32_t supersample,
                       sv_baked_lod *out, sv_error *err);

/* The next mip of an octahedral atlas: src (frames of F texels) halved to
 * frames of F/2 within each frame (alpha averaged, colour weighted by alpha),
 * then each frame's alpha scaled (Castaño) so the fraction of texels with
 * alpha >= 0.5 equals that of the same frame in level0. dst is allocated.
 * SV_ERR_INTERNAL when the frames cannot be halved. */
sv_status sv_octa_mip(const sv_octa_grid *g, const sv_image *level0, const sv_image *src,
                      sv_image *dst, sv_error *err);

/* Frame side when the spec leaves it to the bake: the next power of two at
 * or above texels_per_pixel × largest_pixels (the largest evaluated screen
 * size: a level is never judged, nor planned to be drawn, taller than that;
 * at one texel per pixel the alpha test's blocks cost ficus 0.06 of IoU at
 * 64 px), in [16, 1024], lowered until the n × n grid fits max_atlas (0 =
 * 2048). */
uint32_t sv_octa_frame_pixels(uint32_t n, uint32_t largest_pixels, double texels_per_pixel,
                              uint32_t max_atlas);

/* impostor.json's entry for one octahedral level (docs/runtime.md): its lod
 * and node names, the grid, frame bounds, alpha cutoff, the map files
 * (maps[k]: albedo, normal, ao, depth; "" = not baked) and the albedo's mips
 * (maps[0] then mip_count files atlas_<lod>_albedo_mip<k>.png, k = 1..,
 * octahedral_level.c).
 * Returns a new object (NULL when out of memory). */
cJSON *sv_octa_impostor_json(const sv_octa_grid *g, const char *lod, const char *node,
                             const char maps[4][64], uint32_t mip_count);

/* The method's settings, shared by its schema half (octahedral_settings.c)
 * and its build half (octahedral.c). */
typedef struct octa_settings {
    long grid; /* 0 = default by hemi */
    bool hemi, hemi_set;
    long frame_pixels; /* 0 = from the LOD's largest drawn size */
    long proxy_quads;  /* quads of the glTF proxy */
    double elev_scale; /* 0 = by the scene's viewer */
} octa_settings;

/* The settings object s (NULL: defaults) into o; SV_ERR_SPEC naming the key. */
sv_status octa_parse(const cJSON *s, octa_settings *o, sv_error *err);

struct sv_method;
struct sv_method_ops;
struct sv_level_ops;
extern const struct sv_method sv_method_octahedral;
extern const struct sv_method_ops sv_method_octahedral_ops;
extern const struct sv_level_ops sv_octa_level_ops; /* octahedral_level.c */

#endif
