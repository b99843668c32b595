/* atlas.c — chart packing with stb_rect_pack (Debian's libstb-dev) and the texel
 * filters of quad baking from the billboard-cloud paper (Behrendt et al.,
 * §3.3.7 "Texture generation"): a rectangular median filter with an alpha
 * threshold for downsampling supersampled renders to binary alpha, and colour
 * dilation so mipmaps and bilinear filtering do not bleed background colour.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "atlas.h"

/* stb_rect_pack sorts with qsort, whose order of equal keys is unspecified;
 * a stable merge sort makes the layout the same on every libc. */
static void sv_stable_sort(void *base, size_t n, size_t size,
                           int (*cmp)(const void *, const void *));

#define STBRP_SORT sv_stable_sort
#define STBRP_STATIC
#define STB_RECT_PACK_IMPLEMENTATION
#include <stb_rect_pack.h>

static void merge_sort(unsigned char *a, unsigned char *tmp, size_t n, size_t size,
                       int (*cmp)(const void *, const void *))
{
    if (n < 2) return;
    size_t h = n / 2;
    merge_sort(a, tmp, h, size, cmp);
    merge_sort(a + h * size, tmp, n - h, size, cmp);
    size_t i = 0, j = h, k = 0;
    while (i < h && j < n) {
        if (cmp(a + j * size, a + i * size) < 0) memcpy(tmp + (k++) * size, a + (j++) * size, size);
        else memcpy(tmp + (k++) * size, a + (i++) * size, size);
    }
    while (i < h) memcpy(tmp + (k++) * size, a + (i++) * size, size);
    while (j < n) memcpy(tmp + (k++) * size, a + (j++) * size, size);
    memcpy(a, tmp, n * size);
}

static void sv_stable_sort(void *base, size_t n, size_t size,
                           int (*cmp)(const void *, const void *))
{
    unsigned char *tmp = sv_calloc(n ? n : 1, size);
    if (tmp) {
        merge_sort(base, tmp, n, size, cmp);
        free(tmp);
        return;
    }
    /* No memory: stable insertion sort in place (rects are small structs). */
    unsigned char *a = base, swap[64];
    if (size > sizeof swap) return;
    for (size_t i = 1; i < n; i++)
        for (size_t j = i; j > 0 && cmp(a + j * size, a + (j - 1) * size) < 0; j--) {
            memcpy(swap, a + j * size, size);
            memcpy(a + j * size, a + (j - 1) * size, size);
            memcpy(a + (j - 1) * size, swap, size);
        }
}

bool sv_atlas_pack(sv_chart *charts, uint32_t n, uint32_t width, uint32_t height, uint32_t padding)
{
    if (n == 0) return true;
    if (width == 0 || height == 0 || width > INT32_MAX / 2 || height > INT32_MAX / 2) return false;
    for (uint32_t i = 0; i < n; i++)
        if (charts[i].w == 0 || charts[i].h == 0 || (uint64_t)charts[i].w + padding > width ||
            (uint64_t)charts[i].h + padding > height)
            return false;
    stbrp_rect *rects = sv_calloc(n, sizeof *rects);
    stbrp_node *nodes = sv_calloc(width, sizeof *nodes);
    bool ok = false;
    if (!rects || !nodes) goto out;
    for (uint32_t i = 0; i < n; i++) {
        rects[i].id = (int)i;
        rects[i].w = (stbrp_coord)(charts[i].w + padding);
        rects[i].h = (stbrp_coord)(charts[i].h + padding);
    }
    stbrp_context ctx;
    stbrp_init_target(&ctx, (int)width, (int)height, nodes, (int)width);
    ok = stbrp_pack_rects(&ctx, rects, (int)n) == 1;
    if (ok)
        for (uint32_t i = 0; i < n; i++) {
            charts[rects[i].id].x = (uint32_t)rects[i].x + padding / 2;
            charts[rects[i].id].y = (uint32_t)rects[i].y + padding / 2;
        }
out:
    free(rects);
    free(nodes);
    return ok;
}

