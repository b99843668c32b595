/* octahedral.c — octahedral and hemi-octahedral impostors (
 * octahedral.h has the conventions, docs/methods/octahedral.md the prose).
 *
 * R. Brucks, "Octahedral Impostors" (shaderbits.com, 2018): frames on an
 * octahedron's grid, three frames blended per view by barycentric weight,
 * each sampled through its own frame plane. I. Castaño, "Computing Alpha
 * Mipmaps" (2010): each mip's alpha is scaled so the fraction of texels that
 * pass the 0.5 alpha test equals level 0's, per frame.
 *
 * Pure parts (mapping, selection, the CPU reference runtime, mips, the
 * method) need no GL and link into sylvad; octahedral_bake.c renders the
 * frames through render.h.
 */
#include "octahedral.h"

#include "bake.h"
#include "level.h"
#include "method_ops.h"
#include "vec3.h"

#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- mapping ------------------------------------------------------------- */

static double sgn1(double x)
{
    return x < 0 ? -1.0 : 1.0;
}

void sv_octa_encode(bool hemi, double elev_scale, const double d_in[3], double uv[2])
{
    double d[3] = {d_in[0], d_in[1], d_in[2]};
    if (hemi && d[1] < 0) d[1] = 0;
    if (elev_scale > 0 && elev_scale != 1) d[1] /= elev_scale;
    double s = fabs(d[0]) + fabs(d[1]) + fabs(d[2]);
    if (!(s > 0)) {
        uv[0] = uv[1] = 0;
        return;
    }
    double x = d[0] / s, y = d[1] / s, z = d[2] / s;
    if (hemi) {
        uv[0] = x + z;
        uv[1] = x - z;
    } else if (y >= 0) {
        uv[0] = x;
        uv[1] = z;
    } else {
        uv[0] = (1 - fabs(z)) * sgn1(x);
        uv[1] = (1 - fabs(x)) * sgn1(z);
    }
}

void sv_octa_decode(bool hemi, double elev_scale, const double uv[2], double d[3])
{
    double x, z, y;
    if (hemi) {
        x = 0.5 * (uv[0] + uv[1]);
        z = 0.5 * (uv[0] - uv[1]);
        y = 1 - fabs(x) - fabs(z);
        if (y < 0) y = 0;
    } else {
        x = uv[0];
        z = uv[1];
        y = 1 - fabs(x) - fabs(z);
        if (y < 0) {
            double ox = x;
            x = (1 - fabs(z)) * sgn1(ox);
            z = (1 - fabs(ox)) * sgn1(z);
        }
    }
    d[0] = x;
    d[1] = y;
    if (elev_scale > 0) d[1] *= elev_scale;
    d[2] = z;
    sv_normalize3(d);
}

void sv_octa_frame_dir(const sv_octa_grid *g, uint32_t i, uint32_t j, double d[3])
{
    double den = g->n > 1 ? (double)(g->n - 1) : 1.0;
    double uv[2] = {2.0 * i / den - 1.0, 2.0 * j / den - 1.0};
    sv_octa_decode(g->hemi, g->elev_scale, uv, d);
}

void sv_octa_frame_basis(const double d[3], double right[3], double up[3])
{
    double ref[3] = {0, 1, 0};
    if (fabs(d[1]) > 0.9999) {
        ref[1] = 0;
        ref[2] = d[1] > 0 ? -1 : 1;
    }
    sv_cross3(ref, d, right);
    sv_normalize3(right);
    sv_cross3(d, right, up);
    sv_normalize3(up);
}

