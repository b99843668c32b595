/* image.c — allocation and box-filter reduction of in-memory images, and
 * the sRGB transfer functions (the decoders and encoders live in
 * image_oiio.cpp). */
#include "image.h"
#include "srgb_tables.h"

#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>

/* What img->refs points to: the count of images sharing the pixels and, when
 * the pixels were decoded from a PNG or JPEG (sv_image_set_source), that
 * file's bytes. The count is first, so refs also reads as an atomic_uint. */
typedef struct pixels_ref {
    atomic_uint count;
    uint8_t *src; /* the encoded file, owned; NULL: none */
    size_t src_size;
    const char *mime;  /* "image/png" or "image/jpeg" */
    uint64_t src_hash; /* sv_image_pixel_hash of the pixels it decoded to */
    bool reduced;      /* the pixels are a reduction (sv_image_reduce) ... */
    uint64_t origin;   /* ... of pixels of this sv_image_pixel_hash */
    uint64_t own_hash; /* ... and were these when reduced */
} pixels_ref;

sv_status sv_image_alloc(sv_image *img, uint32_t w, uint32_t h, uint32_t channels, uint32_t bits,
                         sv_error *err)
{
    if (!img) return sv_fail(err, SV_ERR_INTERNAL, "sv_image_alloc: image is NULL");
    memset(img, 0, sizeof *img);
    if (channels < 1 || channels > 4)
        return sv_fail(err, SV_ERR_INTERNAL, "image with %u channels (1..4 allowed)", channels);
    if (bits != 8 && bits != 16)
        return sv_fail(err, SV_ERR_INTERNAL, "image with %u bits per channel (8 or 16 allowed)",
                       bits);
    size_t row, n;
    if (!sv_mul_size((size_t)w, (size_t)channels * (bits / 8), &row) ||
        !sv_mul_size(row, (size_t)h, &n))
        return sv_fail(err, SV_ERR_NOMEM, "image %ux%u with %u channels overflows size_t", w, h,
                       channels);
    void *data = calloc(n ? n : 1, 1);
    pixels_ref *refs = calloc(1, sizeof *refs);
    if (!data || !refs) {
        free(data);
        free(refs);
        return sv_fail(err, SV_ERR_NOMEM, "cannot allocate a %ux%u image (%zu bytes)", w, h, n);
    }
    atomic_init(&refs->count, 1u);
    img->width = w;
    img->height = h;
    img->channels = channels;
    img->bits = bits;
    img->data = data;
    img->refs = refs;
    return SV_OK;
}

void sv_image_free(sv_image *img)
{
    if (!img) return;
    pixels_ref *refs = img->refs;
    if (!refs || atomic_fetch_sub_explicit(&refs->count, 1u, memory_order_acq_rel) == 1u) {
        free(img->data);
        if (refs) free(refs->src);
        free(refs);
    }
    memset(img, 0, sizeof *img);
}

sv_status sv_image_copy(const sv_image *src, sv_image *dst, sv_error *err)
{
    memset(dst, 0, sizeof *dst);
    if (!src->data) return SV_OK;
    if (!src->refs) { /* pixels made elsewhere: a copy of its own */
        sv_status st = sv_image_alloc(dst, src->width, src->height, src->channels, src->bits, err);
        if (st) return st;
        memcpy(dst->data, src->data, sv_image_stride(src) * src->height);
        return SV_OK;
    }
    atomic_fetch_add_explicit(&((pixels_ref *)src->refs)->count, 1u, memory_order_relaxed);
    *dst = *src;
    return SV_OK;
}

uint64_t sv_image_pixel_hash(const sv_image *img)
{
    uint32_t head[4] = {img->width, img->height, img->channels, img->bits};
    /* its own start, not SV_FNV1A_BASIS: texture file names stay as they were */
    uint64_t h = sv_fnv1a(1469598103934665603ull, head, sizeof head);
    return sv_fnv1a(h, img->data, sv_image_stride(img) * img->height);
}

