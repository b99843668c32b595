/* image_decode.c — PNG and JPEG textures decoded in process, with libpng and
 * libjpeg(-turbo); every other format through the OpenImageIO plugin
 * (image_plugin.c).
 *
 * Why: nearly every tree ships PNG or JPEG textures, and loading
 * the plugin to read them costs every offline bake OIIO's start-up and
 * memory (its 261 libraries; docs/benchmarks.md, "Figures moved out of the
 * code"). libpng and libjpeg are small, well-kept and
 * already what OIIO itself calls for these two formats.
 *
 * Same pixels as the plugin, by construction and checked by a test on every
 * texture of the shared trees plus synthetic PNGs of every colour type and
 * bit depth (tests/unit/test_image.c):
 * - PNG: the transforms OIIO's reader sets (png_set_expand: palette to RGB,
 *   1/2/4-bit grey to 8 bits, tRNS to alpha; no gamma, no sBIT shift), then
 *   OIIO's 16 → 8-bit conversion (through float: v / 65535 × 255 + 0.5,
 *   truncated) and the plugin's expansion to RGBA (grey replicated, alpha 255
 *   when absent). Straight alpha, as stored. The chunk walk that refuses a
 *   truncated PNG before libpng sees it is sv_png_check_chunks (image.c),
 *   which the plugin calls too.
 * - JPEG: libjpeg's defaults, as OIIO leaves them (islow DCT, fancy
 *   upsampling), RGB or greyscale out. CMYK/YCCK JPEGs, which OIIO converts
 *   itself, go to the plugin.
 *
 * Decoding reads only the bytes given (memory sources); libpng's and libjpeg's
 * errors come back as SV_ERR_PARSE naming the image, their warnings are
 * ignored (a JPEG cut short decodes with its missing rows grey, as libjpeg
 * and OIIO do).
 */
#include "image.h"
#include "image_io.h"

#include <setjmp.h>
#include <stdio.h> /* before jpeglib.h, which uses FILE */
#include <stdlib.h>
#include <string.h>

#include <jpeglib.h>
#include <png.h>

static bool is_png(const uint8_t *d, size_t n)
{
    return n >= 8 && memcmp(d, "\x89PNG\r\n\x1a\n", 8) == 0;
}

static bool is_jpeg(const uint8_t *d, size_t n)
{
    return n >= 3 && d[0] == 0xFF && d[1] == 0xD8 && d[2] == 0xFF;
}

#define IMAGE_MAX_BYTES_DEFAULT ((uint64_t)1 << 30)

/* The size checks made before any pixel is decoded: w and h within max_size,
 * and w × h × px_bytes (the memory the decode takes a pixel) within
 * max_bytes. */
static sv_status check_size(uint32_t w, uint32_t h, uint32_t max_size, uint64_t px_bytes,
                            uint64_t max_bytes, const char *name, sv_error *err)
{
    if (w == 0 || h == 0)
        return sv_fail(err, SV_ERR_PARSE, "image '%s' has an empty size %ux%u", name, w, h);
    if (w > max_size || h > max_size)
        return sv_fail(err, SV_ERR_LIMIT, "image '%s' is %ux%u, over the %u texel limit per side",
                       name, w, h, max_size);
    uint64_t need = (uint64_t)w * h * px_bytes;
    if (need > max_bytes)
        return sv_fail(err, SV_ERR_LIMIT,
                       "image '%s' is %ux%u: decoding it takes %llu bytes, over the %llu-byte "
                       "budget of a texture",
                       name, w, h, (unsigned long long)need, (unsigned long long)max_bytes);
    return SV_OK;
}

/* OIIO's uint16 → uint8 (convert_pixel_values through float, fmath.h
 * scaled_conversion): (uint8)(v × (1/65535) × 255 + 0.5) in float. */
static uint8_t u16_to_u8(uint16_t v)
{
    float f = (float)v * (1.0f / 65535.0f);
    float s = f * 255.0f + 0.5f;
    return (uint8_t)(s < 0 ? 0 : s > 255 ? 255 : s);
}

/* ---- PNG ------------------------------------------------------------------ */

typedef struct png_src {
    const uint8_t *d;
    size_t n, off;
    char msg[200];
    jmp_buf jmp;
} png_src;

static void png_read_mem(png_structp p, png_bytep out, size_t len)
{
    png_src *s = png_get_io_ptr(p);
    if (len > s->n - s->off) png_error(p, "read past the end of the data");
    memcpy(out, s->d + s->off, len);
    s->off += len;
}

static void png_on_error(png_structp p, png_const_charp msg)
{
    png_src *s = png_get_error_ptr(p);
    snprintf(s->msg, sizeof s->msg, "%s", msg);
    longjmp(s->jmp, 1);
}

static void png_on_warning(png_structp p, png_const_charp msg)
{
    (void)p;
    (void)msg;
}