void sv_octa_select(const sv_octa_grid *g, const double view_dir[3], uint32_t frames[3][2],
                    double w[3])
{
    double uv[2];
    sv_octa_encode(g->hemi, g->elev_scale, view_dir, uv);
    double m = g->n > 1 ? (double)(g->n - 1) : 0.0;
    double gx = (uv[0] * 0.5 + 0.5) * m, gy = (uv[1] * 0.5 + 0.5) * m;
    double top = g->n >= 2 ? (double)(g->n - 2) : 0.0;
    double cx = fmin(floor(gx), top), cy = fmin(floor(gy), top);
    if (cx < 0) cx = 0;
    if (cy < 0) cy = 0;
    double fx = gx - cx, fy = gy - cy;
    uint32_t ix = (uint32_t)cx, iy = (uint32_t)cy;
    uint32_t nx = g->n > 1 ? ix + 1 : ix, ny = g->n > 1 ? iy + 1 : iy;
    if (fx + fy <= 1) {
        frames[0][0] = ix, frames[0][1] = iy, w[0] = 1 - fx - fy;
        frames[1][0] = nx, frames[1][1] = iy, w[1] = fx;
        frames[2][0] = ix, frames[2][1] = ny, w[2] = fy;
    } else {
        frames[0][0] = nx, frames[0][1] = ny, w[0] = fx + fy - 1;
        frames[1][0] = nx, frames[1][1] = iy, w[1] = 1 - fy;
        frames[2][0] = ix, frames[2][1] = ny, w[2] = 1 - fx;
    }
}

/* ---- fitting ------------------------------------------------------------- */

sv_status sv_octa_fit(const sv_mesh *m, uint32_t n, bool hemi, double elev_scale, sv_octa_grid *g,
                      sv_error *err)
{
    double mn[3], mx[3];
    if (!m || !sv_mesh_bounds(m, mn, mx))
        return sv_fail(err, SV_ERR_UNBAKEABLE, "octahedral: the mesh has no vertices");
    if (n < 2 || n > SV_OCTA_MAX_GRID)
        return sv_fail(err, SV_ERR_SPEC, "octahedral.grid: %u outside [2, %d]", n,
                       SV_OCTA_MAX_GRID);
    memset(g, 0, sizeof *g);
    g->n = n;
    g->hemi = hemi;
    g->proxy_quads = SV_OCTA_PROXY_QUADS;
    g->elev_scale = elev_scale > 0 && elev_scale <= 1 ? elev_scale : 1.0;
    for (int k = 0; k < 3; k++) g->centre[k] = 0.5 * (mn[k] + mx[k]);
    /* the vertices triangles use; a frame's extent is the largest |Δ·right|,
     * |Δ·up| over them, and the square frame takes the largest of every frame */
    uint8_t *used = sv_calloc(m->vertex_count ? m->vertex_count : 1, 1);
    if (!used) return sv_fail(err, SV_ERR_NOMEM, "octahedral: out of memory");
    for (size_t i = 0; i < (size_t)m->triangle_count * 3; i++) used[m->indices[i]] = 1;
    double half = 0;
    for (uint32_t j = 0; j < n; j++)
        for (uint32_t i = 0; i < n; i++) {
            double d[3], r[3], u[3];
            sv_octa_frame_dir(g, i, j, d);
            sv_octa_frame_basis(d, r, u);
            for (uint32_t v = 0; v < m->vertex_count; v++) {
                if (!used[v] && m->triangle_count) continue;
                const float *p = &m->positions[3 * (size_t)v];
                double q[3] = {p[0] - g->centre[0], p[1] - g->centre[1], p[2] - g->centre[2]};
                double a = fabs(sv_dot3(q, r)), b = fabs(sv_dot3(q, u));
                if (a > half) half = a;
                if (b > half) half = b;
            }
        }
    free(used);
    /* one texel of margin at 256 texels a frame, and never zero */
    double ext = fmax(fmax(mx[0] - mn[0], mx[1] - mn[1]), mx[2] - mn[2]);
    g->half = half * (1.0 + 1.0 / 128.0) + 1e-6 * (ext > 0 ? ext : 1.0);
    return SV_OK;
}

/* ---- the CPU reference runtime ------------------------------------------- */

typedef struct octa_frame {
    double d[3], r[3], u[3];
    uint32_t i, j;
    double w;
} octa_frame;

/* The four texels (atlas offsets) and weights a GPU's LINEAR filter uses
 * at local (s, t) in [0,1]² of frame (i, j) (t = 0 at the frame's top),
 * texel centres clamped inside the frame. W: the atlas width. */
typedef struct bilinear {
    size_t at[4];
    double w[4];
} bilinear;