sv_status sv_image_set_source(sv_image *img, const void *data, size_t size, sv_error *err)
{
    pixels_ref *refs = img ? img->refs : NULL;
    if (!refs || !img->data || !data) return SV_OK;
    const uint8_t *d = data;
    const char *mime = NULL;
    if (size >= 8 && memcmp(d, "\x89PNG\r\n\x1a\n", 8) == 0) mime = "image/png";
    else if (size >= 3 && d[0] == 0xFF && d[1] == 0xD8 && d[2] == 0xFF) mime = "image/jpeg";
    if (!mime) return SV_OK;
    uint8_t *copy = malloc(size);
    if (!copy) return sv_fail(err, SV_ERR_NOMEM, "cannot keep a %zu-byte texture file", size);
    memcpy(copy, d, size);
    free(refs->src);
    refs->src = copy;
    refs->src_size = size;
    refs->mime = mime;
    refs->src_hash = sv_image_pixel_hash(img);
    return SV_OK;
}

bool sv_image_source(const sv_image *img, const uint8_t **data, size_t *size, const char **mime)
{
    const pixels_ref *refs = img ? img->refs : NULL;
    if (!refs || !refs->src || !img->data || refs->src_hash != sv_image_pixel_hash(img))
        return false;
    *data = refs->src;
    *size = refs->src_size;
    *mime = refs->mime;
    return true;
}

size_t sv_image_stride(const sv_image *img)
{
    return (size_t)img->width * img->channels * (img->bits / 8);
}

double sv_srgb_to_linear(double c)
{
    if (!(c > 0)) return 0;
    if (c >= 1) return 1;
    return c <= 0.04045 ? c / 12.92 : pow((c + 0.055) / 1.055, 2.4);
}

double sv_linear_to_srgb(double l)
{
    if (!(l > 0)) return 0;
    if (l >= 1) return 1;
    return l <= 0.0031308 ? 12.92 * l : 1.055 * pow(l, 1.0 / 2.4) - 0.055;
}

double sv_srgb_decode8(uint8_t code)
{
    return SRGB_DECODE[code];
}

uint8_t sv_srgb_encode8(double l)
{
    if (!(l > 0)) return 0;
    /* the number of boundaries at or below l (binary search, 8 steps) */
    uint32_t lo = 0, hi = 255;
    while (lo < hi) {
        uint32_t mid = (lo + hi) / 2;
        if (SRGB_MID[mid] <= l) lo = mid + 1;
        else hi = mid;
    }
    return (uint8_t)lo;
}

static uint8_t encode16[65536];
static pthread_once_t encode16_once = PTHREAD_ONCE_INIT;

static void encode16_fill(void)
{
    for (uint32_t c = 0; c < 65536; c++) encode16[c] = sv_srgb_encode8(c / 65535.0);
}

const uint8_t *sv_srgb_encode16_table(void)
{
    pthread_once(&encode16_once, encode16_fill);
    return encode16;
}

/* One 2:1 reduction (a side of 1 stays 1): each output texel is the mean of
 * the up to 2x2 input texels it covers; with 4 channels the colour is
 * weighted by alpha, so transparent texels do not darken the edges. 8-bit
 * RGBA colour is averaged in linear (image.h). */
static sv_status halve(sv_image *img, sv_error *err)
{
    uint32_t w = img->width > 1 ? (img->width + 1) / 2 : 1;
    uint32_t h = img->height > 1 ? (img->height + 1) / 2 : 1;
    sv_image out;
    sv_status st = sv_image_alloc(&out, w, h, img->channels, img->bits, err);
    if (st != SV_OK) return st;
    uint32_t c = img->channels;
    bool wide = img->bits == 16, alpha = c == 4, srgb = alpha && !wide;
    double maxv = wide ? 65535.0 : 255.0;
    for (uint32_t y = 0; y < h; y++)
        for (uint32_t x = 0; x < w; x++) {
            double sum[4] = {0}, wsum = 0, n = 0;
            for (uint32_t dy = 0; dy < 2; dy++)
                for (uint32_t dx = 0; dx < 2; dx++) {
                    uint32_t sx = 2 * x + dx, sy = 2 * y + dy;
                    if (sx >= img->width || sy >= img->height) continue;
                    size_t o = ((size_t)sy * img->width + sx) * c;
                    double v[4];
                    for (uint32_t k = 0; k < c; k++)
                        v[k] = wide ? ((const uint16_t *)img->data)[o + k]
                                    : ((const uint8_t *)img->data)[o + k];
                    for (uint32_t k = 0; srgb && k < 3; k++)
                        v[k] = sv_srgb_decode8(((const uint8_t *)img->data)[o + k]);
                    double a = alpha ? v[3] / maxv : 1.0;
                    for (uint32_t k = 0; k < c; k++) sum[k] += (alpha && k < 3) ? v[k] * a : v[k];
                    wsum += a;
                    n += 1;
                }
            size_t o = ((size_t)y * w + x) * c;
            for (uint32_t k = 0; k < c; k++) {
                double v = (alpha && k < 3) ? (wsum > 0 ? sum[k] / wsum : 0) : sum[k] / n;
                if (srgb && k < 3) {
                    ((uint8_t *)out.data)[o + k] = sv_srgb_encode8(v);
                    continue;
                }
                v = floor(v + 0.5);
                if (wide) ((uint16_t *)out.data)[o + k] = (uint16_t)fmin(v, maxv);
                else ((uint8_t *)out.data)[o + k] = (uint8_t)fmin(v, maxv);
            }
        }
    sv_image_free(img);
    *img = out;
    return SV_OK;
}

