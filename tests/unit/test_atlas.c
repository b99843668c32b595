/* test_atlas.c — chart packing, texel-density choice, the median/threshold
 * downsampler and colour dilation (core/render/atlas.c). */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "atlas.h"

static uint64_t rng(uint64_t *s)
{
    *s = *s * 6364136223846793005ull + 1442695040888963407ull;
    return *s >> 33;
}

static bool is_pow2(uint32_t v)
{
    return v && !(v & (v - 1));
}

static void assert_disjoint_with_padding(const sv_chart *c, uint32_t n, uint32_t pad, uint32_t w,
                                         uint32_t h)
{
    for (uint32_t i = 0; i < n; i++) {
        assert_true(c[i].x + c[i].w <= w);
        assert_true(c[i].y + c[i].h <= h);
        for (uint32_t j = i + 1; j < n; j++) {
            bool apart_x = c[j].x >= c[i].x + c[i].w + pad || c[i].x >= c[j].x + c[j].w + pad;
            bool apart_y = c[j].y >= c[i].y + c[i].h + pad || c[i].y >= c[j].y + c[j].h + pad;
            if (!apart_x && !apart_y) fail_msg("charts %u and %u closer than %u texels", i, j, pad);
        }
    }
}

static void atlas_packs_charts_without_overlap_with_padding(void **state)
{
    (void)state;
    enum { N = 60 };
    sv_chart c[N];
    uint64_t s = 7;
    for (int i = 0; i < N; i++) {
        c[i].w = 1 + (uint32_t)(rng(&s) % 90);
        c[i].h = 1 + (uint32_t)(rng(&s) % 90);
    }
    uint32_t w = 0, h = 0;
    assert_true(sv_atlas_fit(c, N, 4, 1024, &w, &h));
    assert_true(is_pow2(w) && is_pow2(h));
    assert_true(w <= 1024 && h <= 1024);
    assert_disjoint_with_padding(c, N, 4, w, h);
}

static void atlas_shrinks_to_the_smallest_power_of_two_that_fits(void **state)
{
    (void)state;
    sv_chart c[4] = {
        {.w = 10, .h = 10}, {.w = 10, .h = 10}, {.w = 10, .h = 10}, {.w = 10, .h = 10}};
    uint32_t w = 0, h = 0;
    assert_true(sv_atlas_fit(c, 4, 2, 2048, &w, &h));
    assert_int_equal(w, 32); /* 2×2 of 12-texel cells: 16 is too small */
    assert_int_equal(h, 32);
    sv_chart wide[2] = {{.w = 30, .h = 5}, {.w = 30, .h = 5}};
    assert_true(sv_atlas_fit(wide, 2, 2, 2048, &w, &h));
    assert_int_equal(w, 32);
    assert_int_equal(h, 16); /* two 7-texel rows fit in half the height */
    assert_disjoint_with_padding(wide, 2, 2, w, h);
    sv_chart big = {.w = 3000, .h = 10};
    assert_false(sv_atlas_fit(&big, 1, 2, 2048, &w, &h));
}

static void atlas_layout_is_deterministic_for_equal_charts(void **state)
{
    (void)state;
    enum { N = 40 };
    sv_chart a[N], b[N];
    for (int i = 0; i < N; i++) {
        a[i].w = b[i].w = 8 + (uint32_t)(i % 3) * 4; /* many equal keys for the sort */
        a[i].h = b[i].h = 8;
    }
    assert_true(sv_atlas_pack(a, N, 128, 128, 2));
    assert_true(sv_atlas_pack(b, N, 128, 128, 2));
    assert_memory_equal(a, b, sizeof a);
    /* Equal charts keep their input order along the skyline (stable sort). */
    assert_true(a[0].y < a[3].y || (a[0].y == a[3].y && a[0].x < a[3].x));
}

