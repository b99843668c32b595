/* test_render.c — the OSMesa backend of render.h: alpha masks, two-sidedness,
 * linear depth, subsets, clipping, shading, determinism. */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "render.h"

/* A quad [-1,1]² in the plane z = z0 (+ slope·x), facing +z, UVs glTF (v down). */
static sv_mesh *quad_mesh(double z0, double slope)
{
    sv_mesh *m = sv_mesh_create(4, 2, 1, 0);
    assert_non_null(m);
    static const float xy[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
    for (int i = 0; i < 4; i++) {
        m->positions[3 * i + 0] = xy[i][0];
        m->positions[3 * i + 1] = xy[i][1];
        m->positions[3 * i + 2] = (float)(z0 + slope * xy[i][0]);
        m->normals[3 * i + 2] = 1.0f;
        m->uvs[2 * i + 0] = 0.5f * (xy[i][0] + 1.0f);
        m->uvs[2 * i + 1] = 0.5f * (1.0f - xy[i][1]);
    }
    static const uint32_t idx[6] = {0, 1, 2, 0, 2, 3};
    memcpy(m->indices, idx, sizeof idx);
    return m;
}

/* Camera on +z looking along -z at the unit square. */
static sv_camera front_camera(void)
{
    sv_camera c = {.origin = {0, 0, 2},
                   .right = {1, 0, 0},
                   .up = {0, 1, 0},
                   .half_width = 1,
                   .half_height = 1,
                   .near_dist = 0,
                   .far_dist = 4};
    return c;
}

static sv_renderer *make_renderer(void)
{
    sv_renderer *r = NULL;
    sv_error err = {0};
    sv_status st = sv_renderer_create(1024, &r, &err);
    if (st != SV_OK) fail_msg("renderer: %s", err.message);
    return r;
}

static uint32_t covered(const sv_image *img)
{
    uint32_t n = 0;
    const uint8_t *p = img->data;
    for (size_t i = 0; i < (size_t)img->width * img->height; i++) n += p[4 * i + 3] != 0;
    return n;
}

static void masked_quad_covers_only_the_opaque_half_of_its_texture(void **state)
{
    (void)state;
    sv_mesh *m = quad_mesh(0, 0);
    free(m->images); /* sv_mesh_create made room for none */
    m->image_count = 1;
    m->images = calloc(1, sizeof *m->images);
    assert_int_equal(sv_image_alloc(&m->images[0], 8, 8, 4, 8, NULL), SV_OK);
    uint8_t *t = m->images[0].data;
    for (int y = 0; y < 8; y++)
        for (int x = 0; x < 8; x++) {
            uint8_t *p = t + 4 * (y * 8 + x);
            p[0] = 200;
            p[1] = 40;
            p[2] = 10;
            p[3] = x < 4 ? 255 : 0; /* left half opaque */
        }
    m->materials[0].base_texture = 0;
    m->materials[0].alpha_mode = SV_ALPHA_MASK;
    m->materials[0].alpha_cutoff = 0.5f;
    sv_renderer *r = make_renderer();
    sv_gpu_mesh *g = NULL;
    assert_int_equal(sv_gpu_mesh_upload(r, m, &g, NULL), SV_OK);
    sv_camera cam = front_camera();
    sv_image img;
    sv_error err = {0};
    assert_int_equal(sv_render(r, g, NULL, 0, &cam, NULL, 64, 64, &img, NULL, &err), SV_OK);
    const uint8_t *px = img.data;
    for (int y = 0; y < 64; y++)
        for (int x = 0; x < 64; x++) {
            const uint8_t *p = px + 4 * (y * 64 + x);
            if (x < 30) {
                assert_int_equal(p[3], 255);
                assert_int_equal(p[0], 200);
                assert_int_equal(p[1], 40);
            } else if (x >= 34) {
                assert_int_equal(p[3], 0);
            }
        }
    uint32_t n = covered(&img);
    assert_in_range(n, 30 * 64, 34 * 64);
    sv_image_free(&img);

    /* The same texture on an OPAQUE material covers everything. */
    m->materials[0].alpha_mode = SV_ALPHA_OPAQUE;
    assert_int_equal(sv_render(r, g, NULL, 0, &cam, NULL, 64, 64, &img, NULL, &err), SV_OK);
    assert_int_equal(covered(&img), 64 * 64);
    sv_image_free(&img);
    sv_gpu_mesh_free(g);
    sv_renderer_destroy(r);
    sv_mesh_destroy(m);
}

/* Meshes whose images share pixels (sv_image_copy) share one texture on the
 * renderer, which lives until its last mesh is freed: the second mesh still
 * draws the texture after the first mesh and its GPU copy are gone. */
static void meshes_sharing_pixels_share_a_texture_until_the_last_is_freed(void **state)
{
    (void)state;
    sv_mesh *a = quad_mesh(0, 0), *b = quad_mesh(0, 0);
    sv_mesh *ms[2] = {a, b};
    for (int k = 0; k < 2; k++) {
        free(ms[k]->images);
        ms[k]->image_count = 1;
        ms[k]->images = calloc(1, sizeof *ms[k]->images);
        ms[k]->materials[0].base_texture = 0;
        ms[k]->materials[0].alpha_mode = SV_ALPHA_MASK;
        ms[k]->materials[0].alpha_cutoff = 0.5f;
    }
    assert_int_equal(sv_image_alloc(&a->images[0], 8, 8, 4, 8, NULL), SV_OK);
    uint8_t *t = a->images[0].data;
    for (int i = 0; i < 64; i++) {
        t[4 * i] = 200, t[4 * i + 1] = 40, t[4 * i + 2] = 10;
        t[4 * i + 3] = (i % 8) < 4 ? 255 : 0;
    }
    assert_int_equal(sv_image_copy(&a->images[0], &b->images[0], NULL), SV_OK);
    assert_ptr_equal(a->images[0].data, b->images[0].data);
    sv_renderer *r = make_renderer();
    sv_gpu_mesh *ga = NULL, *gb = NULL;
    assert_int_equal(sv_gpu_mesh_upload(r, a, &ga, NULL), SV_OK);
    assert_int_equal(sv_gpu_mesh_upload(r, b, &gb, NULL), SV_OK);
    sv_gpu_mesh_free(ga);
    sv_mesh_destroy(a);
    sv_camera cam = front_camera();
    sv_image img;
    sv_error err = {0};
    assert_int_equal(sv_render(r, gb, NULL, 0, &cam, NULL, 64, 64, &img, NULL, &err), SV_OK);
    const uint8_t *p = (const uint8_t *)img.data + 4 * (32 * 64 + 10);
    assert_int_equal(p[3], 255);
    assert_int_equal(p[0], 200);
    assert_int_equal(p[1], 40);
    assert_in_range(covered(&img), 30 * 64, 34 * 64);
    sv_image_free(&img);
    sv_gpu_mesh_free(gb);
    sv_renderer_destroy(r);
    sv_mesh_destroy(b);
}

static void back_facing_triangle_still_renders(void **state)
{
    (void)state;
    sv_mesh *m = quad_mesh(0, 0);
    /* Reverse the winding: both triangles now face away from the camera. */
    for (int t = 0; t < 2; t++) {
        uint32_t tmp = m->indices[3 * t + 1];
        m->indices[3 * t + 1] = m->indices[3 * t + 2];
        m->indices[3 * t + 2] = tmp;
    }
    for (int i = 0; i < 4; i++) m->normals[3 * i + 2] = -1.0f;
    sv_renderer *r = make_renderer();
    sv_gpu_mesh *g = NULL;
    assert_int_equal(sv_gpu_mesh_upload(r, m, &g, NULL), SV_OK);
    sv_camera cam = front_camera();
    sv_image img;
    assert_int_equal(sv_render(r, g, NULL, 0, &cam, NULL, 32, 32, &img, NULL, NULL), SV_OK);
    assert_int_equal(covered(&img), 32 * 32);
    sv_image_free(&img);
    /* Normal shading flips the normal to face the camera: +z → blue 255. */
    sv_render_options o = {.shade = SV_SHADE_NORMAL};
    assert_int_equal(sv_render(r, g, NULL, 0, &cam, &o, 32, 32, &img, NULL, NULL), SV_OK);
    const uint8_t *p = (const uint8_t *)img.data + 4 * (16 * 32 + 16);
    assert_in_range(p[0], 127, 128);
    assert_in_range(p[1], 127, 128);
    assert_int_equal(p[2], 255);
    sv_image_free(&img);
    sv_gpu_mesh_free(g);
    sv_renderer_destroy(r);
    sv_mesh_destroy(m);
}

static void depth_is_linear_distance_along_forward(void **state)
{
    (void)state;
    sv_mesh *m = quad_mesh(0.25, 0.5); /* z = 0.25 + 0.5 x */
    sv_renderer *r = make_renderer();
    sv_gpu_mesh *g = NULL;
    assert_int_equal(sv_gpu_mesh_upload(r, m, &g, NULL), SV_OK);
    sv_camera cam = front_camera();
    cam.half_width = 2; /* the quad covers the middle half of the image in x */
    float *z = calloc(64 * 64, sizeof *z);
    assert_int_equal(sv_render(r, g, NULL, 0, &cam, NULL, 64, 64, NULL, z, NULL), SV_OK);
    for (int y = 0; y < 64; y++)
        for (int x = 0; x < 64; x++) {
            double wx = -2.0 + (x + 0.5) * 4.0 / 64;
            float d = z[y * 64 + x];
            if (fabs(wx) < 0.95) {
                double expect = 2.0 - (0.25 + 0.5 * wx);
                assert_true(fabs(d - expect) < 1e-4);
            } else if (fabs(wx) > 1.05) {
                assert_true(isinf(d));
            }
        }
    free(z);
    sv_gpu_mesh_free(g);
    sv_renderer_destroy(r);
    sv_mesh_destroy(m);
}

static void near_and_far_planes_clip_geometry(void **state)
{
    (void)state;
    sv_mesh *m = quad_mesh(0, 0);
    sv_renderer *r = make_renderer();
    sv_gpu_mesh *g = NULL;
    assert_int_equal(sv_gpu_mesh_upload(r, m, &g, NULL), SV_OK);
    sv_camera cam = front_camera(); /* the quad is at distance 2 */
    sv_image img;
    cam.near_dist = 2.5;
    cam.far_dist = 3.0;
    assert_int_equal(sv_render(r, g, NULL, 0, &cam, NULL, 16, 16, &img, NULL, NULL), SV_OK);
    assert_int_equal(covered(&img), 0);
    sv_image_free(&img);
    cam.near_dist = -1.0; /* negative near is allowed */
    cam.far_dist = 1.5;
    assert_int_equal(sv_render(r, g, NULL, 0, &cam, NULL, 16, 16, &img, NULL, NULL), SV_OK);
    assert_int_equal(covered(&img), 0);
    sv_image_free(&img);
    cam.far_dist = 2.1;
    assert_int_equal(sv_render(r, g, NULL, 0, &cam, NULL, 16, 16, &img, NULL, NULL), SV_OK);
    assert_int_equal(covered(&img), 256);
    sv_image_free(&img);
    sv_gpu_mesh_free(g);
    sv_renderer_destroy(r);
    sv_mesh_destroy(m);
}

static void subset_draws_only_the_listed_triangles(void **state)
{
    (void)state;
    sv_mesh *m = quad_mesh(0, 0);
    sv_renderer *r = make_renderer();
    sv_gpu_mesh *g = NULL;
    assert_int_equal(sv_gpu_mesh_upload(r, m, &g, NULL), SV_OK);
    sv_camera cam = front_camera();
    sv_image img;
    uint32_t only = 0; /* triangle (0,1,2): the lower-right half */
    assert_int_equal(sv_render(r, g, &only, 1, &cam, NULL, 32, 32, &img, NULL, NULL), SV_OK);
    const uint8_t *px = img.data;
    assert_int_equal(px[4 * (28 * 32 + 28) + 3], 255); /* bottom right */
    assert_int_equal(px[4 * (3 * 32 + 3) + 3], 0);     /* top left */
    assert_in_range(covered(&img), 480, 560);
    sv_image_free(&img);
    uint32_t bad = 7;
    sv_error err = {0};
    assert_int_equal(sv_render(r, g, &bad, 1, &cam, NULL, 32, 32, &img, NULL, &err),
                     SV_ERR_INTERNAL);
    assert_non_null(strstr(err.message, "out of range"));
    sv_gpu_mesh_free(g);
    sv_renderer_destroy(r);
    sv_mesh_destroy(m);
}

/* glTF's colour: the texture is sRGB-encoded and decoded before the linear
 * factor multiplies it. A 50 % grey texel (128, linear 0.216) under factor
 * 0.5 is linear 0.108, shown as sRGB 92; multiplying the bytes would give 64.
 * linear = true gives the product itself in 16 bits. */
static void texture_is_decoded_from_srgb_before_the_factor_multiplies(void **state)
{
    (void)state;
    sv_mesh *m = quad_mesh(0, 0);
    free(m->images);
    m->image_count = 1;
    m->images = calloc(1, sizeof *m->images);
    assert_int_equal(sv_image_alloc(&m->images[0], 4, 4, 4, 8, NULL), SV_OK);
    memset(m->images[0].data, 128, 4 * 4 * 4);
    for (int i = 0; i < 16; i++) ((uint8_t *)m->images[0].data)[4 * i + 3] = 255;
    m->materials[0].base_texture = 0;
    for (int k = 0; k < 3; k++) m->materials[0].base_color[k] = 0.5f;
    sv_renderer *r = make_renderer();
    sv_gpu_mesh *g = NULL;
    assert_int_equal(sv_gpu_mesh_upload(r, m, &g, NULL), SV_OK);
    sv_camera cam = front_camera();
    sv_image img;
    assert_int_equal(sv_render(r, g, NULL, 0, &cam, NULL, 16, 16, &img, NULL, NULL), SV_OK);
    const uint8_t *p = (const uint8_t *)img.data + 4 * (8 * 16 + 8);
    uint8_t want = sv_srgb_encode8(0.5 * sv_srgb_decode8(128));
    assert_int_equal(want, 92);
    for (int k = 0; k < 3; k++) assert_in_range(p[k], want - 1, want + 1);
    assert_int_equal(p[3], 255);
    sv_image_free(&img);
    sv_render_options lin = {.shade = SV_SHADE_ALBEDO, .linear = true};
    assert_int_equal(sv_render(r, g, NULL, 0, &cam, &lin, 16, 16, &img, NULL, NULL), SV_OK);
    assert_int_equal(img.bits, 16);
    const uint16_t *q = (const uint16_t *)img.data + 4 * (8 * 16 + 8);
    for (int k = 0; k < 3; k++)
        assert_true(fabs(q[k] / 65535.0 - 0.5 * sv_srgb_decode8(128)) < 2e-3);
    assert_int_equal(q[3], 65535);
    sv_image_free(&img);
    sv_gpu_mesh_free(g);
    sv_renderer_destroy(r);
    sv_mesh_destroy(m);
}

static void lit_shading_darkens_faces_turned_from_the_light(void **state)
{
    (void)state;
    sv_mesh *m = quad_mesh(0, 0);
    sv_renderer *r = make_renderer();
    sv_gpu_mesh *g = NULL;
    assert_int_equal(sv_gpu_mesh_upload(r, m, &g, NULL), SV_OK);
    sv_camera cam = front_camera();
    sv_image a, b;
    sv_render_options toward = {.shade = SV_SHADE_LIT, .light_dir = {0, 0, 1}};
    sv_render_options grazing = {.shade = SV_SHADE_LIT, .light_dir = {1, 0, 0}};
    assert_int_equal(sv_render(r, g, NULL, 0, &cam, &toward, 8, 8, &a, NULL, NULL), SV_OK);
    assert_int_equal(sv_render(r, g, NULL, 0, &cam, &grazing, 8, 8, &b, NULL, NULL), SV_OK);
    const uint8_t *pa = a.data, *pb = b.data;
    assert_int_equal(pa[0], 255); /* white × (0.35 + 0.65·1) */
    /* white × 0.35 (ambient only), lit in linear and shown sRGB-encoded:
     * 255 · OETF(0.35) = 160.9 (89 was the byte-space 0.35 · 255) */
    assert_in_range(pb[0], 159, 162);
    sv_image_free(&a);
    sv_image_free(&b);
    sv_gpu_mesh_free(g);
    sv_renderer_destroy(r);
    sv_mesh_destroy(m);
}

/* Many overlapping textured, masked triangles: a stress on rasteriser order. */
static sv_mesh *random_leaves(uint32_t n, uint64_t seed)
{
    sv_mesh *m = sv_mesh_create(3 * n, n, 2, 1);
    assert_non_null(m);
    uint64_t s = seed;
    for (uint32_t i = 0; i < 3 * n; i++) {
        for (int k = 0; k < 3; k++) {
            s = s * 6364136223846793005ull + 1442695040888963407ull;
            m->positions[3 * i + k] = (float)((double)(s >> 11) / 9007199254740992.0 * 2 - 1);
            m->normals[3 * i + k] = k == 2 ? 1.0f : 0.0f;
        }
        m->uvs[2 * i] = (float)(i % 3 == 1);
        m->uvs[2 * i + 1] = (float)(i % 3 == 2);
        m->indices[i] = i;
    }
    for (uint32_t t = 0; t < n; t++) m->tri_material[t] = t % 2;
    assert_int_equal(sv_image_alloc(&m->images[0], 16, 16, 4, 8, NULL), SV_OK);
    uint8_t *p = m->images[0].data;
    for (int i = 0; i < 256; i++) {
        p[4 * i] = (uint8_t)(i * 7);
        p[4 * i + 1] = (uint8_t)(i * 13);
        p[4 * i + 2] = (uint8_t)(255 - i);
        p[4 * i + 3] = (uint8_t)((i * 37) & 255);
    }
    m->materials[0].base_texture = 0;
    m->materials[0].alpha_mode = SV_ALPHA_MASK;
    m->materials[0].alpha_cutoff = 0.4f;
    m->materials[1].base_color[1] = 0.5f;
    return m;
}

static void render_is_byte_identical_across_runs_and_renderers(void **state)
{
    (void)state;
    sv_mesh *m = random_leaves(3000, 42);
    sv_image img[3];
    float *z[3];
    for (int run = 0; run < 3; run++) {
        sv_renderer *r = make_renderer();
        sv_gpu_mesh *g = NULL;
        assert_int_equal(sv_gpu_mesh_upload(r, m, &g, NULL), SV_OK);
        sv_camera cam = {.origin = {0, 0, 0},
                         .right = {0.6, 0, 0.8},
                         .up = {0, 1, 0},
                         .half_width = 1.3,
                         .half_height = 1.3,
                         .near_dist = -2,
                         .far_dist = 2};
        z[run] = calloc(300 * 200, sizeof(float));
        sv_render_options o = {.shade = SV_SHADE_ALBEDO};
        /* run 2 re-renders on the same renderer after a different-size draw */
        if (run == 2) {
            sv_image junk;
            assert_int_equal(sv_render(r, g, NULL, 0, &cam, &o, 517, 333, &junk, NULL, NULL),
                             SV_OK);
            sv_image_free(&junk);
        }
        assert_int_equal(sv_render(r, g, NULL, 0, &cam, &o, 300, 200, &img[run], z[run], NULL),
                         SV_OK);
        sv_gpu_mesh_free(g);
        sv_renderer_destroy(r);
    }
    assert_true(covered(&img[0]) > 1000);
    for (int run = 1; run < 3; run++) {
        assert_memory_equal(img[0].data, img[run].data, 300 * 200 * 4);
        assert_memory_equal(z[0], z[run], 300 * 200 * sizeof(float));
    }
    for (int run = 0; run < 3; run++) {
        sv_image_free(&img[run]);
        free(z[run]);
    }
    sv_mesh_destroy(m);
}

static void large_targets_render_through_framebuffer_objects(void **state)
{
    (void)state;
    sv_mesh *m = quad_mesh(0, 0);
    sv_renderer *r = NULL;
    assert_int_equal(sv_renderer_create(4096, &r, NULL), SV_OK);
    assert_true(sv_renderer_max_size(r) >= 4096);
    sv_gpu_mesh *g = NULL;
    assert_int_equal(sv_gpu_mesh_upload(r, m, &g, NULL), SV_OK);
    sv_camera cam = front_camera();
    cam.half_width = 2;
    sv_image img;
    assert_int_equal(sv_render(r, g, NULL, 0, &cam, NULL, 4096, 2048, &img, NULL, NULL), SV_OK);
    assert_int_equal(covered(&img), 2048 * 2048);
    sv_image_free(&img);
    sv_error err = {0};
    assert_int_equal(sv_render(r, g, NULL, 0, &cam, NULL, 4097, 16, &img, NULL, &err),
                     SV_ERR_LIMIT);
    assert_null(img.data);
    sv_gpu_mesh_free(g);
    sv_renderer_destroy(r);
    sv_renderer_destroy(NULL);
    sv_gpu_mesh_free(NULL);
    sv_mesh_destroy(m);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(masked_quad_covers_only_the_opaque_half_of_its_texture),
        cmocka_unit_test(meshes_sharing_pixels_share_a_texture_until_the_last_is_freed),
        cmocka_unit_test(back_facing_triangle_still_renders),
        cmocka_unit_test(depth_is_linear_distance_along_forward),
        cmocka_unit_test(near_and_far_planes_clip_geometry),
        cmocka_unit_test(subset_draws_only_the_listed_triangles),
        cmocka_unit_test(texture_is_decoded_from_srgb_before_the_factor_multiplies),
        cmocka_unit_test(lit_shading_darkens_faces_turned_from_the_light),
        cmocka_unit_test(render_is_byte_identical_across_runs_and_renderers),
        cmocka_unit_test(large_targets_render_through_framebuffer_objects),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