bool sv_atlas_fit(sv_chart *charts, uint32_t n, uint32_t padding, uint32_t max_side,
                  uint32_t *width, uint32_t *height)
{
    uint32_t side = 1;
    while (side <= max_side / 2) side *= 2; /* the largest power of two <= max_side */
    if (max_side == 0 || !sv_atlas_pack(charts, n, side, side, padding)) return false;
    /* Shrink while the next smaller square still fits. */
    while (side > 1 && sv_atlas_pack(charts, n, side / 2, side / 2, padding)) side /= 2;
    uint32_t h = side;
    if (side > 1 && sv_atlas_pack(charts, n, side, side / 2, padding)) h = side / 2;
    bool ok = sv_atlas_pack(charts, n, side, h, padding); /* final layout */
    *width = side;
    *height = h;
    return ok;
}

static uint32_t texels_for(double half, double texel)
{
    double t = ceil(2.0 * half / texel - 1e-9);
    if (!(t >= 1.0)) return 1;
    if (t > (double)(UINT32_MAX / 4)) return UINT32_MAX / 4;
    return (uint32_t)t;
}

void sv_chart_size(double half_u, double half_v, double texel, uint32_t *w, uint32_t *h)
{
    *w = texels_for(half_u, texel);
    *h = texels_for(half_v, texel);
}

static bool fits_at(const double *half, uint32_t n, uint32_t padding, uint32_t side, double texel,
                    sv_chart *charts)
{
    for (uint32_t i = 0; i < n; i++)
        sv_chart_size(half[2 * i], half[2 * i + 1], texel, &charts[i].w, &charts[i].h);
    return sv_atlas_pack(charts, n, side, side, padding);
}

sv_status sv_atlas_choose_texel(const double *half, uint32_t n, uint32_t padding, uint32_t max_side,
                                double *texel, sv_error *err)
{
    *texel = 0;
    if (n == 0) {
        *texel = 1.0;
        return SV_OK;
    }
    uint32_t side = 1;
    while (side <= max_side / 2) side *= 2;
    double area = 0, biggest = 0;
    for (uint32_t i = 0; i < n; i++) {
        double a = 2 * half[2 * i], b = 2 * half[2 * i + 1];
        if (!isfinite(a) || !isfinite(b) || a < 0 || b < 0)
            return sv_fail(err, SV_ERR_INTERNAL, "atlas: quad %u has bad extents %g x %g", i, a, b);
        area += a * b;
        if (a > biggest) biggest = a;
        if (b > biggest) biggest = b;
    }
    sv_chart *charts = sv_calloc(n, sizeof *charts);
    if (!charts) return sv_fail(err, SV_ERR_NOMEM, "atlas: out of memory for %u charts", n);
    double hi = biggest > 0 ? biggest : 1.0; /* every chart 1×1 */
    if (!fits_at(half, n, padding, side, hi, charts)) {
        free(charts);
        return sv_fail(err, SV_ERR_LIMIT,
                       "atlas: %u charts with padding %u do not fit %ux%u even at one texel each",
                       n, padding, side, side);
    }
    /* Lower bound: the charts' total area equals the atlas area. */
    double lo = area > 0 ? sqrt(area) / side : hi * 1e-6;
    if (lo >= hi) lo = hi * 0.5;
    if (fits_at(half, n, padding, side, lo, charts)) hi = lo;
    else
        for (int it = 0; it < 60 && hi / lo > 1.0 + 1e-4; it++) {
            double mid = sqrt(lo * hi);
            if (fits_at(half, n, padding, side, mid, charts)) hi = mid;
            else lo = mid;
        }
    free(charts);
    *texel = hi;
    return SV_OK;
}

/* k-th smallest of a[0..n) (quickselect, median-of-three pivot); reorders a.
 * One body for the two element types the median filters use. */
