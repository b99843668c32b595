/* test_image.c — images in memory, the PNG/JPEG decoders (core/io/image_decode.c)
 * and the OpenImageIO shim (core/image.c, core/io/image_oiio.cpp). */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <cmocka.h>
#include "test_skip.h"

#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <dirent.h>
#include <png.h>
#include <sys/stat.h>
#include <unistd.h>

#include "image.h"
#include "image_io.h"

static void fill_pattern(sv_image *img)
{
    size_t n = (size_t)img->width * img->height * img->channels;
    if (img->bits == 8) {
        uint8_t *p = img->data;
        for (size_t i = 0; i < n; i++) p[i] = (uint8_t)(i * 37 + 11);
    } else {
        uint16_t *p = img->data;
        for (size_t i = 0; i < n; i++) p[i] = (uint16_t)(i * 4099 + 7);
    }
}

static void alloc_sizes_the_buffer_and_free_zeroes_the_struct(void **state)
{
    (void)state;
    sv_image img;
    assert_int_equal(sv_image_alloc(&img, 5, 3, 3, 16, NULL), SV_OK);
    assert_int_equal(sv_image_stride(&img), 5 * 3 * 2);
    assert_non_null(img.data);
    uint16_t *p = img.data;
    assert_int_equal(p[5 * 3 * 3 - 1], 0); /* zeroed, and the last element is in bounds */
    sv_image_free(&img);
    assert_null(img.data);
    assert_int_equal(img.width, 0);
    sv_image_free(NULL);
    sv_image_free(&img); /* twice is fine */
}

static void alloc_refuses_overflow_and_bad_formats(void **state)
{
    (void)state;
    sv_image img;
    sv_error err = {0};
    if (sizeof(size_t) == 8) {
        /* 2^32-1 squared × 4 × 2 bytes overflows 64 bits */
        assert_int_equal(sv_image_alloc(&img, UINT32_MAX, UINT32_MAX, 4, 16, &err), SV_ERR_NOMEM);
        assert_non_null(strstr(err.message, "overflow"));
    }
    assert_int_equal(sv_image_alloc(&img, 4, 4, 5, 8, &err), SV_ERR_INTERNAL);
    assert_int_equal(sv_image_alloc(&img, 4, 4, 4, 12, &err), SV_ERR_INTERNAL);
    assert_null(img.data);
}

static uint8_t *encode(const sv_image *img, size_t *n)
{
    uint8_t *out = NULL;
    sv_error err = {0};
    sv_status st = sv_image_encode_png(img, &out, n, &err);
    if (st != SV_OK) print_error("%s\n", err.message);
    assert_int_equal(st, SV_OK);
    assert_true(*n > 8);
    assert_memory_equal(out, "\x89PNG\r\n\x1a\n", 8);
    return out;
}

/* The PNG memo: an image and its shared copies are encoded once
 * while a memo is in use; equal pixels in another buffer, pixels not made by
 * sv_image_alloc, and calls without a memo are encoded; every answer is the
 * same bytes. */
static void png_memo_encodes_shared_pixels_once_and_gives_the_same_bytes(void **state)
{
    (void)state;
    sv_image a, b, c;
    assert_int_equal(sv_image_alloc(&a, 33, 17, 4, 8, NULL), SV_OK);
    uint8_t *p = a.data;
    for (size_t i = 0; i < 33 * 17 * 4; i++) p[i] = (uint8_t)(i * 37 + i / 7);
    assert_int_equal(sv_image_copy(&a, &b, NULL), SV_OK);
    assert_ptr_equal(a.data, b.data);
    assert_int_equal(sv_image_alloc(&c, 33, 17, 4, 8, NULL), SV_OK);
    memcpy(c.data, a.data, 33 * 17 * 4);
    uint8_t raw[16 * 4];
    memcpy(raw, a.data, sizeof raw);
    sv_image loose = {4, 4, 4, 8, raw, NULL};

    size_t n0, n1, n2, n3, n4, n5, nl1, nl2;
    uint8_t *plain = encode(&a, &n0);
    sv_png_memo *m = sv_png_memo_create();
    assert_non_null(m);
    assert_null(sv_png_memo_use(m));
    uint8_t *e1 = encode(&a, &n1), *e2 = encode(&b, &n2);
    assert_int_equal(sv_png_memo_reused(m), 1);
    uint8_t *e3 = encode(&c, &n3);
    assert_int_equal(sv_png_memo_reused(m), 1); /* another buffer: encoded */
    uint8_t *l1 = encode(&loose, &nl1), *l2 = encode(&loose, &nl2);
    assert_int_equal(sv_png_memo_reused(m), 1); /* not sv_image_alloc's: encoded */
    /* the memo keeps the pixels: freeing the images does not free them */
    sv_image_free(&a);
    uint8_t *e4 = encode(&b, &n4);
    assert_int_equal(sv_png_memo_reused(m), 2);
    assert_ptr_equal(sv_png_memo_use(NULL), m);
    uint8_t *e5 = encode(&b, &n5);
    assert_int_equal(sv_png_memo_reused(m), 2); /* no memo in use */
    assert_int_equal(n1, n0);
    assert_int_equal(n2, n0);
    assert_int_equal(n3, n0);
    assert_int_equal(n5, n0);
    assert_memory_equal(e1, plain, n0);
    assert_memory_equal(e2, plain, n0);
    assert_memory_equal(e3, plain, n0);
    assert_memory_equal(e4, plain, n0);
    assert_memory_equal(e5, plain, n0);
    assert_int_equal(nl1, nl2);
    assert_memory_equal(l1, l2, nl1);
    assert_int_equal(n4, n0);
    sv_png_memo_free(m);
    sv_image_free(&b);
    sv_image_free(&c);
    free(plain), free(e1), free(e2), free(e3), free(e4), free(e5), free(l1), free(l2);
}