static void texel_choice_is_the_finest_density_that_fits(void **state)
{
    (void)state;
    double half[8] = {1, 1, 1, 1, 1, 1, 1, 1}; /* four 2×2 m quads */
    double t = 0;
    assert_int_equal(sv_atlas_choose_texel(half, 4, 4, 256, &t, NULL), SV_OK);
    /* 2×2 layout: each chart <= 124 texels: t ≈ 2/124 */
    assert_true(fabs(t - 2.0 / 124) < 2.0 / 124 * 0.01);
    sv_chart c[4];
    for (int i = 0; i < 4; i++) sv_chart_size(1, 1, t, &c[i].w, &c[i].h);
    assert_true(sv_atlas_pack(c, 4, 256, 256, 4));
    for (int i = 0; i < 4; i++) sv_chart_size(1, 1, t * 0.98, &c[i].w, &c[i].h);
    assert_false(sv_atlas_pack(c, 4, 256, 256, 4));
}

static void texel_choice_fails_when_not_even_single_texels_fit(void **state)
{
    (void)state;
    enum { N = 100 };
    double half[2 * N];
    for (int i = 0; i < 2 * N; i++) half[i] = 1;
    double t = 0;
    sv_error err = {0};
    assert_int_equal(sv_atlas_choose_texel(half, N, 4, 32, &t, &err), SV_ERR_LIMIT);
    assert_non_null(strstr(err.message, "do not fit"));
}

static void downsampler_gives_binary_alpha_and_thresholded_coverage(void **state)
{
    (void)state;
    /* 4 texels of 4×4 samples with 0, 4, 5 and 16 covered samples. */
    enum { S = 4, W = 4 };
    uint8_t src[S * S * W * 4];
    memset(src, 0, sizeof src);
    const uint32_t cover[W] = {0, 4, 5, 16};
    for (uint32_t t = 0; t < W; t++)
        for (uint32_t k = 0; k < cover[t]; k++) {
            uint32_t x = t * S + k % S, y = k / S;
            uint8_t *p = src + 4 * (y * S * W + x);
            p[0] = (uint8_t)(10 * (k + 1)); /* values 10, 20, ... : median known */
            p[1] = 77;
            p[2] = (uint8_t)(k == 0 ? 250 : 5);
            p[3] = 255;
        }
    uint8_t dst[W * 4];
    sv_downsample_median(src, W, 1, S, 0.3, dst); /* needs ceil(0.3·16) = 5 */
    for (int t = 0; t < W; t++) assert_true(dst[4 * t + 3] == 0 || dst[4 * t + 3] == 255);
    assert_int_equal(dst[3], 0);
    assert_int_equal(dst[7], 0);    /* 4/16 < 0.3 */
    assert_int_equal(dst[11], 255); /* 5/16 >= 0.3 */
    assert_int_equal(dst[8], 30);   /* median of 10..50 */
    assert_int_equal(dst[9], 77);
    assert_int_equal(dst[10], 5); /* the outlier 250 is rejected */
    assert_int_equal(dst[15], 255);
    assert_int_equal(dst[12], 80);                /* lower median of 10..160 */
    sv_downsample_median(src, W, 1, S, 0.2, dst); /* needs 4 */
    assert_int_equal(dst[7], 255);
}

/* The colour downsampler of linear RGBA16: each channel the median of the
 * covered samples, scaled to their mean luminance (one bright sample among
 * dark ones lifts the texel's light but not its hue), the same threshold as
 * the median filter, and coverage alpha as 8-bit × 257. */
static double y709(double r, double g, double b)
{
    return 0.2126 * r + 0.7152 * g + 0.0722 * b;
}