#define SV_DEFINE_SELECT(name, T)                                                            \
    static T name(T *a, uint32_t n, uint32_t k)                                              \
    {                                                                                        \
        uint32_t lo = 0, hi = n - 1;                                                         \
        while (lo < hi) {                                                                    \
            uint32_t mid = lo + (hi - lo) / 2;                                               \
            T x = a[lo], y = a[mid], z = a[hi];                                              \
            T pivot = x < y ? (y < z ? y : (x < z ? z : x)) : (x < z ? x : (y < z ? z : y)); \
            uint32_t i = lo, j = hi;                                                         \
            while (i <= j) {                                                                 \
                while (a[i] < pivot) i++;                                                    \
                while (a[j] > pivot) j--;                                                    \
                if (i <= j) {                                                                \
                    T t = a[i];                                                              \
                    a[i] = a[j];                                                             \
                    a[j] = t;                                                                \
                    i++;                                                                     \
                    if (j == 0) break;                                                       \
                    j--;                                                                     \
                }                                                                            \
            }                                                                                \
            if (k <= j) hi = j;                                                              \
            else if (k >= i) lo = i;                                                         \
            else return a[k];                                                                \
        }                                                                                    \
        return a[k];                                                                         \
    }
SV_DEFINE_SELECT(select_u8, uint8_t)
SV_DEFINE_SELECT(select_f32, float)
SV_DEFINE_SELECT(select_u16, uint16_t)
#undef SV_DEFINE_SELECT

/* Covered samples needed for an opaque texel: ceil(threshold · s²), at least 1. */
static uint32_t needed(double thr, uint32_t s)
{
    double n = ceil(thr * (double)s * s - 1e-9);
    return n < 1 ? 1 : (uint32_t)n;
}

void sv_downsample_median(const uint8_t *src, uint32_t w, uint32_t h, uint32_t s, double thr,
                          uint8_t *dst)
{
    bool cover = !(thr > 0); /* coverage alpha: any covered sample keeps the texel */
    uint32_t need = needed(thr, s);
    size_t sw = (size_t)w * s;
    uint8_t ch[4][256];
    uint8_t(*buf)[256] = ch;
    uint8_t *big = NULL;
    if ((size_t)s * s > 256) {
        big = malloc(4 * (size_t)s * s);
        if (!big) { /* cannot filter: leave everything empty (callers cap s at 16) */
            memset(dst, 0, (size_t)w * h * 4);
            return;
        }
    }
    for (uint32_t ty = 0; ty < h; ty++)
        for (uint32_t tx = 0; tx < w; tx++) {
            uint32_t c = 0;
            for (uint32_t y = 0; y < s; y++) {
                const uint8_t *row = src + ((size_t)ty * s + y) * sw * 4 + (size_t)tx * s * 4;
                for (uint32_t x = 0; x < s; x++) {
                    const uint8_t *p = row + 4 * (size_t)x;
                    if (p[3] == 0) continue;
                    for (int k = 0; k < 4; k++) {
                        if (big) big[(size_t)k * s * s + c] = p[k];
                        else buf[k][c] = p[k];
                    }
                    c++;
                }
            }
            uint8_t *o = dst + ((size_t)ty * w + tx) * 4;
            if (c < need) {
                o[0] = o[1] = o[2] = o[3] = 0;
                continue;
            }
            for (int k = 0; k < 3; k++)
                o[k] = select_u8(big ? big + (size_t)k * s * s : buf[k], c, (c - 1) / 2);
            if (cover) {
                uint32_t ss = s * s, a = (255u * c + ss / 2) / ss;
                o[3] = (uint8_t)(a < 1 ? 1 : a);
            } else {
                o[3] = 255;
            }
        }
    free(big);
}

