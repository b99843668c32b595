/* octahedral_bake.c — renders an octahedral impostor's frames (octahedral.h;
 * R. Brucks, "Octahedral Impostors", 2018: one orthographic view per grid
 * direction). Separate from octahedral.c so the daemon, which validates
 * settings through the method registry, does not link GL. */
#include "octahedral.h"

#include "classify.h"
#include "parallel.h"

#include "vec3.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- baking -------------------------------------------------------------- */

/* Fills the colour and depth of empty texels (alpha 0) of each frame from
 * the nearest covered texel (8-connected breadth-first search from every
 * covered texel at once, in texel order: deterministic), so bilinear
 * filtering and mips do not pull in black and the runtime's parallax search
 * finds a surface beside a leaf. Frames stay separate. One pass over the
 * atlas. */
static sv_status dilate_frames(sv_image *img, sv_image *depth, uint32_t F, sv_error *err)
{
    uint32_t W = img->width;
    uint8_t *px = img->data;
    uint16_t *dp = depth ? depth->data : NULL;
    size_t N = (size_t)W * W;
    uint32_t *queue = sv_calloc(N ? N : 1, sizeof *queue);
    uint8_t *known = sv_calloc(N ? N : 1, 1);
    if (!queue || !known) {
        free(queue);
        free(known);
        return sv_fail(err, SV_ERR_NOMEM, "octahedral: out of memory for dilation");
    }
    size_t head = 0, tail = 0;
    for (size_t i = 0; i < N; i++)
        if (px[4 * i + 3] > 0) {
            known[i] = 1;
            queue[tail++] = (uint32_t)i;
        }
    while (head < tail) {
        uint32_t i = queue[head++];
        uint32_t x = i % W, y = i / W, fx0 = x / F * F, fy0 = y / F * F;
        for (int dy = -1; dy <= 1; dy++)
            for (int dx = -1; dx <= 1; dx++) {
                int xx = (int)x + dx, yy = (int)y + dy;
                if (xx < (int)fx0 || yy < (int)fy0 || xx >= (int)(fx0 + F) || yy >= (int)(fy0 + F))
                    continue;
                size_t k = (size_t)yy * W + (size_t)xx;
                if (known[k]) continue;
                known[k] = 1;
                memcpy(px + 4 * k, px + 4 * (size_t)i, 3);
                if (dp) dp[k] = dp[i];
                queue[tail++] = (uint32_t)k;
            }
    }
    free(queue);
    free(known);
    return SV_OK;
}

/* Floyd–Steinberg error diffusion of each frame's coverage alpha into
 * binary alpha (serpentine rows, within the frame): the alpha test then
 * keeps the local coverage of leaves smaller than a texel instead of
 * turning a 0.3-covered crown into nothing and a 0.6-covered one into a
 * solid blob. */
static sv_status halftone_frames(sv_image *img, uint32_t n, uint32_t F, sv_error *err)
{
    uint32_t W = img->width;
    uint8_t *px = img->data;
    float *e = sv_calloc(2 * ((size_t)F + 2), sizeof *e);
    if (!e) return sv_fail(err, SV_ERR_NOMEM, "octahedral: out of memory");
    for (uint32_t j = 0; j < n; j++)
        for (uint32_t i = 0; i < n; i++) {
            memset(e, 0, 2 * ((size_t)F + 2) * sizeof *e);
            float *cur = e + 1, *nxt = e + F + 3;
            for (uint32_t y = 0; y < F; y++) {
                bool ltr = (y & 1) == 0;
                for (uint32_t k = 0; k < F; k++) {
                    uint32_t x = ltr ? k : F - 1 - k;
                    uint8_t *p = px + 4 * ((size_t)(j * F + y) * W + i * F + x);
                    float v = p[3] / 255.0f + cur[x];
                    float o = v >= 0.5f ? 1.0f : 0.0f;
                    if (p[3] == 0) o = 0; /* never cover a texel nothing touched */
                    float q = v - o;
                    p[3] = o > 0 ? 255 : 0;
                    int dx = ltr ? 1 : -1;
                    cur[(int)x + dx] += q * 7.0f / 16.0f;
                    nxt[(int)x - dx] += q * 3.0f / 16.0f;
                    nxt[x] += q * 5.0f / 16.0f;
                    nxt[(int)x + dx] += q * 1.0f / 16.0f;
                }
                float *t = cur;
                cur = nxt;
                nxt = t;
                memset(nxt - 1, 0, ((size_t)F + 2) * sizeof *nxt);
            }
        }
    free(e);
    return SV_OK;
}