static void linear_downsampler_keeps_the_median_hue_and_the_mean_light(void **state)
{
    (void)state;
    enum { S = 4, W = 3 };
    uint16_t src[S * S * W * 4];
    memset(src, 0, sizeof src);
    const uint32_t cover[W] = {4, 5, 16};
    for (uint32_t t = 0; t < W; t++)
        for (uint32_t k = 0; k < cover[t]; k++) {
            uint32_t x = t * S + k % S, y = k / S;
            uint16_t *p = src + 4 * (y * S * W + x);
            p[0] = (uint16_t)(k == 0 ? 60000 : 1000); /* one bright sample */
            p[1] = (uint16_t)(100 * (k + 1));
            p[2] = 7;
            p[3] = 65535;
        }
    uint16_t dst[W * 4];
    sv_downsample_colour16(src, W, 1, S, 0.3, dst);
    assert_int_equal(dst[3], 0); /* 4/16 < 0.3 */
    assert_int_equal(dst[0], 0);
    assert_int_equal(dst[7], 65535);
    assert_int_equal(dst[11], 65535);
    /* texel 1: medians 1000, 300, 7; mean luminance of the 5 samples */
    double want = y709((60000 + 4 * 1000) / 5.0, 300, 7), k1 = want / y709(1000, 300, 7);
    assert_int_equal(dst[4], (int)lround(1000 * k1));
    assert_int_equal(dst[5], (int)lround(300 * k1));
    assert_int_equal(dst[6], (int)lround(7 * k1));
    assert_true(fabs(y709(dst[4], dst[5], dst[6]) - want) < 1.0);
    /* texel 2: 16 samples, lower medians 1000 and 800 */
    double want2 = y709((60000 + 15 * 1000) / 16.0, 850, 7), k2 = want2 / y709(1000, 800, 7);
    assert_int_equal(dst[8], (int)lround(1000 * k2));
    assert_int_equal(dst[9], (int)lround(800 * k2));
    sv_downsample_colour16(src, W, 1, S, 0, dst); /* coverage alpha */
    assert_int_equal(dst[3], 64 * 257);           /* 4/16 of 255, rounded: 64 */
    assert_int_equal(dst[7], 80 * 257);
    assert_int_equal(dst[11], 65535);
    /* black samples: luminance 0 gives the mean, 0 */
    memset(src, 0, sizeof src);
    for (uint32_t i = 0; i < S * S * W; i++) src[4 * i + 3] = 65535;
    sv_downsample_colour16(src, W, 1, S, 0.3, dst);
    for (int t = 0; t < W; t++) assert_int_equal(dst[4 * t], 0);
}

/* Dilating RGBA colour takes the alpha-weighted (premultiplied) mean: a
 * texel a third covered pulls a third as hard as a covered one. */
static void dilation_of_rgba_colour_weighs_neighbours_by_alpha(void **state)
{
    (void)state;
    sv_image img;
    assert_int_equal(sv_image_alloc(&img, 3, 1, 4, 16, NULL), SV_OK);
    uint16_t *p = img.data;
    const uint16_t px[12] = {1000, 1000, 1000, 65535, 0, 0, 0, 0, 4000, 4000, 4000, 21845};
    memcpy(p, px, sizeof px);
    const uint8_t mask[3] = {1, 0, 1};
    assert_int_equal(sv_dilate(&img, mask, 3, 1, NULL), SV_OK);
    for (int k = 0; k < 3; k++) assert_int_equal(p[4 + k], 1750); /* not the plain 2500 */
    assert_int_equal(p[7], 0);                                    /* alpha untouched */
    sv_image_free(&img);
}

static int cmp_u8(const void *a, const void *b)
{
    return (int)*(const uint8_t *)a - (int)*(const uint8_t *)b;
}