static void bilinear_at(uint32_t W, uint32_t F, uint32_t i, uint32_t j, double s, double t,
                        bilinear *b)
{
    double x = s * F - 0.5, y = t * F - 0.5;
    if (x < 0) x = 0;
    if (y < 0) y = 0;
    if (x > F - 1) x = F - 1;
    if (y > F - 1) y = F - 1;
    uint32_t x0 = (uint32_t)x, y0 = (uint32_t)y;
    uint32_t x1 = x0 + 1 < F ? x0 + 1 : x0, y1 = y0 + 1 < F ? y0 + 1 : y0;
    double fx = x - x0, fy = y - y0;
    size_t r0 = (size_t)(j * F + y0) * W + i * F, r1 = (size_t)(j * F + y1) * W + i * F;
    b->at[0] = r0 + x0, b->at[1] = r0 + x1, b->at[2] = r1 + x0, b->at[3] = r1 + x1;
    b->w[0] = (1 - fx) * (1 - fy), b->w[1] = fx * (1 - fy);
    b->w[2] = (1 - fx) * fy, b->w[3] = fx * fy;
}

/* Bilinear sample of frame (i, j) at (s, t): straight colour (decoded from
 * sRGB before filtering, as a glTF engine samples it), alpha and depth each
 * interpolated on their own. Returns alpha in [0,1]; prem[3]
 * receives the interpolated colour × that alpha, *depth the interpolated
 * depth value (0.5 without a depth map). */
static double sample_frame(const sv_image *a, uint32_t F, uint32_t i, uint32_t j, double s,
                           double t, double prem[3], const sv_image *depth_map, double *depth)
{
    bilinear b;
    bilinear_at(a->width, F, i, j, s, t, &b);
    const uint8_t *px = a->data;
    const uint16_t *dp = depth_map ? depth_map->data : NULL;
    double alpha = 0, dep = 0, c[3] = {0, 0, 0};
    for (int k = 0; k < 4; k++) {
        const uint8_t *p = px + 4 * b.at[k];
        alpha += p[3] / 255.0 * b.w[k];
        for (int m = 0; m < 3; m++) c[m] += sv_srgb_decode8(p[m]) * b.w[k];
        if (dp) dep += dp[b.at[k]] / 65535.0 * b.w[k];
    }
    for (int m = 0; m < 3; m++) prem[m] = c[m] * alpha;
    if (depth) *depth = dp ? dep : 0.5;
    return alpha;
}

/* Bilinear depth value in [0,1] of frame (i, j) at (s, t), as sample_frame. */
static double sample_depth(const uint16_t *dp, uint32_t W, uint32_t F, uint32_t i, uint32_t j,
                           double s, double t)
{
    bilinear b;
    bilinear_at(W, F, i, j, s, t, &b);
    double v = 0;
    for (int k = 0; k < 4; k++) v += dp[b.at[k]] * b.w[k];
    return v / 65535.0;
}

typedef struct render_job {
    const sv_octa_grid *g;
    const sv_image *albedo, *depth_map;
    const sv_camera *cam;
    octa_frame f[3];
    double base[3][3], ex[3][3], ey[3][3], dr[3], du[3], dd[3], fwd[3], cut;
    uint32_t w, h, y0, y1;
    uint8_t *out;
    float *depth;
} render_job;