/* One octahedral bake's frame drawing (sv_octa_bake), shared by its chunks. */
#define SV_OCTA_BAKE_THREADS 2 /* GL contexts drawing frames at once: the cores */
typedef struct frames_job {
    sv_renderer *r;
    const sv_gpu_mesh *gsrc;
    const sv_mesh *src;
    const sv_octa_grid *g;
    const sv_bake_options *opt;
    const sv_render_options *ro, *rn;
    uint32_t ss, F, B, W;
    double reach;
    sv_baked_lod *out;
    sv_status st[SV_PARALLEL_MAX];
    sv_error err[SV_PARALLEL_MAX];
} frames_job;

/* Draws frames [lo, hi) (k = j·n + i) with ren and gm into J->out: the
 * colour and depth box-filtered ss × ss into the frame's texels. */
static sv_status draw_frames(const frames_job *J, sv_renderer *ren, const sv_gpu_mesh *gm,
                             uint32_t lo, uint32_t hi, sv_error *err)
{
    const sv_octa_grid *g = J->g;
    const sv_bake_options *opt = J->opt;
    const sv_render_options *ro = J->ro, *rn = J->rn;
    uint32_t ss = J->ss, F = J->F, B = J->B, W = J->W, n = g->n;
    double reach = J->reach;
    sv_baked_lod *out = J->out;
    float *dbuf = sv_calloc((size_t)B * B, sizeof *dbuf);
    if (!dbuf) return sv_fail(err, SV_ERR_NOMEM, "octahedral: out of memory");
    sv_status st = SV_OK;
    for (uint32_t k = lo; k < hi && !st; k++) {
        uint32_t i = k % n, j = k / n;
        double d[3];
        sv_camera cam;
        sv_octa_frame_dir(g, i, j, d);
        sv_octa_frame_basis(d, cam.right, cam.up);
        memcpy(cam.origin, g->centre, sizeof cam.origin);
        cam.half_width = cam.half_height = g->half;
        cam.near_dist = -reach;
        cam.far_dist = reach;
        sv_image img = {0}, nimg = {0};
        if ((st = sv_render(ren, gm, NULL, 0, &cam, ro, B, B, &img, dbuf, err))) break;
        if (opt->normal_map &&
            (st = sv_render(ren, gm, NULL, 0, &cam, rn, B, B, &nimg, NULL, err))) {
            sv_image_free(&img);
            break;
        }
        /* box filter ss × ss: alpha = covered fraction, colour = mean of
         * the covered samples in linear (the render is linear RGBA16),
         * encoded to sRGB once, depth = mean over covered samples */
        const uint16_t *ip = img.data;
        const uint8_t *np = nimg.data;
        for (uint32_t y = 0; y < F; y++)
            for (uint32_t x = 0; x < F; x++) {
                double c[3] = {0, 0, 0}, nn[3] = {0, 0, 0}, dep = 0;
                uint32_t cov = 0;
                for (uint32_t sy = 0; sy < ss; sy++)
                    for (uint32_t sx = 0; sx < ss; sx++) {
                        size_t k = (size_t)(y * ss + sy) * B + (x * ss + sx);
                        if (ip[4 * k + 3] < 32768) continue;
                        cov++;
                        for (int m = 0; m < 3; m++) c[m] += ip[4 * k + m];
                        if (np)
                            for (int m = 0; m < 3; m++) nn[m] += np[4 * k + m];
                        dep += dbuf[k];
                    }
                size_t o = (size_t)(j * F + y) * W + (i * F + x);
                uint8_t *a = (uint8_t *)out->albedo.data + 4 * o;
                if (cov) {
                    for (int m = 0; m < 3; m++) a[m] = sv_srgb_encode8(c[m] / cov / 65535.0);
                    a[3] = (uint8_t)lrint(255.0 * cov / (ss * ss));
                } else {
                    a[0] = a[1] = a[2] = a[3] = 0;
                }
                if (np) {
                    uint8_t *q = (uint8_t *)out->normal.data + 3 * o;
                    for (int m = 0; m < 3; m++) q[m] = cov ? (uint8_t)lrint(nn[m] / cov) : 128;
                    if (!cov) q[2] = 255;
                }
                if (out->depth.data) {
                    /* sv_render's depth runs along forward = −d: s = −depth */
                    double s = cov ? -dep / cov : 0;
                    double v = 0.5 + 0.5 * s / g->half;
                    v = fmin(1.0, fmax(0.0, v));
                    ((uint16_t *)out->depth.data)[o] = (uint16_t)lrint(v * 65535.0);
                }
            }
        sv_image_free(&img);
        sv_image_free(&nimg);
    }
    free(dbuf);
    return st;
}

/* parallel.h chunk t: chunk 0 on the bake's renderer; another on a context
 * of its own (SV_ERR_RENDER in J->st[t] when none could be made: the caller
 * draws the chunk itself). */
