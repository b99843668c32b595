/* bake.c — texture baking of the quads of one LOD and the textured result mesh.
 *
 * Implements the billboard-cloud paper (Behrendt et al., "Realistic real-time
 * rendering of landscapes using billboard clouds"), §3.3.7 "Texture generation":
 * every face valid for a plane (not only the faces it simplifies) is rendered
 * orthographically onto it, supersampled so that each small leaf polygon covers
 * at least one sample, then downsampled with a rectangular filter and an
 * alpha threshold (default 0.3) so alpha is binary and needs no depth sorting.
 * §3.3.9 (dynamic lighting): normals are projected as well as colours (normal
 * map in the quad's tangent frame). Colour is dilated into empty texels so
 * mipmaps and bilinear filtering do not bleed background into leaf edges.
 *
 * Choices (documented here and in bake.h):
 *   - Supersampling s = ceil(texel / size5), size5 the 5th percentile of
 *     sqrt(area) over every face baked in the LOD (robust to slivers), clamped
 *     to [1, max_supersample] and at most 16 and the renderer's max size.
 *   - Charts larger than 2048 samples on a side are rendered in tiles aligned to
 *     texel blocks, so memory stays bounded and the result equals one big render.
 *   - Colour is baked in linear, as glTF defines it (image.h): renders come
 *     back as linear RGBA16 (the source's base colour factor × its decoded
 *     texels); a texel's colour is the median of its covered samples scaled
 *     to their mean luminance (the median alone darkens in linear light, see
 *     atlas.h), the dilation works on a 16-bit linear atlas, and the atlas
 *     is encoded to 8-bit sRGB once at the end. Normals keep the median.
 *     The atlas material's factor is 1: the source's factors are in the texels.
 *   - Two sides: the quad is drawn two-sided with one texture, so its colour
 *     is also rendered from the other side (the same faces and slab; the
 *     paper renders from one) and the two are blended per texel in linear
 *     light by the views from which the source shows each: 24 directions of
 *     the scene's viewer, a depth map of the source from each; a view counts
 *     for the front's surface when it faces the surface's shading normal
 *     and sees it, weighted by the cosine, and for the back's when it faces
 *     away from that normal and sees the back's surface. Without any such
 *     view the weight is sv_bake_front_weight of the normal. Alpha,
 *     normals, depth and AO stay the front's.
 *   - AO (sky visibility): 12 fixed directions on the upper hemisphere (Fibonacci
 *     spiral, y >= 0.1); the whole source mesh is rendered to a 1024² depth map
 *     from each; a texel's surface point is visible from a direction when it is
 *     no farther than the stored depth plus two depth-map texels.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "atlas.h"
#include "bake.h"
#include "classify.h"
#include "evaluate.h"
#include "vec3.h"

#define SV_BAKE_TILE_SAMPLES 2048u
#define SV_BAKE_MAX_SS 16u
#define SV_AO_DIRS 12
#define SV_AO_RES 1024u
#define SV_BAKE_SIDE_STEPS 64

void sv_bake_options_init(sv_bake_options *opt)
{
    memset(opt, 0, sizeof *opt);
    opt->max_atlas = 2048;
    opt->max_supersample = 8;
    opt->texel_size = 0;
    opt->alpha_threshold = 0.3;
    opt->padding = 4;
    opt->dilate = 8;
    opt->light_dir[0] = 0.2;
    opt->light_dir[1] = 0.9;
    opt->light_dir[2] = 0.4;
    opt->viewer = SV_VIEWER_SIDE;
}

double sv_bake_front_weight(sv_viewer viewer, const double normal[3])
{
    double n[3] = {normal[0], normal[1], normal[2]};
    double len = sqrt(sv_dot3(n, n));
    if (!(len > 0)) return 0.5;
    for (int k = 0; k < 3; k++) n[k] /= len;
    /* the viewer's band (sv_viewer_band, scene.h), as a product grid: the
     * SIDE helix ties azimuth to elevation, which a weight must not */
    double lo, hi;
    bool by_angle;
    sv_viewer_band(viewer, &lo, &hi, &by_angle);
    double slo = sin(lo * M_PI / 180), shi = sin(hi * M_PI / 180);
    double front = 0, total = 0;
    for (int e = 0; e < 32; e++) {
        double t = (e + 0.5) / 32;
        double y = by_angle ? sin((lo + (hi - lo) * t) * M_PI / 180) : slo + (shi - slo) * t;
        double r = sqrt(fmax(0.0, 1 - y * y));
        for (int a = 0; a < 64; a++) {
            double phi = 2 * M_PI * (a + 0.5) / 64;
            double c = r * cos(phi) * n[0] + y * n[1] + r * sin(phi) * n[2];
            if (c > 0) front += c;
            total += fabs(c);
        }
    }
    return total > 0 ? front / total : 0.5;
}

void sv_baked_lod_free(sv_baked_lod *b)
{
    if (!b) return;
    sv_mesh_destroy(b->mesh);
    free(b->uv_rects);
    sv_image_free(&b->albedo);
    sv_image_free(&b->normal);
    sv_image_free(&b->ao);
    sv_image_free(&b->depth);
    memset(b, 0, sizeof *b);
}

/* Per quad: the faces to render and the depth range that holds them. */
typedef struct quad_job {
    uint32_t *tris;
    uint32_t count;
    double near_dist, far_dist; /* along forward = -normal, from the quad centre */
    double depth_norm;          /* depth map: distance that maps to 65535 */
} quad_job;

static bool part_ok(const sv_quad *q, const uint8_t *tri_part, uint32_t t)
{
    if (q->parts == 0) return true;
    uint8_t part = tri_part ? tri_part[t] : SV_PART_TRUNK;
    return (q->parts & (part == SV_PART_FOLIAGE ? SV_PARTS_FOLIAGE : SV_PARTS_TRUNK)) != 0;
}