void sv_downsample_colour16(const uint16_t *src, uint32_t w, uint32_t h, uint32_t s, double thr,
                            uint16_t *dst)
{
    static const double rec709[3] = {0.2126, 0.7152, 0.0722};
    bool cover = !(thr > 0); /* coverage alpha: any covered sample keeps the texel */
    uint32_t need = needed(thr, s);
    size_t sw = (size_t)w * s;
    uint16_t *buf = malloc(3 * (size_t)s * s * sizeof *buf);
    if (!buf) { /* cannot filter: leave everything empty (callers cap s at 16) */
        memset(dst, 0, (size_t)w * h * 4 * sizeof *dst);
        return;
    }
    for (uint32_t ty = 0; ty < h; ty++)
        for (uint32_t tx = 0; tx < w; tx++) {
            uint32_t c = 0;
            double sum[3] = {0, 0, 0};
            for (uint32_t y = 0; y < s; y++) {
                const uint16_t *row = src + ((size_t)ty * s + y) * sw * 4 + (size_t)tx * s * 4;
                for (uint32_t x = 0; x < s; x++) {
                    const uint16_t *p = row + 4 * (size_t)x;
                    if (p[3] == 0) continue;
                    for (int k = 0; k < 3; k++) {
                        buf[(size_t)k * s * s + c] = p[k];
                        sum[k] += p[k];
                    }
                    c++;
                }
            }
            uint16_t *o = dst + ((size_t)ty * w + tx) * 4;
            if (c < need) {
                o[0] = o[1] = o[2] = o[3] = 0;
                continue;
            }
            double med[3], y_med = 0, y_mean = 0;
            for (int k = 0; k < 3; k++) {
                med[k] = select_u16(buf + (size_t)k * s * s, c, (c - 1) / 2);
                y_med += rec709[k] * med[k];
                y_mean += rec709[k] * sum[k] / c;
            }
            for (int k = 0; k < 3; k++) {
                double v = y_med > 0 ? med[k] * (y_mean / y_med) : sum[k] / c;
                o[k] = (uint16_t)fmin(65535.0, floor(v + 0.5));
            }
            if (cover) {
                uint32_t ss = s * s, a = (255u * c + ss / 2) / ss;
                o[3] = (uint16_t)((a < 1 ? 1 : a) * 257u);
            } else {
                o[3] = 65535u;
            }
        }
    free(buf);
}

void sv_downsample_median_f32(const float *src, uint32_t w, uint32_t h, uint32_t s, double thr,
                              float *dst)
{
    uint32_t need = needed(thr, s);
    size_t sw = (size_t)w * s;
    float *buf = malloc((size_t)s * s * sizeof *buf);
    for (uint32_t ty = 0; ty < h; ty++)
        for (uint32_t tx = 0; tx < w; tx++) {
            uint32_t c = 0;
            for (uint32_t y = 0; y < s && buf; y++) {
                const float *row = src + ((size_t)ty * s + y) * sw + (size_t)tx * s;
                for (uint32_t x = 0; x < s; x++)
                    if (isfinite(row[x])) buf[c++] = row[x];
            }
            dst[(size_t)ty * w + tx] = c < need || !buf ? INFINITY
                                                        : select_f32(buf, c, (c - 1) / 2);
        }
    free(buf);
}