static void png_round_trip_keeps_rgba8_exactly_with_straight_alpha(void **state)
{
    (void)state;
    sv_image img, back;
    assert_int_equal(sv_image_alloc(&img, 7, 5, 4, 8, NULL), SV_OK);
    fill_pattern(&img);
    uint8_t *p = img.data;
    /* a half-transparent texel keeps its colour (no premultiplication) and a fully
     * transparent one keeps its colour too (leaf cards rely on dilated colour) */
    p[0] = 200, p[1] = 100, p[2] = 50, p[3] = 128;
    p[4] = 90, p[5] = 180, p[6] = 20, p[7] = 0;
    size_t n;
    uint8_t *png = encode(&img, &n);
    sv_error err = {0};
    assert_int_equal(sv_image_decode_rgba8(png, n, "x.png", 0, &back, &err), SV_OK);
    assert_int_equal(back.width, 7);
    assert_int_equal(back.height, 5);
    assert_int_equal(back.channels, 4);
    assert_int_equal(back.bits, 8);
    assert_memory_equal(back.data, img.data, 7 * 5 * 4);
    sv_image_free(&img);
    sv_image_free(&back);
    free(png);
}

/* PNG colour type (IHDR byte 25): 0 grey, 2 RGB, 4 grey+alpha, 6 RGBA. */
static int png_colour_type(const uint8_t *png)
{
    return png[25];
}

static void png_leaves_out_an_opaque_alpha_and_grey_colour(void **state)
{
    (void)state;
    /* 288 texels, every one its own colour: more than an indexed PNG holds */
    static const struct {
        bool opaque, grey;
        int type;
    } cases[] = {{false, false, 6}, {true, false, 2}, {false, true, 4}, {true, true, 0}};
    for (size_t c = 0; c < sizeof cases / sizeof *cases; c++) {
        sv_image img, back;
        assert_int_equal(sv_image_alloc(&img, 24, 12, 4, 8, NULL), SV_OK);
        uint8_t *p = img.data;
        for (int i = 0; i < 288; i++) {
            uint8_t v = (uint8_t)(i & 255);
            p[4 * i] = v;
            p[4 * i + 1] = cases[c].grey ? v : (uint8_t)(7 * i + 3 + (i >> 8));
            p[4 * i + 2] = cases[c].grey ? v : (uint8_t)(i >> 8);
            p[4 * i + 3] = cases[c].opaque ? 255 : (uint8_t)(255 - (i >> 3));
        }
        size_t n;
        uint8_t *png = encode(&img, &n);
        assert_int_equal(png_colour_type(png), cases[c].type);
        sv_error err = {0};
        assert_int_equal(sv_image_decode_rgba8(png, n, "x.png", 0, &back, &err), SV_OK);
        assert_memory_equal(back.data, img.data, 288 * 4); /* the same RGBA back */
        sv_image_free(&img);
        sv_image_free(&back);
        free(png);
    }
}

/* An image of at most 256 colours (with alpha, or in colour) is an indexed
 * PNG (colour type 3: a byte a texel, or fewer bits), which decodes to the
 * same RGBA and is smaller than its RGBA PNG; a grey opaque one stays grey. */