static void frames_chunk(void *ctx, uint32_t t, uint32_t lo, uint32_t hi)
{
    frames_job *J = ctx;
    if (t == 0) {
        J->st[0] = draw_frames(J, J->r, J->gsrc, lo, hi, &J->err[0]);
        return;
    }
    sv_renderer *ren = NULL;
    sv_gpu_mesh *gm = NULL;
    if (sv_renderer_create(J->B, &ren, &J->err[t]) != SV_OK || sv_renderer_max_size(ren) < J->B ||
        sv_gpu_mesh_upload(ren, J->src, &gm, &J->err[t]) != SV_OK) {
        J->st[t] = SV_ERR_RENDER;
    } else {
        J->st[t] = draw_frames(J, ren, gm, lo, hi, &J->err[t]);
    }
    sv_gpu_mesh_free(gm);
    sv_renderer_destroy(ren);
}

sv_status sv_octa_bake(sv_renderer *r, const sv_gpu_mesh *gsrc, const sv_mesh *src,
                       const sv_octa_grid *g, const sv_bake_options *opt, uint32_t supersample,
                       sv_baked_lod *out, sv_error *err)
{
    memset(out, 0, sizeof *out);
    double t0 = sv_now();
    uint32_t F = g->frame_pixels, n = g->n;
    if (!F || n < 2 || n > SV_OCTA_MAX_GRID || (uint64_t)F * n > 16384)
        return sv_fail(err, SV_ERR_SPEC, "octahedral: %u frames of %u texels do not fit an atlas",
                       n, F);
    uint32_t ss = supersample ? supersample : 2;
    uint32_t rmax = sv_renderer_max_size(r);
    while (ss > 1 && (uint64_t)F * ss > rmax) ss--;
    uint32_t B = F * ss, W = F * n;
    sv_status st = sv_image_alloc(&out->albedo, W, W, 4, 8, err);
    if (!st && opt->normal_map) st = sv_image_alloc(&out->normal, W, W, 3, 8, err);
    /* the depth map always: the runtime's parallax search reads it */
    if (!st) st = sv_image_alloc(&out->depth, W, W, 1, 16, err);
    double mn[3], mx[3], reach = 0;
    sv_mesh_bounds(src, mn, mx);
    for (int k = 0; k < 3; k++) reach += 0.25 * (mx[k] - mn[k]) * (mx[k] - mn[k]);
    reach = sqrt(reach) * 1.01 + 1e-6;
    sv_render_options ro = {.shade = opt->lit ? SV_SHADE_LIT : SV_SHADE_ALBEDO, .linear = true};
    memcpy(ro.light_dir, opt->light_dir, sizeof ro.light_dir);
    if (opt->lit && !(sv_dot3(ro.light_dir, ro.light_dir) > 0)) {
        ro.light_dir[0] = 0.2, ro.light_dir[1] = 0.9, ro.light_dir[2] = 0.4;
        sv_normalize3(ro.light_dir);
    }
    sv_render_options rn = {.shade = SV_SHADE_NORMAL};
    frames_job J = {r, gsrc, src, g, opt, &ro, &rn, ss, F, B, W, reach, out, {0}, {{0}}};
    if (!st) {
        /* frames k = j·n + i in two contiguous halves, the second on a thread
         * with its own GL context (parallel.h): each frame's texels are its
         * own, and a frame's pixels do not depend on the context that drew
         * it, so the atlas is the same bytes as one context's; a half whose
         * context could not be made is drawn here afterwards */
        uint32_t chunks = sv_parallel_chunks(n * n, SV_OCTA_BAKE_THREADS);
        sv_parallel_for(n * n, SV_OCTA_BAKE_THREADS, frames_chunk, &J);
        for (uint32_t t = 0; t < chunks && !st; t++) {
            if (J.st[t] == SV_ERR_RENDER && t > 0) { /* no second context: here */
                uint32_t lo = (uint32_t)((uint64_t)n * n * t / chunks);
                uint32_t hi = (uint32_t)((uint64_t)n * n * (t + 1) / chunks);
                J.st[t] = draw_frames(&J, r, gsrc, lo, hi, &J.err[t]);
            }
            if (J.st[t]) {
                *err = J.err[t];
                st = J.st[t];
            }
        }
    }
    if (!st) st = halftone_frames(&out->albedo, n, F, err);
    if (!st) st = dilate_frames(&out->albedo, &out->depth, F, err);
    out->seconds_render = sv_now() - t0;
    out->texel_size = 2.0 * g->half / F;
    out->supersample = ss;
    if (st) {
        sv_baked_lod_free(out);
        return st;
    }
    /* the proxy: K quads through the centre, quad q in the plane of the
     * frame nearest the side view at azimuth 180°·q/K from +Z, textured
     * with that frame, so a plain glTF viewer shows the tree from every
     * side (an orthographic frame seen from behind has the silhouette of the
     * opposite view); an engine draws the first quad with the impostor
     * shader (docs/runtime.md) */
    uint32_t K = g->proxy_quads >= 1 && g->proxy_quads <= 8 ? g->proxy_quads : SV_OCTA_PROXY_QUADS;
    /* Each quad passes through the trunk's axis, not the bounds' centre: a
     * frame is an orthographic view along d, so sliding its plane along d
     * keeps the picture and puts the points on the plane (the trunk) where
     * they are; through the centre, a trunk off the centre was drawn once
     * per quad, side by side (a trunk drawn twice otherwise). The axis: the mean
     * x, z of the trunk triangles' vertices (none classified: the centre). */
    double axis[3] = {g->centre[0], g->centre[1], g->centre[2]};
    if (opt->tri_part) {
        double sx = 0, sz = 0;
        size_t cnt = 0;
        for (uint32_t t = 0; t < src->triangle_count; t++) {
            if (opt->tri_part[t] != SV_PART_TRUNK) continue;
            for (int k = 0; k < 3; k++) {
                const float *v = &src->positions[3 * (size_t)src->indices[3 * (size_t)t + k]];
                sx += v[0], sz += v[2], cnt++;
            }
        }
        if (cnt) axis[0] = sx / cnt, axis[2] = sz / cnt;
    }
    out->quad_count = K;
    out->uv_rects = sv_calloc(4 * (size_t)K, sizeof *out->uv_rects);
    uint32_t nimg = 1 + (out->normal.data != NULL);
    sv_mesh *m = out->uv_rects ? sv_mesh_create(4 * K, 2 * K, 1, nimg) : NULL;
    if (!m) {
        sv_baked_lod_free(out);
        return sv_fail(err, SV_ERR_NOMEM, "octahedral: out of memory");
    }
    for (uint32_t q = 0; q < K; q++) {
        double az = M_PI * q / K;
        double side[3] = {sin(az), 0, cos(az)};
        uint32_t fr[3][2];
        double wt[3];
        sv_octa_select(g, side, fr, wt);
        int best = 0;
        for (int k = 1; k < 3; k++)
            if (wt[k] > wt[best]) best = k;
        double d[3], rr[3], uu[3];
        sv_octa_frame_dir(g, fr[best][0], fr[best][1], d);
        sv_octa_frame_basis(d, rr, uu);
        double off = (axis[0] - g->centre[0]) * d[0] + (axis[2] - g->centre[2]) * d[2];
        float *rect = out->uv_rects + 4 * q;
        rect[0] = (float)fr[best][0] / n;
        rect[1] = (float)fr[best][1] / n;
        rect[2] = (float)(fr[best][0] + 1) / n;
        rect[3] = (float)(fr[best][1] + 1) / n;
        static const double cu[4] = {-1, 1, 1, -1}, cv[4] = {-1, -1, 1, 1};
        for (int c = 0; c < 4; c++) {
            uint32_t v = 4 * q + (uint32_t)c;
            for (int k = 0; k < 3; k++) {
                m->positions[3 * v + k] = (float)(g->centre[k] + off * d[k] +
                                                  g->half * (cu[c] * rr[k] + cv[c] * uu[k]));
                m->normals[3 * v + k] = (float)d[k];
            }
            m->uvs[2 * v] = rect[0] + (float)(0.5 * (cu[c] + 1)) * (rect[2] - rect[0]);
            m->uvs[2 * v + 1] = rect[1] + (float)(0.5 * (1 - cv[c])) * (rect[3] - rect[1]);
        }
        static const uint32_t tri[6] = {0, 1, 2, 0, 2, 3};
        for (int k = 0; k < 6; k++) m->indices[6 * q + k] = 4 * q + tri[k];
    }
    sv_material *mat = &m->materials[0];
    sv_material_init(mat);
    snprintf(mat->name, sizeof mat->name, "sylva_impostor");
    mat->alpha_mode = SV_ALPHA_MASK;
    mat->alpha_cutoff = 0.5f;
    mat->double_sided = true;
    mat->unlit = opt->lit;
    mat->base_texture = 0;
    st = sv_image_copy(&out->albedo, &m->images[0], err);
    if (!st && out->normal.data) {
        mat->normal_texture = 1;
        st = sv_image_copy(&out->normal, &m->images[1], err);
    }
    out->mesh = m;
    if (st) sv_baked_lod_free(out);
    return st;
}