sv_status sv_dilate(sv_image *img, const uint8_t *mask, uint32_t fill_channels, uint32_t passes,
                    sv_error *err)
{
    if (!img || !img->data || img->width == 0 || img->height == 0) return SV_OK;
    uint32_t w = img->width, h = img->height, nc = img->channels;
    if (fill_channels > nc) fill_channels = nc;
    size_t npx = (size_t)w * h;
    uint8_t *known = malloc(npx);
    uint32_t *fresh = malloc(npx * sizeof *fresh);
    uint32_t *vals = sv_calloc(npx, 4 * sizeof *vals);
    if (!known || !fresh || !vals) {
        free(known);
        free(fresh);
        free(vals);
        return sv_fail(err, SV_ERR_NOMEM, "dilate: out of memory for %ux%u", w, h);
    }
    bool wide = img->bits == 16;
    /* RGBA colour: a valued texel of the mask weighs its alpha (premultiplied
     * mean, so a barely covered texel does not tint its neighbours as much as
     * a covered one); texels filled by dilation weigh 1 */
    bool weigh = nc == 4 && fill_channels == 3;
    double amax = wide ? 65535.0 : 255.0;
    uint8_t *p8 = img->data;
    uint16_t *p16 = img->data;
#define GET(i, k) (wide ? (uint32_t)p16[(i)*nc + (k)] : (uint32_t)p8[(i)*nc + (k)])
#define PUT(i, k, v)                                 \
    do {                                             \
        if (wide) p16[(i)*nc + (k)] = (uint16_t)(v); \
        else p8[(i)*nc + (k)] = (uint8_t)(v);        \
    } while (0)
    for (size_t i = 0; i < npx; i++) known[i] = mask[i] != 0;
    for (uint32_t pass = 0; pass < passes; pass++) {
        size_t nf = 0;
        for (uint32_t y = 0; y < h; y++)
            for (uint32_t x = 0; x < w; x++) {
                size_t i = (size_t)y * w + x;
                if (known[i]) continue;
                uint32_t sum[4] = {0, 0, 0, 0}, cnt = 0;
                double wsum[3] = {0, 0, 0}, wt = 0;
                for (int dy = -1; dy <= 1; dy++)
                    for (int dx = -1; dx <= 1; dx++) {
                        int64_t yy = (int64_t)y + dy, xx = (int64_t)x + dx;
                        if ((dx == 0 && dy == 0) || yy < 0 || xx < 0 || yy >= h || xx >= w)
                            continue;
                        size_t j = (size_t)yy * w + (size_t)xx;
                        if (known[j] != 1) continue;
                        for (uint32_t k = 0; k < fill_channels; k++) sum[k] += GET(j, k);
                        cnt++;
                        if (weigh) {
                            double a = mask[j] ? GET(j, 3) / amax : 1.0;
                            for (uint32_t k = 0; k < 3; k++) wsum[k] += a * GET(j, k);
                            wt += a;
                        }
                    }
                if (!cnt) continue;
                for (uint32_t k = 0; k < fill_channels; k++)
                    vals[4 * nf + k] = weigh ? (wt > 0 ? (uint32_t)floor(wsum[k] / wt + 0.5) : 0)
                                             : (sum[k] + cnt / 2) / cnt;
                fresh[nf++] = (uint32_t)i;
            }
        if (nf == 0) break;
        /* Commit after the pass so each pass grows the valued region by one texel. */
        for (size_t f = 0; f < nf; f++) {
            size_t i = fresh[f];
            for (uint32_t k = 0; k < fill_channels; k++) PUT(i, k, vals[4 * f + k]);
            known[i] = 1;
        }
    }
    /* Far texels: the mean of every valued texel (so low mip levels keep the hue). */
    uint64_t total[4] = {0, 0, 0, 0}, cnt = 0;
    double wtotal[3] = {0, 0, 0}, wt = 0;
    for (size_t i = 0; i < npx; i++)
        if (known[i]) {
            for (uint32_t k = 0; k < fill_channels; k++) total[k] += GET(i, k);
            cnt++;
            if (weigh) {
                double a = mask[i] ? GET(i, 3) / amax : 1.0;
                for (uint32_t k = 0; k < 3; k++) wtotal[k] += a * GET(i, k);
                wt += a;
            }
        }
    if (cnt && cnt < npx)
        for (size_t i = 0; i < npx; i++)
            if (!known[i])
                for (uint32_t k = 0; k < fill_channels; k++)
                    PUT(i, k,
                        weigh ? (wt > 0 ? (uint32_t)floor(wtotal[k] / wt + 0.5) : 0)
                              : (total[k] + cnt / 2) / cnt);
#undef GET
#undef PUT
    free(known);
    free(fresh);
    free(vals);
    return SV_OK;
}

/* Pull-push (Gortler et al., "The Lumigraph", SIGGRAPH 1996, §3.3's
 * pull-push fill): a pyramid of 2×2 sums of alpha-weighted linear colour
 * and alpha, then each texel of alpha 0 takes the weighted mean of the
 * smallest block of the pyramid above it that holds alpha. The blocks are
 * the mip levels' own, so an engine's straight mip average of a block sees
 * the colour a premultiplied one would. l: w × h linear RGBA16, written
 * only where a[] (w × h alphas, 8-bit) is 0. SV_ERR_NOMEM on failure. */