static void downsampler_median_matches_sorting_on_random_samples(void **state)
{
    (void)state;
    enum { S = 5, W = 16, H = 9 };
    uint8_t *src = malloc(S * S * W * H * 4), dst[W * H * 4];
    uint64_t s = 99;
    for (int i = 0; i < S * S * W * H; i++) {
        for (int k = 0; k < 3; k++) src[4 * i + k] = (uint8_t)(rng(&s) % 7 * 40); /* many ties */
        src[4 * i + 3] = rng(&s) % 3 ? 255 : 0;
    }
    sv_downsample_median(src, W, H, S, 0.3, dst);
    for (int ty = 0; ty < H; ty++)
        for (int tx = 0; tx < W; tx++) {
            uint8_t v[3][S * S];
            int c = 0;
            for (int y = 0; y < S; y++)
                for (int x = 0; x < S; x++) {
                    const uint8_t *p = src + 4 * ((ty * S + y) * W * S + tx * S + x);
                    if (!p[3]) continue;
                    for (int k = 0; k < 3; k++) v[k][c] = p[k];
                    c++;
                }
            const uint8_t *o = dst + 4 * (ty * W + tx);
            if (c < 8) { /* ceil(0.3·25) */
                assert_int_equal(o[3], 0);
                continue;
            }
            assert_int_equal(o[3], 255);
            for (int k = 0; k < 3; k++) {
                qsort(v[k], (size_t)c, 1, cmp_u8);
                assert_int_equal(o[k], v[k][(c - 1) / 2]);
            }
        }
    free(src);
}

static void float_downsampler_takes_the_median_of_covered_depths(void **state)
{
    (void)state;
    float src[2 * 2 * 2] = {1.0f, 3.0f, INFINITY, INFINITY, 2.0f, 100.0f, INFINITY, 0.5f};
    float dst[2];
    sv_downsample_median_f32(src, 2, 1, 2, 0.3, dst);
    assert_true(dst[0] == 2.0f); /* lower median of 1,2,3,100 */
    assert_true(isinf(dst[1]));  /* 1 of 4 < 0.3 */
}

static void dilation_fills_transparent_texels_with_neighbour_colour_and_keeps_alpha(void **state)
{
    (void)state;
    sv_image img;
    assert_int_equal(sv_image_alloc(&img, 8, 8, 4, 8, NULL), SV_OK);
    uint8_t *p = img.data, mask[64] = {0};
    p[4 * (1 * 8 + 1) + 0] = 255;
    p[4 * (1 * 8 + 1) + 3] = 255;
    mask[1 * 8 + 1] = 1; /* red */
    p[4 * (6 * 8 + 6) + 2] = 255;
    p[4 * (6 * 8 + 6) + 3] = 255;
    mask[6 * 8 + 6] = 1; /* blue */
    assert_int_equal(sv_dilate(&img, mask, 3, 1, NULL), SV_OK);
    const uint8_t *a = p + 4 * (0 * 8 + 0), *b = p + 4 * (2 * 8 + 2);
    const uint8_t *c = p + 4 * (7 * 8 + 7), *d = p + 4 * (4 * 8 + 4);
    assert_int_equal(a[0], 255);
    assert_int_equal(a[2], 0); /* next to red */
    assert_int_equal(b[0], 255);
    assert_int_equal(c[2], 255);
    assert_int_equal(c[0], 0); /* next to blue */
    assert_int_equal(d[0], 128);
    assert_int_equal(d[2], 128); /* far: mean of all */
    for (int i = 0; i < 64; i++)
        assert_int_equal(p[4 * i + 3], mask[i] ? 255 : 0); /* alpha untouched */
    sv_image_free(&img);
}

static void dilation_reaches_as_many_texels_as_passes(void **state)
{
    (void)state;
    sv_image img;
    assert_int_equal(sv_image_alloc(&img, 16, 1, 1, 16, NULL), SV_OK);
    uint16_t *p = img.data;
    uint8_t mask[16] = {0};
    p[0] = 1000;
    mask[0] = 1;
    p[15] = 3000;
    mask[15] = 1;
    assert_int_equal(sv_dilate(&img, mask, 1, 3, NULL), SV_OK);
    assert_int_equal(p[3], 1000);
    assert_int_equal(p[12], 3000);
    assert_int_equal(p[7], 2000); /* beyond reach: mean of valued texels */
    sv_image_free(&img);
}

