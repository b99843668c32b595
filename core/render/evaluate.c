/* evaluate.c — accuracy of a stand-in against the original (see evaluate.h).
 *
 * What every bake measures (docs/accuracy.md; docs/design.md, pipeline
 * step 7): V orthographic views placed by the scene's viewer, supersampled
 * renders box-filtered to each screen size, coverage IoU Σmin/Σmax, colour
 * error on premultiplied colour, depth error relative to the bounding radius.
 * The orbit views are a Fibonacci lattice (Á. González, "Measurement of areas
 * on a sphere using Fibonacci and latitude–longitude lattices", Math. Geosci.
 * 2010, §2); ground and aerial views use the same golden-angle azimuths over an
 * elevation band, uniform in sin(elevation) (equal area per view).
 */
#include "evaluate.h"
#include "image.h"
#include "image_io.h"
#include "vec3.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define DEFAULT_VIEWS 24
#define DEFAULT_SUPERSAMPLE 4
static const uint32_t default_sizes[] = {256, 128, 64, 32};
/* sv_evaluate_cutoffs: samples a filtered pixel at most (16 × 16) */
#define SV_CUTOFF_MAX_BLOCK 256

struct sv_evaluator {
    sv_renderer *r;
    const sv_gpu_mesh *g;
    double centre[3], radius;
    uint32_t view_count, size_count, base;
    uint32_t sizes[SV_EVAL_MAX_SIZES]; /* descending */
    sv_render_options ropt;
    double *dirs;                         /* 3 × view_count */
    sv_eval_image *orig;                  /* view_count × size_count */
    sv_eval_image full;                   /* scratch: one render at base resolution */
    float *depth;                         /* scratch: base × base depth buffer */
    sv_eval_image tmp[SV_EVAL_MAX_SIZES]; /* scratch: one subset, per size */
    double *ftmp;                         /* scratch: the fused filter's rows (filter_render) */
    int src[SV_EVAL_MAX_SIZES]; /* size s > 0 is filtered from size src[s]; -1: from full */
    bool need_full;             /* some size is filtered from full: it is filled every render */
    /* Cropping: most of a view is background, which filters to
     * exact zeros. When every size is filtered by integer factors (the fused
     * filter for the largest, then size from size), the base image is cut
     * into tiles of `tile` × `tile` pixels, tile the lcm of the factors, so
     * each filtered pixel of every size lies in one tile; only the tiles of a
     * row between its first and last covered one are filtered and compared.
     * tile 0: sizes that do not divide, every pixel is processed. */
    uint32_t tile, tiles; /* tile side in base pixels; tiles per side */
    uint32_t *orig_span;  /* view_count × 2·tiles: the original's spans (lo, hi) */
    uint32_t *span;       /* scratch 4 × 2·tiles: where the result's images (acc)
                                          and one subset's (tmp) may be non-zero, the union of
                                          a result's and the original's, a new render's */
};

/* ---- view placement and cameras ----------------------------------------- */

void sv_eval_place_views(sv_viewer viewer, uint32_t n, double *dirs)
{
    const double golden = M_PI * (3.0 - sqrt(5.0));
    double lo, hi;
    bool by_angle;
    sv_viewer_band(viewer, &lo, &hi, &by_angle);
    if (viewer == SV_VIEWER_SIDE) {
        /* ../shared/tools/sveval's helix: azimuth 360°·i/n, elevation from
         * -10° to 40° (the band) with both ends included */
        for (uint32_t i = 0; i < n; i++) {
            double a = 2.0 * M_PI * i / n;
            double el = (n > 1 ? lo + (hi - lo) * i / (n - 1) : (lo + hi) / 2) * M_PI / 180.0;
            dirs[3 * i] = cos(el) * sin(a);
            dirs[3 * i + 1] = sin(el);
            dirs[3 * i + 2] = cos(el) * cos(a);
        }
        return;
    }
    double y_lo = sin(lo * M_PI / 180.0), y_hi = sin(hi * M_PI / 180.0);
    for (uint32_t i = 0; i < n; i++) {
        /* Orbit: top to bottom; bands: bottom to top. Both uniform in y = sin(e). */
        double t = (i + 0.5) / n;
        double y = viewer == SV_VIEWER_ORBIT ? 1.0 - 2.0 * t : y_lo + (y_hi - y_lo) * t;
        double rr = sqrt(fmax(0.0, 1.0 - y * y)), phi = golden * i;
        dirs[3 * i] = rr * cos(phi);
        dirs[3 * i + 1] = y;
        dirs[3 * i + 2] = rr * sin(phi);
    }
}

void sv_eval_camera(const double centre[3], double radius, const double dir[3], sv_camera *cam)
{
    /* forward = up × right must equal -dir: right = ref × dir, up = dir × right. */
    double d[3] = {dir[0], dir[1], dir[2]};
    sv_normalize3(d);
    double ref[3] = {0, 1, 0};
    if (fabs(d[1]) > 0.999) ref[1] = 0, ref[2] = d[1] > 0 ? -1 : 1;
    memset(cam, 0, sizeof *cam);
    sv_cross3(ref, d, cam->right);
    sv_normalize3(cam->right);
    sv_cross3(d, cam->right, cam->up);
    sv_normalize3(cam->up);
    memcpy(cam->origin, centre, sizeof cam->origin);
    cam->half_width = cam->half_height = radius;
    /* a stand-in may stick out of the original's sphere towards or away
     * from the camera (quad corners): keep it, as sveval does (2r) */
    cam->near_dist = -2.0 * radius;
    cam->far_dist = 2.0 * radius;
}

/* ---- image planes -------------------------------------------------------- */

sv_status sv_eval_image_alloc(sv_eval_image *img, uint32_t w, uint32_t h, sv_error *err)
{
    memset(img, 0, sizeof *img);
    size_t n;
    if (!w || !h || !sv_mul_size(w, h, &n) || n > SIZE_MAX / (3 * sizeof(float)))
        return sv_fail(err, SV_ERR_NOMEM, "evaluate: image %ux%u has a bad size", w, h);
    img->coverage = calloc(n, sizeof(float));
    img->color = calloc(3 * n, sizeof(float));
    img->depth = calloc(n, sizeof(float));
    img->lum = calloc(n, sizeof(float));
    if (!img->coverage || !img->color || !img->depth || !img->lum) {
        sv_eval_image_free(img);
        return sv_fail(err, SV_ERR_NOMEM, "evaluate: cannot allocate a %ux%u image", w, h);
    }
    img->width = w;
    img->height = h;
    return SV_OK;
}

void sv_eval_image_free(sv_eval_image *img)
{
    if (!img) return;
    free(img->coverage);
    free(img->color);
    free(img->depth);
    free(img->lum);
    memset(img, 0, sizeof *img);
}

static void image_zero(sv_eval_image *img)
{
    size_t n = (size_t)img->width * img->height;
    memset(img->coverage, 0, n * sizeof(float));
    memset(img->color, 0, 3 * n * sizeof(float));
    memset(img->depth, 0, n * sizeof(float));
    memset(img->lum, 0, n * sizeof(float));
}

/* The linear Rec. 709 weights of each 8-bit sRGB code: lut[k][c] is weight
 * k × sv_srgb_decode8(c), so a sample's luminance is three lookups (the
 * table: the same floats every run). */
typedef struct lum_lut {
    float w[3][256];
} lum_lut;

static void lum_lut_init(lum_lut *t)
{
    static const double w[3] = {0.2126, 0.7152, 0.0722};
    for (int k = 0; k < 3; k++)
        for (int c = 0; c < 256; c++) t->w[k][c] = (float)(w[k] * sv_srgb_decode8((uint8_t)c));
}