static sv_status pull_push(uint16_t *l, const uint8_t *a, uint32_t w, uint32_t h, sv_error *err)
{
    uint32_t lw[40], lh[40];
    size_t off[40], total = 0;
    int n = 0;
    for (uint32_t cw = w, ch = h; (cw > 1 || ch > 1) && n < 40; n++) {
        cw = (cw + 1) / 2;
        ch = (ch + 1) / 2;
        lw[n] = cw;
        lh[n] = ch;
        off[n] = total;
        total += (size_t)cw * ch;
    }
    if (n == 0) return SV_OK;
    float *p = sv_calloc(total, 4 * sizeof *p); /* r, g, b (premultiplied), weight */
    if (!p) return sv_fail(err, SV_ERR_NOMEM, "dilate: out of memory for a %ux%u pyramid", w, h);
    for (uint32_t y = 0; y < h; y++)
        for (uint32_t x = 0; x < w; x++) {
            size_t i = (size_t)y * w + x;
            float wt = a[i] / 255.0f;
            if (!(wt > 0)) continue;
            float *q = p + 4 * (off[0] + (size_t)(y / 2) * lw[0] + x / 2);
            for (int k = 0; k < 3; k++) q[k] += wt * (l[4 * i + k] / 65535.0f);
            q[3] += wt;
        }
    for (int v = 1; v < n; v++)
        for (uint32_t y = 0; y < lh[v - 1]; y++)
            for (uint32_t x = 0; x < lw[v - 1]; x++) {
                const float *c = p + 4 * (off[v - 1] + (size_t)y * lw[v - 1] + x);
                float *q = p + 4 * (off[v] + (size_t)(y / 2) * lw[v] + x / 2);
                for (int k = 0; k < 4; k++) q[k] += c[k];
            }
    /* push: a block's mean colour, or its parent's where it holds no alpha */
    for (int v = n - 1; v >= 0; v--)
        for (uint32_t y = 0; y < lh[v]; y++)
            for (uint32_t x = 0; x < lw[v]; x++) {
                float *q = p + 4 * (off[v] + (size_t)y * lw[v] + x);
                if (q[3] > 0) {
                    for (int k = 0; k < 3; k++) q[k] /= q[3];
                } else if (v + 1 < n) {
                    const float *pa = p + 4 * (off[v + 1] + (size_t)(y / 2) * lw[v + 1] + x / 2);
                    memcpy(q, pa, 3 * sizeof *q);
                }
                q[3] = 1;
            }
    for (uint32_t y = 0; y < h; y++)
        for (uint32_t x = 0; x < w; x++) {
            size_t i = (size_t)y * w + x;
            if (a[i]) continue;
            const float *q = p + 4 * (off[0] + (size_t)(y / 2) * lw[0] + x / 2);
            for (int k = 0; k < 3; k++) {
                double c = q[k] < 0 ? 0 : q[k] > 1 ? 1 : q[k];
                l[4 * i + k] = (uint16_t)lround(c * 65535.0);
            }
        }
    free(p);
    return SV_OK;
}

sv_status sv_atlas_fill(sv_image *lin, sv_error *err)
{
    if (!lin || !lin->data || lin->channels != 4 || lin->bits != 16) return SV_OK;
    uint32_t w = lin->width, h = lin->height;
    size_t npx = (size_t)w * h;
    uint8_t *a = malloc(npx ? npx : 1);
    if (!a) return sv_fail(err, SV_ERR_NOMEM, "atlas fill: out of memory for %ux%u", w, h);
    uint16_t *l = lin->data;
    size_t clear = 0;
    for (size_t i = 0; i < npx; i++) { /* the alpha the 8-bit atlas will hold */
        a[i] = (uint8_t)((l[4 * i + 3] * 255u + 32767u) / 65535u);
        clear += a[i] == 0;
    }
    sv_status st = clear && clear < npx ? pull_push(l, a, w, h, err) : SV_OK;
    free(a);
    return st;
}

static uint32_t rgb_dist2(uint32_t a, uint32_t b)
{
    uint32_t d = 0;
    for (int k = 0; k < 3; k++) {
        int x = (int)((a >> (8 * k)) & 255) - (int)((b >> (8 * k)) & 255);
        d += (uint32_t)(x * x);
    }
    return d;
}

/* The index in cand (n colours, ok[i] says which may be chosen) nearest to c
 * in sRGB bytes; ties to the lower index. */
static uint32_t nearest_colour(uint32_t c, const uint32_t *cand, const bool *ok, uint32_t n)
{
    uint32_t best = 0, bd = UINT32_MAX;
    for (uint32_t j = 0; j < n; j++)
        if (ok[j] && rgb_dist2(c, cand[j]) < bd) bd = rgb_dist2(c, cand[j]), best = j;
    return best;
}