/* Rows [y0, y1) of sv_octa_render. */
static void render_rows(const render_job *J)
{
    const sv_octa_grid *g = J->g;
    const sv_image *albedo = J->albedo, *depth_map = J->depth_map;
    const sv_camera *cam = J->cam;
    const octa_frame *f = J->f;
    const double(*base)[3] = J->base, (*ex)[3] = J->ex, (*ey)[3] = J->ey;
    const double *dr = J->dr, *du = J->du, *dd = J->dd, *fwd = J->fwd, cut = J->cut;
    uint32_t w = J->w, h = J->h, F = g->frame_pixels;
    uint8_t *out = J->out;
    float *depth = J->depth;
    const double inv = 0.5 / g->half;
    const uint16_t *dp = depth_map ? depth_map->data : NULL;
    for (uint32_t y = J->y0; y < J->y1; y++)
        for (uint32_t x = 0; x < w; x++) {
            double sx = (2.0 * (x + 0.5) / w - 1.0) * cam->half_width;
            double sy = (1.0 - 2.0 * (y + 0.5) / h) * cam->half_height;
            double a = 0, prem[3] = {0, 0, 0}, hsum = 0, psum[3] = {0, 0, 0};
            for (int k = 0; k < 3; k++) {
                if (f[k].w <= 0 || dd[k] <= 1e-4) continue;
                double a0 = base[k][0] + sx * ex[k][0] + sy * ey[k][0];
                double qr = base[k][1] + sx * ex[k][1] + sy * ey[k][1];
                double qu = base[k][2] + sx * ex[k][2] + sy * ey[k][2];
                /* parallax (octahedral.h): start on the frame plane, move to
                 * the ray's point at the height the depth map gives where the
                 * last point projects, SV_OCTA_PARALLAX_STEPS times */
                double hgt = 0, s = 0, t = 0, pr = 0, pu = 0;
                bool inside = true;
                for (int it = 0; it <= (dp ? SV_OCTA_PARALLAX_STEPS : 0); it++) {
                    double tt = (a0 - hgt) / dd[k];
                    pr = qr - tt * dr[k];
                    pu = qu - tt * du[k];
                    s = pr * inv + 0.5;
                    t = 0.5 - pu * inv;
                    inside = s >= 0 && s <= 1 && t >= 0 && t <= 1;
                    if (!inside || !dp || it == SV_OCTA_PARALLAX_STEPS) break;
                    hgt = (sample_depth(dp, depth_map->width, F, f[k].i, f[k].j, s, t) - 0.5) *
                          2.0 * g->half;
                }
                if (!inside) continue;
                double c[3], dv = 0.5;
                double ak = sample_frame(albedo, F, f[k].i, f[k].j, s, t, c, depth_map, &dv);
                if (!(ak > 0)) continue;
                a += f[k].w * ak;
                for (int m = 0; m < 3; m++) prem[m] += f[k].w * c[m];
                /* the surface point, relative to the centre: P + h·d_k with P
                 * on the frame plane (right, up coordinates pr, pu) */
                double hh = (dv - 0.5) * 2.0 * g->half, wk = f[k].w * ak;
                for (int m = 0; m < 3; m++)
                    psum[m] += wk * (pr * f[k].r[m] + pu * f[k].u[m] + hh * f[k].d[m]);
                hsum += wk;
            }
            size_t oi = (size_t)y * w + x;
            if (a >= cut) {
                for (int m = 0; m < 3; m++) {
                    out[4 * oi + m] = sv_srgb_encode8(prem[m] / a);
                }
                out[4 * oi + 3] = 255;
                if (depth) {
                    double wp[3];
                    for (int m = 0; m < 3; m++)
                        wp[m] = psum[m] / hsum + g->centre[m] - cam->origin[m];
                    depth[oi] = (float)sv_dot3(wp, fwd);
                }
            } else if (depth) {
                depth[oi] = INFINITY;
            }
        }
}

static void *render_rows_thread(void *arg)
{
    render_rows(arg);
    return NULL;
}