static void png_of_few_colours_is_indexed(void **state)
{
    (void)state;
    static const struct {
        bool opaque, grey;
        int colours, type;
    } cases[] = {{false, false, 256, 3}, {true, false, 200, 3}, {false, true, 16, 3},
                 {true, true, 100, 0}, {false, false, 2, 3}};
    for (size_t c = 0; c < sizeof cases / sizeof *cases; c++) {
        sv_image img, back;
        assert_int_equal(sv_image_alloc(&img, 64, 64, 4, 8, NULL), SV_OK);
        uint8_t *p = img.data;
        uint32_t seed = 12345;
        for (int i = 0; i < 64 * 64; i++) {
            seed = seed * 1103515245u + 12345u;
            int k = (int)((seed >> 16) % (uint32_t)cases[c].colours);
            p[4 * i] = (uint8_t)(k * 5);
            p[4 * i + 1] = cases[c].grey ? (uint8_t)(k * 5) : (uint8_t)(k * 3 + 1);
            p[4 * i + 2] = cases[c].grey ? (uint8_t)(k * 5) : (uint8_t)(200 - k / 2);
            p[4 * i + 3] = cases[c].opaque ? 255 : (uint8_t)(k % 3 == 0 ? 0 : 255 - k / 4);
        }
        size_t n;
        uint8_t *png = encode(&img, &n);
        assert_int_equal(png_colour_type(png), cases[c].type);
        sv_error err = {0};
        assert_int_equal(sv_image_decode_rgba8(png, n, "x.png", 0, &back, &err), SV_OK);
        assert_memory_equal(back.data, img.data, 64 * 64 * 4);
        if (cases[c].type == 3) { /* smaller than the same texels one colour short of indexed */
            p[0] ^= 1, p[1] ^= 1; /* a new colour: the 257th where there were 256 */
            size_t m;
            uint8_t *full = encode(&img, &m);
            if (png_colour_type(full) != 3) assert_true(n < m);
            free(full);
        }
        sv_image_free(&img);
        sv_image_free(&back);
        free(png);
    }
}

static void png_encoding_is_deterministic_and_write_matches_encode(void **state)
{
    (void)state;
    sv_image img;
    assert_int_equal(sv_image_alloc(&img, 33, 17, 3, 8, NULL), SV_OK);
    fill_pattern(&img);
    size_t n1, n2;
    uint8_t *a = encode(&img, &n1), *b = encode(&img, &n2);
    assert_int_equal(n1, n2);
    assert_memory_equal(a, b, n1);
    char path[] = "/tmp/sylva-test-image-XXXXXX";
    int fd = mkstemp(path);
    assert_true(fd >= 0);
    close(fd);
    sv_error err = {0};
    assert_int_equal(sv_image_write_png(&img, path, &err), SV_OK);
    /* written through path.tmp and a rename (sv_write_file): none left */
    char tmp[sizeof path + 4];
    snprintf(tmp, sizeof tmp, "%s.tmp", path);
    assert_int_not_equal(access(tmp, F_OK), 0);
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    uint8_t *c = malloc(n1 + 16);
    size_t got = fread(c, 1, n1 + 16, f);
    fclose(f);
    unlink(path);
    assert_int_equal(got, n1);
    assert_memory_equal(c, a, n1);
    free(a);
    free(b);
    free(c);
    sv_image_free(&img);
}

static void png_16_bit_round_trips_to_the_nearest_8_bit_value(void **state)
{
    (void)state;
    sv_image img, back;
    assert_int_equal(sv_image_alloc(&img, 6, 4, 4, 16, NULL), SV_OK);
    fill_pattern(&img);
    size_t n;
    uint8_t *png = encode(&img, &n);
    /* bit depth 16 in IHDR (byte 24) */
    assert_int_equal(png[24], 16);
    assert_int_equal(sv_image_decode_rgba8(png, n, "deep.png", 0, &back, NULL), SV_OK);
    const uint16_t *s = img.data;
    const uint8_t *d = back.data;
    for (size_t i = 0; i < 6 * 4 * 4; i++) {
        int want = (s[i] + 128) / 257;
        assert_true(abs((int)d[i] - want) <= 1);
    }
    sv_image_free(&img);
    sv_image_free(&back);
    free(png);
}

static void gray_and_rgb_images_expand_to_opaque_rgba(void **state)
{
    (void)state;
    sv_image g, back;
    assert_int_equal(sv_image_alloc(&g, 3, 2, 1, 8, NULL), SV_OK);
    fill_pattern(&g);
    size_t n;
    uint8_t *png = encode(&g, &n);
    assert_int_equal(sv_image_decode_rgba8(png, n, "g.png", 0, &back, NULL), SV_OK);
    const uint8_t *s = g.data, *d = back.data;
    for (size_t i = 0; i < 6; i++) {
        assert_int_equal(d[4 * i], s[i]);
        assert_int_equal(d[4 * i + 1], s[i]);
        assert_int_equal(d[4 * i + 2], s[i]);
        assert_int_equal(d[4 * i + 3], 255);
    }
    sv_image_free(&g);
    sv_image_free(&back);
    free(png);
}