/* A texture of at most 256 colours (an indexed PNG: the ez-tree leaves) stays
 * one, so that its file stays an indexed PNG (docs/outputs.md "Sizes"; as
 * RGBA the aspen's leaves were 461 KB against the input's 142 KB): each
 * filled texel (px's alpha 0) of o takes, of the colours of the visible
 * texels, the one nearest its fill (sRGB bytes); when the fills would
 * need more transparent entries than the palette has room for (256 less the
 * visible colours), the most used are kept and the others go to the
 * nearest kept. The fill's purpose, a mip average that sees the leaf's
 * colours and not black, is kept; the leaf colours are dense enough that
 * the nearest is a few levels away. Nothing is done (o keeps the full
 * fill) when px has more than 256 colours or 256 visible ones. */
static sv_status snap_fill_to_palette(const sv_image *src, uint8_t *o, sv_error *err)
{
    const uint8_t *px = src->data;
    size_t npx = (size_t)src->width * src->height;
    uint32_t pal[256], vis[256]; /* keys (sv_texel_key); visible colours' R << 16 | G << 8 | B */
    uint32_t np = sv_image_colours(src, pal), nv = 0;
    if (np > 256) return SV_OK;
    for (uint32_t i = 0; i < np; i++)
        if ((pal[i] >> 24) != 255) {
            uint32_t rgb = pal[i] & 0xFFFFFFu;
            bool dup = false;
            for (uint32_t j = 0; j < nv && !dup; j++) dup = vis[j] == rgb;
            if (!dup) vis[nv++] = rgb;
        }
    uint32_t visible = 0; /* palette entries with alpha: they stay */
    for (uint32_t i = 0; i < np; i++) visible += (pal[i] >> 24) != 255;
    if (nv == 0 || visible >= 256) return SV_OK;
    uint32_t room = 256 - visible;
    uint8_t *pick = malloc(npx);
    uint32_t *cache = malloc((size_t)4096 * 2 * sizeof *cache); /* fill rgb, index + 1 */
    if (!pick || !cache) {
        free(pick);
        free(cache);
        return sv_fail(err, SV_ERR_NOMEM, "dilate: out of memory");
    }
    memset(cache, 0, (size_t)4096 * 2 * sizeof *cache);
    bool ok[256];
    for (uint32_t j = 0; j < nv; j++) ok[j] = true;
    size_t count[256] = {0};
    for (size_t i = 0; i < npx; i++) {
        if (px[4 * i + 3]) continue;
        uint32_t c = (uint32_t)o[4 * i] << 16 | (uint32_t)o[4 * i + 1] << 8 | (uint32_t)o[4 * i + 2];
        uint32_t h = ((c * 2654435761u) >> 20) & 4095u;
        uint32_t j;
        if (cache[2 * h + 1] && cache[2 * h] == c) {
            j = cache[2 * h + 1] - 1;
        } else {
            j = nearest_colour(c, vis, ok, nv);
            cache[2 * h] = c;
            cache[2 * h + 1] = j + 1;
        }
        pick[i] = (uint8_t)j;
        count[j]++;
    }
    uint32_t need = 0;
    for (uint32_t j = 0; j < nv; j++) need += count[j] > 0;
    if (need > room) { /* keep the `room` most used; the rest to the nearest kept */
        bool keep[256] = {false};
        for (uint32_t r = 0; r < room; r++) {
            uint32_t b = nv;
            for (uint32_t j = 0; j < nv; j++)
                if (!keep[j] && count[j] > 0 && (b == nv || count[j] > count[b])) b = j;
            if (b < nv) keep[b] = true;
        }
        uint8_t to[256];
        for (uint32_t j = 0; j < nv; j++)
            to[j] = (uint8_t)(keep[j] ? j : nearest_colour(vis[j], vis, keep, nv));
        for (size_t i = 0; i < npx; i++)
            if (!px[4 * i + 3]) pick[i] = to[pick[i]];
    }
    for (size_t i = 0; i < npx; i++)
        if (!px[4 * i + 3])
            for (int k = 0; k < 3; k++) o[4 * i + k] = (uint8_t)(vis[pick[i]] >> (16 - 8 * k));
    free(pick);
    free(cache);
    return SV_OK;
}