sv_status sv_octa_render(const sv_octa_grid *g, const sv_image *albedo, const sv_image *depth_map,
                         const sv_camera *cam, uint32_t w, uint32_t h, sv_image *rgba, float *depth,
                         sv_error *err)
{
    memset(rgba, 0, sizeof *rgba);
    uint32_t F = g->frame_pixels;
    if (!albedo || !albedo->data || albedo->channels != 4 || albedo->bits != 8 || !F ||
        albedo->width != g->n * F || albedo->height != g->n * F)
        return sv_fail(err, SV_ERR_INTERNAL, "octahedral: atlas is not %u frames of %u texels",
                       g->n, F);
    if (depth_map && (!depth_map->data || depth_map->bits != 16 || depth_map->channels != 1 ||
                      depth_map->width != albedo->width || depth_map->height != albedo->height))
        depth_map = NULL;
    sv_status st = sv_image_alloc(rgba, w, h, 4, 8, err);
    if (st) return st;
    double fwd[3];
    sv_cross3(cam->up, cam->right, fwd);       /* sv_camera_forward, without linking GL */
    double D[3] = {-fwd[0], -fwd[1], -fwd[2]}; /* towards the viewer (orthographic) */
    uint32_t fr[3][2];
    double wt[3];
    sv_octa_select(g, D, fr, wt);
    octa_frame f[3];
    for (int k = 0; k < 3; k++) {
        f[k].i = fr[k][0];
        f[k].j = fr[k][1];
        f[k].w = wt[k];
        sv_octa_frame_dir(g, f[k].i, f[k].j, f[k].d);
        sv_octa_frame_basis(f[k].d, f[k].r, f[k].u);
    }
    /* Per frame, everything along a pixel's ray is linear in the pixel's
     * offsets (sx, sy) from the camera origin: q·d_k, q·right_k, q·up_k. */
    render_job J;
    memset(&J, 0, sizeof J);
    J.cut = g->cutoff > 0 ? g->cutoff : 0.5;
    double o[3] = {cam->origin[0] - g->centre[0], cam->origin[1] - g->centre[1],
                   cam->origin[2] - g->centre[2]};
    for (int k = 0; k < 3; k++) {
        const double *ax[3] = {f[k].d, f[k].r, f[k].u};
        for (int a = 0; a < 3; a++) {
            J.base[k][a] = sv_dot3(o, ax[a]);
            J.ex[k][a] = sv_dot3(cam->right, ax[a]);
            J.ey[k][a] = sv_dot3(cam->up, ax[a]);
        }
        J.dd[k] = sv_dot3(D, f[k].d);
        J.dr[k] = sv_dot3(D, f[k].r);
        J.du[k] = sv_dot3(D, f[k].u);
    }
    J.g = g;
    J.albedo = albedo;
    J.depth_map = depth_map;
    J.cam = cam;
    memcpy(J.f, f, sizeof f);
    memcpy(J.fwd, fwd, sizeof fwd);
    J.w = w;
    J.h = h;
    J.out = rgba->data;
    J.depth = depth;
    /* two halves of the rows on two threads (each pixel on its own: the
     * same bytes whatever the split); one thread when it cannot start */
    render_job J2 = J;
    J.y0 = 0;
    J.y1 = h / 2;
    J2.y0 = h / 2;
    J2.y1 = h;
    pthread_t th;
    bool threaded = h >= 64 && pthread_create(&th, NULL, render_rows_thread, &J2) == 0;
    render_rows(&J);
    if (threaded) pthread_join(th, NULL);
    else render_rows(&J2);
    return SV_OK;
}

/* ---- mips (Castaño) ------------------------------------------------------ */

/* Fraction of the frame's texels whose alpha (scaled by k) passes 0.5. */
static double frame_coverage(const uint8_t *a, uint32_t stride, uint32_t x0, uint32_t y0,
                             uint32_t F, double k)
{
    size_t pass = 0;
    for (uint32_t y = 0; y < F; y++)
        for (uint32_t x = 0; x < F; x++)
            if (a[(size_t)(y0 + y) * stride + 4 * (size_t)(x0 + x) + 3] * k >= 127.5) pass++;
    return (double)pass / ((double)F * F);
}

sv_status sv_octa_mip(const sv_octa_grid *g, const sv_image *level0, const sv_image *src,
                      sv_image *dst, sv_error *err)
{
    memset(dst, 0, sizeof *dst);
    uint32_t F = src->width / g->n, F0 = level0->width / g->n;
    if (F < 2 || src->width != g->n * F || src->channels != 4 || src->bits != 8)
        return sv_fail(err, SV_ERR_INTERNAL, "octahedral: cannot halve %u-texel frames", F);
    uint32_t W = src->width / 2;
    sv_status st = sv_image_alloc(dst, W, W, 4, 8, err);
    if (st) return st;
    const uint8_t *s = src->data;
    uint8_t *d = dst->data;
    size_t ss = (size_t)src->width * 4, ds = (size_t)W * 4;
    /* 2×2 box within each frame (frames are whole texel blocks at every level):
     * alpha averaged, colour weighted by alpha (straight colour of the covered
     * texels; the plain mean where all four are empty, which dilation filled),
     * in linear colour, encoded to sRGB again */
    for (uint32_t y = 0; y < W; y++)
        for (uint32_t x = 0; x < W; x++) {
            double a = 0, c[3] = {0, 0, 0}, cp[3] = {0, 0, 0};
            for (int k = 0; k < 4; k++) {
                const uint8_t *p = s + (size_t)(2 * y + (k >> 1)) * ss +
                                   4 * (size_t)(2 * x + (k & 1));
                a += p[3];
                for (int m = 0; m < 3; m++) {
                    double v = sv_srgb_decode8(p[m]);
                    c[m] += v * (double)p[3];
                    cp[m] += v;
                }
            }
            uint8_t *o = d + (size_t)y * ds + 4 * (size_t)x;
            for (int m = 0; m < 3; m++) o[m] = sv_srgb_encode8(a > 0 ? c[m] / a : cp[m] / 4.0);
            o[3] = (uint8_t)lrint(a / 4.0);
        }
    /* alpha scaled per frame so the tested coverage stays level 0's */
    uint32_t Fd = F / 2;
    for (uint32_t j = 0; j < g->n; j++)
        for (uint32_t i = 0; i < g->n; i++) {
            double want = frame_coverage(level0->data, level0->width * 4, i * F0, j * F0, F0, 1.0);
            double lo = 0, hi = 8;
            if (want <= 0) continue;
            for (int it = 0; it < 24; it++) {
                double mid = 0.5 * (lo + hi);
                if (frame_coverage(d, W * 4, i * Fd, j * Fd, Fd, mid) < want) lo = mid;
                else hi = mid;
            }
            /* coverage is a step function of the scale: take the side of
             * the step nearer the goal */
            double c_lo = frame_coverage(d, W * 4, i * Fd, j * Fd, Fd, lo);
            double c_hi = frame_coverage(d, W * 4, i * Fd, j * Fd, Fd, hi);
            double k = fabs(c_lo - want) < fabs(c_hi - want) ? lo : hi;
            for (uint32_t y = 0; y < Fd; y++)
                for (uint32_t x = 0; x < Fd; x++) {
                    uint8_t *o = d + (size_t)(j * Fd + y) * ds + 4 * (size_t)(i * Fd + x);
                    o[3] = (uint8_t)lrint(fmin(255.0, o[3] * k));
                }
        }
    return SV_OK;
}

