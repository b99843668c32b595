/* image_png.c — PNG encoding with libpng (see image.h).
 *
 * Every bake writes PNGs (atlases, mips, depth maps, the preview); few decode
 * anything. Encoding through libpng directly keeps OpenImageIO, whose 261
 * shared libraries cost time and memory at every process start, out
 * of the processes that never decode a texture: OIIO is the decoding plugin
 * (image_plugin.c), loaded on first use.
 *
 * The stream is deterministic: IHDR, PLTE and tRNS when indexed, IDAT, IEND
 * only (no time, text or physical-size chunks), zlib level 6 (level 9 was
 * 1 % smaller on an atlas for 4.8 times the time; docs/outputs.md "Sizes"),
 * libpng's default adaptive filters, no channel the pixels do not need
 * (alpha, colour), and an image of at most 256 colours indexed. 16-bit
 * samples are written big-endian as PNG requires. A memo (sv_png_memo) lets
 * the write stage encode each atlas once for its three files.
 */
#include "image.h"
#include "image_io.h"

#include <png.h>
#include <setjmp.h>
#include <stdlib.h>
#include <string.h>

#ifndef SV_PNG_ZLIB_LEVEL
#define SV_PNG_ZLIB_LEVEL 6
#endif

typedef struct png_sink {
    uint8_t *data;
    size_t size, cap;
    bool oom;
} png_sink;

static void sink_write(png_structp png, png_bytep bytes, png_size_t n)
{
    png_sink *s = png_get_io_ptr(png);
    if (s->oom) return;
    if (n > SIZE_MAX - s->size) {
        s->oom = true;
        return;
    }
    if (s->size + n > s->cap) {
        size_t cap = s->cap ? s->cap : 65536;
        while (cap < s->size + n) cap = cap > SIZE_MAX / 2 ? s->size + n : cap * 2;
        uint8_t *p = realloc(s->data, cap);
        if (!p) {
            s->oom = true;
            return;
        }
        s->data = p;
        s->cap = cap;
    }
    memcpy(s->data + s->size, bytes, n);
    s->size += n;
}

static void sink_flush(png_structp png)
{
    (void)png;
}

/* libpng reports errors by longjmp from here; the message goes to the
 * caller's sv_error through the error pointer. */
static void png_error_fn(png_structp png, png_const_charp msg)
{
    sv_error *err = png_get_error_ptr(png);
    if (err) sv_fail(err, SV_ERR_IO, "PNG encoding failed: %s", msg);
    png_longjmp(png, 1);
}

static void png_warning_fn(png_structp png, png_const_charp msg)
{
    (void)png;
    (void)msg;
}

/* An indexed image: at most 256 RGBA colours (entries with alpha below 255
 * first, so tRNS is short; then ascending), one byte a texel. */
typedef struct indexed {
    png_color rgb[256];
    png_byte alpha[256];
    int count, translucent; /* entries; those with alpha < 255 */
    uint8_t *index;         /* width × height */
} indexed;

/* Fills ix when img (8-bit, 2 to 4 channels after needed_channels) has at
 * most 256 distinct colours: an indexed PNG (colour type 3) holds it in a
 * byte a texel, where RGBA takes four (the ez-tree leaf textures are
 * indexed PNGs, and keep their size through a bake that colours their
 * transparent texels, sv_texture_dilate). False when it has more, is 16-bit
 * or grey (a grey PNG is a byte a texel already), or memory runs out (the
 * caller then writes it as it is). Decoders give back the same RGBA. */
static bool to_indexed(const sv_image *img, indexed *ix)
{
    memset(ix, 0, sizeof *ix);
    uint32_t pal[256], c = img->channels;
    uint32_t count = c >= 2 ? sv_image_colours(img, pal) : 257;
    if (count > 256) return false;
    size_t n = (size_t)img->width * img->height;
    if (!(ix->index = malloc(n ? n : 1))) return false;
    const uint8_t *px = img->data;
    for (size_t i = 0; i < n; i++) { /* its entry: a search of the descending keys */
        uint32_t k = sv_texel_key(px + i * c, c), lo = 0, hi = count - 1;
        while (lo < hi) {
            uint32_t mid = (lo + hi) / 2;
            if (pal[mid] > k) lo = mid + 1;
            else hi = mid;
        }
        ix->index[i] = (uint8_t)lo;
    }
    for (uint32_t e = 0; e < count; e++) {
        ix->rgb[e] = (png_color){(png_byte)(pal[e] >> 16), (png_byte)(pal[e] >> 8),
                                 (png_byte)pal[e]};
        ix->alpha[e] = (png_byte)(255 - (pal[e] >> 24));
        if (ix->alpha[e] < 255) ix->translucent = (int)e + 1;
    }
    ix->count = (int)count;
    return true;
}

/* The encoder proper; rows is allocated by the caller so that nothing leaks
 * across the longjmp. ix: write img as that indexed image (NULL: as it is). */