sv_status sv_texture_dilate(const sv_image *src, uint32_t passes, sv_image *out, bool *changed,
                            sv_error *err)
{
    memset(out, 0, sizeof *out);
    *changed = false;
    if (!src || !src->data || src->channels != 4 || src->bits != 8 || passes == 0) return SV_OK;
    uint32_t w = src->width, h = src->height;
    size_t npx = (size_t)w * h, clear = 0;
    const uint8_t *px = src->data;
    for (size_t i = 0; i < npx; i++) clear += px[4 * i + 3] == 0;
    if (clear == 0 || clear == npx) return SV_OK;
    sv_image lin = {0};
    uint8_t *mask = malloc(npx);
    uint32_t *dist = malloc(npx * sizeof *dist);
    sv_status st = SV_OK;
    if (!mask || !dist) {
        st = sv_fail(err, SV_ERR_NOMEM, "dilate: out of memory for a %ux%u texture", w, h);
        goto done;
    }
    if ((st = sv_image_alloc(&lin, w, h, 4, 16, err)) != SV_OK) goto done;
    uint16_t *l = lin.data;
    for (size_t i = 0; i < npx; i++) {
        mask[i] = px[4 * i + 3];
        for (int k = 0; k < 3; k++)
            l[4 * i + k] = (uint16_t)lround(sv_srgb_decode8(px[4 * i + k]) * 65535.0);
        l[4 * i + 3] = (uint16_t)(px[4 * i + 3] * 257u);
    }
    if ((st = pull_push(l, mask, w, h, err)) != SV_OK) goto done;
    /* Chebyshev distance to the nearest texel with alpha (two raster passes
     * over the 8-neighbourhood): the transparent texels an engine's first
     * mip levels blend in, on which the change is judged */
    for (size_t i = 0; i < npx; i++) dist[i] = mask[i] ? 0 : UINT32_MAX - 1;
    for (uint32_t y = 0; y < h; y++)
        for (uint32_t x = 0; x < w; x++) {
            uint32_t *d = &dist[(size_t)y * w + x];
            if (x > 0 && d[-1] + 1 < *d) *d = d[-1] + 1;
            if (y > 0)
                for (int dx = -1; dx <= 1; dx++) {
                    if ((dx < 0 && x == 0) || (dx > 0 && x + 1 >= w)) continue;
                    uint32_t v = dist[(size_t)(y - 1) * w + (size_t)((int64_t)x + dx)];
                    if (v + 1 < *d) *d = v + 1;
                }
        }
    for (uint32_t y = h; y-- > 0;)
        for (uint32_t x = w; x-- > 0;) {
            uint32_t *d = &dist[(size_t)y * w + x];
            if (x + 1 < w && d[1] + 1 < *d) *d = d[1] + 1;
            if (y + 1 < h)
                for (int dx = -1; dx <= 1; dx++) {
                    if ((dx < 0 && x == 0) || (dx > 0 && x + 1 >= w)) continue;
                    uint32_t v = dist[(size_t)(y + 1) * w + (size_t)((int64_t)x + dx)];
                    if (v + 1 < *d) *d = v + 1;
                }
        }
    if ((st = sv_image_alloc(out, w, h, 4, 8, err)) != SV_OK) goto done;
    const uint8_t *enc = sv_srgb_encode16_table();
    uint8_t *o = out->data;
    memcpy(o, px, npx * 4);
    for (size_t i = 0; i < npx; i++)
        if (!mask[i])
            for (int k = 0; k < 3; k++) o[4 * i + k] = enc[l[4 * i + k]];
    if ((st = snap_fill_to_palette(src, o, err)) != SV_OK) {
        sv_image_free(out);
        goto done;
    }
    size_t reached = 0, moved = 0;
    for (size_t i = 0; i < npx; i++) {
        if (mask[i]) continue;
        bool big = false;
        for (int k = 0; k < 3; k++)
            if (abs((int)o[4 * i + k] - (int)px[4 * i + k]) > 8) big = true;
        if (dist[i] <= passes) {
            reached++;
            moved += big;
        }
    }
    *changed = moved > 0 && moved * 100 >= reached;
    if (!*changed) sv_image_free(out);
done:
    free(mask);
    free(dist);
    sv_image_free(&lin);
    return st;
}