static float sample_lum(const lum_lut *t, const uint8_t *p)
{
    return t->w[0][p[0]] + t->w[1][p[1]] + t->w[2][p[2]];
}

/* Fills `out` (already sized like rgba) from a render. */
static sv_status from_render_into(const sv_image *rgba, const float *depth, sv_eval_image *out,
                                  sv_error *err)
{
    if (rgba->channels != 4 || rgba->bits != 8 || rgba->width != out->width ||
        rgba->height != out->height || !rgba->data)
        return sv_fail(err, SV_ERR_INTERNAL, "evaluate: render is not RGBA8 of %ux%u", out->width,
                       out->height);
    size_t n = (size_t)out->width * out->height;
    const uint8_t *p = rgba->data;
    lum_lut lt;
    lum_lut_init(&lt);
    for (size_t i = 0; i < n; i++, p += 4) {
        bool on = p[3] >= 128;
        out->coverage[i] = on ? 1.0f : 0.0f;
        for (int k = 0; k < 3; k++) out->color[3 * i + k] = on ? p[k] / 255.0f : 0.0f;
        out->lum[i] = on ? sample_lum(&lt, p) : 0.0f;
        float z = depth && on && isfinite(depth[i]) ? depth[i] : 0.0f;
        out->depth[i] = z;
    }
    return SV_OK;
}

sv_status sv_eval_image_from_render(const sv_image *rgba, const float *depth, sv_eval_image *out,
                                    sv_error *err)
{
    memset(out, 0, sizeof *out);
    sv_status st = sv_eval_image_alloc(out, rgba->width, rgba->height, err);
    if (st == SV_OK && (st = from_render_into(rgba, depth, out, err)) != SV_OK)
        sv_eval_image_free(out);
    return st;
}

/* Area weights of a 1-D box filter from n source pixels to m output pixels:
 * output j covers source interval [j·n/m, (j+1)·n/m). first[j] is the first
 * source index, and w[j·span .. ] the weights (normalised to sum 1). */
typedef struct box1d {
    uint32_t span;
    uint32_t *first;
    double *w;
} box1d;

static bool box1d_make(uint32_t n, uint32_t m, box1d *b)
{
    double s = (double)n / m;
    b->span = (uint32_t)ceil(s) + 1;
    b->first = calloc(m, sizeof *b->first);
    b->w = calloc((size_t)m * b->span, sizeof *b->w);
    if (!b->first || !b->w) return false;
    for (uint32_t j = 0; j < m; j++) {
        double lo = j * s, hi = (j + 1) * s;
        uint32_t i0 = (uint32_t)floor(lo);
        b->first[j] = i0;
        for (uint32_t k = 0; k < b->span; k++) {
            uint32_t i = i0 + k;
            if (i >= n) break;
            double ov = fmin(hi, i + 1.0) - fmax(lo, (double)i);
            b->w[(size_t)j * b->span + k] = ov > 0 ? ov / s : 0.0;
        }
    }
    return true;
}

static void box1d_free(box1d *b)
{
    free(b->first);
    free(b->w);
}

/* The integer-ratio box filter of filter_plane over output rows [y0, y1) and
 * columns [x0, x1) only: src W wide, dst w wide, factors fx, fy, tap weights
 * wx, wy (box1d's ov/s = 1/f). Each output pixel gets the products and sums
 * of the whole-image filter, in the same order; tmp (w × H × ch doubles) is
 * indexed as there. */
static void filter_plane_rect(const float *src, uint32_t W, float *dst, uint32_t w, uint32_t ch,
                              uint32_t fx, uint32_t fy, double wx, double wy, double *tmp,
                              uint32_t y0, uint32_t y1, uint32_t x0, uint32_t x1)
{
    for (uint32_t y = y0 * fy; y < y1 * fy; y++) {
        const float *row = src + (size_t)y * W * ch;
        double *out = tmp + (size_t)y * w * ch;
        for (uint32_t x = x0; x < x1; x++) {
            const float *p = row + (size_t)x * fx * ch;
            for (uint32_t c = 0; c < ch; c++) {
                double acc = 0;
                for (uint32_t k = 0; k < fx; k++) acc += wx * p[(size_t)k * ch + c];
                out[(size_t)x * ch + c] = acc;
            }
        }
    }
    size_t rowlen = (size_t)w * ch;
    for (uint32_t y = y0; y < y1; y++) {
        const double *t = tmp + (size_t)y * fy * rowlen;
        float *d = dst + (size_t)y * rowlen;
        for (size_t i = (size_t)x0 * ch; i < (size_t)x1 * ch; i++) {
            double acc = 0;
            for (uint32_t k = 0; k < fy; k++) acc += wy * t[(size_t)k * rowlen + i];
            d[i] = (float)acc;
        }
    }
}

/* Filters one plane with `ch` interleaved channels: src W×H → dst w×h, through
 * tmp (w×H×ch doubles). An integer ratio (the evaluator's case: 1024 → 256 →
 * 128 …) takes a loop over exactly its f taps: the same products in the same
 * order as the general loop (every tap weighs box1d's ov/s = 1/f, and the
 * general loop's extra tap weighs 0 and adds +0.0), so the same bits, without
 * the index arithmetic and the wasted tap. */
static void filter_plane(const float *src, uint32_t W, uint32_t H, float *dst, uint32_t w,
                         uint32_t h, uint32_t ch, const box1d *bx, const box1d *by, double *tmp)
{
    if (W % w == 0 && H % h == 0 && W >= w && H >= h) {
        filter_plane_rect(src, W, dst, w, ch, W / w, H / h, bx->w[0], by->w[0], tmp, 0, h, 0, w);
        return;
    }
    for (uint32_t y = 0; y < H; y++) {
        const float *row = src + (size_t)y * W * ch;
        for (uint32_t x = 0; x < w; x++) {
            const double *wt = &bx->w[(size_t)x * bx->span];
            uint32_t i0 = bx->first[x];
            for (uint32_t c = 0; c < ch; c++) {
                double acc = 0;
                for (uint32_t k = 0; k < bx->span && i0 + k < W; k++)
                    acc += wt[k] * row[(size_t)(i0 + k) * ch + c];
                tmp[((size_t)y * w + x) * ch + c] = acc;
            }
        }
    }
    for (uint32_t y = 0; y < h; y++) {
        const double *wt = &by->w[(size_t)y * by->span];
        uint32_t i0 = by->first[y];
        for (uint32_t x = 0; x < w; x++)
            for (uint32_t c = 0; c < ch; c++) {
                double acc = 0;
                for (uint32_t k = 0; k < by->span && i0 + k < H; k++)
                    acc += wt[k] * tmp[((size_t)(i0 + k) * w + x) * ch + c];
                dst[((size_t)y * w + x) * ch + c] = (float)acc;
            }
    }
}

/* from_render_into followed by the box filter to out's size by the integer
 * factor f = W / out->width, in one pass over the render (no float image at
 * base resolution written and read again per view), over
 * output rows [y0, y1) and columns [x0, x1) only. Every channel gets the same
 * values (a covered pixel's p/255.0f, its depth; 0 elsewhere) multiplied by
 * the same weights in the same order as the two steps did, so the result has
 * the same bits. tmp: out->width × H × 6, indexed as for the whole image.
 * The luminance plane is each covered sample's linear luminance, filtered
 * alike: averaged in linear light, as sveval's lum_ratio counts it. */