static void tga_without_magic_decodes_by_its_name(void **state)
{
    (void)state;
    /* uncompressed 2×2 true-colour TGA, 32 bpp, top-left origin, BGRA */
    uint8_t tga[18 + 16] = {0, 0, 2, 0, 0, 0, 0, 0, 0, 0, 0, 0, 2, 0, 2, 0, 32, 0x28};
    const uint8_t px[16] = {255, 0, 0, 255, 0, 255, 0, 255, 0, 0, 255, 128, 10, 20, 30, 0};
    memcpy(tga + 18, px, 16);
    sv_image img;
    sv_error err = {0};
    sv_status st = sv_image_decode_rgba8(tga, sizeof tga, "leaf.TGA", 0, &img, &err);
    if (st != SV_OK) print_error("%s\n", err.message);
    assert_int_equal(st, SV_OK);
    assert_int_equal(img.width, 2);
    const uint8_t *d = img.data;
    assert_int_equal(d[0], 0); /* first texel blue in BGRA → RGBA (0,0,255,255) */
    assert_int_equal(d[2], 255);
    assert_int_equal(d[3], 255);
    assert_int_equal(d[8], 255); /* third texel red, alpha 128 */
    assert_int_equal(d[11], 128);
    sv_image_free(&img);
    /* the same bytes under a name that does not say TGA: no magic, refused */
    assert_int_equal(sv_image_decode_rgba8(tga, sizeof tga, "leaf.bin", 0, &img, &err),
                     SV_ERR_FORMAT);
}

static void jpeg_from_the_data_set_decodes(void **state)
{
    (void)state;
    const char *data = sv_test_data("the JPEG decode of bark.jpg");
    char path[1024];
    snprintf(path, sizeof path, "%s/scopia_bonsai-tree/bark.jpg", data);
    FILE *f = fopen(path, "rb");
    if (!f) fail_msg("cannot open %s", path);
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    uint8_t *b = malloc((size_t)n);
    assert_int_equal(fread(b, 1, (size_t)n, f), (size_t)n);
    fclose(f);
    sv_image img;
    sv_error err = {0};
    assert_int_equal(sv_image_decode_rgba8(b, (size_t)n, "bark.jpg", 0, &img, &err), SV_OK);
    assert_true(img.width > 0 && img.height > 0);
    assert_int_equal(((uint8_t *)img.data)[3], 255);
    sv_image_free(&img);
    /* limit */
    assert_int_equal(sv_image_decode_rgba8(b, (size_t)n, "bark.jpg", 8, &img, &err), SV_ERR_LIMIT);
    assert_non_null(strstr(err.message, "bark.jpg"));
    free(b);
}

/* ---- the in-process PNG and JPEG decoders against the plugin ---- */

typedef struct mem_out {
    uint8_t *d;
    size_t n, cap;
} mem_out;

static void mem_write(png_structp p, png_bytep d, size_t n)
{
    mem_out *m = png_get_io_ptr(p);
    if (m->n + n > m->cap) {
        m->cap = 2 * (m->n + n);
        m->d = realloc(m->d, m->cap);
        assert_non_null(m->d);
    }
    memcpy(m->d + m->n, d, n);
    m->n += n;
}

static void mem_flush(png_structp p)
{
    (void)p;
}

/* A w×h PNG of colour type `ctype` and bit depth `depth` with pseudo-random
 * samples (palette and tRNS when asked), written by libpng into *n bytes. */