/* A leaf texture black where it is transparent (the Scopia bush's): its
 * transparent texels take the leaf's colour, in linear light, so an engine's
 * mip levels do not blend black in; alpha and the opaque texels' bytes stay. */
static void texture_dilation_colours_black_transparent_texels(void **state)
{
    (void)state;
    sv_image img, out;
    assert_int_equal(sv_image_alloc(&img, 16, 16, 4, 8, NULL), SV_OK);
    uint8_t *p = img.data;
    for (uint32_t y = 4; y < 12; y++)
        for (uint32_t x = 4; x < 12; x++) {
            uint8_t *t = p + 4 * (y * 16 + x);
            t[0] = 40;
            t[1] = 160;
            t[2] = 20;
            t[3] = (x == 4 || y == 4) ? 128 : 255;
        }
    bool changed = false;
    assert_int_equal(sv_texture_dilate(&img, 2, &out, &changed, NULL), SV_OK);
    assert_true(changed);
    assert_non_null(out.data);
    const uint8_t *o = out.data;
    for (uint32_t i = 0; i < 256; i++) {
        assert_int_equal(o[4 * i + 3], p[4 * i + 3]);
        if (p[4 * i + 3]) assert_memory_equal(o + 4 * i, p + 4 * i, 4);
        else { /* every transparent texel: the leaf's colour (near, then the mean) */
            assert_in_range(o[4 * i], 39, 41);
            assert_in_range(o[4 * i + 1], 159, 161);
            assert_in_range(o[4 * i + 2], 19, 21);
        }
    }
    sv_image_free(&out);
    sv_image_free(&img);
}

/* The distinct RGBA colours of an RGBA8 image (at most 4096 counted). */
static uint32_t colours(const sv_image *img)
{
    static uint32_t seen[4096];
    uint32_t n = 0;
    const uint8_t *p = img->data;
    for (size_t i = 0; i < (size_t)img->width * img->height; i++) {
        uint32_t c = (uint32_t)p[4 * i] | (uint32_t)p[4 * i + 1] << 8 |
                     (uint32_t)p[4 * i + 2] << 16 | (uint32_t)p[4 * i + 3] << 24;
        uint32_t j = 0;
        while (j < n && seen[j] != c) j++;
        if (j == n && n < 4096) seen[n++] = c;
    }
    return n;
}

/* A texture of at most 256 colours (an indexed PNG's: the ez-tree leaves)
 * stays within 256 (its file stays indexed, docs/outputs.md "Sizes"): each
 * coloured transparent texel takes a visible texel's colour, the one nearest
 * its fill; with 250 visible colours at most 6 are added. One of more
 * colours gets the fill as it is. */