static void filter_render_rect(const sv_image *rgba, const float *depth, sv_eval_image *out,
                               double *tmp, uint32_t y0, uint32_t y1, uint32_t x0, uint32_t x1)
{
    uint32_t W = rgba->width, H = rgba->height, w = out->width, h = out->height;
    uint32_t fx = W / w, fy = H / h;
    const double wx = 1.0 / ((double)W / w), wy = 1.0 / ((double)H / h); /* box1d's ov/s */
    float lut[256]; /* v / 255.0f: the same float division, done 256 times, not 3 per pixel */
    for (int v = 0; v < 256; v++) lut[v] = v / 255.0f;
    lum_lut lt;
    lum_lut_init(&lt);
    for (uint32_t y = y0 * fy; y < y1 * fy; y++) {
        const uint8_t *row = (const uint8_t *)rgba->data + (size_t)y * W * 4;
        const float *drow = depth ? depth + (size_t)y * W : NULL;
        double *t = tmp + (size_t)y * w * 6;
        for (uint32_t x = x0; x < x1; x++) {
            double a = 0, r = 0, g = 0, b = 0, z = 0, l = 0;
            /* no covered sample: each sum would add wx·0.0f = +0.0 to +0.0 */
            uint8_t any = 0;
            for (uint32_t k = 0; k < fx; k++) any |= row[4 * ((size_t)x * fx + k) + 3];
            for (uint32_t k = 0; any >= 128 && k < fx; k++) {
                size_t i = (size_t)x * fx + k;
                const uint8_t *p = row + 4 * i;
                bool on = p[3] >= 128;
                a += wx * (on ? 1.0f : 0.0f);
                r += wx * (on ? lut[p[0]] : 0.0f);
                g += wx * (on ? lut[p[1]] : 0.0f);
                b += wx * (on ? lut[p[2]] : 0.0f);
                z += wx * (drow && on && isfinite(drow[i]) ? drow[i] : 0.0f);
                l += wx * (on ? sample_lum(&lt, p) : 0.0f);
            }
            t[6 * x] = a, t[6 * x + 1] = r, t[6 * x + 2] = g, t[6 * x + 3] = b, t[6 * x + 4] = z;
            t[6 * x + 5] = l;
        }
    }
    for (uint32_t y = y0; y < y1; y++) {
        const double *t = tmp + (size_t)y * fy * w * 6;
        for (uint32_t x = x0; x < x1; x++) {
            double s[6] = {0, 0, 0, 0, 0, 0};
            for (uint32_t k = 0; k < fy; k++)
                for (int c = 0; c < 6; c++) s[c] += wy * t[((size_t)k * w + x) * 6 + c];
            size_t o = (size_t)y * w + x;
            out->coverage[o] = (float)s[0];
            out->color[3 * o] = (float)s[1];
            out->color[3 * o + 1] = (float)s[2];
            out->color[3 * o + 2] = (float)s[3];
            out->depth[o] = (float)s[4];
            out->lum[o] = (float)s[5];
        }
    }
}

static void filter_render(const sv_image *rgba, const float *depth, sv_eval_image *out, double *tmp)
{
    filter_render_rect(rgba, depth, out, tmp, 0, out->height, 0, out->width);
}

sv_status sv_eval_image_from_render_filtered(const sv_image *rgba, const float *depth, uint32_t w,
                                             uint32_t h, sv_eval_image *out, sv_error *err)
{
    memset(out, 0, sizeof *out);
    if (rgba->channels != 4 || rgba->bits != 8 || !rgba->data || !w || !h || rgba->width % w ||
        rgba->height % h)
        return sv_fail(err, SV_ERR_INVALID,
                       "evaluate: cannot filter a %ux%u render to %ux%u in one pass", rgba->width,
                       rgba->height, w, h);
    size_t n;
    double *tmp = NULL;
    if (!sv_mul_size((size_t)w * 6, rgba->height, &n) || !(tmp = sv_calloc(n, sizeof *tmp)))
        return sv_fail(err, SV_ERR_NOMEM, "evaluate: out of memory");
    sv_status st = sv_eval_image_alloc(out, w, h, err);
    if (st == SV_OK) filter_render(rgba, depth, out, tmp);
    free(tmp);
    return st;
}

/* Box-filters src into out (already allocated at its target size). */
static sv_status downsample_into(const sv_eval_image *src, sv_eval_image *out, sv_error *err)
{
    uint32_t W = src->width, H = src->height, w = out->width, h = out->height;
    box1d bx = {0}, by = {0};
    size_t n;
    double *tmp = NULL;
    sv_status st = SV_OK;
    if (!sv_mul_size((size_t)w * 3, H, &n) || !(tmp = sv_calloc(n, sizeof *tmp)) ||
        !box1d_make(W, w, &bx) || !box1d_make(H, h, &by)) {
        st = sv_fail(err, SV_ERR_NOMEM, "evaluate: cannot filter %ux%u to %ux%u", W, H, w, h);
        goto out;
    }
    filter_plane(src->coverage, W, H, out->coverage, w, h, 1, &bx, &by, tmp);
    filter_plane(src->color, W, H, out->color, w, h, 3, &bx, &by, tmp);
    filter_plane(src->depth, W, H, out->depth, w, h, 1, &bx, &by, tmp);
    filter_plane(src->lum, W, H, out->lum, w, h, 1, &bx, &by, tmp);
out:
    free(tmp);
    box1d_free(&bx);
    box1d_free(&by);
    return st;
}

sv_status sv_eval_image_downsample(const sv_eval_image *src, uint32_t w, uint32_t h,
                                   sv_eval_image *out, sv_error *err)
{
    sv_status st = sv_eval_image_alloc(out, w, h, err);
    if (st == SV_OK && (st = downsample_into(src, out, err)) != SV_OK) sv_eval_image_free(out);
    return st;
}

/* sv_eval_image_accumulate over rows [y0, y1) and columns [x0, x1) only. */
static void accumulate_rect(sv_eval_image *dst, const sv_eval_image *src, float wf, uint32_t y0,
                            uint32_t y1, uint32_t x0, uint32_t x1)
{
    for (uint32_t y = y0; y < y1; y++) {
        size_t row = (size_t)y * dst->width;
        for (size_t i = row + x0; i < row + x1; i++) {
            dst->coverage[i] += wf * src->coverage[i];
            dst->depth[i] += wf * src->depth[i];
            dst->lum[i] += wf * src->lum[i];
        }
        for (size_t i = 3 * (row + x0); i < 3 * (row + x1); i++)
            dst->color[i] += wf * src->color[i];
    }
}

void sv_eval_image_accumulate(sv_eval_image *dst, const sv_eval_image *src, double weight)
{
    size_t n = (size_t)dst->width * dst->height;
    float wf = (float)weight;
    for (size_t i = 0; i < n; i++) {
        dst->coverage[i] += wf * src->coverage[i];
        dst->depth[i] += wf * src->depth[i];
        dst->lum[i] += wf * src->lum[i];
    }
    for (size_t i = 0; i < 3 * n; i++) dst->color[i] += wf * src->color[i];
}

/* The running sums of sv_eval_compare. */
typedef struct compare_sums {
    double smin, smax, cerr, dsum;
    double lum_a, lum_b; /* Σ min(a,b)·Y of each (evaluate.h) */
    size_t covered;
} compare_sums;

/* Pixel i's mean linear luminance over its covered samples (the lum plane
 * ÷ coverage). */
static double luminance(const sv_eval_image *img, size_t i, double cov)
{
    return img->lum[i] / cov;
}

