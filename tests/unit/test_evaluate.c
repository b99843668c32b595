/* sylva-test: cost=10 (tests/run.sh starts the longest first) */
/* test_evaluate.c — accuracy evaluation (evaluate.h): view placement, cameras,
 * the box filter, the metrics, and (with the OSMesa renderer) whole evaluations:
 * self-comparison, a moved-away result, a sub-pixel shift, subset blending and
 * the preview image. */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <cmocka.h>
#include "test_skip.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "evaluate.h"
#include "image_io.h"

#define DEG (180.0 / M_PI)

/* ---- fixtures ---------------------------------------------------------- */

static double rnd(uint64_t *s)
{
    *s ^= *s >> 12;
    *s ^= *s << 25;
    *s ^= *s >> 27;
    return (double)((*s * 2685821657736338717ull) >> 11) * (1.0 / 9007199254740992.0);
}

/* A synthetic tree: `leaves` small quads of random orientation in a crown
 * around (0, 2, 0) with three leaf colours, plus a trunk quad pair. Translated
 * by `shift`. Deterministic. */
static sv_mesh *tree_mesh_h(uint32_t leaves, double h, const double shift[3])
{
    sv_mesh *m = sv_mesh_create(4 * leaves + 8, 2 * leaves + 4, 4, 0);
    assert_non_null(m);
    uint64_t s = 42;
    for (uint32_t l = 0; l < leaves; l++) {
        double c[3], r2;
        do {
            for (int k = 0; k < 3; k++) c[k] = rnd(&s) * 2 - 1;
            r2 = c[0] * c[0] + c[1] * c[1] + c[2] * c[2];
        } while (r2 > 1);
        c[1] += 2.0;
        double a = rnd(&s) * 2 * M_PI, b = rnd(&s) * M_PI;
        double u[3] = {cos(a) * h, 0, sin(a) * h};
        double v[3] = {-sin(a) * cos(b) * h, sin(b) * h, cos(a) * cos(b) * h};
        static const double q[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
        for (int i = 0; i < 4; i++)
            for (int k = 0; k < 3; k++)
                m->positions[3 * (4 * l + i) + k] = (float)(c[k] + q[i][0] * u[k] + q[i][1] * v[k] +
                                                            shift[k]);
        uint32_t o = 4 * l, *t = &m->indices[6 * l];
        t[0] = o, t[1] = o + 1, t[2] = o + 2, t[3] = o, t[4] = o + 2, t[5] = o + 3;
        m->tri_material[2 * l] = m->tri_material[2 * l + 1] = l % 3;
    }
    /* Trunk: two crossed vertical quads from y = 0 to 1.2. */
    for (int p = 0; p < 2; p++) {
        uint32_t o = 4 * leaves + 4 * p;
        static const double q[4][2] = {{-1, 0}, {1, 0}, {1, 1.2}, {-1, 1.2}};
        for (int i = 0; i < 4; i++) {
            double x = q[i][0] * 0.08;
            m->positions[3 * (o + i)] = (float)((p ? 0 : x) + shift[0]);
            m->positions[3 * (o + i) + 1] = (float)(q[i][1] + shift[1]);
            m->positions[3 * (o + i) + 2] = (float)((p ? x : 0) + shift[2]);
        }
        uint32_t *t = &m->indices[3 * (2 * leaves + 2 * p)];
        t[0] = o, t[1] = o + 1, t[2] = o + 2, t[3] = o, t[4] = o + 2, t[5] = o + 3;
        m->tri_material[2 * leaves + 2 * p] = m->tri_material[2 * leaves + 2 * p + 1] = 3;
    }
    static const float col[4][3] = {
        {0.2f, 0.6f, 0.1f}, {0.3f, 0.7f, 0.2f}, {0.1f, 0.4f, 0.1f}, {0.4f, 0.25f, 0.1f}};
    for (int i = 0; i < 4; i++) {
        memcpy(m->materials[i].base_color, col[i], sizeof col[i]);
        m->materials[i].double_sided = true;
    }
    sv_mesh_compute_normals(m);
    return m;
}

static sv_mesh *tree_mesh(uint32_t leaves, const double shift[3])
{
    return tree_mesh_h(leaves, 0.05, shift);
}

/* Concatenates a and b into one mesh (same materials as a). */
static sv_mesh *concat(const sv_mesh *a, const sv_mesh *b)
{
    sv_mesh *m = sv_mesh_create(a->vertex_count + b->vertex_count,
                                a->triangle_count + b->triangle_count, a->material_count, 0);
    assert_non_null(m);
    memcpy(m->positions, a->positions, 12 * (size_t)a->vertex_count);
    memcpy(m->positions + 3 * a->vertex_count, b->positions, 12 * (size_t)b->vertex_count);
    memcpy(m->normals, a->normals, 12 * (size_t)a->vertex_count);
    memcpy(m->normals + 3 * a->vertex_count, b->normals, 12 * (size_t)b->vertex_count);
    memcpy(m->indices, a->indices, 12 * (size_t)a->triangle_count);
    for (size_t i = 0; i < 3 * (size_t)b->triangle_count; i++)
        m->indices[3 * a->triangle_count + i] = b->indices[i] + a->vertex_count;
    memcpy(m->tri_material, a->tri_material, 4 * (size_t)a->triangle_count);
    memcpy(m->tri_material + a->triangle_count, b->tri_material, 4 * (size_t)b->triangle_count);
    memcpy(m->materials, a->materials, sizeof(sv_material) * a->material_count);
    return m;
}

/* A w×h eval image of "leaves": random s×s squares inside a disc, shifted by
 * (dx, dy) pixels. Colour (0.2, 0.6, 0.1). */
static void leaf_image(sv_eval_image *img, uint32_t size, uint32_t leaf, int dx, int dy)
{
    assert_int_equal(sv_eval_image_alloc(img, size, size, NULL), SV_OK);
    uint64_t s = 7;
    double c = size / 2.0, r = size * 0.4;
    for (int l = 0; l < 15000; l++) {
        double x, y;
        do {
            x = rnd(&s) * size, y = rnd(&s) * size;
        } while ((x - c) * (x - c) + (y - c) * (y - c) > r * r);
        for (uint32_t j = 0; j < leaf; j++)
            for (uint32_t i = 0; i < leaf; i++) {
                long px = (long)x + i + dx, py = (long)y + j + dy;
                if (px < 0 || py < 0 || px >= size || py >= size) continue;
                size_t k = (size_t)py * size + (size_t)px;
                img->coverage[k] = 1;
                img->color[3 * k] = 0.2f, img->color[3 * k + 1] = 0.6f,
                               img->color[3 * k + 2] = 0.1f;
                img->depth[k] = 0.5f;
            }
    }
}

/* ---- pure tests: views, cameras, filter, metrics ------------------------ */

static void elevation(const double *d, double *deg)
{
    *deg = asin(d[1]) * DEG;
}

static void ground_views_stay_near_the_horizon(void **state)
{
    (void)state;
    double d[3 * 24], e, sx = 0, sz = 0;
    sv_eval_place_views(SV_VIEWER_GROUND, 24, d);
    for (int i = 0; i < 24; i++) {
        assert_float_equal(
            sqrt(d[3 * i] * d[3 * i] + d[3 * i + 1] * d[3 * i + 1] + d[3 * i + 2] * d[3 * i + 2]),
            1.0, 1e-12);
        elevation(&d[3 * i], &e);
        assert_true(e >= 0.0 && e <= 20.0);
        sx += d[3 * i], sz += d[3 * i + 2];
    }
    /* all around the tree, not from one side */
    assert_true(hypot(sx, sz) / 24 < 0.1);
}

static void aerial_views_look_from_above(void **state)
{
    (void)state;
    double d[3 * 24], e, lo = 90, hi = 0;
    sv_eval_place_views(SV_VIEWER_AERIAL, 24, d);
    for (int i = 0; i < 24; i++) {
        elevation(&d[3 * i], &e);
        assert_true(e >= 40.0 - 1e-9 && e <= 90.0);
        lo = fmin(lo, e), hi = fmax(hi, e);
    }
    assert_true(lo < 45 && hi > 75); /* spans the band */
}

static void orbit_views_cover_the_whole_sphere_evenly(void **state)
{
    (void)state;
    double d[3 * 24], s[3] = {0, 0, 0}, min_angle = M_PI;
    sv_eval_place_views(SV_VIEWER_ORBIT, 24, d);
    int below = 0, above = 0;
    for (int i = 0; i < 24; i++) {
        below += d[3 * i + 1]<-0.5, above += d[3 * i + 1]> 0.5;
        for (int k = 0; k < 3; k++) s[k] += d[3 * i + k];
        for (int j = 0; j < i; j++) {
            double dot = d[3 * i] * d[3 * j] + d[3 * i + 1] * d[3 * j + 1] +
                         d[3 * i + 2] * d[3 * j + 2];
            min_angle = fmin(min_angle, acos(fmin(1.0, dot)));
        }
    }
    assert_true(below >= 4 && above >= 4);
    assert_true(sqrt(s[0] * s[0] + s[1] * s[1] + s[2] * s[2]) / 24 < 0.05);
    assert_true(min_angle * DEG > 20.0); /* no two views nearly the same */
    /* deterministic */
    double d2[3 * 24];
    sv_eval_place_views(SV_VIEWER_ORBIT, 24, d2);
    assert_memory_equal(d, d2, sizeof d);
}

static void camera_looks_at_the_centre_along_minus_view_direction(void **state)
{
    (void)state;
    const double c[3] = {1, 2, 3};
    const double dirs[3][3] = {{0, 0, 1}, {0, 1, 0}, {0.6, -0.8, 0}};
    for (int i = 0; i < 3; i++) {
        sv_camera cam;
        sv_eval_camera(c, 2.5, dirs[i], &cam);
        double f[3];
        sv_camera_forward(&cam, f);
        for (int k = 0; k < 3; k++) assert_float_equal(f[k], -dirs[i][k], 1e-12);
        double ru = cam.right[0] * cam.up[0] + cam.right[1] * cam.up[1] + cam.right[2] * cam.up[2];
        assert_float_equal(ru, 0.0, 1e-12);
        assert_float_equal(cam.half_width, 2.5, 0);
        assert_true(cam.near_dist <= -2.5 && cam.far_dist >= 2.5);
        assert_memory_equal(cam.origin, c, sizeof c);
        if (i == 0) assert_float_equal(cam.up[1], 1.0, 1e-12); /* upright for side views */
    }
}

static void box_filter_averages_blocks_and_preserves_total_coverage(void **state)
{
    (void)state;
    sv_eval_image a, b;
    assert_int_equal(sv_eval_image_alloc(&a, 8, 8, NULL), SV_OK);
    /* left half covered */
    for (int y = 0; y < 8; y++)
        for (int x = 0; x < 3; x++) a.coverage[y * 8 + x] = 1, a.color[3 * (y * 8 + x)] = 0.5f;
    assert_int_equal(sv_eval_image_downsample(&a, 2, 2, &b, NULL), SV_OK);
    assert_float_equal(b.coverage[0], 0.75, 1e-6); /* 3 of 4 columns */
    assert_float_equal(b.coverage[1], 0.0, 1e-6);
    assert_float_equal(b.color[0], 0.375, 1e-6);
    sv_eval_image_free(&b);
    /* sizes that do not divide: area weights keep the total */
    assert_int_equal(sv_eval_image_downsample(&a, 3, 5, &b, NULL), SV_OK);
    double sum = 0;
    for (int i = 0; i < 15; i++) sum += b.coverage[i];
    assert_float_equal(sum * (64.0 / 15.0), 24.0, 1e-4);
    assert_float_equal(b.coverage[0], 1.0, 1e-6); /* [0, 2.67) fully covered */
    assert_float_equal(b.coverage[1], (3 - 8.0 / 3) / (8.0 / 3), 1e-5); /* partly */
    sv_eval_image_free(&b);
    sv_eval_image_free(&a);
    sv_eval_image_free(NULL);
}

/* The evaluator filters a render to its largest size in one pass;
 * it must give the very bits of the two steps it replaces (conversion to float
 * planes, then the box filter), on a render with every alpha and colour value,
 * depths, and infinite depths. */
static void fused_filter_has_the_bits_of_convert_then_filter(void **state)
{
    (void)state;
    const uint32_t W = 64, H = 48;
    sv_image rgba = {.width = W, .height = H, .channels = 4, .bits = 8};
    uint8_t *px = malloc((size_t)W * H * 4);
    rgba.data = px;
    float *depth = malloc((size_t)W * H * sizeof *depth);
    assert_non_null(px);
    assert_non_null(depth);
    uint32_t s = 12345;
    for (size_t i = 0; i < (size_t)W * H; i++) {
        for (int c = 0; c < 4; c++) {
            s = s * 1103515245u + 12345u;
            px[4 * i + c] = (uint8_t)(s >> 16);
        }
        s = s * 1103515245u + 12345u;
        depth[i] = (s >> 8) % 97 == 0 ? INFINITY : (float)((s >> 8) % 1000) / 7.0f;
    }
    const uint32_t sizes[][2] = {{16, 12}, {8, 6}, {64, 48}, {32, 24}};
    for (size_t k = 0; k < sizeof sizes / sizeof sizes[0]; k++) {
        sv_eval_image full, two, one;
        assert_int_equal(sv_eval_image_from_render(&rgba, depth, &full, NULL), SV_OK);
        assert_int_equal(sv_eval_image_downsample(&full, sizes[k][0], sizes[k][1], &two, NULL),
                         SV_OK);
        assert_int_equal(
            sv_eval_image_from_render_filtered(&rgba, depth, sizes[k][0], sizes[k][1], &one, NULL),
            SV_OK);
        size_t n = (size_t)sizes[k][0] * sizes[k][1];
        assert_memory_equal(one.coverage, two.coverage, n * sizeof(float));
        assert_memory_equal(one.color, two.color, 3 * n * sizeof(float));
        assert_memory_equal(one.depth, two.depth, n * sizeof(float));
        sv_eval_image_free(&full);
        sv_eval_image_free(&two);
        sv_eval_image_free(&one);
    }
    sv_eval_image one;
    assert_int_equal(sv_eval_image_from_render_filtered(&rgba, depth, 10, 10, &one, NULL),
                     SV_ERR_INVALID); /* 64 / 10: not in one pass */
    free(px);
    free(depth);
}

static void filtering_in_integer_steps_equals_filtering_once(void **state)
{
    (void)state;
    sv_eval_image a, b, c, d;
    leaf_image(&a, 512, 3, 0, 0);
    assert_int_equal(sv_eval_image_downsample(&a, 128, 128, &b, NULL), SV_OK);
    assert_int_equal(sv_eval_image_downsample(&b, 16, 16, &c, NULL), SV_OK);
    assert_int_equal(sv_eval_image_downsample(&a, 16, 16, &d, NULL), SV_OK);
    for (size_t i = 0; i < 256; i++) {
        assert_float_equal(c.coverage[i], d.coverage[i], 1e-5);
        assert_float_equal(c.color[3 * i + 1], d.color[3 * i + 1], 1e-5);
        assert_float_equal(c.depth[i], d.depth[i], 1e-5);
    }
    sv_eval_image_free(&a);
    sv_eval_image_free(&b);
    sv_eval_image_free(&c);
    sv_eval_image_free(&d);
}

static void identical_images_give_iou_1_and_zero_errors(void **state)
{
    (void)state;
    sv_eval_image a, b;
    leaf_image(&a, 64, 2, 0, 0);
    leaf_image(&b, 64, 2, 0, 0);
    sv_eval_metrics m = sv_eval_compare(&a, &b, 1.0);
    assert_float_equal(m.iou, 1.0, 0);
    assert_float_equal(m.color_error, 0.0, 0);
    assert_float_equal(m.depth_error, 0.0, 0);
    /* empty vs empty is a perfect match too */
    sv_eval_image z1, z2;
    assert_int_equal(sv_eval_image_alloc(&z1, 4, 4, NULL), SV_OK);
    assert_int_equal(sv_eval_image_alloc(&z2, 4, 4, NULL), SV_OK);
    assert_float_equal(sv_eval_compare(&z1, &z2, 1.0).iou, 1.0, 0);
    /* empty vs leaves: nothing in common */
    sv_eval_image z3;
    assert_int_equal(sv_eval_image_alloc(&z3, 64, 64, NULL), SV_OK);
    m = sv_eval_compare(&a, &z3, 1.0);
    assert_float_equal(m.iou, 0.0, 0);
    assert_true(m.color_error > 0.0);
    sv_eval_image_free(&a);
    sv_eval_image_free(&b);
    sv_eval_image_free(&z1);
    sv_eval_image_free(&z2);
    sv_eval_image_free(&z3);
}

static void depth_and_colour_errors_measure_the_difference(void **state)
{
    (void)state;
    sv_eval_image a, b;
    leaf_image(&a, 32, 2, 0, 0);
    leaf_image(&b, 32, 2, 0, 0);
    for (size_t i = 0; i < 32 * 32; i++) {
        b.depth[i] = b.coverage[i] * 0.75f;        /* 0.25 deeper */
        b.color[3 * i + 1] = b.coverage[i] * 0.3f; /* green 0.6 → 0.3 */
    }
    sv_eval_metrics m = sv_eval_compare(&a, &b, 2.0);
    assert_float_equal(m.iou, 1.0, 0);
    assert_float_equal(m.depth_error, 0.125, 1e-6); /* 0.25 / radius 2 */
    assert_float_equal(m.color_error, 0.1, 1e-6);   /* 0.3 on one of 3 channels */
    sv_eval_image_free(&a);
    sv_eval_image_free(&b);
}

static void subpixel_shift_of_leaves_matters_less_at_small_sizes(void **state)
{
    (void)state;
    /* 1024² supersampled leaves of 6 samples (1.5 px at 256 px), shifted by 8
     * samples = a quarter pixel at 32 px and 2 pixels at 256 px. */
    sv_eval_image a, b;
    leaf_image(&a, 1024, 6, 0, 0);
    leaf_image(&b, 1024, 6, 8, 0);
    double iou[2];
    const uint32_t sizes[2] = {32, 256};
    for (int i = 0; i < 2; i++) {
        sv_eval_image fa, fb;
        assert_int_equal(sv_eval_image_downsample(&a, sizes[i], sizes[i], &fa, NULL), SV_OK);
        assert_int_equal(sv_eval_image_downsample(&b, sizes[i], sizes[i], &fb, NULL), SV_OK);
        iou[i] = sv_eval_compare(&fa, &fb, 1.0).iou;
        sv_eval_image_free(&fa);
        sv_eval_image_free(&fb);
    }
    print_message("sub-pixel shift: IoU %.3f at 32 px, %.3f at 256 px, %.3f point-sampled\n",
                  iou[0], iou[1], sv_eval_compare(&a, &b, 1.0).iou);
    assert_true(iou[0] > 0.9);
    assert_true(iou[1] < iou[0] - 0.1);
    sv_eval_image_free(&a);
    sv_eval_image_free(&b);
}

static void accumulate_blends_with_weights(void **state)
{
    (void)state;
    sv_eval_image a, b, acc;
    leaf_image(&a, 16, 2, 0, 0);
    leaf_image(&b, 16, 2, 3, 0);
    assert_int_equal(sv_eval_image_alloc(&acc, 16, 16, NULL), SV_OK);
    sv_eval_image_accumulate(&acc, &a, 0.25);
    sv_eval_image_accumulate(&acc, &b, 0.75);
    for (size_t i = 0; i < 256; i++) {
        assert_float_equal(acc.coverage[i], 0.25 * a.coverage[i] + 0.75 * b.coverage[i], 1e-6);
        assert_float_equal(acc.color[3 * i + 1],
                           0.25 * a.color[3 * i + 1] + 0.75 * b.color[3 * i + 1], 1e-6);
    }
    sv_eval_image_free(&a);
    sv_eval_image_free(&b);
    sv_eval_image_free(&acc);
}

static void max_pixels_interpolates_where_the_curve_crosses_the_tolerance(void **state)
{
    (void)state;
    sv_eval_result r = {.size_count = 4};
    const uint32_t px[4] = {256, 128, 64, 32};
    const double iou[4] = {0.6, 0.8, 0.9, 0.95};
    for (int i = 0; i < 4; i++) r.sizes[i].pixels = px[i], r.sizes[i].mean.iou = iou[i];
    assert_float_equal(sv_eval_max_pixels(&r, 0.85), 64 * sqrt(2.0), 1e-9); /* halfway in log2 */
    assert_float_equal(sv_eval_max_pixels(&r, 0.9), 64, 1e-9);
    assert_float_equal(sv_eval_max_pixels(&r, 0.5), 256, 0); /* passes everywhere */
    assert_float_equal(sv_eval_max_pixels(&r, 0.99), 0, 0);  /* fails everywhere */
    sv_eval_result_free(&r);
    sv_eval_result_free(NULL);
}

/* The tolerance scales as 1/size: (1 − IoU) · S <= tol · ref. */
static void scaled_max_pixels_keeps_the_error_band_in_pixels(void **state)
{
    (void)state;
    sv_eval_result r = {.size_count = 4};
    const uint32_t px[4] = {256, 128, 64, 32};
    const double iou[4] = {0.6, 0.8, 0.9, 0.95};
    for (int i = 0; i < 4; i++) r.sizes[i].pixels = px[i], r.sizes[i].mean.iou = iou[i];
    /* error 0.1 at 64 px: exactly the budget 0.1 × 64 there, more above */
    assert_float_equal(sv_eval_max_pixels_scaled(&r, 0.1, 64), 64, 1e-6);
    /* budget 0.05 × 64 = 3.2: the error 0.05 at 32 px meets 3.2 / 32 = 0.1
     * easily; 64 px needs 0.05 and has 0.1; between, err(S) · S = 3.2 */
    double s = sv_eval_max_pixels_scaled(&r, 0.05, 64);
    assert_true(s > 32 && s < 64);
    double t = (log2(s) - 5.0), err = 0.05 + t * 0.05;
    assert_float_equal(err * s, 3.2, 1e-6);
    /* ref 0: one tolerance at every size, the former rule */
    assert_float_equal(sv_eval_max_pixels_scaled(&r, 0.1, 0), sv_eval_max_pixels(&r, 0.9), 0);
    /* a constant error: S = budget / error, also outside the measured sizes */
    for (int i = 0; i < 4; i++) r.sizes[i].mean.iou = 0.5;
    assert_float_equal(sv_eval_max_pixels_scaled(&r, 0.1, 64), 12.8, 1e-6);
    for (int i = 0; i < 4; i++) r.sizes[i].mean.iou = 0.99;
    assert_float_equal(sv_eval_max_pixels_scaled(&r, 0.1, 64), 640, 1e-6);
    /* the original itself: good at any size */
    for (int i = 0; i < 4; i++) r.sizes[i].mean.iou = 1.0;
    assert_true(isinf(sv_eval_max_pixels_scaled(&r, 0.1, 64)));
    sv_eval_result_free(&r);
}

/* ---- render-based tests -------------------------------------------------- */

typedef struct fixture {
    sv_renderer *r;
} fixture;

static int setup(void **state)
{
    fixture *f = calloc(1, sizeof *f);
    if (!f) return -1;
    sv_error err = {0};
    /* no OSMesa context is a failure (libosmesa6 is a dependency), not a skip */
    if (sv_renderer_create(1024, &f->r, &err) != SV_OK) {
        fprintf(stderr, "no OSMesa context: %s\n", err.message);
        f->r = NULL;
    }
    *state = f;
    return 0;
}

static int teardown(void **state)
{
    fixture *f = *state;
    if (f) sv_renderer_destroy(f->r);
    free(f);
    return 0;
}

static sv_renderer *need_renderer(void **state)
{
    fixture *f = *state;
    if (!f->r) fail_msg("render tests need an OSMesa context");
    return f->r;
}

static sv_gpu_mesh *upload(sv_renderer *r, const sv_mesh *m)
{
    sv_gpu_mesh *g = NULL;
    sv_error err = {0};
    if (sv_gpu_mesh_upload(r, m, &g, &err) != SV_OK) fail_msg("upload: %s", err.message);
    return g;
}

static sv_evaluator *evaluator(sv_renderer *r, const sv_mesh *m, const sv_gpu_mesh *g,
                               sv_viewer viewer, uint32_t views)
{
    sv_eval_options o = {.viewer = viewer, .view_count = views};
    sv_evaluator *e = NULL;
    sv_error err = {0};
    if (sv_evaluator_create(r, m, g, &o, &e, &err) != SV_OK) fail_msg("create: %s", err.message);
    return e;
}

static sv_eval_result run(sv_evaluator *e, const sv_gpu_mesh *g)
{
    sv_eval_result res;
    sv_error err = {0};
    if (sv_evaluate(e, g, &res, &err) != SV_OK) fail_msg("evaluate: %s", err.message);
    return res;
}

static void original_against_itself_scores_iou_1_and_zero_error_at_every_size(void **state)
{
    sv_renderer *r = need_renderer(state);
    const double zero[3] = {0, 0, 0};
    sv_mesh *m = tree_mesh(2000, zero);
    sv_gpu_mesh *g = upload(r, m);
    sv_evaluator *e = evaluator(r, m, g, SV_VIEWER_ORBIT, 6);
    sv_eval_result res = run(e, g);
    assert_int_equal(res.size_count, 4);
    assert_int_equal(res.view_count, 6);
    const uint32_t px[4] = {256, 128, 64, 32};
    for (uint32_t s = 0; s < 4; s++) {
        assert_int_equal(res.sizes[s].pixels, px[s]);
        assert_float_equal(res.sizes[s].mean.iou, 1.0, 1e-12);
        assert_float_equal(res.sizes[s].worst.iou, 1.0, 1e-12);
        assert_float_equal(res.sizes[s].worst.color_error, 0.0, 1e-12);
        assert_float_equal(res.sizes[s].worst.depth_error, 0.0, 1e-12);
    }
    for (uint32_t i = 0; i < 6 * 4; i++) assert_float_equal(res.per_view[i].iou, 1.0, 1e-12);
    sv_eval_result_free(&res);
    sv_evaluator_destroy(e);
    sv_gpu_mesh_free(g);
    sv_mesh_destroy(m);
}

/* lum_ratio is sveval's brightness figure: 1 for the original itself; the
 * same mesh with every linear factor halved shows half the light where both
 * cover (each sample decoded from its sRGB bytes: within their rounding). */
static void halved_factors_give_a_lum_ratio_of_one_half(void **state)
{
    sv_renderer *r = need_renderer(state);
    const double zero[3] = {0, 0, 0};
    sv_mesh *m = tree_mesh(2000, zero), *dark = tree_mesh(2000, zero);
    for (uint32_t k = 0; k < dark->material_count; k++)
        for (int c = 0; c < 3; c++) dark->materials[k].base_color[c] *= 0.5f;
    sv_gpu_mesh *g = upload(r, m), *gd = upload(r, dark);
    sv_evaluator *e = evaluator(r, m, g, SV_VIEWER_ORBIT, 4);
    sv_eval_result same = run(e, g), half = run(e, gd);
    sv_eval_result id;
    assert_int_equal(sv_eval_identity(e, &id, NULL), SV_OK); /* the original's own level */
    for (uint32_t s = 0; s < same.size_count; s++) {
        assert_float_equal(same.sizes[s].lum_ratio, 1.0, 1e-12);
        assert_float_equal(half.sizes[s].lum_ratio, 0.5, 0.005);
        assert_float_equal(id.sizes[s].lum_ratio, 1.0, 0);
    }
    sv_eval_result_free(&id);
    sv_eval_result_free(&same);
    sv_eval_result_free(&half);
    sv_evaluator_destroy(e);
    sv_gpu_mesh_free(g);
    sv_gpu_mesh_free(gd);
    sv_mesh_destroy(m);
    sv_mesh_destroy(dark);
}

static void result_moved_away_scores_a_clearly_worse_iou(void **state)
{
    sv_renderer *r = need_renderer(state);
    const double zero[3] = {0, 0, 0}, away[3] = {0.8, 0.3, -0.5};
    sv_mesh *m = tree_mesh(2000, zero), *moved = tree_mesh(2000, away);
    sv_gpu_mesh *g = upload(r, m), *gm = upload(r, moved);
    sv_evaluator *e = evaluator(r, m, g, SV_VIEWER_ORBIT, 6);
    sv_eval_result res = run(e, gm);
    for (uint32_t s = 0; s < res.size_count; s++) {
        print_message("moved: %3u px IoU mean %.3f worst %.3f colour %.4f depth %.4f\n",
                      res.sizes[s].pixels, res.sizes[s].mean.iou, res.sizes[s].worst.iou,
                      res.sizes[s].mean.color_error, res.sizes[s].mean.depth_error);
        assert_true(res.sizes[s].mean.iou < 0.7);
        assert_true(res.sizes[s].worst.iou <= res.sizes[s].mean.iou);
        assert_true(res.sizes[s].mean.color_error > 0.01);
    }
    sv_eval_result_free(&res);
    sv_evaluator_destroy(e);
    sv_gpu_mesh_free(g);
    sv_gpu_mesh_free(gm);
    sv_mesh_destroy(m);
    sv_mesh_destroy(moved);
}

/* sv_evaluate_cutoffs judges every cutoff (k + 0.5) / 255 of the swept
 * material from one render a view: each k's figure equals sv_evaluate's with
 * the material's cutoff set to it (calibrate.c rests on this), with an opaque
 * material and another alpha-tested one (cutoff 0.5, not swept) drawn too. */
static void cutoff_sweep_equals_evaluating_each_cutoff(void **state)
{
    sv_renderer *r = need_renderer(state);
    const double zero[3] = {0, 0, 0};
    sv_mesh *orig = tree_mesh(2000, zero);
    /* three big quads through the crown (materials 0, 0, 2) and a trunk quad (1) */
    sv_mesh *m = sv_mesh_create(16, 8, 3, 0);
    assert_non_null(m);
    static const double c[4][3] = {{0, 2, 0}, {0.2, 2.3, 0.1}, {-0.1, 1.8, -0.2}, {0, 0.6, 0}};
    static const double q[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
    for (int p = 0; p < 4; p++) {
        double a = p * 1.1, s = p == 3 ? 0.1 : 1.0, h = p == 3 ? 0.6 : 1.0;
        double u[3] = {cos(a) * s, 0, sin(a) * s}, v[3] = {0, h, 0};
        for (int i = 0; i < 4; i++) {
            for (int k = 0; k < 3; k++)
                m->positions[3 * (4 * p + i) + k] = (float)(c[p][k] + q[i][0] * u[k] +
                                                            q[i][1] * v[k]);
            m->uvs[2 * (4 * p + i)] = (float)(q[i][0] > 0);
            m->uvs[2 * (4 * p + i) + 1] = (float)(q[i][1] > 0);
        }
        uint32_t o = 4 * p, *t = &m->indices[6 * p];
        t[0] = o, t[1] = o + 1, t[2] = o + 2, t[3] = o, t[4] = o + 2, t[5] = o + 3;
        m->tri_material[2 * p] = m->tri_material[2 * p + 1] = p == 3 ? 1 : p == 2 ? 2 : 0;
    }
    free(m->images);
    m->image_count = 1;
    m->images = calloc(1, sizeof *m->images);
    assert_int_equal(sv_image_alloc(&m->images[0], 32, 32, 4, 8, NULL), SV_OK);
    uint64_t s = 3;
    uint8_t *t = m->images[0].data;
    for (int i = 0; i < 32 * 32; i++) {
        t[4 * i] = 60, t[4 * i + 1] = 150, t[4 * i + 2] = 40;
        t[4 * i + 3] = (uint8_t)(rnd(&s) * 256); /* every alpha value */
    }
    for (int k = 0; k < 3; k++) {
        m->materials[k].base_color[0] = m->materials[k].base_color[1] = 1;
        m->materials[k].base_color[2] = m->materials[k].base_color[3] = 1;
        m->materials[k].double_sided = true;
        m->materials[k].base_texture = k == 1 ? -1 : 0;
        m->materials[k].alpha_mode = k == 1 ? SV_ALPHA_OPAQUE : SV_ALPHA_MASK;
    }
    m->materials[2].alpha_cutoff = 0.5f;
    sv_mesh_compute_normals(m);
    sv_gpu_mesh *g = upload(r, orig), *gm = upload(r, m);
    sv_eval_options o = {.viewer = SV_VIEWER_GROUND,
                         .view_count = 5,
                         .size_count = 1,
                         .sizes = {64},
                         .supersample = 4};
    sv_evaluator *e = NULL;
    sv_error err = {0};
    if (sv_evaluator_create(r, orig, g, &o, &e, &err) != SV_OK) fail_msg("create: %s", err.message);
    double iou[255];
    m->materials[0].alpha_cutoff = 0;
    if (sv_evaluate_cutoffs(e, gm, iou, &err) != SV_OK) fail_msg("cutoffs: %s", err.message);
    static const uint32_t ks[] = {0, 1, 37, 63, 64, 127, 128, 191, 253, 254};
    double lo = 1, hi = 0;
    for (size_t i = 0; i < sizeof ks / sizeof *ks; i++) {
        m->materials[0].alpha_cutoff = (float)((ks[i] + 0.5) / 255.0);
        sv_eval_result res = run(e, gm);
        print_message("cutoff byte %3u: sweep %.9f evaluate %.9f\n", ks[i], iou[ks[i]],
                      res.sizes[0].mean.iou);
        assert_float_equal(iou[ks[i]], res.sizes[0].mean.iou, 1e-9);
        lo = fmin(lo, iou[ks[i]]), hi = fmax(hi, iou[ks[i]]);
        sv_eval_result_free(&res);
    }
    assert_true(hi - lo > 0.05); /* the cutoff matters: the check can fail */
    sv_evaluator_destroy(e);
    sv_gpu_mesh_free(g);
    sv_gpu_mesh_free(gm);
    sv_mesh_destroy(orig);
    sv_mesh_destroy(m);
}

/* A size that divides no larger one (64 under 96) is filtered from the render
 * itself: it was once filtered from a float image never filled, all zeros on
 * both sides, IoU 1 whatever the candidate. */
static void a_size_dividing_no_larger_one_is_measured_too(void **state)
{
    sv_renderer *r = need_renderer(state);
    const double zero[3] = {0, 0, 0}, away[3] = {0.8, 0.3, -0.5};
    sv_mesh *m = tree_mesh(2000, zero), *moved = tree_mesh(2000, away);
    sv_gpu_mesh *g = upload(r, m), *gm = upload(r, moved);
    sv_eval_options o = {
        .viewer = SV_VIEWER_ORBIT, .view_count = 6, .size_count = 2, .sizes = {96, 64}};
    sv_evaluator *e = NULL;
    sv_error err = {0};
    if (sv_evaluator_create(r, m, g, &o, &e, &err) != SV_OK) fail_msg("create: %s", err.message);
    sv_eval_result self = run(e, g), res = run(e, gm);
    assert_int_equal(res.size_count, 2);
    for (uint32_t s = 0; s < 2; s++) {
        print_message("96/64: %3u px IoU self %.3f moved %.3f\n", res.sizes[s].pixels,
                      self.sizes[s].mean.iou, res.sizes[s].mean.iou);
        assert_float_equal(self.sizes[s].mean.iou, 1.0, 1e-12);
        assert_true(res.sizes[s].mean.iou < 0.7);
    }
    /* the two sizes see the same shapes: close figures */
    assert_true(fabs(res.sizes[0].mean.iou - res.sizes[1].mean.iou) < 0.1);
    sv_eval_result_free(&self);
    sv_eval_result_free(&res);
    sv_evaluator_destroy(e);
    sv_gpu_mesh_free(g);
    sv_gpu_mesh_free(gm);
    sv_mesh_destroy(m);
    sv_mesh_destroy(moved);
}

static void subpixel_shifted_result_scores_near_1_at_32_px_and_lower_at_256(void **state)
{
    sv_renderer *r = need_renderer(state);
    const double zero[3] = {0, 0, 0};
    sv_mesh *m = tree_mesh_h(8000, 0.02, zero);
    double c[3], radius;
    sv_mesh_sphere(m, c, &radius);
    /* A quarter pixel at 32 px (the image spans 2·radius) = 2 px at 256 px,
     * about half a leaf; vertical, so every ground view sees it almost in full. */
    const double shift[3] = {0, 0.25 * 2 * radius / 32, 0};
    sv_mesh *s = tree_mesh_h(8000, 0.02, shift);
    sv_gpu_mesh *g = upload(r, m), *gs = upload(r, s);
    sv_evaluator *e = evaluator(r, m, g, SV_VIEWER_GROUND, 6);
    sv_eval_result res = run(e, gs);
    double i256 = res.sizes[0].mean.iou, i32 = res.sizes[3].mean.iou;
    print_message("quarter-pixel shift: IoU %.3f at 256 px, %.3f at 32 px\n", i256, i32);
    assert_int_equal(res.sizes[3].pixels, 32);
    assert_true(i32 > 0.9);
    assert_true(i256 < i32 - 0.1);
    assert_true(res.sizes[1].mean.iou < res.sizes[2].mean.iou); /* monotone in between */
    sv_eval_result_free(&res);
    sv_evaluator_destroy(e);
    sv_gpu_mesh_free(g);
    sv_gpu_mesh_free(gs);
    sv_mesh_destroy(m);
    sv_mesh_destroy(s);
}

static void evaluator_places_ground_views_near_the_horizon(void **state)
{
    sv_renderer *r = need_renderer(state);
    const double zero[3] = {0, 0, 0};
    sv_mesh *m = tree_mesh(20, zero);
    sv_gpu_mesh *g = upload(r, m);
    sv_eval_options o = {.viewer = SV_VIEWER_GROUND,
                         .view_count = 5,
                         .sizes = {64, 16},
                         .size_count = 2,
                         .supersample = 2};
    sv_evaluator *e = NULL;
    assert_int_equal(sv_evaluator_create(r, m, g, &o, &e, NULL), SV_OK);
    assert_int_equal(sv_evaluator_view_count(e), 5);
    for (uint32_t v = 0; v < 5; v++) {
        double d[3], el;
        sv_evaluator_view_dir(e, v, d);
        elevation(d, &el);
        assert_true(el >= 0 && el <= 20);
    }
    sv_eval_result res = run(e, g);
    assert_int_equal(res.sizes[0].pixels, 64);
    assert_int_equal(res.sizes[1].pixels, 16);
    sv_eval_result_free(&res);
    sv_evaluator_destroy(e);
    sv_gpu_mesh_free(g);
    sv_mesh_destroy(m);
}

typedef struct pick {
    uint32_t *a, *b; /* triangle lists of the two copies */
    uint32_t na, nb;
    double wa; /* weight of a */
    int calls;
} pick;

static sv_status pick_subsets(void *user, const double dir[3],
                              sv_eval_subset out[SV_EVAL_MAX_SUBSETS], uint32_t *count,
                              sv_error *err)
{
    (void)err;
    pick *p = user;
    assert_float_equal(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2], 1.0, 1e-9);
    p->calls++;
    out[0] = (sv_eval_subset){p->a, p->na, p->wa};
    out[1] = (sv_eval_subset){p->b, p->nb, 1.0 - p->wa};
    *count = 2;
    return SV_OK;
}

static void subset_callback_blends_two_renders_by_weight(void **state)
{
    sv_renderer *r = need_renderer(state);
    const double zero[3] = {0, 0, 0}, away[3] = {3, 0, 0};
    sv_mesh *m = tree_mesh(100, zero), *far = tree_mesh(100, away);
    sv_mesh *both = concat(m, far);
    sv_gpu_mesh *g = upload(r, m), *gb = upload(r, both);
    sv_evaluator *e = evaluator(r, m, g, SV_VIEWER_GROUND, 4);
    pick p = {.na = m->triangle_count, .nb = far->triangle_count};
    p.a = calloc(p.na, sizeof *p.a);
    p.b = calloc(p.nb, sizeof *p.b);
    assert_non_null(p.a);
    assert_non_null(p.b);
    for (uint32_t t = 0; t < p.na; t++) p.a[t] = t;
    for (uint32_t t = 0; t < p.nb; t++) p.b[t] = p.na + t;
    sv_eval_result res;
    sv_error err = {0};
    p.wa = 1.0;
    assert_int_equal(sv_evaluate_subsets(e, gb, pick_subsets, &p, &res, &err), SV_OK);
    assert_int_equal(p.calls, 4);
    /* only the original's copy; the combined mesh is uploaded relative to its
     * own centre, so a few edge samples may round the other way */
    assert_float_equal(res.sizes[0].mean.iou, 1.0, 1e-4);
    sv_eval_result_free(&res);
    p.wa = 0.5;
    assert_int_equal(sv_evaluate_subsets(e, gb, pick_subsets, &p, &res, &err), SV_OK);
    /* half the coverage where the original is (the far copy is out of frame
     * in most views): IoU about 0.5 */
    print_message("blend 0.5: IoU %.3f\n", res.sizes[3].mean.iou);
    assert_true(res.sizes[3].mean.iou > 0.4 && res.sizes[3].mean.iou < 0.6);
    sv_eval_result_free(&res);
    p.wa = 1.5; /* weights 1.5 and -0.5 */
    assert_int_equal(sv_evaluate_subsets(e, gb, pick_subsets, &p, &res, &err), SV_ERR_INVALID);
    assert_non_null(strstr(err.message, "weights"));
    assert_null(res.per_view);
    free(p.a);
    free(p.b);
    sv_evaluator_destroy(e);
    sv_gpu_mesh_free(g);
    sv_gpu_mesh_free(gb);
    sv_mesh_destroy(m);
    sv_mesh_destroy(far);
    sv_mesh_destroy(both);
}

static void preview_shows_original_result_and_heat_for_four_views(void **state)
{
    sv_renderer *r = need_renderer(state);
    const double zero[3] = {0, 0, 0}, away[3] = {0.5, 0, 0};
    sv_mesh *m = tree_mesh(200, zero), *moved = tree_mesh(200, away);
    sv_gpu_mesh *g = upload(r, m), *gm = upload(r, moved);
    sv_eval_options o = {.view_count = 8, .sizes = {64, 32}, .size_count = 2};
    sv_evaluator *e = NULL;
    sv_error err = {0};
    assert_int_equal(sv_evaluator_create(r, m, g, &o, &e, &err), SV_OK);
    char dir[] = "/tmp/sv_eval_XXXXXX";
    assert_non_null(mkdtemp(dir));
    char path[64];
    snprintf(path, sizeof path, "%s/preview.png", dir);
    double heat[2];
    const sv_gpu_mesh *results[2] = {g, gm};
    for (int k = 0; k < 2; k++) {
        assert_int_equal(sv_evaluator_preview(e, results[k], NULL, NULL, path, &err), SV_OK);
        FILE *f = fopen(path, "rb");
        assert_non_null(f);
        static uint8_t bytes[1 << 20];
        size_t n = fread(bytes, 1, sizeof bytes, f);
        fclose(f);
        sv_image img = {0};
        assert_int_equal(sv_image_decode_rgba8(bytes, n, "preview.png", 4096, &img, &err), SV_OK);
        assert_int_equal(img.width, 3 * 64);
        assert_int_equal(img.height, 4 * 64);
        /* total red in the heat column; the original column is not blank */
        double red = 0, orig_var = 0;
        const uint8_t *p = img.data;
        for (uint32_t y = 0; y < img.height; y++)
            for (uint32_t x = 0; x < img.width; x++) {
                const uint8_t *q = p + 4 * ((size_t)y * img.width + x);
                if (x >= 128) red += q[0];
                if (x < 64) orig_var += abs(q[1] - 128);
            }
        heat[k] = red;
        assert_true(orig_var > 1000);
        sv_image_free(&img);
    }
    assert_float_equal(heat[0], 0.0, 0); /* self: black */
    assert_true(heat[1] > 1000);         /* moved: red */
    unlink(path);
    rmdir(dir);
    sv_evaluator_destroy(e);
    sv_gpu_mesh_free(g);
    sv_gpu_mesh_free(gm);
    sv_mesh_destroy(m);
    sv_mesh_destroy(moved);
}

/* ---- cropping: the evaluator filters and compares only the tiles
 * of each row between its first and last covered one, and must give the bits
 * of the whole-image path. The reference below is that path through the
 * public functions: the render filtered to the largest size in one pass, each
 * smaller size from the smallest larger size it divides, sv_eval_compare. */

static void full_path_images(const sv_image *rgba, const float *depth, const sv_eval_options *o,
                             sv_eval_image *out)
{
    assert_int_equal(
        sv_eval_image_from_render_filtered(rgba, depth, o->sizes[0], o->sizes[0], &out[0], NULL),
        SV_OK);
    for (uint32_t s = 1; s < o->size_count; s++) {
        uint32_t p = s;
        while (p-- > 0 && o->sizes[p] % o->sizes[s] != 0) {}
        assert_true(p < s);
        assert_int_equal(sv_eval_image_downsample(&out[p], o->sizes[s], o->sizes[s], &out[s], NULL),
                         SV_OK);
    }
}

static void free_images(sv_eval_image *imgs, uint32_t n)
{
    for (uint32_t s = 0; s < n; s++) sv_eval_image_free(&imgs[s]);
}

/* The original's images of view v, the whole-image way. */
static void original_images(sv_renderer *r, const sv_mesh *m, const sv_gpu_mesh *g,
                            const sv_evaluator *e, const sv_eval_options *o, uint32_t v,
                            sv_eval_image *out)
{
    uint32_t base = o->sizes[0] * o->supersample;
    double c[3], rad, dir[3];
    sv_mesh_frame_sphere(m, c, &rad);
    sv_evaluator_view_dir(e, v, dir);
    sv_camera cam;
    sv_eval_camera(c, rad, dir, &cam);
    sv_image img = {0};
    float *depth = malloc((size_t)base * base * sizeof *depth);
    assert_non_null(depth);
    assert_int_equal(sv_render(r, g, NULL, 0, &cam, NULL, base, base, &img, depth, NULL), SV_OK);
    full_path_images(&img, depth, o, out);
    sv_image_free(&img);
    free(depth);
}

/* Drawn stand-ins that test the crop's edges: nothing covered (alpha < 128
 * everywhere, colours and depths that must be ignored), a few samples in one
 * corner (a different corner per view, touching the image's edges, one of
 * them at infinite depth), and noise with coverage everywhere. */
enum { DRAW_EMPTY, DRAW_CORNER, DRAW_NOISE };
typedef struct pattern {
    int kind;
    uint32_t view; /* the view the next call draws */
} pattern;

static void paint_pattern(int kind, uint32_t view, uint32_t w, uint32_t h, uint8_t *px,
                          float *depth)
{
    uint32_t s = 977 * view + 31 * (uint32_t)kind + 1;
    for (size_t i = 0; i < (size_t)w * h; i++) {
        for (int c = 0; c < 4; c++) {
            s = s * 1103515245u + 12345u;
            px[4 * i + c] = (uint8_t)(s >> 16);
        }
        if (kind != DRAW_NOISE) px[4 * i + 3] &= 127;
        s = s * 1103515245u + 12345u;
        depth[i] = kind == DRAW_NOISE && (s >> 8) % 13 == 0
                       ? INFINITY
                       : (float)((s >> 8) % 1000) / 300.0f - 1.5f;
    }
    if (kind != DRAW_CORNER) return;
    uint32_t x0 = view % 2 ? w - 3 : 0, y0 = (view / 2) % 2 ? h - 2 : 0;
    for (uint32_t y = y0; y < y0 + 2; y++)
        for (uint32_t x = x0; x < x0 + 3; x++) px[4 * ((size_t)y * w + x) + 3] |= 128;
    depth[(size_t)y0 * w + x0] = INFINITY;
}

static sv_status draw_pattern(void *user, const sv_camera *cam, uint32_t w, uint32_t h,
                              sv_image *color, float *depth, sv_error *err)
{
    (void)cam;
    pattern *p = user;
    sv_status st = sv_image_alloc(color, w, h, 4, 8, err);
    if (st == SV_OK) paint_pattern(p->kind, p->view++, w, h, color->data, depth);
    return st;
}

static void assert_same_metrics(const sv_eval_metrics *got, const sv_eval_metrics *want, uint32_t v,
                                uint32_t s)
{
    if (memcmp(got, want, sizeof *got) != 0)
        fail_msg("view %u size %u: cropped (%.17g %.17g %.17g) != whole (%.17g %.17g %.17g)", v, s,
                 got->iou, got->color_error, got->depth_error, want->iou, want->color_error,
                 want->depth_error);
}

static void cropped_evaluation_of_drawn_images_has_the_bits_of_the_whole_image_path(void **state)
{
    sv_renderer *r = need_renderer(state);
    const double zero[3] = {0, 0, 0};
    sv_mesh *tree = tree_mesh(300, zero);
    /* a zero-area triangle: an original that covers no pixel in any view */
    sv_mesh *flat = sv_mesh_create(3, 1, 1, 0);
    assert_non_null(flat);
    const float line[9] = {0, 0, 0, 1, 1, 0, 2, 2, 0};
    memcpy(flat->positions, line, sizeof line);
    flat->indices[0] = 0, flat->indices[1] = 1, flat->indices[2] = 2;
    sv_mesh_compute_normals(flat);
    const sv_mesh *originals[2] = {tree, flat};
    /* tiles of 8 base pixels ({64, 32, 16}), of lcm(2, 4, 6) = 12 ({96, 48, 32}:
     * 32 is filtered from 96, not from 48) */
    const sv_eval_options opts[2] = {
        {.view_count = 4, .sizes = {64, 32, 16}, .size_count = 3, .supersample = 2},
        {.view_count = 4, .sizes = {96, 48, 32}, .size_count = 3, .supersample = 2},
    };
    for (int mi = 0; mi < 2; mi++) {
        sv_gpu_mesh *g = upload(r, originals[mi]);
        for (int oi = 0; oi < 2; oi++) {
            const sv_eval_options *o = &opts[oi];
            uint32_t base = o->sizes[0] * o->supersample, n = o->size_count;
            sv_evaluator *e = NULL;
            sv_error err = {0};
            assert_int_equal(sv_evaluator_create(r, originals[mi], g, o, &e, &err), SV_OK);
            for (int kind = DRAW_EMPTY; kind <= DRAW_NOISE; kind++) {
                pattern p = {kind, 0};
                sv_eval_result res;
                assert_int_equal(sv_evaluate_drawn(e, draw_pattern, &p, &res, &err), SV_OK);
                assert_int_equal(p.view, o->view_count);
                for (uint32_t v = 0; v < o->view_count; v++) {
                    sv_eval_image want_o[SV_EVAL_MAX_SIZES], want_r[SV_EVAL_MAX_SIZES];
                    original_images(r, originals[mi], g, e, o, v, want_o);
                    sv_image img = {0};
                    float *depth = malloc((size_t)base * base * sizeof *depth);
                    assert_non_null(depth);
                    p.view = v;
                    assert_int_equal(draw_pattern(&p, NULL, base, base, &img, depth, NULL), SV_OK);
                    full_path_images(&img, depth, o, want_r);
                    double c[3], rad;
                    sv_mesh_frame_sphere(originals[mi], c, &rad);
                    if (!(rad > 0)) rad = 1.0;
                    for (uint32_t s = 0; s < n; s++) {
                        sv_eval_metrics want = sv_eval_compare(&want_o[s], &want_r[s], rad);
                        assert_same_metrics(&res.per_view[(size_t)v * n + s], &want, v, s);
                    }
                    if (mi == 1) /* nothing to compare with: IoU 1 only when nothing is drawn */
                        assert_true(res.per_view[(size_t)v * n].iou ==
                                    (kind == DRAW_EMPTY ? 1.0 : 0.0));
                    free_images(want_o, n);
                    free_images(want_r, n);
                    sv_image_free(&img);
                    free(depth);
                }
                sv_eval_result_free(&res);
            }
            sv_evaluator_destroy(e);
        }
        sv_gpu_mesh_free(g);
    }
    sv_mesh_destroy(tree);
    sv_mesh_destroy(flat);
}

/* The same for a blend of two renders (sv_evaluate_subsets): each subset is
 * cropped on its own and accumulated into the blend within its tiles. */
static void cropped_blend_of_subsets_has_the_bits_of_the_whole_image_path(void **state)
{
    sv_renderer *r = need_renderer(state);
    const double zero[3] = {0, 0, 0}, side[3] = {0.6, -0.4, 0};
    sv_mesh *m = tree_mesh(300, zero), *moved = tree_mesh(150, side);
    sv_gpu_mesh *g = upload(r, m), *gm = upload(r, moved);
    const sv_eval_options o = {
        .view_count = 4, .sizes = {64, 32, 16}, .size_count = 3, .supersample = 2};
    uint32_t base = 128, n = o.size_count;
    sv_evaluator *e = NULL;
    sv_error err = {0};
    assert_int_equal(sv_evaluator_create(r, m, g, &o, &e, &err), SV_OK);
    /* leaves (the first 200 triangles) at 0.25, the rest (leaves and trunk) at 0.75 */
    pick p = {.na = 200, .nb = moved->triangle_count - 200, .wa = 0.25};
    p.a = calloc(p.na, sizeof *p.a);
    p.b = calloc(p.nb, sizeof *p.b);
    assert_non_null(p.a);
    assert_non_null(p.b);
    for (uint32_t t = 0; t < p.na; t++) p.a[t] = t;
    for (uint32_t t = 0; t < p.nb; t++) p.b[t] = p.na + t;
    sv_eval_result res;
    assert_int_equal(sv_evaluate_subsets(e, gm, pick_subsets, &p, &res, &err), SV_OK);
    double c[3], rad;
    sv_mesh_frame_sphere(m, c, &rad);
    float *depth = malloc((size_t)base * base * sizeof *depth);
    assert_non_null(depth);
    for (uint32_t v = 0; v < o.view_count; v++) {
        sv_eval_image want_o[SV_EVAL_MAX_SIZES], acc[SV_EVAL_MAX_SIZES], one[SV_EVAL_MAX_SIZES];
        original_images(r, m, g, e, &o, v, want_o);
        for (uint32_t s = 0; s < n; s++)
            assert_int_equal(sv_eval_image_alloc(&acc[s], o.sizes[s], o.sizes[s], NULL), SV_OK);
        double dir[3];
        sv_evaluator_view_dir(e, v, dir);
        sv_camera cam;
        sv_eval_camera(c, rad, dir, &cam);
        const uint32_t *tris[2] = {p.a, p.b}, counts[2] = {p.na, p.nb};
        const double weights[2] = {p.wa, 1.0 - p.wa};
        for (int k = 0; k < 2; k++) {
            sv_image img = {0};
            assert_int_equal(
                sv_render(r, gm, tris[k], counts[k], &cam, NULL, base, base, &img, depth, NULL),
                SV_OK);
            full_path_images(&img, depth, &o, one);
            for (uint32_t s = 0; s < n; s++) sv_eval_image_accumulate(&acc[s], &one[s], weights[k]);
            free_images(one, n);
            sv_image_free(&img);
        }
        for (uint32_t s = 0; s < n; s++) {
            sv_eval_metrics want = sv_eval_compare(&want_o[s], &acc[s], rad);
            assert_same_metrics(&res.per_view[(size_t)v * n + s], &want, v, s);
        }
        free_images(want_o, n);
        free_images(acc, n);
    }
    free(depth);
    sv_eval_result_free(&res);
    free(p.a);
    free(p.b);
    sv_evaluator_destroy(e);
    sv_gpu_mesh_free(g);
    sv_gpu_mesh_free(gm);
    sv_mesh_destroy(m);
    sv_mesh_destroy(moved);
}

static void bad_options_and_empty_meshes_are_refused(void **state)
{
    sv_renderer *r = need_renderer(state);
    const double zero[3] = {0, 0, 0};
    sv_mesh *m = tree_mesh(10, zero), *empty = sv_mesh_create(0, 0, 1, 0);
    assert_non_null(empty);
    sv_gpu_mesh *g = upload(r, m);
    sv_evaluator *e = (sv_evaluator *)m;
    sv_error err = {0};
    sv_eval_options o = {.sizes = {64, 64}, .size_count = 2};
    assert_int_equal(sv_evaluator_create(r, m, g, &o, &e, &err), SV_ERR_INVALID);
    assert_null(e);
    assert_non_null(strstr(err.message, "distinct"));
    o = (sv_eval_options){.sizes = {4096}, .size_count = 1};
    assert_int_equal(sv_evaluator_create(r, m, g, &o, &e, &err), SV_ERR_INVALID);
    assert_non_null(strstr(err.message, "maximum"));
    o = (sv_eval_options){.sizes = {32}, .size_count = 1, .view_count = 2};
    assert_int_equal(sv_evaluator_create(r, empty, g, &o, &e, &err), SV_ERR_INVALID);
    assert_non_null(strstr(err.message, "empty"));
    sv_evaluator_destroy(NULL);
    sv_gpu_mesh_free(g);
    sv_mesh_destroy(m);
    sv_mesh_destroy(empty);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(fused_filter_has_the_bits_of_convert_then_filter),
        cmocka_unit_test(ground_views_stay_near_the_horizon),
        cmocka_unit_test(aerial_views_look_from_above),
        cmocka_unit_test(orbit_views_cover_the_whole_sphere_evenly),
        cmocka_unit_test(camera_looks_at_the_centre_along_minus_view_direction),
        cmocka_unit_test(box_filter_averages_blocks_and_preserves_total_coverage),
        cmocka_unit_test(filtering_in_integer_steps_equals_filtering_once),
        cmocka_unit_test(identical_images_give_iou_1_and_zero_errors),
        cmocka_unit_test(depth_and_colour_errors_measure_the_difference),
        cmocka_unit_test(subpixel_shift_of_leaves_matters_less_at_small_sizes),
        cmocka_unit_test(accumulate_blends_with_weights),
        cmocka_unit_test(max_pixels_interpolates_where_the_curve_crosses_the_tolerance),
        cmocka_unit_test(scaled_max_pixels_keeps_the_error_band_in_pixels),
        cmocka_unit_test(original_against_itself_scores_iou_1_and_zero_error_at_every_size),
        cmocka_unit_test(halved_factors_give_a_lum_ratio_of_one_half),
        cmocka_unit_test(result_moved_away_scores_a_clearly_worse_iou),
        cmocka_unit_test(a_size_dividing_no_larger_one_is_measured_too),
        cmocka_unit_test(cutoff_sweep_equals_evaluating_each_cutoff),
        cmocka_unit_test(subpixel_shifted_result_scores_near_1_at_32_px_and_lower_at_256),
        cmocka_unit_test(evaluator_places_ground_views_near_the_horizon),
        cmocka_unit_test(subset_callback_blends_two_renders_by_weight),
        cmocka_unit_test(preview_shows_original_result_and_heat_for_four_views),
        cmocka_unit_test(bad_options_and_empty_meshes_are_refused),
        cmocka_unit_test(cropped_evaluation_of_drawn_images_has_the_bits_of_the_whole_image_path),
        cmocka_unit_test(cropped_blend_of_subsets_has_the_bits_of_the_whole_image_path),
    };
    return sv_test_exit(cmocka_run_group_tests(tests, setup, teardown));
}