/* Decodes a PNG (chunks already checked) into RGBA8 (gray16 false) or its
 * first channel at 16 bits (gray16 true). */
static sv_status decode_png(const uint8_t *d, size_t n, const char *name, uint32_t max_size,
                            uint64_t max_bytes, bool gray16, sv_image *out, sv_error *err)
{
    png_src src = {.d = d, .n = n};
    png_structp p = png_create_read_struct(PNG_LIBPNG_VER_STRING, &src, png_on_error,
                                           png_on_warning);
    png_infop info = p ? png_create_info_struct(p) : NULL;
    if (!info) {
        png_destroy_read_struct(&p, NULL, NULL);
        return sv_fail(err, SV_ERR_NOMEM, "image '%s': out of memory for libpng", name);
    }
    /* volatile: changed between setjmp and a longjmp back to it */
    uint8_t *volatile buf = NULL;
    png_bytep *volatile rows = NULL;
    sv_status st = SV_OK;
    if (setjmp(src.jmp)) {
        st = sv_fail(err, SV_ERR_PARSE, "cannot decode image '%s' (png): %s", name, src.msg);
        goto out;
    }
    png_set_read_fn(p, &src, png_read_mem);
    png_read_info(p, info);
    png_set_expand(p);
    if (png_get_bit_depth(p, info) == 16) png_set_swap(p); /* native-endian uint16 */
    png_read_update_info(p, info);
    uint32_t w = png_get_image_width(p, info), h = png_get_image_height(p, info);
    int ch = png_get_channels(p, info), depth = png_get_bit_depth(p, info);
    /* the whole image at its depth, then the result beside it */
    uint64_t px_bytes = (uint64_t)(ch > 0 ? ch : 4) * (uint64_t)(depth == 16 ? 2 : 1) +
                        (gray16 ? 2 : 4);
    if ((st = check_size(w, h, max_size, px_bytes, max_bytes, name, err))) goto out;
    size_t rowbytes = png_get_rowbytes(p, info);
    if (ch < 1 || ch > 4 || (depth != 8 && depth != 16) ||
        rowbytes != (size_t)w * (size_t)ch * (size_t)(depth / 8)) {
        st = sv_fail(err, SV_ERR_PARSE, "image '%s' (png): %d channels of %d bits", name, ch,
                     depth);
        goto out;
    }
    buf = malloc(rowbytes * h);
    rows = malloc(sizeof *rows * h);
    if (!buf || !rows) {
        st = sv_fail(err, SV_ERR_NOMEM, "image '%s' is too large to decode (%ux%u)", name, w, h);
        goto out;
    }
    for (uint32_t y = 0; y < h; y++) rows[y] = buf + (size_t)y * rowbytes;
    png_read_image(p, rows);
    png_read_end(p, NULL);
    if (gray16) {
        if ((st = sv_image_alloc(out, w, h, 1, 16, err))) goto out;
        uint16_t *o = out->data;
        for (size_t i = 0, np = (size_t)w * h; i < np; i++)
            o[i] = depth == 16 ? ((const uint16_t *)buf)[i * (size_t)ch]
                               : (uint16_t)(buf[i * (size_t)ch] * 257u);
        goto out;
    }
    if ((st = sv_image_alloc(out, w, h, 4, 8, err))) goto out;
    uint8_t *o = out->data;
    for (size_t i = 0, np = (size_t)w * h; i < np; i++) {
        uint8_t s[4];
        for (int c = 0; c < ch; c++)
            s[c] = depth == 16 ? u16_to_u8(((const uint16_t *)buf)[i * (size_t)ch + (size_t)c])
                               : buf[i * (size_t)ch + (size_t)c];
        uint8_t *px = o + 4 * i;
        if (ch <= 2) px[0] = px[1] = px[2] = s[0];
        else memcpy(px, s, 3);
        px[3] = ch == 2 ? s[1] : ch == 4 ? s[3] : 255;
    }
out:
    png_destroy_read_struct(&p, &info, NULL);
    free(buf);
    free(rows);
    if (st) sv_image_free(out);
    return st;
}

/* ---- JPEG ----------------------------------------------------------------- */

typedef struct jpeg_fail {
    struct jpeg_error_mgr mgr;
    jmp_buf jmp;
    char msg[JMSG_LENGTH_MAX];
} jpeg_fail;

static void jpeg_on_error(j_common_ptr c)
{
    jpeg_fail *f = (jpeg_fail *)c->err;
    f->mgr.format_message(c, f->msg);
    longjmp(f->jmp, 1);
}

static void jpeg_on_message(j_common_ptr c)
{
    (void)c;
}

/* Decodes a JPEG into RGBA8; *cmyk set (and nothing decoded) for a CMYK or
 * YCCK JPEG, which the plugin converts. */