/* Adds the pixels of rows [y0, y1), columns [x0, x1) to the sums, row by row. */
static void compare_rect(const sv_eval_image *a, const sv_eval_image *b, compare_sums *cs,
                         uint32_t y0, uint32_t y1, uint32_t x0, uint32_t x1)
{
    double smin = cs->smin, smax = cs->smax, cerr = cs->cerr, dsum = cs->dsum;
    double lum_a = cs->lum_a, lum_b = cs->lum_b;
    size_t covered = cs->covered;
    for (uint32_t y = y0; y < y1; y++) {
        size_t row = (size_t)y * a->width;
        for (size_t i = row + x0; i < row + x1; i++) {
            double ca = a->coverage[i], cb = b->coverage[i];
            double lo = fmin(ca, cb), hi = fmax(ca, cb);
            smin += lo;
            smax += hi;
            if (hi > 0) {
                double e = 0;
                for (int k = 0; k < 3; k++)
                    e += fabs((double)a->color[3 * i + k] - b->color[3 * i + k]);
                cerr += e / 3.0;
                covered++;
            }
            if (lo > 0) {
                double za = a->depth[i] / ca, zb = b->depth[i] / cb;
                dsum += lo * fabs(za - zb);
                lum_a += lo * luminance(a, i, ca);
                lum_b += lo * luminance(b, i, cb);
            }
        }
    }
    cs->smin = smin, cs->smax = smax, cs->cerr = cerr, cs->dsum = dsum;
    cs->lum_a = lum_a, cs->lum_b = lum_b;
    cs->covered = covered;
}

static sv_eval_metrics compare_metrics(const compare_sums *cs, double radius)
{
    sv_eval_metrics m;
    m.iou = cs->smax > 0 ? cs->smin / cs->smax : 1.0;
    m.color_error = cs->covered ? cs->cerr / (double)cs->covered : 0.0;
    m.depth_error = cs->smin > 0 && radius > 0 ? cs->dsum / cs->smin / radius : 0.0;
    return m;
}

sv_eval_metrics sv_eval_compare(const sv_eval_image *a, const sv_eval_image *b, double radius)
{
    compare_sums cs = {0};
    compare_rect(a, b, &cs, 0, a->height, 0, a->width);
    return compare_metrics(&cs, radius);
}

/* ---- cropping to the covered tiles --------------------------------------- */

/* Spans: for each of `tiles` tile rows, the tile columns [lo[t], hi[t]) that
 * may hold coverage; lo[t] >= hi[t] when none can. lo and hi are one array
 * of 2·tiles, hi = lo + tiles. */

/* Whether a sample of pixels [x0, x1) of an RGBA8 row is covered (alpha >=
 * 128): the OR of whole pixels (a loop compilers vectorise), then its alpha
 * byte, read back through memory so that byte order does not matter. */
static bool any_covered(const uint8_t *row, uint32_t x0, uint32_t x1)
{
    uint32_t any = 0;
    for (uint32_t x = x0; x < x1; x++) {
        uint32_t px;
        memcpy(&px, row + 4 * (size_t)x, sizeof px);
        any |= px;
    }
    uint8_t b[4];
    memcpy(b, &any, sizeof b);
    return b[3] >= 128;
}

/* Sets the spans of a base-resolution RGBA8 render: the tiles between the
 * first and the last covered sample (alpha >= 128) of each tile row. Scans a
 * row only outside the span found so far, a tile at a time, so a covered
 * image costs its margins and an empty one a single pass. */
static void render_spans(const sv_image *rgba, uint32_t tile, uint32_t tiles, uint32_t *lo)
{
    uint32_t *hi = lo + tiles, W = rgba->width;
    for (uint32_t t = 0; t < tiles; t++) {
        uint32_t l = tiles, h = 0;
        for (uint32_t y = t * tile; y < (t + 1) * tile; y++) {
            const uint8_t *row = (const uint8_t *)rgba->data + (size_t)y * W * 4;
            for (uint32_t c = 0; c < l; c++)
                if (any_covered(row, c * tile, (c + 1) * tile)) l = c;
            if (l >= tiles) continue; /* nothing covered yet */
            for (uint32_t c = tiles; c > h; c--)
                if (any_covered(row, (c - 1) * tile, c * tile)) h = c;
        }
        lo[t] = l, hi[t] = h;
    }
}

static void spans_empty(uint32_t tiles, uint32_t *lo)
{
    for (uint32_t t = 0; t < tiles; t++) lo[t] = tiles, lo[tiles + t] = 0;
}

/* dst = the spans of either a or b (dst may be a or b). */
static void spans_union(uint32_t tiles, const uint32_t *a, const uint32_t *b, uint32_t *dst)
{
    for (uint32_t t = 0; t < tiles; t++) {
        uint32_t l = a[t] < b[t] ? a[t] : b[t];
        uint32_t h = a[tiles + t] > b[tiles + t] ? a[tiles + t] : b[tiles + t];
        dst[t] = l, dst[tiles + t] = h;
    }
}

/* Zeroes columns [x0, x1) of rows [y0, y1) of img. */
static void zero_rect(sv_eval_image *img, uint32_t y0, uint32_t y1, uint32_t x0, uint32_t x1)
{
    for (uint32_t y = y0; x0 < x1 && y < y1; y++) {
        size_t row = (size_t)y * img->width;
        memset(img->coverage + row + x0, 0, (x1 - x0) * sizeof(float));
        memset(img->depth + row + x0, 0, (x1 - x0) * sizeof(float));
        memset(img->lum + row + x0, 0, (x1 - x0) * sizeof(float));
        memset(img->color + 3 * (row + x0), 0, 3 * (size_t)(x1 - x0) * sizeof(float));
    }
}

/* Zeroes the pixels of img (ts pixels per tile) inside the spans `held` (where
 * img may be non-zero) but outside the spans `keep` (about to be written;
 * NULL: none). */
static void zero_held(sv_eval_image *img, uint32_t tiles, uint32_t ts, const uint32_t *held,
                      const uint32_t *keep)
{
    for (uint32_t t = 0; t < tiles; t++) {
        uint32_t a = held[t], b = held[tiles + t];
        uint32_t c = keep ? keep[t] : b, d = keep ? keep[tiles + t] : b;
        if (a >= b) continue;
        if (c >= d) c = d = b; /* nothing kept: all of [a, b) */
        zero_rect(img, t * ts, (t + 1) * ts, a * ts, (c < b ? c : b) * ts);
        zero_rect(img, t * ts, (t + 1) * ts, (d > a ? d : a) * ts, b * ts);
    }
}

/* ---- the evaluator ------------------------------------------------------- */

void sv_eval_result_free(sv_eval_result *r)
{
    if (!r) return;
    free(r->per_view);
    memset(r, 0, sizeof *r);
}

uint32_t sv_evaluator_view_count(const sv_evaluator *e)
{
    return e->view_count;
}

void sv_evaluator_view_dir(const sv_evaluator *e, uint32_t view, double dir[3])
{
    memcpy(dir, &e->dirs[3 * (size_t)view], 3 * sizeof(double));
}

void sv_evaluator_destroy(sv_evaluator *e)
{
    if (!e) return;
    if (e->orig)
        for (size_t i = 0; i < (size_t)e->view_count * e->size_count; i++)
            sv_eval_image_free(&e->orig[i]);
    for (uint32_t s = 0; s < SV_EVAL_MAX_SIZES; s++) sv_eval_image_free(&e->tmp[s]);
    sv_eval_image_free(&e->full);
    free(e->ftmp);
    free(e->depth);
    free(e->orig_span);
    free(e->span);
    free(e->orig);
    free(e->dirs);
    free(e);
}

/* A tile's side in the pixels of the evaluator's size `width`: tile row t
 * holds that size's rows [t·ts, (t+1)·ts). */
static uint32_t tile_side(const sv_evaluator *e, uint32_t width)
{
    return e->tile / (e->base / width);
}