sv_status sv_image_reduce(sv_image *img, uint32_t max_side, sv_error *err)
{
    if (!img || !img->data || max_side == 0) return SV_OK;
    if (img->width <= max_side && img->height <= max_side) return SV_OK;
    uint64_t origin;
    if (!sv_image_reduced_from(img, &origin)) origin = sv_image_pixel_hash(img);
    while (img->width > max_side || img->height > max_side) {
        sv_status st = halve(img, err);
        if (st != SV_OK) return st;
    }
    pixels_ref *refs = img->refs;
    if (refs) {
        refs->reduced = true;
        refs->origin = origin;
        refs->own_hash = sv_image_pixel_hash(img);
    }
    return SV_OK;
}

bool sv_image_reduced_from(const sv_image *img, uint64_t *origin)
{
    const pixels_ref *refs = img ? img->refs : NULL;
    if (!refs || !refs->reduced || !img->data || refs->own_hash != sv_image_pixel_hash(img))
        return false;
    *origin = refs->origin;
    return true;
}

sv_status sv_png_check_chunks(const uint8_t *d, size_t n, const char *name, sv_error *err)
{
    size_t off = 8;
    while (true) {
        if (n < off || n - off < 12)
            return sv_fail(err, SV_ERR_PARSE, "image '%s' is a truncated PNG (%zu bytes, no IEND)",
                           name, n);
        uint32_t len = (uint32_t)d[off] << 24 | (uint32_t)d[off + 1] << 16 |
                       (uint32_t)d[off + 2] << 8 | d[off + 3];
        if (len > 0x7fffffffu || (size_t)len > n - off - 12)
            return sv_fail(err, SV_ERR_PARSE,
                           "image '%s' is a truncated PNG (chunk at byte %zu says %u bytes)", name,
                           off, len);
        bool iend = memcmp(d + off + 4, "IEND", 4) == 0;
        off += 12 + (size_t)len;
        if (iend) return SV_OK;
    }
}

uint32_t sv_texel_key(const uint8_t *p, uint32_t c)
{
    uint32_t r = p[0], g = c >= 3 ? p[1] : p[0], b = c >= 3 ? p[2] : p[0],
             a = (c == 2 || c == 4) ? p[c - 1] : 255;
    return (255 - a) << 24 | r << 16 | g << 8 | b;
}

uint32_t sv_image_colours(const sv_image *img, uint32_t keys[256])
{
    uint32_t c = img->channels;
    if (img->bits != 8 || c < 2 || c > 4 || !img->data) return 257;
    enum { SLOTS = 1024 }; /* open addressing, at most a quarter full */
    uint32_t key[SLOTS];
    bool used[SLOTS] = {false};
    uint32_t n = 0;
    const uint8_t *px = img->data;
    for (size_t i = 0, len = (size_t)img->width * img->height; i < len; i++) {
        uint32_t k = sv_texel_key(px + i * c, c), h = (k * 2654435761u) >> 22;
        while (used[h] && key[h] != k) h = (h + 1) & (SLOTS - 1);
        if (used[h]) continue;
        if (n == 256) return 257;
        used[h] = true;
        key[h] = k;
        keys[n++] = k;
    }
    for (uint32_t i = 1; i < n; i++) /* insertion sort, descending: at most 256 */
        for (uint32_t j = i; j > 0 && keys[j - 1] < keys[j]; j--) {
            uint32_t t = keys[j];
            keys[j] = keys[j - 1];
            keys[j - 1] = t;
        }
    return n;
}