static void texture_dilation_keeps_an_indexed_texture_indexed(void **state)
{
    (void)state;
    for (int visible = 2; visible <= 300; visible += 248) { /* 2, 250 */
        sv_image img, out;
        assert_int_equal(sv_image_alloc(&img, 64, 64, 4, 8, NULL), SV_OK);
        uint8_t *p = img.data;
        for (uint32_t y = 8; y < 56; y++) /* a leaf: its colours in bands */
            for (uint32_t x = 8; x < 56; x++) {
                uint8_t *t = p + 4 * (y * 64 + x);
                int k = (int)((y - 8) * 48 + (x - 8)) * visible / (48 * 48);
                t[0] = (uint8_t)(20 + k / 4);
                t[1] = (uint8_t)(100 + k / 2);
                t[2] = (uint8_t)(10 + k % 4);
                t[3] = 255;
            }
        uint32_t before = colours(&img);
        assert_int_equal(before, (uint32_t)visible + 1); /* and transparent black */
        bool changed = false;
        assert_int_equal(sv_texture_dilate(&img, 8, &out, &changed, NULL), SV_OK);
        assert_true(changed);
        assert_true(colours(&out) <= 256);
        const uint8_t *o = out.data;
        for (uint32_t i = 0; i < 64 * 64; i++) {
            assert_int_equal(o[4 * i + 3], p[4 * i + 3]);
            if (p[4 * i + 3]) continue;
            bool found = false; /* a visible texel's colour */
            for (uint32_t j = 0; j < 64 * 64 && !found; j++)
                found = p[4 * j + 3] && memcmp(o + 4 * i, p + 4 * j, 3) == 0;
            assert_true(found);
        }
        /* two bands: near the first band's corner, the first band's colour */
        if (visible == 2) assert_memory_equal(o + 4 * (6 * 64 + 6), p + 4 * (8 * 64 + 8), 3);
        sv_image_free(&out);
        sv_image_free(&img);
    }
    /* 320 visible colours: the fill as it is, beyond the visible ones */
    sv_image img, out;
    assert_int_equal(sv_image_alloc(&img, 64, 64, 4, 8, NULL), SV_OK);
    uint8_t *p = img.data;
    for (uint32_t i = 0; i < 64 * 64; i++)
        if (i % 64 >= 16 && i % 64 < 48 && i / 64 >= 16 && i / 64 < 48) {
            p[4 * i] = (uint8_t)(i % 64 * 4), p[4 * i + 1] = (uint8_t)(i / 64 * 4);
            p[4 * i + 2] = (uint8_t)(i % 5), p[4 * i + 3] = 255;
        }
    assert_true(colours(&img) > 257);
    bool changed = false;
    assert_int_equal(sv_texture_dilate(&img, 8, &out, &changed, NULL), SV_OK);
    assert_true(changed);
    assert_true(colours(&out) > colours(&img));
    sv_image_free(&out);
    sv_image_free(&img);
}

/* An input whose author already dilated it (transparent texels hold their
 * neighbours' colour) is left alone, so its own file is written; so are
 * images with no transparent texel and images that are not RGBA8. */
static void texture_dilation_leaves_dilated_and_opaque_textures_alone(void **state)
{
    (void)state;
    sv_image img, out;
    assert_int_equal(sv_image_alloc(&img, 16, 16, 4, 8, NULL), SV_OK);
    uint8_t *p = img.data;
    for (uint32_t i = 0; i < 256; i++) {
        p[4 * i] = 40;
        p[4 * i + 1] = 160;
        p[4 * i + 2] = 20;
        uint32_t x = i % 16, y = i / 16;
        p[4 * i + 3] = (x >= 4 && x < 12 && y >= 4 && y < 12) ? 255 : 0;
    }
    p[0] = p[1] = p[2] = 0; /* one far corner texel black: 1 of 192 */
    bool changed = true;
    assert_int_equal(sv_texture_dilate(&img, 8, &out, &changed, NULL), SV_OK);
    assert_false(changed);
    assert_null(out.data);
    for (uint32_t i = 0; i < 256; i++) p[4 * i + 3] = 255;
    changed = true;
    assert_int_equal(sv_texture_dilate(&img, 8, &out, &changed, NULL), SV_OK);
    assert_false(changed);
    sv_image_free(&img);
    assert_int_equal(sv_image_alloc(&img, 4, 4, 3, 8, NULL), SV_OK);
    changed = true;
    assert_int_equal(sv_texture_dilate(&img, 8, &out, &changed, NULL), SV_OK);
    assert_false(changed);
    sv_image_free(&img);
}

/* The atlas fill: each clear texel takes the alpha-weighted mean of the
 * smallest aligned 2^k block above it that holds alpha, in linear light:
 * constant over blocks, and what a premultiplied mip average would see.
 * 8×8, RGBA16: a red texel (alpha 1) at (0,0) and a green one (alpha 1/3)
 * at (1,0); a blue one (alpha 1) at (7,7). */