/* Filters a render (base × base RGBA8, depth) into out[0..size_count) within
 * the spans `span`: the fused filter for the largest size, then each size
 * from size src[s], tile row by tile row. out is zero outside the spans
 * `held` on entry, and outside `span` on return: only held minus span is
 * cleared: clearing whole images costs more than the filtering. */
static void filter_cropped(sv_evaluator *e, const sv_image *color, const float *depth,
                           const uint32_t *held, const uint32_t *span, sv_eval_image *out)
{
    const uint32_t *hi = span + e->tiles;
    for (uint32_t s = 0; s < e->size_count; s++)
        zero_held(&out[s], e->tiles, tile_side(e, out[s].width), held, span);
    uint32_t ts = tile_side(e, out[0].width);
    for (uint32_t t = 0; t < e->tiles; t++)
        if (span[t] < hi[t])
            filter_render_rect(color, depth, &out[0], e->ftmp, t * ts, (t + 1) * ts, span[t] * ts,
                               hi[t] * ts);
    for (uint32_t s = 1; s < e->size_count; s++) {
        const sv_eval_image *src = &out[e->src[s]];
        sv_eval_image *dst = &out[s];
        uint32_t W = src->width, w = dst->width, f = W / w;
        const double wf = 1.0 / ((double)W / w); /* box1d's ov/s, as filter_plane takes it */
        ts = tile_side(e, w);
        for (uint32_t t = 0; t < e->tiles; t++) {
            uint32_t y0 = t * ts, y1 = (t + 1) * ts, x0 = span[t] * ts, x1 = hi[t] * ts;
            if (x0 >= x1) continue;
            filter_plane_rect(src->coverage, W, dst->coverage, w, 1, f, f, wf, wf, e->ftmp, y0, y1,
                              x0, x1);
            filter_plane_rect(src->color, W, dst->color, w, 3, f, f, wf, wf, e->ftmp, y0, y1, x0,
                              x1);
            filter_plane_rect(src->depth, W, dst->depth, w, 1, f, f, wf, wf, e->ftmp, y0, y1, x0,
                              x1);
            filter_plane_rect(src->lum, W, dst->lum, w, 1, f, f, wf, wf, e->ftmp, y0, y1, x0, x1);
        }
    }
}

/* Renders triangles tris of g from view v at base resolution and filters the
 * render to every size into out[0..size_count). A box filter by an integer
 * factor of a box filter by an integer factor is the box filter by their
 * product, so each size is filtered from the smallest larger image it divides
 * (exact, and much cheaper than filtering the base image every time).
 * When the evaluator crops (e->tile), span (2·tiles) says where out may be
 * non-zero: on entry, from its last render (or empty for zeroed images); on
 * return, the new render's covered spans, the only ones filtered. Otherwise
 * span is untouched. */
static sv_status render_view_by(sv_evaluator *e, const sv_gpu_mesh *g, const uint32_t *tris,
                                uint32_t tri_count, sv_eval_draw_fn draw, void *user, uint32_t v,
                                sv_eval_image *out, uint32_t *span, sv_error *err)
{
    sv_camera cam;
    sv_eval_camera(e->centre, e->radius, &e->dirs[3 * (size_t)v], &cam);
    sv_image color = {0};
    sv_status st = draw ? draw(user, &cam, e->base, e->base, &color, e->depth, err)
                        : sv_render(e->r, g, tris, tri_count, &cam, &e->ropt, e->base, e->base,
                                    &color, e->depth, err);
    uint32_t s0 = 0;
    bool fused = st == SV_OK && e->ftmp && color.channels == 4 && color.bits == 8 && color.data &&
                 color.width == e->base && color.height == e->base;
    if (fused && e->tile) {
        uint32_t *now = e->span + 6 * (size_t)e->tiles;
        render_spans(&color, e->tile, e->tiles, now);
        filter_cropped(e, &color, e->depth, span, now, out);
        memcpy(span, now, 2 * (size_t)e->tiles * sizeof *span);
        s0 = e->size_count;
    } else if (fused) {
        filter_render(&color, e->depth, &out[0], e->ftmp); /* the largest size, fused */
        s0 = 1;
        /* a size that divides no larger one is filtered from the render itself */
        if (e->need_full) st = from_render_into(&color, e->depth, &e->full, err);
    } else if (st == SV_OK) {
        st = from_render_into(&color, e->depth, &e->full, err);
    }
    for (uint32_t s = s0; st == SV_OK && s < e->size_count; s++)
        st = downsample_into(s && e->src[s] >= 0 ? &out[e->src[s]] : &e->full, &out[s], err);
    sv_image_free(&color);
    return st;
}

static sv_status render_view(sv_evaluator *e, const sv_gpu_mesh *g, const uint32_t *tris,
                             uint32_t tri_count, uint32_t v, sv_eval_image *out, uint32_t *span,
                             sv_error *err)
{
    return render_view_by(e, g, tris, tri_count, NULL, NULL, v, out, span, err);
}

static uint32_t gcd_u32(uint32_t a, uint32_t b)
{
    while (b) {
        uint32_t t = a % b;
        a = b, b = t;
    }
    return a;
}

/* Chooses each size's source (the smallest larger size it divides that
 * divides the base, else the base image) and whether the evaluator crops:
 * only when the largest size divides the base (the fused filter) and every
 * other size has a source, so that every filter is by an integer factor. */
static void plan_filters(sv_evaluator *e)
{
    bool crop = e->base % e->sizes[0] == 0;
    uint32_t tile = crop ? e->base / e->sizes[0] : 0;
    e->src[0] = -1;
    for (uint32_t s = 1; s < e->size_count; s++) {
        e->src[s] = -1;
        for (uint32_t p = s; p-- > 0;)
            if (e->base % e->sizes[p] == 0 && e->sizes[p] % e->sizes[s] == 0) {
                e->src[s] = (int)p;
                break;
            }
        if (e->src[s] < 0) crop = false;
        else if (crop) {
            uint32_t f = e->base / e->sizes[s]; /* divides the base: so does the lcm */
            tile = tile / gcd_u32(tile, f) * f;
        }
    }
    e->tile = crop ? tile : 0;
    e->tiles = crop ? e->base / tile : 0;
}

static int cmp_desc(const void *a, const void *b)
{
    uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return (x < y) - (x > y);
}