/* ---- the method ---------------------------------------------------------- */

static sv_status octa_run(const sv_method_input *in, const cJSON *settings, sv_stand_in *out,
                          sv_error *err)
{
    octa_settings s;
    sv_status st = octa_parse(settings, &s, err);
    if (st) return st;
    if (!in->mesh || in->mesh->triangle_count == 0)
        return sv_fail(err, SV_ERR_UNBAKEABLE, "octahedral: the mesh has no triangles");
    bool hemi = s.hemi_set ? s.hemi : (in->scene && in->scene->viewer == SV_VIEWER_GROUND);
    uint32_t n = s.grid ? (uint32_t)s.grid : (hemi ? 8u : 12u);
    sv_octa_grid *g = calloc(1, sizeof *g);
    if (!g) return sv_fail(err, SV_ERR_NOMEM, "octahedral: out of memory");
    /* ground viewers look from 0–20°: the rings go nearer the horizon */
    double es = s.elev_scale > 0                                     ? s.elev_scale
                : in->scene && in->scene->viewer == SV_VIEWER_GROUND ? SV_OCTA_GROUND_SCALE
                                                                     : 1.0;
    if ((st = sv_octa_fit(in->mesh, n, hemi, es, g, err))) {
        free(g);
        return st;
    }
    g->frame_pixels = (uint32_t)s.frame_pixels; /* 0: the pipeline sizes it */
    g->proxy_quads = (uint32_t)s.proxy_quads;
    char name[32];
    snprintf(name, sizeof name, "%s%u", hemi ? "hocta" : "octa", n);
    sv_lod_plan *l = sv_stand_in_add_lod(out, name);
    if (!l) {
        free(g);
        return sv_fail(err, SV_ERR_NOMEM, "octahedral: out of memory");
    }
    l->payload = g; /* its hooks: sv_octa_level_ops (octahedral_level.c) */
    l->trunk = SV_TRUNK_NONE;
    return SV_OK;
}

uint32_t sv_octa_frame_pixels(uint32_t n, uint32_t largest_pixels, double texels_per_pixel,
                              uint32_t max_atlas)
{
    uint32_t f = SV_OCTA_MIN_FRAME_PIXELS;
    uint32_t want = (uint32_t)(texels_per_pixel * largest_pixels);
    while (f < want && f < 1024) f *= 2;
    uint32_t cap = max_atlas ? max_atlas : 2048;
    while (f > SV_OCTA_MIN_FRAME_PIXELS && (uint64_t)f * n > cap) f /= 2;
    return f;
}