/* Signed distance of vertex v from the plane, and its (u, v) from the centre. */
static void vertex_frame(const sv_mesh *m, const sv_quad *q, uint32_t v, double out[3])
{
    const float *p = m->positions + 3 * (size_t)v;
    double r[3] = {(double)p[0] - q->centre[0], (double)p[1] - q->centre[1],
                   (double)p[2] - q->centre[2]};
    out[0] = sv_dot3(r, q->normal);
    out[1] = sv_dot3(r, q->axis_u);
    out[2] = sv_dot3(r, q->axis_v);
}

static sv_status select_faces(const sv_mesh *src, const sv_quad *q, uint32_t qi,
                              const uint8_t *tri_part, quad_job *job, sv_error *err)
{
    double slab = q->slab > 0 ? q->slab : 0;
    double ext = 0; /* largest |distance| of a selected vertex */
    if (q->bake_faces) {
        job->tris = sv_calloc(q->bake_face_count ? q->bake_face_count : 1, sizeof(uint32_t));
        if (!job->tris)
            return sv_fail(err, SV_ERR_NOMEM, "bake: out of memory for quad %u faces", qi);
        for (uint32_t i = 0; i < q->bake_face_count; i++) {
            uint32_t t = q->bake_faces[i];
            if (t >= src->triangle_count)
                return sv_fail(err, SV_ERR_INTERNAL, "bake: quad %u names face %u of %u", qi, t,
                               src->triangle_count);
            job->tris[job->count++] = t;
        }
    } else {
        job->tris = sv_calloc(src->triangle_count ? src->triangle_count : 1, sizeof(uint32_t));
        if (!job->tris)
            return sv_fail(err, SV_ERR_NOMEM, "bake: out of memory for quad %u faces", qi);
        double tol = 1e-9 * (fabs(q->d) + q->half_u + q->half_v + slab);
        for (uint32_t t = 0; t < src->triangle_count; t++) {
            if (!part_ok(q, tri_part, t)) continue;
            double f[3][3];
            for (int j = 0; j < 3; j++) vertex_frame(src, q, src->indices[3 * (size_t)t + j], f[j]);
            double dmin = fmin(f[0][0], fmin(f[1][0], f[2][0]));
            double dmax = fmax(f[0][0], fmax(f[1][0], f[2][0]));
            if (q->clip ? (dmin > slab + tol || dmax < -slab - tol)
                        : (dmin < -slab - tol || dmax > slab + tol))
                continue;
            /* Faces that project outside the rectangle would only be clipped away. */
            double umin = fmin(f[0][1], fmin(f[1][1], f[2][1]));
            double umax = fmax(f[0][1], fmax(f[1][1], f[2][1]));
            double vmin = fmin(f[0][2], fmin(f[1][2], f[2][2]));
            double vmax = fmax(f[0][2], fmax(f[1][2], f[2][2]));
            if (umin > q->half_u || umax < -q->half_u || vmin > q->half_v || vmax < -q->half_v)
                continue;
            job->tris[job->count++] = t;
        }
    }
    for (uint32_t i = 0; i < job->count; i++)
        for (int j = 0; j < 3; j++) {
            double f[3];
            vertex_frame(src, q, src->indices[3 * (size_t)job->tris[i] + j], f);
            if (fabs(f[0]) > ext) ext = fabs(f[0]);
        }
    double range = q->clip ? slab : fmax(slab, ext);
    double eps = 1e-5 * (range + q->half_u + q->half_v) + 1e-9;
    job->near_dist = -range - (q->clip ? 0 : eps);
    job->far_dist = range + (q->clip ? 0 : eps);
    if (q->clip && !(range > 0)) {
        job->near_dist = -eps;
        job->far_dist = eps;
    }
    job->depth_norm = slab > 0 ? slab : (ext > 0 ? ext : 1.0);
    return SV_OK;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* 5th percentile of sqrt(area) over the faces of every job (each face once). */
static sv_status face_size_p5(const sv_mesh *src, const quad_job *jobs, uint32_t n, double *size,
                              sv_error *err)
{
    *size = 0;
    uint8_t *seen = sv_calloc(src->triangle_count ? src->triangle_count : 1, 1);
    double *sz = sv_calloc(src->triangle_count ? src->triangle_count : 1, sizeof *sz);
    if (!seen || !sz) {
        free(seen);
        free(sz);
        return sv_fail(err, SV_ERR_NOMEM, "bake: out of memory for face statistics");
    }
    size_t c = 0;
    for (uint32_t i = 0; i < n; i++)
        for (uint32_t k = 0; k < jobs[i].count; k++) {
            uint32_t t = jobs[i].tris[k];
            if (seen[t]) continue;
            seen[t] = 1;
            double a = sv_tri_area(src, t);
            if (a > 0 && isfinite(a)) sz[c++] = sqrt(a);
        }
    if (c) {
        qsort(sz, c, sizeof *sz, cmp_double);
        *size = sz[(size_t)floor(0.05 * (double)(c - 1))];
    }
    free(seen);
    free(sz);
    return SV_OK;
}

/* The camera seeing texels [x0,x1) × [y0,y1) (row 0 at +v) of a w × h chart. */
static sv_camera tile_camera(const sv_quad *q, const quad_job *job, uint32_t w, uint32_t h,
                             uint32_t x0, uint32_t x1, uint32_t y0, uint32_t y1)
{
    double tu = 2 * q->half_u / w, tv = 2 * q->half_v / h;
    double cu = -q->half_u + 0.5 * (x0 + x1) * tu;
    double cv = q->half_v - 0.5 * (y0 + y1) * tv;
    sv_camera c;
    for (int k = 0; k < 3; k++) {
        c.origin[k] = q->centre[k] + cu * q->axis_u[k] + cv * q->axis_v[k];
        c.right[k] = q->axis_u[k];
        c.up[k] = q->axis_v[k];
    }
    c.half_width = 0.5 * (x1 - x0) * tu;
    c.half_height = 0.5 * (y1 - y0) * tv;
    c.near_dist = job->near_dist;
    c.far_dist = job->far_dist;
    return c;
}

/* Depth maps of the whole source from fixed sky directions (see top). */
typedef struct ao_views {
    sv_camera cam[SV_AO_DIRS];
    float *depth[SV_AO_DIRS];
    double bias;
} ao_views;

static void ao_free(ao_views *a)
{
    for (int i = 0; i < SV_AO_DIRS; i++) free(a->depth[i]);
}

static sv_status ao_prepare(sv_renderer *r, const sv_gpu_mesh *g, const sv_mesh *src, ao_views *a,
                            sv_error *err)
{
    memset(a, 0, sizeof *a);
    double c[3], rad;
    sv_mesh_sphere(src, c, &rad);
    if (!(rad > 0)) rad = 1;
    uint32_t res = SV_AO_RES;
    if (res > sv_renderer_max_size(r)) res = sv_renderer_max_size(r);
    a->bias = 2.0 * (2.0 * rad * 1.01 / res); /* two depth-map texels */
    const double golden = M_PI * (3.0 - sqrt(5.0));
    for (int i = 0; i < SV_AO_DIRS; i++) {
        double y = 0.1 + 0.9 * (i + 0.5) / SV_AO_DIRS, s = sqrt(1 - y * y);
        double dir[3] = {s * cos(golden * i), y, s * sin(golden * i)};
        double fwd[3] = {-dir[0], -dir[1], -dir[2]};
        double h[3] = {0, 1, 0};
        if (fabs(fwd[1]) > 0.9) {
            h[0] = 1;
            h[1] = 0;
        }
        sv_camera *cam = &a->cam[i];
        double rt[3] = {fwd[1] * h[2] - fwd[2] * h[1], fwd[2] * h[0] - fwd[0] * h[2],
                        fwd[0] * h[1] - fwd[1] * h[0]};
        sv_normalize3(rt);
        /* up = right × fwd, so that up × right = fwd */
        double up[3] = {rt[1] * fwd[2] - rt[2] * fwd[1], rt[2] * fwd[0] - rt[0] * fwd[2],
                        rt[0] * fwd[1] - rt[1] * fwd[0]};
        memcpy(cam->origin, c, sizeof c);
        memcpy(cam->right, rt, sizeof rt);
        memcpy(cam->up, up, sizeof up);
        cam->half_width = cam->half_height = rad * 1.01;
        cam->near_dist = -rad * 1.02;
        cam->far_dist = rad * 1.02;
        a->depth[i] = sv_calloc((size_t)res * res, sizeof(float));
        if (!a->depth[i]) {
            ao_free(a);
            return sv_fail(err, SV_ERR_NOMEM, "bake: out of memory for AO depth maps");
        }
        sv_status st = sv_render(r, g, NULL, 0, cam, NULL, res, res, NULL, a->depth[i], err);
        if (st != SV_OK) {
            ao_free(a);
            return st;
        }
    }
    return SV_OK;
}

/* Fraction of the directions from which world point p is unoccluded. */
static double ao_visibility(const ao_views *a, uint32_t res, const double p[3])
{
    int vis = 0;
    for (int i = 0; i < SV_AO_DIRS; i++) {
        const sv_camera *c = &a->cam[i];
        double d[3] = {p[0] - c->origin[0], p[1] - c->origin[1], p[2] - c->origin[2]};
        double fwd[3];
        sv_camera_forward(c, fwd);
        double x = (sv_dot3(d, c->right) / c->half_width * 0.5 + 0.5) * res;
        double y = (0.5 - sv_dot3(d, c->up) / c->half_height * 0.5) * res;
        double z = sv_dot3(d, fwd);
        if (x < 0 || y < 0 || x >= res || y >= res) {
            vis++;
            continue;
        }
        float stored = a->depth[i][(size_t)y * res + (size_t)x];
        if (z <= (double)stored + a->bias) vis++;
    }
    return (double)vis / SV_AO_DIRS;
}

/* Depth maps of the whole source from the viewer's directions, for the
 * two sides' blend: which of the views see a texel's front and back
 * surfaces (the colour closest to what those views show). */
#define SV_SIDE_ROWS 4
#define SV_SIDE_COLS 6
#define SV_SIDE_DIRS (SV_SIDE_ROWS * SV_SIDE_COLS)
#define SV_SIDE_RES 128u
typedef struct side_views {
    double dir[SV_SIDE_DIRS][3]; /* unit, towards the viewer */
    sv_camera cam[SV_SIDE_DIRS];
    double fwd[SV_SIDE_DIRS][3]; /* each camera's forward */
    float *depth[SV_SIDE_DIRS];
    uint32_t res;
    double bias;
} side_views;

static void side_free(side_views *a)
{
    for (int i = 0; i < SV_SIDE_DIRS; i++) free(a->depth[i]);
}

/* The directions: SV_SIDE_ROWS elevations at the middles of equal slices of
 * the viewer's band (scene.h; SIDE in angle, the others in sin(elevation)),
 * SV_SIDE_COLS azimuths each, every row turned by half a step from the last. */
static sv_status side_prepare(sv_renderer *r, const sv_gpu_mesh *g, const sv_mesh *src,
                              sv_viewer viewer, side_views *a, sv_error *err)
{
    memset(a, 0, sizeof *a);
    double c[3], rad;
    sv_mesh_sphere(src, c, &rad);
    if (!(rad > 0)) rad = 1;
    a->res = SV_SIDE_RES < sv_renderer_max_size(r) ? SV_SIDE_RES : sv_renderer_max_size(r);
    a->bias = 2.0 * (2.0 * rad * 1.01 / a->res); /* two depth-map texels */
    double lo, hi;
    bool by_angle;
    sv_viewer_band(viewer, &lo, &hi, &by_angle);
    double slo = sin(lo * M_PI / 180), shi = sin(hi * M_PI / 180);
    for (int i = 0; i < SV_SIDE_DIRS; i++) {
        int row = i / SV_SIDE_COLS, col = i % SV_SIDE_COLS;
        double t = (row + 0.5) / SV_SIDE_ROWS;
        double y = by_angle ? sin((lo + (hi - lo) * t) * M_PI / 180) : slo + (shi - slo) * t;
        double rr = sqrt(fmax(0.0, 1 - y * y)), phi = 2 * M_PI * (col + 0.5 * row) / SV_SIDE_COLS;
        double *d = a->dir[i];
        d[0] = rr * cos(phi);
        d[1] = y;
        d[2] = rr * sin(phi);
        sv_eval_camera(c, rad * 1.01, d, &a->cam[i]);
        sv_camera_forward(&a->cam[i], a->fwd[i]);
        a->depth[i] = sv_calloc((size_t)a->res * a->res, sizeof(float));
        if (!a->depth[i]) {
            side_free(a);
            return sv_fail(err, SV_ERR_NOMEM, "bake: out of memory for side depth maps");
        }
        sv_status st = sv_render(r, g, NULL, 0, &a->cam[i], NULL, a->res, a->res, NULL, a->depth[i],
                                 err);
        if (st != SV_OK) {
            side_free(a);
            return st;
        }
    }
    return SV_OK;
}

/* Whether world point p is the surface view i sees (within the bias). */
static bool side_visible(const side_views *a, int i, const double p[3])
{
    const sv_camera *c = &a->cam[i];
    double d[3] = {p[0] - c->origin[0], p[1] - c->origin[1], p[2] - c->origin[2]};
    double x = (sv_dot3(d, c->right) / c->half_width * 0.5 + 0.5) * a->res;
    double y = (0.5 - sv_dot3(d, c->up) / c->half_height * 0.5) * a->res;
    if (x < 0 || y < 0 || x >= a->res || y >= a->res) return true;
    return sv_dot3(d, a->fwd[i]) <= (double)a->depth[i][(size_t)y * a->res + (size_t)x] + a->bias;
}

typedef struct bake_ctx {
    sv_renderer *r;
    const sv_gpu_mesh *g;
    const sv_bake_options *opt;
    uint32_t s;
    double thr;
    uint32_t aw, ah; /* atlas size */
    uint8_t *mask;   /* aw*ah: texel opaque */
    uint16_t *lin;   /* aw*ah RGBA16: the albedo atlas in linear colour */
    sv_baked_lod *out;
    const ao_views *ao;
    uint32_t ao_res;
    /* sv_bake_front_weight of a unit normal of height y = -1 + 2 i / STEPS
     * (the viewers are symmetric about +Y, so y is all it depends on) */
    double side_w[SV_BAKE_SIDE_STEPS + 1];
    const side_views *sides; /* NULL: the weights come from side_w alone */
    /* bake_quad's tile buffers, made for the first quad and kept for the
     * others (every tile of a bake has the same size bound): allocated per
     * quad they were page-faulted in anew each time */
    struct tile_scratch {
        uint8_t *tex;
        uint16_t *tex16, *back16;
        float *zs, *zt, *zb;
    } ts;
} bake_ctx;

static void tile_scratch_free(struct tile_scratch *t)
{
    free(t->tex);
    free(t->tex16);
    free(t->back16);
    free(t->zs);
    free(t->zt);
    free(t->zb);
    memset(t, 0, sizeof *t);
}

/* The colour of the tile seen from the plane's other side, blended into
 * tex16 (linear RGBA16, tw × th texels, as sv_downsample_colour16 gave it
 * from the front camera `cam`, whose side is `side`): a two-sided quad shows
 * its one texture from both sides, where the source shows whatever faces
 * that side (a leaf drawn as two cards a hair apart, upper side and
 * underside, shows one from each side). A texel takes, in linear light,
 * w × the front's colour + (1 - w) × the back's. n is the shading normal
 * of the surface the front sees, turned towards the front (`nrm`, the
 * median of SV_SHADE_NORMAL samples in the front camera's frame,
 * sv_downsample_median); the front's surface point is at depth zt, the
 * back's at the back render's depth (zs: scratch of the samples' size, zb:
 * of the texels'). w = Σ over b->sides' views d with d·n > 0 that see the
 * front's point of d·n, over that plus Σ over views with d·n < 0 that see
 * the back's point of -d·n; without such views, b->side_w's weight of n. The back camera
 * mirrors u (right = -axis_u), so its image is mirrored back column by
 * column. Alpha (coverage) stays the front's: the covered samples are the
 * same from both sides, and a texel the back leaves empty (an edge
 * rasterised the other way) keeps the front's colour. back16 is scratch of
 * tex16's size. */
static sv_status capture_back(bake_ctx *b, const quad_job *job, const sv_camera *cam,
                              const double side[3], const sv_render_options *ro, const uint8_t *nrm,
                              const float *zt, float *zs, float *zb, uint32_t tw, uint32_t th,
                              uint16_t *tex16, uint16_t *back16, sv_error *err)
{
    uint32_t s = b->s, sw = tw * s, sh = th * s;
    sv_camera bc = *cam;
    for (int k = 0; k < 3; k++) bc.right[k] = -cam->right[k];
    bc.near_dist = -cam->far_dist;
    bc.far_dist = -cam->near_dist;
    sv_image img;
    sv_status st = sv_render(b->r, b->g, job->tris, job->count, &bc, ro, sw, sh, &img,
                             b->sides ? zs : NULL, err);
    if (st != SV_OK) return st;
    uint16_t *px = img.data;
    for (uint32_t y = 0; y < sh; y++) {
        uint16_t *row = px + 4 * (size_t)y * sw;
        float *zrow = zs + (size_t)y * sw;
        for (uint32_t x = 0; x < sw / 2; x++) {
            for (int k = 0; k < 4; k++) {
                uint16_t t = row[4 * (size_t)x + k];
                row[4 * (size_t)x + k] = row[4 * (size_t)(sw - 1 - x) + k];
                row[4 * (size_t)(sw - 1 - x) + k] = t;
            }
            if (b->sides) {
                float t = zrow[x];
                zrow[x] = zrow[sw - 1 - x];
                zrow[sw - 1 - x] = t;
            }
        }
    }
    sv_downsample_colour16(px, tw, th, s, b->thr, back16);
    if (b->sides) sv_downsample_median_f32(zs, tw, th, s, b->thr, zb);
    sv_image_free(&img);
    double fwd[3];
    sv_camera_forward(cam, fwd);
    double tx = 2 * cam->half_width / tw, ty = 2 * cam->half_height / th;
    for (size_t i = 0; i < (size_t)tw * th; i++) {
        uint16_t *f = tex16 + 4 * i;
        const uint16_t *k = back16 + 4 * i;
        if (!f[3] || !k[3]) continue;
        /* the normal in world space: camera x = right, y = up, z = side */
        const uint8_t *n = nrm + 4 * i;
        double c[3] = {n[0] / 127.5 - 1, n[1] / 127.5 - 1, n[2] / 127.5 - 1};
        if (c[2] < 0) /* towards the front, whatever the source's normals say */
            for (int j = 0; j < 3; j++) c[j] = -c[j];
        double len = sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
        double y = c[0] * cam->right[1] + c[1] * cam->up[1] + c[2] * side[1];
        y = len > 0 ? y / len : 0;
        double t = (y + 1) * 0.5 * SV_BAKE_SIDE_STEPS;
        int lo = (int)floor(t);
        if (lo < 0) lo = 0;
        if (lo >= SV_BAKE_SIDE_STEPS) lo = SV_BAKE_SIDE_STEPS - 1;
        double fr = t - lo, w = b->side_w[lo] + (b->side_w[lo + 1] - b->side_w[lo]) * fr;
        if (b->sides && isfinite(zt[i]) && isfinite(zb[i])) {
            /* the views that see the front's surface on its face, against
             * those that see the back's on the other face */
            double nw[3], pf[3], pb[3];
            double u = -cam->half_width + ((double)(i % tw) + 0.5) * tx;
            double v = cam->half_height - ((double)(i / tw) + 0.5) * ty;
            for (int j = 0; j < 3; j++) {
                nw[j] = (c[0] * cam->right[j] + c[1] * cam->up[j] + c[2] * side[j]) /
                        (len > 0 ? len : 1);
                double on = cam->origin[j] + u * cam->right[j] + v * cam->up[j];
                pf[j] = on + (double)zt[i] * fwd[j];
                pb[j] = on - (double)zb[i] * fwd[j];
            }
            double af = 0, ab = 0;
            for (int d = 0; d < SV_SIDE_DIRS; d++) {
                double cd = sv_dot3(b->sides->dir[d], nw);
                if (cd > 0 && side_visible(b->sides, d, pf)) af += cd;
                if (cd < 0 && side_visible(b->sides, d, pb)) ab -= cd;
            }
            if (af + ab > 0) w = af / (af + ab);
        }
        for (int j = 0; j < 3; j++) f[j] = (uint16_t)lround(w * f[j] + (1 - w) * k[j]);
    }
    return SV_OK;
}

static sv_status bake_quad(bake_ctx *b, const sv_quad *q, const quad_job *job, const sv_chart *ch,
                           sv_error *err)
{
    uint32_t s = b->s;
    uint32_t tile = SV_BAKE_TILE_SAMPLES / s;
    if (tile == 0) tile = 1;
    uint32_t w = ch->w, h = ch->h;
    sv_status st = SV_OK;
    struct tile_scratch *ts = &b->ts;
    if (!ts->tex) {
        ts->tex = malloc((size_t)tile * tile * 4);
        ts->tex16 = malloc((size_t)tile * tile * 4 * sizeof *ts->tex16);
        ts->back16 = malloc((size_t)tile * tile * 4 * sizeof *ts->back16);
        ts->zs = malloc((size_t)tile * s * tile * s * sizeof(float));
        ts->zt = malloc((size_t)tile * tile * sizeof(float));
        ts->zb = malloc((size_t)tile * tile * sizeof(float));
        if (!ts->tex || !ts->tex16 || !ts->back16 || !ts->zs || !ts->zt || !ts->zb) {
            tile_scratch_free(ts);
            return sv_fail(err, SV_ERR_NOMEM, "bake: out of memory for a %ux%u tile", tile * s,
                           tile * s);
        }
    }
    uint8_t *tex = ts->tex;
    uint16_t *tex16 = ts->tex16, *back16 = ts->back16;
    float *zs = ts->zs, *zt = ts->zt, *zb = ts->zb;
    sv_render_options ro = {.shade = b->opt->lit ? SV_SHADE_LIT : SV_SHADE_ALBEDO, .linear = true};
    memcpy(ro.light_dir, b->opt->light_dir, sizeof ro.light_dir);
    sv_render_options rn = {.shade = SV_SHADE_NORMAL};
    double tu = 2 * q->half_u / w, tv = 2 * q->half_v / h;
    /* the front camera looks along axis_v × axis_u (render.h): its side is
     * axis_u × axis_v, the normal for the quads the methods make */
    double side[3];
    sv_cross3(q->axis_u, q->axis_v, side);
    for (uint32_t y0 = 0; y0 < h; y0 += tile)
        for (uint32_t x0 = 0; x0 < w; x0 += tile) {
            uint32_t x1 = x0 + tile < w ? x0 + tile : w, y1 = y0 + tile < h ? y0 + tile : h;
            uint32_t tw = x1 - x0, th = y1 - y0;
            sv_camera cam = tile_camera(q, job, w, h, x0, x1, y0, y1);
            sv_image img;
            st = sv_render(b->r, b->g, job->tris, job->count, &cam, &ro, tw * s, th * s, &img, zs,
                           err);
            if (st != SV_OK) goto out;
            sv_downsample_colour16(img.data, tw, th, s, b->thr, tex16);
            sv_downsample_median_f32(zs, tw, th, s, b->thr, zt);
            sv_image_free(&img);
            /* the front's normals: the blend's weights and the normal map */
            st = sv_render(b->r, b->g, job->tris, job->count, &cam, &rn, tw * s, th * s, &img, NULL,
                           err);
            if (st != SV_OK) goto out;
            sv_downsample_median(img.data, tw, th, s, b->thr, tex);
            sv_image_free(&img);
            st = capture_back(b, job, &cam, side, &ro, tex, zt, zs, zb, tw, th, tex16, back16, err);
            if (st != SV_OK) goto out;
            for (uint32_t y = 0; y < th; y++)
                for (uint32_t x = 0; x < tw; x++) {
                    size_t ai = (size_t)(ch->y + y0 + y) * b->aw + ch->x + x0 + x;
                    const uint16_t *t = tex16 + 4 * ((size_t)y * tw + x);
                    memcpy(b->lin + 4 * ai, t, 4 * sizeof *t);
                    b->mask[ai] = t[3] != 0;
                    if (!t[3]) continue;
                    float dist = zt[(size_t)y * tw + x];
                    if (b->out->depth.data) {
                        double v = fabs((double)dist) / job->depth_norm;
                        ((uint16_t *)b->out->depth.data)[ai] = (uint16_t)lround(65535.0 *
                                                                                (v < 1 ? v : 1));
                    }
                    if (b->out->ao.data) {
                        double pu = -q->half_u + (x0 + x + 0.5) * tu;
                        double pv = q->half_v - (y0 + y + 0.5) * tv;
                        double p[3];
                        for (int k = 0; k < 3; k++)
                            p[k] = q->centre[k] + pu * q->axis_u[k] + pv * q->axis_v[k] -
                                   (double)dist * q->normal[k];
                        double vis = ao_visibility(b->ao, b->ao_res, p);
                        ((uint8_t *)b->out->ao.data)[ai] = (uint8_t)lround(255.0 * vis);
                    }
                }
            if (b->out->normal.data) {
                uint8_t *nm = b->out->normal.data;
                for (uint32_t y = 0; y < th; y++)
                    for (uint32_t x = 0; x < tw; x++) {
                        size_t ai = (size_t)(ch->y + y0 + y) * b->aw + ch->x + x0 + x;
                        memcpy(nm + 3 * ai, tex + 4 * ((size_t)y * tw + x), 3);
                    }
            }
        }
out:
    return st;
}

/* The 8-bit atlas of the linear one (same size): R, G, B encoded with the
 * sRGB OETF, alpha rounded to 8 bits. */
static void encode_atlas(const sv_image *lin, sv_image *atlas)
{
    const uint16_t *src = lin->data;
    uint8_t *dst = atlas->data;
    size_t n = (size_t)lin->width * lin->height * 4;
    for (size_t i = 0; i < n; i += 4) {
        for (int k = 0; k < 3; k++) dst[i + k] = sv_srgb_encode8(src[i + k] / 65535.0);
        dst[i + 3] = (uint8_t)((src[i + 3] * 255u + 32767u) / 65535u);
    }
}

/* The stand-in mesh: 4 vertices and 2 triangles per quad with the atlas
 * material, then `keep` (materials and images copied, indices offset). */
static sv_status build_mesh(const sv_lod_plan *lod, const sv_mesh *keep, bool lit,
                            sv_baked_lod *out, sv_error *err)
{
    uint32_t n = lod->quad_count;
    if (n == 0) {
        if (keep) return sv_mesh_merge(NULL, keep, &out->mesh, err);
        out->mesh = sv_mesh_create(0, 0, 0, 0);
        return out->mesh ? SV_OK : sv_fail(err, SV_ERR_NOMEM, "bake: out of memory");
    }
    if (n > UINT32_MAX / 4)
        return sv_fail(err, SV_ERR_LIMIT, "bake: %u quads overflow the result mesh", n);
    uint32_t nimg = 1 + (out->normal.data != NULL) + (out->ao.data != NULL);
    sv_mesh *m = sv_mesh_create(4 * n, 2 * n, 1, nimg);
    if (!m) return sv_fail(err, SV_ERR_NOMEM, "bake: out of memory for the result mesh");
    static const float cu[4] = {0, 1, 1, 0}, cv[4] = {1, 1, 0, 0}; /* corner → (u, v down) */
    for (uint32_t i = 0; i < n; i++) {
        const sv_quad *q = &lod->quads[i];
        double corners[4][3];
        sv_quad_corners(q, corners);
        const float *rect = out->uv_rects + 4 * (size_t)i;
        for (int c = 0; c < 4; c++) {
            size_t v = 4 * (size_t)i + (size_t)c;
            for (int k = 0; k < 3; k++) {
                m->positions[3 * v + k] = (float)corners[c][k];
                m->normals[3 * v + k] = (float)q->normal[k];
            }
            m->uvs[2 * v] = rect[0] + cu[c] * (rect[2] - rect[0]);
            m->uvs[2 * v + 1] = rect[1] + cv[c] * (rect[3] - rect[1]);
        }
        static const uint32_t tri[6] = {0, 1, 2, 0, 2, 3};
        for (int k = 0; k < 6; k++) m->indices[6 * (size_t)i + k] = 4 * i + tri[k];
        m->tri_material[2 * i] = m->tri_material[2 * i + 1] = 0;
    }
    sv_material *mat = &m->materials[0];
    sv_material_init(mat);
    snprintf(mat->name, sizeof mat->name, "sylva_atlas_%s", lod->name);
    mat->alpha_mode = SV_ALPHA_MASK;
    mat->alpha_cutoff = 0.5f;
    mat->double_sided = true;
    mat->unlit = lit; /* static lighting is in the albedo */
    mat->base_texture = 0;
    sv_status st = sv_image_copy(&out->albedo, &m->images[0], err);
    uint32_t next = 1;
    if (st == SV_OK && out->normal.data) {
        mat->normal_texture = (int32_t)next;
        st = sv_image_copy(&out->normal, &m->images[next++], err);
    }
    if (st == SV_OK && out->ao.data) {
        mat->occlusion_texture = (int32_t)next;
        st = sv_image_copy(&out->ao, &m->images[next++], err);
    }
    if (st == SV_OK && keep && keep->triangle_count) {
        sv_mesh *merged = NULL;
        st = sv_mesh_merge(m, keep, &merged, err);
        sv_mesh_destroy(m);
        m = merged;
    }
    if (st != SV_OK) {
        sv_mesh_destroy(m);
        return st;
    }
    out->mesh = m;
    return SV_OK;
}

sv_status sv_bake_lod(sv_renderer *r, const sv_gpu_mesh *gsrc, const sv_mesh *src,
                      const sv_lod_plan *lod, const sv_mesh *keep, const sv_bake_options *opt_in,
                      sv_baked_lod *out, sv_error *err)
{
    memset(out, 0, sizeof *out);
    if (!r || !gsrc || !src || !lod)
        return sv_fail(err, SV_ERR_INTERNAL, "bake: NULL renderer, mesh or LOD");
    double t_start = sv_now(), t_pack = 0;
    sv_bake_options opt;
    if (opt_in) opt = *opt_in;
    else sv_bake_options_init(&opt);
    if (!opt.max_atlas) opt.max_atlas = 2048;
    if (!opt.max_supersample) opt.max_supersample = 8;
    if (opt.max_supersample > SV_BAKE_MAX_SS) opt.max_supersample = SV_BAKE_MAX_SS;
    if (!(opt.alpha_threshold > 0)) opt.alpha_threshold = 0.3;
    if (opt.alpha_threshold > 1) opt.alpha_threshold = 1;
    if (!opt.padding) opt.padding = 4;
    if (!opt.dilate) opt.dilate = 8;
    if (!(sv_dot3(opt.light_dir, opt.light_dir) > 0)) {
        opt.light_dir[0] = 0.2;
        opt.light_dir[1] = 0.9;
        opt.light_dir[2] = 0.4;
    }
    sv_normalize3(opt.light_dir);

    uint32_t n = lod->quad_count;
    sv_status st = SV_OK;
    quad_job *jobs = sv_calloc(n ? n : 1, sizeof *jobs);
    sv_chart *charts = sv_calloc(n ? n : 1, sizeof *charts);
    double *half = sv_calloc(n ? 2 * (size_t)n : 1, sizeof *half);
    out->uv_rects = sv_calloc(n ? 4 * (size_t)n : 1, sizeof *out->uv_rects);
    uint8_t *mask = NULL;
    sv_image lin = {0};
    ao_views ao;
    side_views sides;
    bool have_ao = false, have_sides = false;
    if (!jobs || !charts || !half || !out->uv_rects) {
        st = sv_fail(err, SV_ERR_NOMEM, "bake: out of memory for %u quads", n);
        goto out;
    }
    out->quad_count = n;
    for (uint32_t i = 0; i < n; i++) {
        const sv_quad *q = &lod->quads[i];
        if (!(q->half_u >= 0) || !(q->half_v >= 0) || !isfinite(q->half_u) ||
            !isfinite(q->half_v) || !isfinite(q->d)) {
            st = sv_fail(err, SV_ERR_INTERNAL, "bake: quad %u of %s has bad extents", i, lod->name);
            goto out;
        }
        if ((st = select_faces(src, q, i, opt.tri_part, &jobs[i], err)) != SV_OK) goto out;
        half[2 * i] = q->half_u;
        half[2 * i + 1] = q->half_v;
    }

    /* Texel density and layout (pack). */
    double tp0 = sv_now();
    double texel = opt.texel_size;
    if (n && !(texel > 0) &&
        (st = sv_atlas_choose_texel(half, n, opt.padding, opt.max_atlas, &texel, err)) != SV_OK)
        goto out;
    if (!(opt.texel_size > 0) && opt.texel_floor > texel) texel = opt.texel_floor;
    if (!(texel > 0)) texel = 1.0;
    uint32_t aw = 1, ah = 1;
    for (uint32_t i = 0; i < n; i++)
        sv_chart_size(half[2 * i], half[2 * i + 1], texel, &charts[i].w, &charts[i].h);
    /* Packing is a heuristic, not monotone in the chart sizes: the texel
     * floor, a hair coarser than the finest texel that packed, can fail to
     * pack (decorativePlant's 8 clusters in 512²). A chosen (not given)
     * texel then grows by 2 % until the charts fit. */
    for (int grow = 0; n && !(opt.texel_size > 0) && grow < 64 &&
                       !sv_atlas_fit(charts, n, opt.padding, opt.max_atlas, &aw, &ah);
         grow++) {
        texel *= 1.02;
        for (uint32_t i = 0; i < n; i++)
            sv_chart_size(half[2 * i], half[2 * i + 1], texel, &charts[i].w, &charts[i].h);
    }
    if (n && !sv_atlas_fit(charts, n, opt.padding, opt.max_atlas, &aw, &ah)) {
        st = sv_fail(err, SV_ERR_LIMIT, "bake: %u charts at texel size %g do not fit a %ux%u atlas",
                     n, texel, opt.max_atlas, opt.max_atlas);
        goto out;
    }
    t_pack = sv_now() - tp0;
    out->texel_size = texel;
    for (uint32_t i = 0; i < n; i++) {
        float *rc = out->uv_rects + 4 * (size_t)i;
        rc[0] = (float)((double)charts[i].x / aw);
        rc[1] = (float)((double)charts[i].y / ah);
        rc[2] = (float)((double)(charts[i].x + charts[i].w) / aw);
        rc[3] = (float)((double)(charts[i].y + charts[i].h) / ah);
    }

    /* Supersampling: the 5th-percentile face covers at least one sample. */
    double p5 = 0;
    if ((st = face_size_p5(src, jobs, n, &p5, err)) != SV_OK) goto out;
    double sf = p5 > 0 ? ceil(texel / p5 - 1e-9) : 1;
    if (opt.coverage_alpha && sf < 4)
        sf = 4; /* coverage needs a few levels between empty and full */
    uint32_t s = sf < 1 ? 1 : sf > opt.max_supersample ? opt.max_supersample : (uint32_t)sf;
    if (s > sv_renderer_max_size(r)) s = sv_renderer_max_size(r);
    if (s > SV_BAKE_TILE_SAMPLES) s = SV_BAKE_TILE_SAMPLES;
    out->supersample = s;

    if (n) {
        if ((st = sv_image_alloc(&out->albedo, aw, ah, 4, 8, err)) != SV_OK ||
            (opt.normal_map && (st = sv_image_alloc(&out->normal, aw, ah, 3, 8, err)) != SV_OK) ||
            (opt.ao_map && (st = sv_image_alloc(&out->ao, aw, ah, 1, 8, err)) != SV_OK) ||
            (opt.depth_map && (st = sv_image_alloc(&out->depth, aw, ah, 1, 16, err)) != SV_OK))
            goto out;
        if ((st = sv_image_alloc(&lin, aw, ah, 4, 16, err)) != SV_OK) goto out;
        mask = sv_calloc((size_t)aw * ah, 1);
        if (!mask) {
            st = sv_fail(err, SV_ERR_NOMEM, "bake: out of memory for a %ux%u mask", aw, ah);
            goto out;
        }
        if (opt.ao_map) {
            if ((st = ao_prepare(r, gsrc, src, &ao, err)) != SV_OK) goto out;
            have_ao = true;
        }
        if ((st = side_prepare(r, gsrc, src, opt.viewer, &sides, err)) != SV_OK) goto out;
        have_sides = true;
        bake_ctx b = {r,
                      gsrc,
                      &opt,
                      s,
                      opt.coverage_alpha ? 0 : opt.alpha_threshold,
                      aw,
                      ah,
                      mask,
                      lin.data,
                      out,
                      have_ao ? &ao : NULL,
                      SV_AO_RES < sv_renderer_max_size(r) ? SV_AO_RES : sv_renderer_max_size(r),
                      {0},
                      &sides,
                      {0}};
        for (int k = 0; k <= SV_BAKE_SIDE_STEPS; k++) {
            double y = -1.0 + 2.0 * k / SV_BAKE_SIDE_STEPS;
            double nv[3] = {sqrt(fmax(0.0, 1 - y * y)), y, 0};
            b.side_w[k] = sv_bake_front_weight(opt.viewer, nv);
        }
        for (uint32_t i = 0; i < n && st == SV_OK; i++)
            st = bake_quad(&b, &lod->quads[i], &jobs[i], &charts[i], err);
        tile_scratch_free(&b.ts);
        if (st != SV_OK) goto out;
        /* Colour (not alpha) for empty texels: pull-push for the albedo, so
         * its mips see a premultiplied mean (a ring dilation carried leaves'
         * darker antialiased edges outward, and its gradients cost PNG bytes);
         * ring dilation for the other maps. */
        if ((st = sv_atlas_fill(&lin, err)) != SV_OK ||
            (st = sv_dilate(&out->normal, mask, 3, opt.dilate, err)) != SV_OK ||
            (st = sv_dilate(&out->ao, mask, 1, opt.dilate, err)) != SV_OK ||
            (st = sv_dilate(&out->depth, mask, 1, opt.dilate, err)) != SV_OK)
            goto out;
        encode_atlas(&lin, &out->albedo);
    }
    st = build_mesh(lod, keep, opt.lit, out, err);
out:
    if (have_ao) ao_free(&ao);
    if (have_sides) side_free(&sides);
    for (uint32_t i = 0; jobs && i < n; i++) free(jobs[i].tris);
    free(jobs);
    free(charts);
    free(half);
    free(mask);
    sv_image_free(&lin);
    if (st != SV_OK) {
        sv_baked_lod_free(out);
        return st;
    }
    out->seconds_pack = t_pack;
    out->seconds_render = sv_now() - t_start - t_pack;
    return SV_OK;
}