sv_status sv_evaluator_create(sv_renderer *r, const sv_mesh *original, const sv_gpu_mesh *g,
                              const sv_eval_options *opt, sv_evaluator **out, sv_error *err)
{
    *out = NULL;
    sv_eval_options o = {0};
    if (opt) o = *opt;
    if (o.size_count > SV_EVAL_MAX_SIZES)
        return sv_fail(err, SV_ERR_INVALID, "evaluate: %u sizes asked, at most %d", o.size_count,
                       SV_EVAL_MAX_SIZES);
    if (o.size_count == 0) {
        o.size_count = sizeof default_sizes / sizeof *default_sizes;
        memcpy(o.sizes, default_sizes, sizeof default_sizes);
    }
    qsort(o.sizes, o.size_count, sizeof *o.sizes, cmp_desc);
    for (uint32_t s = 0; s < o.size_count; s++)
        if (o.sizes[s] == 0 || (s && o.sizes[s] == o.sizes[s - 1]))
            return sv_fail(err, SV_ERR_INVALID,
                           "evaluate: screen sizes must be positive and distinct");
    if (!o.view_count) o.view_count = DEFAULT_VIEWS;
    if (o.view_count > 4096)
        return sv_fail(err, SV_ERR_INVALID, "evaluate: %u views asked, at most 4096", o.view_count);
    if (!o.supersample) o.supersample = DEFAULT_SUPERSAMPLE;
    uint32_t rmax = sv_renderer_max_size(r);
    if (o.sizes[0] > rmax)
        return sv_fail(err, SV_ERR_INVALID, "evaluate: size %u exceeds the renderer's maximum %u",
                       o.sizes[0], rmax);
    if (o.supersample > rmax / o.sizes[0]) o.supersample = rmax / o.sizes[0];

    double mn[3], mx[3];
    if (!sv_mesh_bounds(original, mn, mx))
        return sv_fail(err, SV_ERR_INVALID, "evaluate: the original mesh is empty");
    sv_evaluator *e = calloc(1, sizeof *e);
    if (!e) return sv_fail(err, SV_ERR_NOMEM, "evaluate: out of memory");
    e->r = r;
    e->g = g;
    sv_mesh_frame_sphere(original, e->centre, &e->radius);
    if (!(e->radius > 0)) e->radius = 1.0; /* a single point: any frame will do */
    e->view_count = o.view_count;
    e->size_count = o.size_count;
    memcpy(e->sizes, o.sizes, sizeof e->sizes);
    e->base = o.sizes[0] * o.supersample;
    e->ropt = o.render;
    sv_status st = SV_OK;
    e->dirs = sv_calloc(e->view_count, 3 * sizeof(double));
    e->orig = sv_calloc((size_t)e->view_count * e->size_count, sizeof(sv_eval_image));
    if (!e->dirs || !e->orig) {
        st = sv_fail(err, SV_ERR_NOMEM, "evaluate: out of memory");
        goto out;
    }
    sv_eval_place_views(o.viewer, e->view_count, e->dirs);
    plan_filters(e);
    if (e->tile) {
        size_t per = 2 * (size_t)e->tiles;
        e->orig_span = sv_calloc(e->view_count, per * sizeof *e->orig_span);
        e->span = sv_calloc(4, per * sizeof *e->span);
        if (!e->orig_span || !e->span) {
            st = sv_fail(err, SV_ERR_NOMEM, "evaluate: out of memory");
            goto out;
        }
    }
    if (e->base % e->sizes[0] == 0) { /* the fused filter's rows; else the float image */
        size_t nt;
        if (sv_mul_size((size_t)e->sizes[0] * 6, e->base, &nt))
            e->ftmp = sv_calloc(nt, sizeof *e->ftmp);
    }
    e->need_full = !e->ftmp;
    for (uint32_t s = 1; s < e->size_count; s++) e->need_full |= e->src[s] < 0;
    if (e->need_full && (st = sv_eval_image_alloc(&e->full, e->base, e->base, err)) != SV_OK)
        goto out;
    if (!(e->depth = sv_calloc((size_t)e->base * e->base, sizeof *e->depth))) {
        st = sv_fail(err, SV_ERR_NOMEM, "evaluate: cannot allocate a depth buffer");
        goto out;
    }
    for (uint32_t s = 0; s < e->size_count; s++)
        if ((st = sv_eval_image_alloc(&e->tmp[s], e->sizes[s], e->sizes[s], err)) != SV_OK)
            goto out;
    for (uint32_t v = 0; v < e->view_count; v++) {
        sv_eval_image *row = &e->orig[(size_t)v * e->size_count];
        for (uint32_t s = 0; s < e->size_count; s++)
            if ((st = sv_eval_image_alloc(&row[s], e->sizes[s], e->sizes[s], err)) != SV_OK)
                goto out;
        uint32_t *span = e->tile ? &e->orig_span[(size_t)v * 2 * e->tiles] : NULL;
        if ((st = render_view(e, g, NULL, 0, v, row, span, err)) != SV_OK) goto out;
    }
out:
    if (st != SV_OK) sv_evaluator_destroy(e);
    else *out = e;
    return st;
}

/* Renders the result from view v (blending subsets) into acc[0..size_count);
 * when the evaluator crops, span receives where acc may be covered. */
static sv_status render_result(sv_evaluator *e, const sv_gpu_mesh *result, sv_eval_subset_fn fn,
                               void *user, uint32_t v, sv_eval_image *acc, uint32_t *span,
                               sv_error *err)
{
    if (!fn) return render_view(e, result, NULL, 0, v, acc, span, err);
    sv_eval_subset sub[SV_EVAL_MAX_SUBSETS];
    memset(sub, 0, sizeof sub);
    uint32_t count = 0;
    sv_status st = fn(user, &e->dirs[3 * (size_t)v], sub, &count, err);
    if (st != SV_OK) return st;
    double wsum = 0;
    for (uint32_t k = 0; k < count && k < SV_EVAL_MAX_SUBSETS; k++) {
        if (!(sub[k].weight >= 0)) count = 0;
        wsum += sub[k].weight;
    }
    if (count < 1 || count > SV_EVAL_MAX_SUBSETS || fabs(wsum - 1.0) > 1e-6)
        return sv_fail(err, SV_ERR_INVALID,
                       "evaluate: view %u: subset callback gave %u subsets with weights summing "
                       "to %g (need 1..%d, non-negative, sum 1)",
                       v, count, wsum, SV_EVAL_MAX_SUBSETS);
    uint32_t *sspan = e->tile ? e->span + 2 * (size_t)e->tiles : NULL;
    for (uint32_t s = 0; s < e->size_count; s++)
        if (!e->tile) image_zero(&acc[s]);
        else zero_held(&acc[s], e->tiles, tile_side(e, acc[s].width), span, NULL);
    if (e->tile) spans_empty(e->tiles, span);
    for (uint32_t k = 0; k < count; k++) {
        if (sub[k].weight == 0) continue;
        if (sub[k].tris && sub[k].tri_count == 0) continue; /* an empty subset draws nothing */
        if ((st = render_view(e, result, sub[k].tris, sub[k].tri_count, v, e->tmp, sspan, err)) !=
            SV_OK)
            return st;
        if (!e->tile) {
            for (uint32_t s = 0; s < e->size_count; s++)
                sv_eval_image_accumulate(&acc[s], &e->tmp[s], sub[k].weight);
            continue;
        }
        /* outside its spans the subset is +0.0: acc + weight·0 is acc */
        for (uint32_t s = 0; s < e->size_count; s++) {
            uint32_t ts = tile_side(e, acc[s].width);
            for (uint32_t t = 0; t < e->tiles; t++)
                if (sspan[t] < sspan[e->tiles + t])
                    accumulate_rect(&acc[s], &e->tmp[s], (float)sub[k].weight, t * ts, (t + 1) * ts,
                                    sspan[t] * ts, sspan[e->tiles + t] * ts);
        }
        spans_union(e->tiles, span, sspan, span);
    }
    return SV_OK;
}

static sv_status alloc_sizes(const sv_evaluator *e, sv_eval_image *imgs, sv_error *err)
{
    for (uint32_t s = 0; s < e->size_count; s++) {
        sv_status st = sv_eval_image_alloc(&imgs[s], e->sizes[s], e->sizes[s], err);
        if (st != SV_OK) return st;
    }
    return SV_OK;
}

static sv_status evaluate_any(sv_evaluator *e, const sv_gpu_mesh *result, sv_eval_subset_fn fn,
                              sv_eval_draw_fn draw, void *user, sv_eval_result *out, sv_error *err);

sv_status sv_evaluate_subsets(sv_evaluator *e, const sv_gpu_mesh *result, sv_eval_subset_fn fn,
                              void *user, sv_eval_result *out, sv_error *err)
{
    return evaluate_any(e, result, fn, NULL, user, out, err);
}