static void atlas_fill_takes_the_weighted_mean_of_the_smallest_block_with_alpha(void **state)
{
    (void)state;
    sv_image img;
    assert_int_equal(sv_image_alloc(&img, 8, 8, 4, 16, NULL), SV_OK);
    uint16_t *p = img.data;
#define PX(x, y) (p + 4 * ((y)*8 + (x)))
    PX(0, 0)[0] = 65535, PX(0, 0)[3] = 65535;
    PX(1, 0)[1] = 65535, PX(1, 0)[3] = 21845;
    PX(7, 7)[2] = 65535, PX(7, 7)[3] = 65535;
    PX(5, 5)[3] = 100; /* alpha 0 in 8 bits: filled too */
    assert_int_equal(sv_atlas_fill(&img, NULL), SV_OK);
    /* (0,1) and (1,1): the 2×2 block of the red and the green, 3:1 */
    for (int x = 0; x < 2; x++) {
        assert_in_range(PX(x, 1)[0], 49151 - 2, 49151 + 2);
        assert_in_range(PX(x, 1)[1], 16384 - 2, 16384 + 2);
        assert_int_equal(PX(x, 1)[2], 0);
        assert_int_equal(PX(x, 1)[3], 0);
    }
    /* (3,3): no alpha in its 2×2 block; the 4×4 one at the origin holds the red and the green */
    assert_in_range(PX(3, 3)[0], 49151 - 2, 49151 + 2);
    /* (6,6): the blue's 2×2 block */
    assert_int_equal(PX(6, 6)[2], 65535);
    assert_int_equal(PX(6, 6)[0], 0);
    /* (5,5), alpha 100 of 65535: the blue's 4×4 block; its alpha is kept */
    assert_int_equal(PX(5, 5)[2], 65535);
    assert_int_equal(PX(5, 5)[3], 100);
    /* (0,7): only the whole image holds alpha there: red 3, green 1, blue 3
     * parts of 7 */
    assert_in_range(PX(0, 7)[0], 28086 - 2, 28086 + 2);
    assert_in_range(PX(0, 7)[2], 28086 - 2, 28086 + 2);
    assert_in_range(PX(0, 7)[1], 9362 - 2, 9362 + 2);
    /* covered texels are untouched */
    assert_int_equal(PX(1, 0)[0], 0);
    assert_int_equal(PX(1, 0)[1], 65535);
#undef PX
    sv_image_free(&img);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(atlas_packs_charts_without_overlap_with_padding),
        cmocka_unit_test(atlas_fill_takes_the_weighted_mean_of_the_smallest_block_with_alpha),
        cmocka_unit_test(atlas_shrinks_to_the_smallest_power_of_two_that_fits),
        cmocka_unit_test(atlas_layout_is_deterministic_for_equal_charts),
        cmocka_unit_test(texel_choice_is_the_finest_density_that_fits),
        cmocka_unit_test(texel_choice_fails_when_not_even_single_texels_fit),
        cmocka_unit_test(downsampler_gives_binary_alpha_and_thresholded_coverage),
        cmocka_unit_test(downsampler_median_matches_sorting_on_random_samples),
        cmocka_unit_test(linear_downsampler_keeps_the_median_hue_and_the_mean_light),
        cmocka_unit_test(dilation_of_rgba_colour_weighs_neighbours_by_alpha),
        cmocka_unit_test(float_downsampler_takes_the_median_of_covered_depths),
        cmocka_unit_test(dilation_fills_transparent_texels_with_neighbour_colour_and_keeps_alpha),
        cmocka_unit_test(dilation_reaches_as_many_texels_as_passes),
        cmocka_unit_test(texture_dilation_colours_black_transparent_texels),
        cmocka_unit_test(texture_dilation_keeps_an_indexed_texture_indexed),
        cmocka_unit_test(texture_dilation_leaves_dilated_and_opaque_textures_alone),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