cJSON *sv_octa_impostor_json(const sv_octa_grid *g, const char *lod, const char *node,
                             const char maps[4][64], uint32_t mip_count)
{
    cJSON *o = cJSON_CreateObject();
    if (!o) return NULL;
    cJSON_AddStringToObject(o, "lod", lod);
    cJSON_AddStringToObject(o, "node", node);
    cJSON_AddStringToObject(o, "layout", g->hemi ? "hemi-octahedral" : "octahedral");
    cJSON_AddBoolToObject(o, "hemi", g->hemi);
    /* 1 = Brucks' layout; below 1 the rings lie nearer the horizon (octahedral.h) */
    cJSON_AddNumberToObject(o, "elevation_scale", g->elev_scale > 0 ? g->elev_scale : 1.0);
    cJSON_AddNumberToObject(o, "grid", g->n);
    cJSON_AddNumberToObject(o, "frame_pixels", g->frame_pixels);
    cJSON_AddItemToObject(o, "centre", cJSON_CreateDoubleArray(g->centre, 3));
    cJSON_AddNumberToObject(o, "half", g->half);
    /* a camera-facing square of this half size holds every frame plane's
     * footprint (a frame square of half `half` seen at any angle) */
    cJSON_AddNumberToObject(o, "billboard_half", g->half * sqrt(2.0));
    cJSON_AddNumberToObject(o, "alpha_cutoff", 0.5);
    cJSON_AddStringToObject(o, "up", "+Y");
    cJSON *mo = cJSON_AddObjectToObject(o, "maps");
    static const char *const keys[4] = {"albedo", "normal", "ao", "depth"};
    for (int k = 0; k < 4; k++)
        if (maps[k][0]) cJSON_AddStringToObject(mo, keys[k], maps[k]);
    cJSON *mips = cJSON_AddArrayToObject(o, "mips");
    cJSON_AddItemToArray(mips, cJSON_CreateString(maps[0]));
    for (uint32_t k = 1; k <= mip_count; k++) {
        char f[128];
        snprintf(f, sizeof f, "atlas_%s_albedo_mip%u.png", lod, k);
        cJSON_AddItemToArray(mips, cJSON_CreateString(f));
    }
    return o;
}

/* method.h planes_json: the proxy's quads (quad q: the baked mesh's
 * vertices 4q..4q+3, in the plane of its frame, with that frame's atlas
 * rectangle) and "impostor": true; impostor.json has the rest. */
static void octa_planes_json(const sv_lod_plan *lod, const sv_baked_lod *b,
                             uint32_t source_triangles, cJSON *entry, cJSON *quads)
{
    if (!lod->payload || !b->uv_rects || b->mesh->vertex_count < 4 * b->quad_count) return;
    const float *P = b->mesh->positions, *N = b->mesh->normals;
    for (uint32_t q = 0; q < b->quad_count; q++) {
        double n[3] = {N[12 * q], N[12 * q + 1], N[12 * q + 2]}, c[4][3];
        for (int k = 0; k < 4; k++)
            for (int m = 0; m < 3; m++) c[k][m] = P[12 * q + 3 * k + m];
        cJSON *qo = cJSON_CreateObject();
        cJSON_AddItemToObject(qo, "normal", cJSON_CreateDoubleArray(n, 3));
        /* the plane through the quad (it passes through the trunk's axis) */
        cJSON_AddNumberToObject(qo, "d", -(n[0] * c[0][0] + n[1] * c[0][1] + n[2] * c[0][2]));
        cJSON *ca = cJSON_AddArrayToObject(qo, "corners");
        for (int k = 0; k < 4; k++) cJSON_AddItemToArray(ca, cJSON_CreateDoubleArray(c[k], 3));
        const float *uv = b->uv_rects + 4 * q;
        double uvd[4] = {uv[0], uv[1], uv[2], uv[3]};
        cJSON_AddItemToObject(qo, "uv", cJSON_CreateDoubleArray(uvd, 4));
        cJSON_AddNumberToObject(qo, "faces", source_triangles);
        cJSON_AddStringToObject(qo, "part", "all");
        cJSON_AddItemToArray(quads, qo);
    }
    cJSON_AddBoolToObject(entry, "impostor", true);
}

const sv_method_ops sv_method_octahedral_ops = {
    .method = &sv_method_octahedral,
    .run = octa_run,
    .planes_json = octa_planes_json,
    .levels = &sv_octa_level_ops,
};