sv_status sv_evaluate_drawn(sv_evaluator *e, sv_eval_draw_fn draw, void *user, sv_eval_result *out,
                            sv_error *err)
{
    if (!draw) {
        memset(out, 0, sizeof *out);
        return sv_fail(err, SV_ERR_INTERNAL, "evaluate: no draw function");
    }
    return evaluate_any(e, NULL, NULL, draw, user, out, err);
}

static sv_status evaluate_any(sv_evaluator *e, const sv_gpu_mesh *result, sv_eval_subset_fn fn,
                              sv_eval_draw_fn draw, void *user, sv_eval_result *out, sv_error *err)
{
    memset(out, 0, sizeof *out);
    double t0 = sv_now();
    sv_eval_image acc[SV_EVAL_MAX_SIZES];
    memset(acc, 0, sizeof acc);
    sv_status st = SV_OK;
    out->per_view = sv_calloc((size_t)e->view_count * e->size_count, sizeof *out->per_view);
    if (!out->per_view) {
        st = sv_fail(err, SV_ERR_NOMEM, "evaluate: out of memory");
        goto out;
    }
    if ((st = alloc_sizes(e, acc, err)) != SV_OK) goto out;
    out->view_count = e->view_count;
    out->size_count = e->size_count;
    for (uint32_t s = 0; s < e->size_count; s++) {
        out->sizes[s].pixels = e->sizes[s];
        out->sizes[s].worst = (sv_eval_metrics){INFINITY, -INFINITY, -INFINITY};
    }
    uint32_t *span = e->span, *both = e->tile ? e->span + 4 * (size_t)e->tiles : NULL;
    double lum[SV_EVAL_MAX_SIZES][2] = {{0}};
    for (uint32_t v = 0; v < e->view_count; v++) {
        st = draw ? render_view_by(e, NULL, NULL, 0, draw, user, v, acc, span, err)
                  : render_result(e, result, fn, user, v, acc, span, err);
        if (st != SV_OK) goto out;
        /* Where neither image is covered both are +0.0, which adds exactly
         * nothing to any sum of sv_eval_compare: only the union's spans are
         * visited, in the same row-major order. */
        if (e->tile) spans_union(e->tiles, span, &e->orig_span[(size_t)v * 2 * e->tiles], both);
        for (uint32_t s = 0; s < e->size_count; s++) {
            const sv_eval_image *o = &e->orig[(size_t)v * e->size_count + s];
            compare_sums cs = {0};
            if (!e->tile) compare_rect(o, &acc[s], &cs, 0, o->height, 0, o->width);
            for (uint32_t t = 0, ts = e->tile ? tile_side(e, o->width) : 0; t < e->tiles; t++)
                if (both[t] < both[e->tiles + t])
                    compare_rect(o, &acc[s], &cs, t * ts, (t + 1) * ts, both[t] * ts,
                                 both[e->tiles + t] * ts);
            sv_eval_metrics m = compare_metrics(&cs, e->radius);
            out->per_view[(size_t)v * e->size_count + s] = m;
            lum[s][0] += cs.lum_a;
            lum[s][1] += cs.lum_b;
            sv_eval_size *z = &out->sizes[s];
            z->mean.iou += m.iou / e->view_count;
            z->mean.color_error += m.color_error / e->view_count;
            z->mean.depth_error += m.depth_error / e->view_count;
            z->worst.iou = fmin(z->worst.iou, m.iou);
            z->worst.color_error = fmax(z->worst.color_error, m.color_error);
            z->worst.depth_error = fmax(z->worst.depth_error, m.depth_error);
        }
    }
    for (uint32_t s = 0; s < e->size_count; s++)
        out->sizes[s].lum_ratio = lum[s][0] > 0 ? lum[s][1] / lum[s][0] : 1.0;
    out->seconds = sv_now() - t0;
out:
    for (uint32_t s = 0; s < SV_EVAL_MAX_SIZES; s++) sv_eval_image_free(&acc[s]);
    if (st != SV_OK) sv_eval_result_free(out);
    return st;
}

/* One view's sums for every cutoff, in samples (the original's filtered
 * coverage o of a pixel of the largest size is a whole number of its f × f
 * samples, and so is the result's): a pixel with j samples above k covers
 * j at that k, so with its sample bytes sorted in descending order
 * s_1 >= ... >= s_n it adds min(o·n, j) and max(o·n, j) for k in
 * [s_{j+1}, s_j) — ranges kept as differences in dmin and dmax [256]. */
static void cutoff_sums(const sv_evaluator *e, const sv_image *amax, uint32_t v, int64_t *dmin,
                        int64_t *dmax)
{
    uint32_t px = e->sizes[0], f = e->base / px, n = f * f;
    const float *orig = e->orig[(size_t)v * e->size_count].coverage;
    uint8_t buf[SV_CUTOFF_MAX_BLOCK];
    const uint8_t *a = amax->data;
    for (uint32_t y = 0; y < px; y++)
        for (uint32_t x = 0; x < px; x++) {
            int64_t o = lround((double)orig[(size_t)y * px + x] * n);
            uint32_t m = 0;
            for (uint32_t i = 0; i < f; i++) {
                const uint8_t *row = a + 4 * ((size_t)(y * f + i) * e->base + (size_t)x * f);
                for (uint32_t j = 0; j < f; j++)
                    if (row[4 * j + 3]) buf[m++] = row[4 * j + 3];
            }
            if (!m && !o) continue;
            for (uint32_t i = 1; i < m; i++) { /* insertion sort, descending: blocks are small */
                uint8_t t = buf[i];
                uint32_t j = i;
                for (; j > 0 && buf[j - 1] < t; j--) buf[j] = buf[j - 1];
                buf[j] = t;
            }
            uint32_t hi = 255; /* k in [lo, hi): j samples above k */
            for (uint32_t j = 0; j <= m; j++) {
                uint32_t lo = j < m ? buf[j] : 0;
                if (lo >= hi) continue;
                int64_t mn = o < j ? o : j, mx = o < j ? j : o;
                dmin[lo] += mn, dmin[hi] -= mn;
                dmax[lo] += mx, dmax[hi] -= mx;
                hi = lo;
            }
        }
}

sv_status sv_evaluate_cutoffs(sv_evaluator *e, const sv_gpu_mesh *result, double iou[255],
                              sv_error *err)
{
    for (uint32_t k = 0; k < 255; k++) iou[k] = 0;
    uint32_t f = e->base / e->sizes[0];
    if (f * e->sizes[0] != e->base || (size_t)f * f > SV_CUTOFF_MAX_BLOCK)
        return sv_fail(err, SV_ERR_INTERNAL,
                       "evaluate: cutoffs need a base of at most %d samples a pixel, in whole "
                       "pixels (%u for %u px)",
                       SV_CUTOFF_MAX_BLOCK, e->base, e->sizes[0]);
    sv_render_options ro = e->ropt;
    ro.shade = SV_SHADE_ALPHA_MAX;
    for (uint32_t v = 0; v < e->view_count; v++) {
        sv_camera cam;
        sv_eval_camera(e->centre, e->radius, &e->dirs[3 * (size_t)v], &cam);
        sv_image amax = {0};
        sv_status st = sv_render(e->r, result, NULL, 0, &cam, &ro, e->base, e->base, &amax, NULL,
                                 err);
        if (st != SV_OK) return st;
        int64_t dmin[256] = {0}, dmax[256] = {0};
        cutoff_sums(e, &amax, v, dmin, dmax);
        sv_image_free(&amax);
        int64_t smin = 0, smax = 0;
        for (uint32_t k = 0; k < 255; k++) {
            smin += dmin[k], smax += dmax[k];
            iou[k] += (smax > 0 ? (double)smin / (double)smax : 1.0) / e->view_count;
        }
    }
    return SV_OK;
}