static uint8_t *synthetic_png(uint32_t w, uint32_t h, int ctype, int depth, bool trns,
                              bool interlace, unsigned seed, size_t *n)
{
    png_structp p = png_create_write_struct(PNG_LIBPNG_VER_STRING, NULL, NULL, NULL);
    png_infop info = png_create_info_struct(p);
    assert_non_null(info);
    mem_out m = {0};
    if (setjmp(png_jmpbuf(p))) fail_msg("libpng could not write the test PNG");
    png_set_write_fn(p, &m, mem_write, mem_flush);
    png_set_IHDR(p, info, w, h, depth, ctype, interlace ? PNG_INTERLACE_ADAM7 : PNG_INTERLACE_NONE,
                 PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    int ch = ctype == PNG_COLOR_TYPE_GRAY || ctype == PNG_COLOR_TYPE_PALETTE ? 1
             : ctype == PNG_COLOR_TYPE_GRAY_ALPHA                            ? 2
             : ctype == PNG_COLOR_TYPE_RGB                                   ? 3
                                                                             : 4;
    unsigned r = seed;
#define RND() (r = r * 1103515245u + 12345u, (r >> 8))
    if (ctype == PNG_COLOR_TYPE_PALETTE) {
        png_color pal[256];
        for (int i = 0; i < 256; i++)
            pal[i] = (png_color){(png_byte)RND(), (png_byte)RND(), (png_byte)RND()};
        png_set_PLTE(p, info, pal, 1 << depth);
        if (trns) {
            png_byte a[128];
            for (int i = 0; i < 128; i++) a[i] = (png_byte)RND();
            png_set_tRNS(p, info, a, (1 << depth) / 2 ? (1 << depth) / 2 : 1, NULL);
        }
    } else if (trns) {
        png_color_16 key = {0, 1, 0, 1, 1};
        png_set_tRNS(p, info, NULL, 0, &key);
    }
    png_write_info(p, info);
    if (depth == 16) png_set_swap(p);
    int passes = png_set_interlace_handling(p);
    size_t rowbytes = ((size_t)w * ch * depth + 7) / 8;
    uint8_t *img = calloc(h, rowbytes);
    assert_non_null(img);
    uint32_t maxv = depth == 16 ? 65535u : (1u << depth) - 1;
    /* keyed images draw from {0, 1} so the tRNS colour occurs */
    if (trns && ctype != PNG_COLOR_TYPE_PALETTE) maxv = 1;
    for (uint32_t y = 0; y < h; y++) {
        uint8_t *row = img + y * rowbytes;
        for (uint32_t i = 0; i < w * (uint32_t)ch; i++) {
            uint32_t v = RND() % (maxv + 1);
            if (depth == 16) ((uint16_t *)row)[i] = (uint16_t)v;
            else if (depth == 8) row[i] = (uint8_t)v;
            else row[i * depth / 8] |= (uint8_t)(v << (8 - depth - (i * depth) % 8));
        }
    }
#undef RND
    for (int pass = 0; pass < passes; pass++)
        for (uint32_t y = 0; y < h; y++) png_write_row(p, img + y * rowbytes);
    png_write_end(p, info);
    png_destroy_write_struct(&p, &info);
    free(img);
    *n = m.n;
    return m.d;
}

/* The in-process decoders give the plugin's pixels, RGBA8 and gray16. */
static void assert_same_as_plugin(const uint8_t *d, size_t n, const char *what)
{
    sv_image a, b;
    sv_error e1 = {0}, e2 = {0};
    sv_status s1 = sv_image_decode_rgba8(d, n, what, 0, &a, &e1);
    sv_status s2 = sv_image_plugin_decode_rgba8(d, n, what, 0, &b, &e2);
    if (s1 != SV_OK || s2 != SV_OK)
        fail_msg("%s: decode %d (%s), plugin %d (%s)", what, s1, e1.message, s2, e2.message);
    if (a.width != b.width || a.height != b.height ||
        memcmp(a.data, b.data, (size_t)a.width * a.height * 4) != 0)
        fail_msg("%s: the in-process decoder and the plugin give other pixels", what);
    sv_image_free(&a);
    sv_image_free(&b);
    if (n < 8 || memcmp(d, "\x89PNG", 4) != 0) return;
    assert_int_equal(sv_image_decode_gray16(d, n, what, 0, &a, &e1), SV_OK);
    assert_int_equal(sv_image_plugin_decode_gray16(d, n, what, 0, &b, &e2), SV_OK);
    if (memcmp(a.data, b.data, (size_t)a.width * a.height * 2) != 0)
        fail_msg("%s: gray16 differs from the plugin's", what);
    sv_image_free(&a);
    sv_image_free(&b);
}

/* First in the group: PNG and JPEG decode without loading the plugin. */
static void png_and_jpeg_decode_without_the_plugin(void **state)
{
    (void)state;
    size_t n;
    uint8_t *png = synthetic_png(9, 7, PNG_COLOR_TYPE_RGB_ALPHA, 8, false, false, 1, &n);
    sv_image img;
    sv_error err = {0};
    assert_int_equal(sv_image_decode_rgba8(png, n, "a.png", 0, &img, &err), SV_OK);
    sv_image_free(&img);
    assert_int_equal(sv_image_decode_gray16(png, n, "a.png", 0, &img, &err), SV_OK);
    sv_image_free(&img);
    free(png);
    char path[1024];
    snprintf(path, sizeof path, "%s/scopia_bonsai-tree/bark.jpg",
             sv_test_data("the JPEG decode of bark.jpg"));
    FILE *f = fopen(path, "rb");
    if (!f) fail_msg("cannot open %s", path);
    uint8_t buf[1 << 16];
    size_t got = fread(buf, 1, sizeof buf, f);
    fclose(f);
    assert_true(got > 0 && got < sizeof buf);
    assert_int_equal(sv_image_decode_rgba8(buf, got, "bark.jpg", 0, &img, &err), SV_OK);
    sv_image_free(&img);
    assert_null(sv_image_plugin_symbol("sv_plugin_decode_rgba8"));
}

static void png_of_every_colour_type_and_depth_decodes_as_the_plugin_does(void **state)
{
    (void)state;
    static const struct {
        int ctype, depth;
        bool trns, interlace;
    } cases[] = {
        {PNG_COLOR_TYPE_GRAY, 1, false, false},       {PNG_COLOR_TYPE_GRAY, 2, false, true},
        {PNG_COLOR_TYPE_GRAY, 4, false, false},       {PNG_COLOR_TYPE_GRAY, 8, false, false},
        {PNG_COLOR_TYPE_GRAY, 8, true, false},        {PNG_COLOR_TYPE_GRAY, 16, false, false},
        {PNG_COLOR_TYPE_GRAY_ALPHA, 8, false, false}, {PNG_COLOR_TYPE_GRAY_ALPHA, 16, false, true},
        {PNG_COLOR_TYPE_RGB, 8, false, false},        {PNG_COLOR_TYPE_RGB, 8, true, false},
        {PNG_COLOR_TYPE_RGB, 16, false, false},       {PNG_COLOR_TYPE_RGB, 16, true, false},
        {PNG_COLOR_TYPE_RGB_ALPHA, 8, false, true},   {PNG_COLOR_TYPE_RGB_ALPHA, 16, false, false},
        {PNG_COLOR_TYPE_PALETTE, 1, false, false},    {PNG_COLOR_TYPE_PALETTE, 2, true, false},
        {PNG_COLOR_TYPE_PALETTE, 4, true, true},      {PNG_COLOR_TYPE_PALETTE, 8, false, false},
        {PNG_COLOR_TYPE_PALETTE, 8, true, false},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        size_t n;
        uint8_t *d = synthetic_png(37, 23, cases[i].ctype, cases[i].depth, cases[i].trns,
                                   cases[i].interlace, (unsigned)i + 7, &n);
        char what[64];
        snprintf(what, sizeof what, "type %d, %d bits%s%s", cases[i].ctype, cases[i].depth,
                 cases[i].trns ? ", tRNS" : "", cases[i].interlace ? ", interlaced" : "");
        assert_same_as_plugin(d, n, what);
        free(d);
    }
    /* every 16-bit value: OIIO's 16 → 8-bit rounding, exactly */
    png_structp p = png_create_write_struct(PNG_LIBPNG_VER_STRING, NULL, NULL, NULL);
    png_infop info = png_create_info_struct(p);
    mem_out m = {0};
    if (setjmp(png_jmpbuf(p))) fail_msg("libpng could not write the ramp");
    png_set_write_fn(p, &m, mem_write, mem_flush);
    png_set_IHDR(p, info, 256, 256, 16, PNG_COLOR_TYPE_GRAY, PNG_INTERLACE_NONE,
                 PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_write_info(p, info);
    png_set_swap(p);
    uint16_t row[256];
    for (uint32_t y = 0; y < 256; y++) {
        for (uint32_t x = 0; x < 256; x++) row[x] = (uint16_t)(y * 256 + x);
        png_write_row(p, (png_bytep)row);
    }
    png_write_end(p, info);
    png_destroy_write_struct(&p, &info);
    assert_same_as_plugin(m.d, m.n, "the 16-bit ramp");
    free(m.d);
}

static void every_texture_of_the_shared_trees_decodes_as_the_plugin_does(void **state)
{
    (void)state;
    const char *data = sv_test_data("the shared trees' textures");
    DIR *top = opendir(data);
    if (!top) fail_msg("cannot open %s", data);
    int count = 0;
    struct dirent *t;
    while ((t = readdir(top))) {
        if (t->d_name[0] == '.') continue;
        char dir[1024];
        snprintf(dir, sizeof dir, "%s/%s", data, t->d_name);
        DIR *in = opendir(dir);
        if (!in) continue;
        struct dirent *e;
        while ((e = readdir(in))) {
            const char *dot = strrchr(e->d_name, '.');
            if (!dot || (strcmp(dot, ".png") && strcmp(dot, ".jpg") && strcmp(dot, ".jpeg")))
                continue;
            char path[2048];
            snprintf(path, sizeof path, "%s/%s", dir, e->d_name);
            FILE *f = fopen(path, "rb");
            if (!f) fail_msg("cannot open %s", path);
            fseek(f, 0, SEEK_END);
            long n = ftell(f);
            fseek(f, 0, SEEK_SET);
            uint8_t *b = malloc((size_t)n);
            assert_int_equal(fread(b, 1, (size_t)n, f), (size_t)n);
            fclose(f);
            assert_same_as_plugin(b, (size_t)n, path);
            free(b);
            count++;
        }
        closedir(in);
    }
    closedir(top);
    assert_true(count >= 10); /* the data set has a dozen PNG and JPEG textures */
}

static void garbage_truncated_and_oversized_images_are_refused(void **state)
{
    (void)state;
    sv_image img, src;
    sv_error err = {0};
    assert_int_equal(sv_image_decode_rgba8("hello", 5, "x.png", 0, &img, &err), SV_ERR_FORMAT);
    assert_non_null(strstr(err.message, "x.png"));
    assert_int_equal(sv_image_decode_rgba8("", 0, "e.png", 0, &img, &err), SV_ERR_PARSE);
    assert_int_equal(sv_image_alloc(&src, 40, 30, 4, 8, NULL), SV_OK);
    fill_pattern(&src);
    size_t n;
    uint8_t *png = encode(&src, &n);
    const size_t cuts[] = {8, 20, 33, n / 2, n - 13};
    for (size_t i = 0; i < sizeof cuts / sizeof cuts[0]; i++) {
        sv_status st = sv_image_decode_rgba8(png, cuts[i], "cut.png", 0, &img, &err);
        assert_int_not_equal(st, SV_OK);
        assert_null(img.data);
        assert_non_null(strstr(err.message, "cut.png"));
    }
    assert_int_equal(sv_image_decode_rgba8(png, n, "big.png", 32, &img, &err), SV_ERR_LIMIT);
    assert_non_null(strstr(err.message, "40x30"));
    /* the name is only a hint: a hostile name never makes the shim open a file */
    assert_int_equal(sv_image_decode_rgba8(png, n, "../../etc/passwd.png", 0, &img, &err), SV_OK);
    assert_int_equal(img.width, 40);
    sv_image_free(&img);
    sv_image_free(&src);
    free(png);
}

/* The read-back table is the exact encoder at every 16-bit code, and it is
 * not the identity (a byte-space copy would fail). */
static void srgb_table_equals_the_encoder_at_every_16_bit_code(void **state)
{
    (void)state;
    const uint8_t *t = sv_srgb_encode16_table();
    for (uint32_t c = 0; c < 65536; c++)
        if (t[c] != sv_srgb_encode8(c / 65535.0)) fail_msg("code %u: %u", c, t[c]);
    assert_int_equal(t[0], 0);
    assert_int_equal(t[65535], 255);
    assert_int_equal(t[65535 / 2], 188); /* linear 0.5 shows as sRGB 188 */
}

static void encoding_an_empty_image_fails_cleanly(void **state)
{
    (void)state;
    sv_image empty = {0};
    uint8_t *out = (uint8_t *)1;
    size_t n = 5;
    sv_error err = {0};
    assert_int_not_equal(sv_image_encode_png(&empty, &out, &n, &err), SV_OK);
    assert_null(out);
    assert_int_equal(n, 0);
    assert_int_not_equal(sv_image_write_png(&empty, "/tmp/never-written.png", &err), SV_OK);
    sv_image img;
    assert_int_equal(sv_image_alloc(&img, 2, 2, 4, 8, NULL), SV_OK);
    assert_int_equal(sv_image_write_png(&img, "/nonexistent-dir/x.png", &err), SV_ERR_IO);
    assert_non_null(strstr(err.message, "/nonexistent-dir/x.png"));
    sv_image_free(&img);
}

/* sv_image_reduce: halves (odd sides rounded up) until within max_side;
 * colour weighted by alpha, alpha averaged; smaller images untouched. */
static void reduce_halves_with_an_alpha_weighted_box_filter(void **state)
{
    (void)state;
    sv_image img;
    assert_int_equal(sv_image_alloc(&img, 5, 3, 4, 8, NULL), SV_OK);
    uint8_t *px = img.data;
    for (uint32_t i = 0; i < 15; i++) {
        bool odd = (i % 5) % 2; /* columns 1 and 3 transparent green */
        uint8_t c[4] = {odd ? 0 : 200, odd ? 255 : 0, 0, odd ? 0 : 255};
        memcpy(px + 4 * i, c, 4);
    }
    assert_int_equal(sv_image_reduce(&img, 8, NULL), SV_OK); /* within: unchanged */
    assert_true(img.width == 5 && img.height == 3);
    assert_int_equal(sv_image_reduce(&img, 2, NULL), SV_OK);
    assert_true(img.width == 2 && img.height == 1); /* 5x3 -> 3x2 -> 2x1 */
    px = img.data;
    /* the transparent green never bleeds into the colour */
    assert_int_equal(px[0], 200);
    assert_int_equal(px[1], 0);
    /* alpha: texel (0,0) of 3x2 averaged columns 0-1 = 127.5 -> 128 (rows 0-1),
     * then with (0,1) of 3x2 = row 2 columns 0-1 = 128: 128 */
    assert_int_equal(px[3], 128);
    sv_image_free(&img);
    /* 16-bit grey: a plain mean */
    assert_int_equal(sv_image_alloc(&img, 2, 2, 1, 16, NULL), SV_OK);
    uint16_t v[4] = {0, 1000, 2000, 3001};
    memcpy(img.data, v, sizeof v);
    assert_int_equal(sv_image_reduce(&img, 1, NULL), SV_OK);
    assert_true(img.width == 1 && img.height == 1);
    assert_int_equal(((uint16_t *)img.data)[0], 1500); /* 1500.25 rounds down */
    sv_image_free(&img);
}

/* The sRGB transfer functions: exact at the ends and the knee, the table
 * agrees with the formula, and encode8 inverts decode8 on every code. */
static void srgb_codes_round_trip_and_match_the_formula(void **state)
{
    (void)state;
    assert_true(sv_srgb_to_linear(0) == 0 && sv_srgb_to_linear(1) == 1);
    assert_true(fabs(sv_srgb_to_linear(0.5) - 0.21404114) < 1e-7);
    assert_true(fabs(sv_linear_to_srgb(sv_srgb_to_linear(0.3)) - 0.3) < 1e-12);
    for (int c = 0; c < 256; c++) {
        assert_true(fabs(sv_srgb_decode8((uint8_t)c) - sv_srgb_to_linear(c / 255.0)) < 1e-15);
        assert_int_equal(sv_srgb_encode8(sv_srgb_decode8((uint8_t)c)), c);
    }
    for (double l = 0; l <= 1.0; l += 1.0 / 4097)
        assert_int_equal(sv_srgb_encode8(l), (int)lround(255.0 * sv_linear_to_srgb(l)));
    assert_int_equal(sv_srgb_encode8(-1), 0);
    assert_int_equal(sv_srgb_encode8(2), 255);
    assert_int_equal(sv_srgb_encode8(NAN), 0);
}

/* Halving RGBA8 colour averages light, not bytes: black beside white is
 * linear 0.5, sRGB 188 (the byte mean 128 would be linear 0.22). */
static void reduce_averages_rgba8_colour_in_linear(void **state)
{
    (void)state;
    sv_image img;
    assert_int_equal(sv_image_alloc(&img, 2, 2, 4, 8, NULL), SV_OK);
    uint8_t *px = img.data;
    for (int i = 0; i < 4; i++) {
        memset(px + 4 * i, i % 2 ? 255 : 0, 3);
        px[4 * i + 3] = 255;
    }
    assert_int_equal(sv_image_reduce(&img, 1, NULL), SV_OK);
    px = img.data;
    for (int k = 0; k < 3; k++) assert_int_equal(px[k], 188);
    assert_int_equal(px[3], 255);
    sv_image_free(&img);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(png_and_jpeg_decode_without_the_plugin), /* first: nothing loaded it */
        cmocka_unit_test(alloc_sizes_the_buffer_and_free_zeroes_the_struct),
        cmocka_unit_test(srgb_codes_round_trip_and_match_the_formula),
        cmocka_unit_test(reduce_averages_rgba8_colour_in_linear),
        cmocka_unit_test(alloc_refuses_overflow_and_bad_formats),
        cmocka_unit_test(png_round_trip_keeps_rgba8_exactly_with_straight_alpha),
        cmocka_unit_test(png_encoding_is_deterministic_and_write_matches_encode),
        cmocka_unit_test(png_leaves_out_an_opaque_alpha_and_grey_colour),
        cmocka_unit_test(png_of_few_colours_is_indexed),
        cmocka_unit_test(png_16_bit_round_trips_to_the_nearest_8_bit_value),
        cmocka_unit_test(gray_and_rgb_images_expand_to_opaque_rgba),
        cmocka_unit_test(tga_without_magic_decodes_by_its_name),
        cmocka_unit_test(jpeg_from_the_data_set_decodes),
        cmocka_unit_test(png_of_every_colour_type_and_depth_decodes_as_the_plugin_does),
        cmocka_unit_test(every_texture_of_the_shared_trees_decodes_as_the_plugin_does),
        cmocka_unit_test(garbage_truncated_and_oversized_images_are_refused),
        cmocka_unit_test(srgb_table_equals_the_encoder_at_every_16_bit_code),
        cmocka_unit_test(encoding_an_empty_image_fails_cleanly),
        cmocka_unit_test(png_memo_encodes_shared_pixels_once_and_gives_the_same_bytes),
        cmocka_unit_test(reduce_halves_with_an_alpha_weighted_box_filter),
    };
    return sv_test_exit(cmocka_run_group_tests(tests, NULL, NULL));
}