static sv_status encode(const sv_image *img, const indexed *ix, png_sink *sink, png_bytep *rows,
                        sv_error *err)
{
    static const int color_type[5] = {0, PNG_COLOR_TYPE_GRAY, PNG_COLOR_TYPE_GRAY_ALPHA,
                                      PNG_COLOR_TYPE_RGB, PNG_COLOR_TYPE_RGB_ALPHA};
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, err, png_error_fn,
                                              png_warning_fn);
    if (!png) return sv_fail(err, SV_ERR_NOMEM, "PNG encoding: out of memory");
    png_infop info = png_create_info_struct(png);
    if (!info) {
        png_destroy_write_struct(&png, NULL);
        return sv_fail(err, SV_ERR_NOMEM, "PNG encoding: out of memory");
    }
    if (setjmp(png_jmpbuf(png))) { /* png_error_fn filled err */
        png_destroy_write_struct(&png, &info);
        return SV_ERR_IO;
    }
    png_set_write_fn(png, sink, sink_write, sink_flush);
    png_set_compression_level(png, SV_PNG_ZLIB_LEVEL);
    if (ix) {
        /* the fewest bits a texel that hold every index, packed by libpng */
        int depth = ix->count <= 2 ? 1 : ix->count <= 4 ? 2 : ix->count <= 16 ? 4 : 8;
        png_set_IHDR(png, info, img->width, img->height, depth, PNG_COLOR_TYPE_PALETTE,
                     PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
        png_set_PLTE(png, info, ix->rgb, ix->count);
        if (ix->translucent) png_set_tRNS(png, info, ix->alpha, ix->translucent, NULL);
        png_write_info(png, info);
        if (depth < 8) png_set_packing(png);
        for (uint32_t y = 0; y < img->height; y++)
            rows[y] = ix->index + (size_t)y * img->width;
        png_write_image(png, rows);
        png_write_end(png, NULL);
        png_destroy_write_struct(&png, &info);
        if (sink->oom) return sv_fail(err, SV_ERR_NOMEM, "PNG encoding: out of memory");
        return SV_OK;
    }
    png_set_IHDR(png, info, img->width, img->height, (int)img->bits, color_type[img->channels],
                 PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_write_info(png, info);
    if (img->bits == 16) {
        const uint16_t probe = 1;
        if (*(const uint8_t *)&probe == 1) png_set_swap(png); /* little-endian host */
    }
    size_t stride = sv_image_stride(img);
    for (uint32_t y = 0; y < img->height; y++) rows[y] = (png_bytep)img->data + (size_t)y * stride;
    png_write_image(png, rows);
    png_write_end(png, NULL);
    png_destroy_write_struct(&png, &info);
    if (sink->oom) return sv_fail(err, SV_ERR_NOMEM, "PNG encoding: out of memory");
    return SV_OK;
}

/* ---- the memo (image.h) ---- */

typedef struct memo_entry {
    sv_image img; /* a shared copy: keeps the pixels, and so their address, alive */
    uint8_t *png;
    size_t size;
} memo_entry;

struct sv_png_memo {
    memo_entry *e;
    size_t count, cap;
    size_t reused;
};

static _Thread_local sv_png_memo *active_memo;

sv_png_memo *sv_png_memo_create(void)
{
    return calloc(1, sizeof(sv_png_memo));
}

void sv_png_memo_free(sv_png_memo *m)
{
    if (!m) return;
    for (size_t i = 0; i < m->count; i++) {
        sv_image_free(&m->e[i].img);
        free(m->e[i].png);
    }
    free(m->e);
    free(m);
}

sv_png_memo *sv_png_memo_use(sv_png_memo *m)
{
    sv_png_memo *prev = active_memo;
    active_memo = m;
    return prev;
}

size_t sv_png_memo_reused(const sv_png_memo *m)
{
    return m ? m->reused : 0;
}

static const memo_entry *memo_find(const sv_png_memo *m, const sv_image *img)
{
    for (size_t i = 0; m && img->refs && i < m->count; i++) {
        const sv_image *o = &m->e[i].img;
        if (o->data == img->data && o->width == img->width && o->height == img->height &&
            o->channels == img->channels && o->bits == img->bits)
            return &m->e[i];
    }
    return NULL;
}

/* Keeps a copy of png (size bytes) for img's pixels; nothing when img's
 * pixels cannot be shared or memory runs out (the next call encodes). */
static void memo_add(sv_png_memo *m, const sv_image *img, const uint8_t *png, size_t size)
{
    if (!m || !img->refs) return;
    if (m->count == m->cap) {
        size_t cap = m->cap ? 2 * m->cap : 8;
        memo_entry *e = realloc(m->e, cap * sizeof *e);
        if (!e) return;
        m->e = e;
        m->cap = cap;
    }
    memo_entry *e = &m->e[m->count];
    memset(e, 0, sizeof *e);
    if (!(e->png = malloc(size ? size : 1))) return;
    if (sv_image_copy(img, &e->img, NULL) != SV_OK) {
        free(e->png);
        return;
    }
    memcpy(e->png, png, size);
    e->size = size;
    m->count++;
}

/* The channels img's PNG needs (PNG colour types grey, grey+alpha, RGB,
 * RGBA): alpha only when some texel is not opaque, colour only when some
 * texel is not grey (R = G = B). Decoders give back the same RGBA. */
static uint32_t needed_channels(const sv_image *img)
{
    uint32_t c = img->channels;
    bool has_alpha = c == 2 || c == 4, has_colour = c >= 3;
    if (!has_alpha && !has_colour) return c;
    bool alpha = false, colour = false;
    size_t n = (size_t)img->width * img->height;
    uint32_t maxv = img->bits == 16 ? 65535u : 255u;
    for (size_t i = 0; i < n && !(alpha && colour); i++) {
        uint32_t v[4];
        for (uint32_t k = 0; k < c; k++)
            v[k] = img->bits == 16 ? ((const uint16_t *)img->data)[i * c + k]
                                   : ((const uint8_t *)img->data)[i * c + k];
        if (has_alpha && v[c - 1] != maxv) alpha = true;
        if (has_colour && (v[0] != v[1] || v[0] != v[2])) colour = true;
    }
    return (colour ? 3u : 1u) + (alpha ? 1u : 0u);
}

/* Copies into out (allocated by sv_image_alloc) the channels of img that
 * needed_channels keeps: R (grey) or RGB, then alpha when kept. */
static sv_status pack_channels(const sv_image *img, uint32_t channels, sv_image *out, sv_error *err)
{
    sv_status st = sv_image_alloc(out, img->width, img->height, channels, img->bits, err);
    if (st != SV_OK) return st;
    uint32_t c = img->channels, colour = channels >= 3 ? 3 : 1;
    bool alpha = channels == 2 || channels == 4;
    size_t n = (size_t)img->width * img->height, bpc = img->bits / 8;
    const uint8_t *s = img->data;
    uint8_t *d = out->data;
    for (size_t i = 0; i < n; i++) {
        memcpy(d, s + i * c * bpc, colour * bpc);
        d += colour * bpc;
        if (alpha) {
            memcpy(d, s + (i * c + c - 1) * bpc, bpc);
            d += bpc;
        }
    }
    return SV_OK;
}

sv_status sv_image_encode_png(const sv_image *img, uint8_t **out, size_t *out_size, sv_error *err)
{
    const memo_entry *hit = img ? memo_find(active_memo, img) : NULL;
    if (hit && out && out_size) {
        if (!(*out = malloc(hit->size ? hit->size : 1)))
            return sv_fail(err, SV_ERR_NOMEM, "PNG encoding: out of memory");
        memcpy(*out, hit->png, hit->size);
        *out_size = hit->size;
        active_memo->reused++;
        return SV_OK;
    }

    if (!out || !out_size) return sv_fail(err, SV_ERR_INTERNAL, "sv_image_encode_png: no output");
    *out = NULL;
    *out_size = 0;
    if (!img || !img->data || img->width == 0 || img->height == 0)
        return sv_fail(err, SV_ERR_INTERNAL, "cannot write an empty image as PNG");
    if (img->channels < 1 || img->channels > 4 || (img->bits != 8 && img->bits != 16))
        return sv_fail(err, SV_ERR_INTERNAL, "cannot write a %u-channel %u-bit image as PNG",
                       img->channels, img->bits);
    if (img->width > PNG_UINT_31_MAX || img->height > PNG_UINT_31_MAX)
        return sv_fail(err, SV_ERR_LIMIT, "image %ux%u is too large for PNG", img->width,
                       img->height);
    sv_image packed = {0};
    const sv_image *src = img;
    uint32_t channels = needed_channels(img);
    if (channels != img->channels) {
        sv_status st = pack_channels(img, channels, &packed, err);
        if (st != SV_OK) return st;
        src = &packed;
    }
    png_bytep *rows = calloc(img->height, sizeof *rows);
    if (!rows) {
        sv_image_free(&packed);
        return sv_fail(err, SV_ERR_NOMEM, "PNG encoding: out of memory");
    }
    png_sink sink = {0};
    indexed ix;
    bool pal = channels >= 2 && to_indexed(src, &ix);
    sv_status st = encode(src, pal ? &ix : NULL, &sink, rows, err);
    if (pal) free(ix.index);
    free(rows);
    sv_image_free(&packed);
    if (st != SV_OK) {
        free(sink.data);
        return st;
    }
    *out = sink.data;
    *out_size = sink.size;
    memo_add(active_memo, img, sink.data, sink.size);
    return SV_OK;
}

sv_status sv_image_write_png(const sv_image *img, const char *path, sv_error *err)
{
    if (!path) return sv_fail(err, SV_ERR_INTERNAL, "sv_image_write_png: path is NULL");
    uint8_t *bytes = NULL;
    size_t n = 0;
    sv_status st = sv_image_encode_png(img, &bytes, &n, err);
    if (st != SV_OK) return st;
    st = sv_write_file(path, bytes, n, err);
    free(bytes);
    return st;
}