sv_status sv_eval_identity(const sv_evaluator *e, sv_eval_result *out, sv_error *err)
{
    memset(out, 0, sizeof *out);
    out->per_view = sv_calloc((size_t)e->view_count * e->size_count, sizeof *out->per_view);
    if (!out->per_view) return sv_fail(err, SV_ERR_NOMEM, "evaluate: out of memory");
    out->view_count = e->view_count;
    out->size_count = e->size_count;
    const sv_eval_metrics same = {1.0, 0.0, 0.0};
    for (size_t i = 0; i < (size_t)e->view_count * e->size_count; i++) out->per_view[i] = same;
    for (uint32_t s = 0; s < e->size_count; s++) {
        out->sizes[s].pixels = e->sizes[s];
        out->sizes[s].mean = out->sizes[s].worst = same;
        out->sizes[s].lum_ratio = 1.0;
    }
    return SV_OK;
}

sv_status sv_evaluate(sv_evaluator *e, const sv_gpu_mesh *result, sv_eval_result *out,
                      sv_error *err)
{
    return sv_evaluate_subsets(e, result, NULL, NULL, out, err);
}

/* ---- preview ------------------------------------------------------------- */

static uint8_t to8(double x)
{
    if (!(x > 0)) return 0;
    if (x >= 1) return 255;
    return (uint8_t)lrint(x * 255.0);
}

/* Writes tile (T×T) of an eval image over grey at (x0, y0) of the RGB8 canvas. */
static void paint_tile(sv_image *canvas, const sv_eval_image *img, uint32_t x0, uint32_t y0)
{
    size_t stride = sv_image_stride(canvas);
    for (uint32_t y = 0; y < img->height; y++)
        for (uint32_t x = 0; x < img->width; x++) {
            size_t i = (size_t)y * img->width + x;
            uint8_t *p = (uint8_t *)canvas->data + (size_t)(y0 + y) * stride + (size_t)(x0 + x) * 3;
            double bg = 0.5 * (1.0 - img->coverage[i]);
            for (int k = 0; k < 3; k++) p[k] = to8(img->color[3 * i + k] + bg);
        }
}

static void paint_heat(sv_image *canvas, const sv_eval_image *a, const sv_eval_image *b,
                       uint32_t x0, uint32_t y0)
{
    size_t stride = sv_image_stride(canvas);
    for (uint32_t y = 0; y < a->height; y++)
        for (uint32_t x = 0; x < a->width; x++) {
            size_t i = (size_t)y * a->width + x;
            uint8_t *p = (uint8_t *)canvas->data + (size_t)(y0 + y) * stride + (size_t)(x0 + x) * 3;
            double dc = fabs((double)a->coverage[i] - b->coverage[i]), de = 0;
            for (int k = 0; k < 3; k++)
                de += fabs((double)a->color[3 * i + k] - b->color[3 * i + k]);
            /* colour where both are covered (edges are coverage, shown red);
             * colour differences are small: amplify */
            de = fmin(1.0, 4.0 * de / 3.0 * fmin(a->coverage[i], b->coverage[i]));
            p[0] = to8(fmax(dc, de));
            p[1] = to8(de);
            p[2] = 0;
        }
}

sv_status sv_evaluator_preview(sv_evaluator *e, const sv_gpu_mesh *result, sv_eval_subset_fn fn,
                               void *user, const char *png_path, sv_error *err)
{
    const uint32_t rows = 4, t = e->sizes[0];
    sv_image canvas = {0};
    sv_eval_image acc[SV_EVAL_MAX_SIZES];
    memset(acc, 0, sizeof acc);
    sv_status st = sv_image_alloc(&canvas, 3 * t, rows * t, 3, 8, err);
    if (st == SV_OK) st = alloc_sizes(e, acc, err);
    for (uint32_t row = 0; st == SV_OK && row < rows; row++) {
        uint32_t v = (uint32_t)((uint64_t)row * e->view_count / rows);
        if ((st = render_result(e, result, fn, user, v, acc, e->span, err)) != SV_OK) break;
        const sv_eval_image *o = &e->orig[(size_t)v * e->size_count];
        paint_tile(&canvas, o, 0, row * t);
        paint_tile(&canvas, &acc[0], t, row * t);
        paint_heat(&canvas, o, &acc[0], 2 * t, row * t);
    }
    if (st == SV_OK) st = sv_image_write_png(&canvas, png_path, err);
    for (uint32_t s = 0; s < SV_EVAL_MAX_SIZES; s++) sv_eval_image_free(&acc[s]);
    sv_image_free(&canvas);
    return st;
}

/* ---- LOD switching ------------------------------------------------------- */

/* Mean coverage error at screen size px: measured values interpolated in
 * log2(size), held constant outside the measured range. */
double sv_eval_error_at(const sv_eval_result *r, double px)
{
    uint32_t n = r ? r->size_count : 0;
    if (n == 0) return 1.0;
    if (px >= r->sizes[0].pixels) return 1.0 - r->sizes[0].mean.iou;
    if (px <= r->sizes[n - 1].pixels) return 1.0 - r->sizes[n - 1].mean.iou;
    for (uint32_t s = 0; s + 1 < n; s++) {
        const sv_eval_size *hi = &r->sizes[s], *lo = &r->sizes[s + 1];
        if (px < lo->pixels) continue;
        double l0 = log2((double)lo->pixels), l1 = log2((double)hi->pixels);
        double t = l1 > l0 ? (log2(px) - l0) / (l1 - l0) : 0;
        return (1.0 - lo->mean.iou) + t * (lo->mean.iou - hi->mean.iou);
    }
    return 1.0 - r->sizes[n - 1].mean.iou;
}

double sv_eval_max_pixels_scaled(const sv_eval_result *r, double max_error, double ref_pixels)
{
    if (ref_pixels <= 0) return sv_eval_max_pixels(r, 1.0 - max_error);
    if (!r || r->size_count == 0) return 0.0;
    bool exact = true;
    for (uint32_t s = 0; s < r->size_count; s++) exact = exact && r->sizes[s].mean.iou >= 1.0;
    if (exact) return INFINITY;
    double budget = max_error * ref_pixels;
    /* the largest log2 size that passes: scan down in steps of 1/16, then
     * bisect the step where it starts to pass */
    const double top = 24, bottom = -8, step = 1.0 / 16;
    double fail = top + step;
    for (double x = top; x >= bottom; x -= step) {
        double px = exp2(x);
        if (sv_eval_error_at(r, px) * px <= budget) {
            if (x >= top) return exp2(top);
            double pass = x;
            for (int k = 0; k < 40; k++) {
                double mid = 0.5 * (pass + fail), mp = exp2(mid);
                if (sv_eval_error_at(r, mp) * mp <= budget) pass = mid;
                else fail = mid;
            }
            return exp2(pass);
        }
        fail = x;
    }
    return 0.0;
}

double sv_eval_max_pixels(const sv_eval_result *r, double min_iou)
{
    if (!r || r->size_count == 0) return 0.0;
    /* sizes are largest first: walk up from the smallest. */
    int last = (int)r->size_count - 1;
    if (r->sizes[last].mean.iou < min_iou) return 0.0;
    for (int s = last - 1; s >= 0; s--) {
        const sv_eval_size *pass = &r->sizes[s + 1], *fail = &r->sizes[s];
        if (fail->mean.iou >= min_iou) continue;
        double t = (pass->mean.iou - min_iou) / (pass->mean.iou - fail->mean.iou);
        double l0 = log2((double)pass->pixels), l1 = log2((double)fail->pixels);
        return exp2(l0 + t * (l1 - l0));
    }
    return (double)r->sizes[0].pixels;
}