static sv_status decode_jpeg(const uint8_t *d, size_t n, const char *name, uint32_t max_size,
                             uint64_t max_bytes, sv_image *out, bool *cmyk, sv_error *err)
{
    struct jpeg_decompress_struct ci;
    jpeg_fail f;
    *cmyk = false;
    ci.err = jpeg_std_error(&f.mgr);
    f.mgr.error_exit = jpeg_on_error;
    f.mgr.output_message = jpeg_on_message;
    uint8_t *volatile row = NULL;
    sv_status st = SV_OK;
    jpeg_create_decompress(&ci);
    if (setjmp(f.jmp)) {
        st = sv_fail(err, SV_ERR_PARSE, "cannot decode image '%s' (jpeg): %s", name, f.msg);
        goto out;
    }
    jpeg_mem_src(&ci, d, (unsigned long)n);
    jpeg_read_header(&ci, TRUE);
    if (ci.jpeg_color_space == JCS_CMYK || ci.jpeg_color_space == JCS_YCCK) {
        *cmyk = true;
        goto out;
    }
    jpeg_start_decompress(&ci);
    uint32_t w = ci.output_width, h = ci.output_height;
    int ch = ci.output_components;
    if ((st = check_size(w, h, max_size, 4, max_bytes, name, err))) goto out; /* row by row */
    if (ch != 1 && ch != 3) {
        st = sv_fail(err, SV_ERR_PARSE, "image '%s' (jpeg) has %d channels", name, ch);
        goto out;
    }
    if ((st = sv_image_alloc(out, w, h, 4, 8, err))) goto out;
    row = malloc((size_t)w * (size_t)ch);
    if (!row) {
        st = sv_fail(err, SV_ERR_NOMEM, "image '%s': out of memory", name);
        goto out;
    }
    uint8_t *o = out->data;
    while (ci.output_scanline < h) {
        uint32_t y = ci.output_scanline;
        JSAMPROW r = row;
        if (jpeg_read_scanlines(&ci, &r, 1) != 1) break;
        uint8_t *px = o + (size_t)y * w * 4;
        for (uint32_t x = 0; x < w; x++, px += 4) {
            const uint8_t *s = row + (size_t)x * (size_t)ch;
            px[0] = s[0];
            px[1] = ch == 3 ? s[1] : s[0];
            px[2] = ch == 3 ? s[2] : s[0];
            px[3] = 255;
        }
    }
    jpeg_finish_decompress(&ci);
out:
    jpeg_destroy_decompress(&ci);
    free(row);
    if (st) sv_image_free(out);
    return st;
}

/* ---- entry points ----------------------------------------------------------- */

/* Common argument checks; *name_out never NULL afterwards. */
static sv_status begin(const void *data, size_t size, const char **name, uint32_t *max_size,
                       sv_image *out, sv_error *err)
{
    if (!out) return sv_fail(err, SV_ERR_INTERNAL, "image decode: out is NULL");
    memset(out, 0, sizeof *out);
    if (!*name) *name = "(unnamed)";
    if (!data || size == 0) return sv_fail(err, SV_ERR_PARSE, "image '%s' is empty", *name);
    if (*max_size == 0) *max_size = 16384;
    return SV_OK;
}

sv_status sv_image_decode_rgba8_within(const void *data, size_t size, const char *name,
                                       uint32_t max_size, uint64_t max_bytes, sv_image *out,
                                       sv_error *err)
{
    sv_status st = begin(data, size, &name, &max_size, out, err);
    if (st) return st;
    if (max_bytes == 0) max_bytes = IMAGE_MAX_BYTES_DEFAULT;
    const uint8_t *d = data;
    if (is_png(d, size)) {
        if ((st = sv_png_check_chunks(d, size, name, err))) return st;
        return decode_png(d, size, name, max_size, max_bytes, false, out, err);
    }
    if (is_jpeg(d, size)) {
        bool cmyk = false;
        st = decode_jpeg(d, size, name, max_size, max_bytes, out, &cmyk, err);
        if (st || !cmyk) return st;
    }
    return sv_image_plugin_decode_rgba8_within(data, size, name, max_size, max_bytes, out, err);
}

sv_status sv_image_decode_rgba8(const void *data, size_t size, const char *name, uint32_t max_size,
                                sv_image *out, sv_error *err)
{
    return sv_image_decode_rgba8_within(data, size, name, max_size, 0, out, err);
}

sv_status sv_image_decode_gray16(const void *data, size_t size, const char *name, uint32_t max_size,
                                 sv_image *out, sv_error *err)
{
    sv_status st = begin(data, size, &name, &max_size, out, err);
    if (st) return st;
    const uint8_t *d = data;
    if (!is_png(d, size)) /* the plugin names what it is */
        return sv_image_plugin_decode_gray16(data, size, name, max_size, out, err);
    if ((st = sv_png_check_chunks(d, size, name, err))) return st;
    return decode_png(d, size, name, max_size, IMAGE_MAX_BYTES_DEFAULT, true, out, err);
}
