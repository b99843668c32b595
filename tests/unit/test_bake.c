/* sylva-test: cost=8 (tests/run.sh starts the longest first) */
/* test_bake.c — quad baking (billboard-cloud paper §3.3.7) on synthetic meshes,
 * and a timing run on the bundled oak when SYLVA_DATA/examples are present. */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <cmocka.h>
#include "test_data.h"
#include "test_skip.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bake.h"
#include "pipeline_internal.h"
#include "classify.h"

/* Texture of the synthetic leaf: 4×4 blocks of distinct colours; the top-right
 * block (texture x >= 3/4, y < 1/4) is transparent. */
static void leaf_texel(uint32_t bx, uint32_t by, uint8_t out[4])
{
    out[0] = (uint8_t)(40 + 60 * bx);
    out[1] = (uint8_t)(30 + 70 * by);
    out[2] = (uint8_t)(200 - 40 * bx);
    out[3] = (bx == 3 && by == 0) ? 0 : 255;
}

typedef struct scene {
    sv_mesh *m;
    sv_renderer *r;
    sv_gpu_mesh *g;
} scene;

/* Mesh: rectangles given as z = z0 + sx·x over [x0,x1]×[y0,y1]; rect 0 gets the
 * leaf texture (material 0, MASK), the others a flat colour (material 1). */
typedef struct rect {
    double x0, x1, y0, y1, z0, sx;
} rect;

static scene make_scene(const rect *rs, uint32_t n)
{
    scene s = {0};
    s.m = sv_mesh_create(4 * n, 2 * n, 2, 1);
    assert_non_null(s.m);
    for (uint32_t i = 0; i < n; i++) {
        const rect *q = &rs[i];
        const double xy[4][2] = {{q->x0, q->y0}, {q->x1, q->y0}, {q->x1, q->y1}, {q->x0, q->y1}};
        for (int c = 0; c < 4; c++) {
            uint32_t v = 4 * i + (uint32_t)c;
            s.m->positions[3 * v] = (float)xy[c][0];
            s.m->positions[3 * v + 1] = (float)xy[c][1];
            s.m->positions[3 * v + 2] = (float)(q->z0 + q->sx * xy[c][0]);
            s.m->uvs[2 * v] = (float)((xy[c][0] - q->x0) / (q->x1 - q->x0));
            s.m->uvs[2 * v + 1] = (float)((q->y1 - xy[c][1]) / (q->y1 - q->y0));
        }
        static const uint32_t tri[6] = {0, 1, 2, 0, 2, 3};
        for (int k = 0; k < 6; k++) s.m->indices[6 * i + k] = 4 * i + tri[k];
        s.m->tri_material[2 * i] = s.m->tri_material[2 * i + 1] = i == 0 ? 0 : 1;
    }
    sv_mesh_compute_normals(s.m);
    assert_int_equal(sv_image_alloc(&s.m->images[0], 64, 64, 4, 8, NULL), SV_OK);
    uint8_t *px = s.m->images[0].data;
    for (uint32_t y = 0; y < 64; y++)
        for (uint32_t x = 0; x < 64; x++) leaf_texel(x / 16, y / 16, px + 4 * (y * 64 + x));
    s.m->materials[0].base_texture = 0;
    s.m->materials[0].alpha_mode = SV_ALPHA_MASK;
    s.m->materials[0].alpha_cutoff = 0.5f;
    s.m->materials[1].base_color[0] = 0.0f; /* flat cyan */
    sv_error err = {0};
    if (sv_renderer_create(2048, &s.r, &err) != SV_OK) fail_msg("renderer: %s", err.message);
    assert_int_equal(sv_gpu_mesh_upload(s.r, s.m, &s.g, NULL), SV_OK);
    return s;
}

static void scene_free(scene *s)
{
    sv_gpu_mesh_free(s->g);
    sv_renderer_destroy(s->r);
    sv_mesh_destroy(s->m);
}

/* One quad over [-1,1]² in the plane z = 0, seen from +z. */
static sv_lod_plan one_quad(sv_quad *q, double slab)
{
    memset(q, 0, sizeof *q);
    q->normal[2] = 1;
    q->axis_u[0] = 1;
    q->axis_v[1] = 1;
    q->half_u = q->half_v = 1;
    q->slab = slab;
    q->group = q->parent = -1;
    sv_lod_plan lod = {.quads = q, .quad_count = 1};
    strcpy(lod.name, "lod0");
    return lod;
}

static void bake_options(sv_bake_options *o)
{
    sv_bake_options_init(o);
    o->texel_size = 2.0 / 64; /* a 64×64 chart */
    o->max_supersample = 2;
}

/* Texel (x, y) of the quad's chart. */
static const uint8_t *chart_texel(const sv_baked_lod *b, const sv_image *img, uint32_t i,
                                  uint32_t x, uint32_t y)
{
    uint32_t cx = (uint32_t)lround(b->uv_rects[4 * i] * img->width);
    uint32_t cy = (uint32_t)lround(b->uv_rects[4 * i + 1] * img->height);
    size_t bpp = img->channels * img->bits / 8;
    return (const uint8_t *)img->data + ((size_t)(cy + y) * img->width + cx + x) * bpp;
}

static void baked_albedo_matches_the_source_texture_where_covered(void **state)
{
    (void)state;
    rect leaf = {-1, 1, -1, 1, 0, 0};
    scene s = make_scene(&leaf, 1);
    sv_quad q;
    sv_lod_plan lod = one_quad(&q, 0.1);
    sv_bake_options o;
    bake_options(&o);
    sv_baked_lod b;
    sv_error err = {0};
    if (sv_bake_lod(s.r, s.g, s.m, &lod, NULL, &o, &b, &err) != SV_OK)
        fail_msg("bake: %s", err.message);
    assert_int_equal(b.quad_count, 1);
    assert_true(fabs(b.uv_rects[2] - b.uv_rects[0] - 64.0 / b.albedo.width) < 1e-6);
    uint32_t opaque = 0;
    for (uint32_t y = 0; y < 64; y++)
        for (uint32_t x = 0; x < 64; x++) {
            if (x % 16 == 0 || x % 16 == 15 || y % 16 == 0 || y % 16 == 15)
                continue; /* block edges: bilinear mixes two colours */
            uint8_t want[4];
            leaf_texel(x / 16, y / 16, want);
            const uint8_t *got = chart_texel(&b, &b.albedo, 0, x, y);
            assert_int_equal(got[3], want[3]);
            if (!want[3]) continue;
            opaque++;
            for (int k = 0; k < 3; k++) assert_in_range(got[k], want[k] - 2, want[k] + 2);
        }
    assert_int_equal(opaque, 15 * 14 * 14);
    /* Binary alpha everywhere. */
    const uint8_t *px = b.albedo.data;
    for (size_t i = 0; i < (size_t)b.albedo.width * b.albedo.height; i++)
        assert_true(px[4 * i + 3] == 0 || px[4 * i + 3] == 255);
    assert_null(b.normal.data);
    assert_null(b.ao.data);
    assert_null(b.depth.data);
    sv_baked_lod_free(&b);
    scene_free(&s);
}

/* The atlas holds the colour a glTF engine draws for the source: its linear
 * factor × its decoded texel, encoded to sRGB once. A 50 % grey texel (128)
 * under factor 0.5 bakes to 92, not the byte product 64, and the atlas
 * material's own factor is 1. */
static void baked_colour_is_the_linear_factor_times_the_decoded_texel(void **state)
{
    (void)state;
    rect leaf = {-1, 1, -1, 1, 0, 0};
    scene s = make_scene(&leaf, 1);
    sv_gpu_mesh_free(s.g);
    uint8_t *px = s.m->images[0].data;
    for (uint32_t i = 0; i < 64 * 64; i++) {
        memset(px + 4 * i, 128, 3);
        px[4 * i + 3] = 255;
    }
    for (int k = 0; k < 3; k++) s.m->materials[0].base_color[k] = 0.5f;
    assert_int_equal(sv_gpu_mesh_upload(s.r, s.m, &s.g, NULL), SV_OK);
    sv_quad q;
    sv_lod_plan lod = one_quad(&q, 0.1);
    sv_bake_options o;
    bake_options(&o);
    sv_baked_lod b;
    assert_int_equal(sv_bake_lod(s.r, s.g, s.m, &lod, NULL, &o, &b, NULL), SV_OK);
    uint8_t want = sv_srgb_encode8(0.5 * sv_srgb_decode8(128));
    for (uint32_t y = 1; y < 63; y += 7)
        for (uint32_t x = 1; x < 63; x += 7) {
            const uint8_t *got = chart_texel(&b, &b.albedo, 0, x, y);
            assert_int_equal(got[3], 255);
            for (int k = 0; k < 3; k++) assert_in_range(got[k], want - 1, want + 1);
        }
    const sv_material *mat = &b.mesh->materials[0];
    for (int k = 0; k < 4; k++) assert_true(mat->base_color[k] == 1.0f);
    sv_baked_lod_free(&b);
    scene_free(&s);
}

static void transparent_texels_get_dilated_leaf_colour(void **state)
{
    (void)state;
    rect leaf = {-1, 1, -1, 1, 0, 0};
    scene s = make_scene(&leaf, 1);
    sv_quad q;
    sv_lod_plan lod = one_quad(&q, 0.1);
    sv_bake_options o;
    bake_options(&o);
    sv_baked_lod b;
    assert_int_equal(sv_bake_lod(s.r, s.g, s.m, &lod, NULL, &o, &b, NULL), SV_OK);
    /* Inside the transparent block, next to the opaque block on its left. */
    const uint8_t *hole = chart_texel(&b, &b.albedo, 0, 48, 5);
    uint8_t left[4];
    leaf_texel(2, 0, left);
    assert_int_equal(hole[3], 0);
    assert_in_range(hole[0], left[0] - 3, left[0] + 3);
    assert_in_range(hole[1], left[1] - 3, left[1] + 3);
    sv_baked_lod_free(&b);
    scene_free(&s);
}

/* A leaf modelled as two cards a hair apart, the textured upper side facing
 * +z and a flat cyan underside: the two-sided quad shows one texture from
 * both sides, so each texel blends, in linear light, what the two sides
 * show, each by how much it is seen (the front alone showed the upper side
 * from below too). Seen from all around (ORBIT), half and half. */
static void both_sides_of_a_two_layer_leaf_are_blended_in_linear_light(void **state)
{
    (void)state;
    /* the weights: a plane is seen half from each side all around and on a
     * side helix; facing up, mostly from above on the helix, only from above
     * by an aerial viewer */
    const double z[3] = {0, 0, 1}, up[3] = {0, 1, 0}, down[3] = {0, -1, 0};
    assert_true(fabs(sv_bake_front_weight(SV_VIEWER_ORBIT, z) - 0.5) < 1e-9);
    assert_true(fabs(sv_bake_front_weight(SV_VIEWER_SIDE, z) - 0.5) < 1e-9);
    assert_true(fabs(sv_bake_front_weight(SV_VIEWER_ORBIT, up) - 0.5) < 1e-9);
    double w = sv_bake_front_weight(SV_VIEWER_SIDE, up);
    assert_true(w > 0.93 && w < 0.95); /* |sin| over [-10°, 40°]: 0.939 */
    assert_true(fabs(sv_bake_front_weight(SV_VIEWER_SIDE, down) - (1 - w)) < 1e-9);
    assert_true(sv_bake_front_weight(SV_VIEWER_AERIAL, up) == 1.0);
    rect rs[2] = {{-1, 1, -1, 1, 0.001, 0}, {-1, 1, -1, 1, -0.001, 0}};
    scene s = make_scene(rs, 2);
    sv_quad q;
    sv_lod_plan lod = one_quad(&q, 0.1);
    sv_bake_options o;
    bake_options(&o);
    o.viewer = SV_VIEWER_ORBIT;
    sv_baked_lod b;
    assert_int_equal(sv_bake_lod(s.r, s.g, s.m, &lod, NULL, &o, &b, NULL), SV_OK);
    const uint8_t cyan[3] = {0, 255, 255};
    for (uint32_t y = 2; y < 64; y += 16)
        for (uint32_t x = 6; x < 64; x += 16) { /* block interiors, away from u's mirror */
            uint8_t up[4];
            leaf_texel(x / 16, y / 16, up);
            const uint8_t *got = chart_texel(&b, &b.albedo, 0, x, y);
            assert_int_equal(got[3], 255);
            for (int k = 0; k < 3; k++) {
                /* the leaf's hole shows the underside from both sides */
                double lin = up[3] ? 0.5 * (sv_srgb_decode8(up[k]) + sv_srgb_decode8(cyan[k]))
                                   : sv_srgb_decode8(cyan[k]);
                int want = sv_srgb_encode8(lin);
                if (abs(got[k] - want) > 2)
                    fail_msg("texel %u,%u channel %d: %d, want %d", x, y, k, got[k], want);
            }
        }
    sv_baked_lod_free(&b);
    scene_free(&s);
}

static void face_outside_the_slab_is_not_baked(void **state)
{
    (void)state;
    /* A flat cyan card in front of the leaf (z = 0.5), outside slab 0.1. */
    rect rs[2] = {{-1, 1, -1, 1, 0, 0}, {-0.5, 1, -0.5, 1, 0.5, 0}};
    scene s = make_scene(rs, 2);
    sv_quad q;
    sv_lod_plan lod = one_quad(&q, 0.1);
    sv_bake_options o;
    bake_options(&o);
    sv_baked_lod b;
    assert_int_equal(sv_bake_lod(s.r, s.g, s.m, &lod, NULL, &o, &b, NULL), SV_OK);
    uint8_t want[4];
    leaf_texel(2, 1, want);
    const uint8_t *got = chart_texel(&b, &b.albedo, 0, 40, 24); /* under the card */
    assert_int_equal(got[3], 255);
    assert_in_range(got[0], want[0] - 2, want[0] + 2);
    got = chart_texel(&b, &b.albedo, 0, 56, 8); /* the leaf's hole, covered by the card */
    assert_int_equal(got[3], 0);
    sv_baked_lod_free(&b);

    /* With a thick slab the card is baked and hides the leaf. */
    q.slab = 0.6;
    assert_int_equal(sv_bake_lod(s.r, s.g, s.m, &lod, NULL, &o, &b, NULL), SV_OK);
    got = chart_texel(&b, &b.albedo, 0, 56, 8);
    assert_int_equal(got[3], 255);
    assert_int_equal(got[0], 0);
    assert_int_equal(got[1], 255);
    sv_baked_lod_free(&b);
    scene_free(&s);
}

static void clip_mode_keeps_only_the_part_of_a_face_inside_the_slab(void **state)
{
    (void)state;
    rect tilted = {-1, 1, -1, 1, 0, 1}; /* z = x: crosses the plane */
    scene s = make_scene(&tilted, 1);
    s.m->materials[0].base_texture = -1;
    s.m->materials[0].alpha_mode = SV_ALPHA_OPAQUE;
    sv_quad q;
    sv_lod_plan lod = one_quad(&q, 0.25);
    sv_bake_options o;
    bake_options(&o);
    sv_baked_lod b;
    assert_int_equal(sv_bake_lod(s.r, s.g, s.m, &lod, NULL, &o, &b, NULL), SV_OK);
    for (uint32_t x = 0; x < 64; x++) /* whole-face selection: the face is outside */
        assert_int_equal(chart_texel(&b, &b.albedo, 0, x, 32)[3], 0);
    sv_baked_lod_free(&b);
    q.clip = true;
    assert_int_equal(sv_bake_lod(s.r, s.g, s.m, &lod, NULL, &o, &b, NULL), SV_OK);
    for (uint32_t x = 0; x < 64; x++) {
        double wx = -1 + (x + 0.5) * 2.0 / 64;
        uint8_t a = chart_texel(&b, &b.albedo, 0, x, 32)[3];
        if (fabs(wx) < 0.23) assert_int_equal(a, 255);
        else if (fabs(wx) > 0.27) assert_int_equal(a, 0);
    }
    sv_baked_lod_free(&b);
    scene_free(&s);
}

static void quads_bake_only_faces_of_their_parts(void **state)
{
    (void)state;
    rect rs[2] = {{-1, 0, -1, 1, 0, 0}, {0, 1, -1, 1, 0.01, 0}};
    scene s = make_scene(rs, 2);
    uint8_t part[4] = {SV_PART_FOLIAGE, SV_PART_FOLIAGE, SV_PART_TRUNK, SV_PART_TRUNK};
    sv_quad q;
    sv_lod_plan lod = one_quad(&q, 0.1);
    q.parts = SV_PARTS_FOLIAGE;
    sv_bake_options o;
    bake_options(&o);
    o.tri_part = part;
    sv_baked_lod b;
    assert_int_equal(sv_bake_lod(s.r, s.g, s.m, &lod, NULL, &o, &b, NULL), SV_OK);
    assert_int_equal(chart_texel(&b, &b.albedo, 0, 10, 40)[3], 255); /* foliage half */
    assert_int_equal(chart_texel(&b, &b.albedo, 0, 50, 40)[3], 0);   /* trunk half */
    sv_baked_lod_free(&b);
    o.tri_part = NULL; /* NULL: every face is trunk */
    assert_int_equal(sv_bake_lod(s.r, s.g, s.m, &lod, NULL, &o, &b, NULL), SV_OK);
    assert_int_equal(chart_texel(&b, &b.albedo, 0, 10, 40)[3], 0);
    sv_baked_lod_free(&b);
    scene_free(&s);
}

static void normal_map_of_a_plane_facing_the_quad_is_straight_up(void **state)
{
    (void)state;
    rect leaf = {-1, 1, -1, 1, 0.05, 0};
    scene s = make_scene(&leaf, 1);
    sv_quad q;
    sv_lod_plan lod = one_quad(&q, 0.1);
    sv_bake_options o;
    bake_options(&o);
    o.normal_map = true;
    o.depth_map = true;
    sv_baked_lod b;
    assert_int_equal(sv_bake_lod(s.r, s.g, s.m, &lod, NULL, &o, &b, NULL), SV_OK);
    assert_non_null(b.normal.data);
    assert_int_equal(b.normal.channels, 3);
    for (uint32_t y = 20; y < 60; y += 7)
        for (uint32_t x = 2; x < 40; x += 5) {
            const uint8_t *n = chart_texel(&b, &b.normal, 0, x, y);
            assert_in_range(n[0], 127, 128);
            assert_in_range(n[1], 127, 128);
            assert_int_equal(n[2], 255);
            /* depth: 0.05 from the plane of a 0.1 slab → half scale */
            const uint16_t *d = (const uint16_t *)chart_texel(&b, &b.depth, 0, x, y);
            assert_in_range(*d, 32767 - 70, 32768 + 70);
        }
    /* The mesh's atlas material references the normal map. */
    assert_int_equal(b.mesh->materials[0].normal_texture, 1);
    assert_int_equal(b.mesh->image_count, 2);
    sv_baked_lod_free(&b);
    scene_free(&s);
}

static void ambient_occlusion_darkens_texels_under_a_roof(void **state)
{
    (void)state;
    /* The leaf in z = 0 and, for the second bake, a roof far above it (y = 3). */
    rect rs[1] = {{-1, 1, -1, 1, 0, 0}};
    scene open = make_scene(rs, 1);
    sv_quad q;
    sv_lod_plan lod = one_quad(&q, 0.1);
    sv_bake_options o;
    bake_options(&o);
    o.ao_map = true;
    sv_baked_lod b;
    assert_int_equal(sv_bake_lod(open.r, open.g, open.m, &lod, NULL, &o, &b, NULL), SV_OK);
    uint8_t ao_open = *chart_texel(&b, &b.ao, 0, 20, 40);
    sv_baked_lod_free(&b);
    scene_free(&open);

    scene roofed = make_scene(rs, 1);
    sv_mesh *m = roofed.m;
    sv_mesh *roof = sv_mesh_create(4, 2, 1, 0);
    const float rp[4][3] = {{-6, 3, -6}, {-6, 3, 6}, {6, 3, 6}, {6, 3, -6}};
    memcpy(roof->positions, rp, sizeof rp);
    const uint32_t ri[6] = {0, 1, 2, 0, 2, 3};
    memcpy(roof->indices, ri, sizeof ri);
    sv_mesh_compute_normals(roof);
    sv_mesh *both = NULL;
    assert_int_equal(sv_mesh_merge(m, roof, &both, NULL), SV_OK);
    sv_mesh_destroy(roof);
    sv_gpu_mesh_free(roofed.g);
    sv_mesh_destroy(m);
    roofed.m = both;
    assert_int_equal(sv_gpu_mesh_upload(roofed.r, both, &roofed.g, NULL), SV_OK);
    assert_int_equal(sv_bake_lod(roofed.r, roofed.g, both, &lod, NULL, &o, &b, NULL), SV_OK);
    uint8_t ao_roof = *chart_texel(&b, &b.ao, 0, 20, 40);
    assert_int_equal(b.mesh->materials[0].occlusion_texture, 1);
    sv_baked_lod_free(&b);
    scene_free(&roofed);
    assert_true(ao_open >= 250);
    assert_true(ao_roof < ao_open - 100);
}

static void result_mesh_has_two_triangles_per_quad_then_the_kept_mesh(void **state)
{
    (void)state;
    rect leaf = {-1, 1, -1, 1, 0, 0};
    scene s = make_scene(&leaf, 1);
    sv_quad qs[2];
    sv_lod_plan lod = one_quad(&qs[0], 0.1);
    qs[1] = qs[0];
    qs[1].centre[0] = 5; /* empty quad elsewhere */
    qs[1].half_u = 0.5;
    lod.quads = qs;
    lod.quad_count = 2;
    sv_bake_options o;
    sv_bake_options_init(&o); /* texel size chosen to fit the atlas */
    o.max_atlas = 256;
    sv_baked_lod b;
    assert_int_equal(sv_bake_lod(s.r, s.g, s.m, &lod, s.m, &o, &b, NULL), SV_OK);
    assert_true(b.albedo.width <= 256 && b.albedo.height <= 256);
    assert_true(b.texel_size > 0 && b.texel_size < 2.0 / 64);
    sv_mesh *m = b.mesh;
    assert_int_equal(m->triangle_count, 2 * 2 + s.m->triangle_count);
    assert_int_equal(m->vertex_count, 4 * 2 + s.m->vertex_count);
    assert_int_equal(m->material_count, 1 + s.m->material_count);
    assert_int_equal(m->image_count, 1 + s.m->image_count);
    assert_int_equal(m->materials[0].alpha_mode, SV_ALPHA_MASK);
    assert_true(m->materials[0].double_sided);
    assert_int_equal(m->materials[0].base_texture, 0);
    assert_int_equal(m->materials[1].base_texture, 1); /* kept texture, re-indexed */
    assert_int_equal(m->tri_material[4], 1);
    /* the mesh shares the atlas's pixels (sv_image_copy, counted): the same
     * buffer, which outlives the atlas's own image */
    assert_ptr_equal(m->images[0].data, b.albedo.data);
    assert_non_null(m->images[0].refs);
    size_t nb = (size_t)b.albedo.width * b.albedo.height * 4;
    uint8_t *before = malloc(nb);
    assert_non_null(before);
    memcpy(before, b.albedo.data, nb);
    sv_image_free(&b.albedo); /* the mesh's pixels stay (ASan: no use after free) */
    assert_null(b.albedo.data);
    assert_memory_equal(m->images[0].data, before, nb);
    free(before);
    /* Corner 3 (-u,+v) is the chart's top-left: uv (u0, v0); corner 1 (+u,-v): (u1, v1). */
    assert_true(m->positions[3 * 3] == -1.0f && m->positions[3 * 3 + 1] == 1.0f);
    assert_true(m->uvs[2 * 3] == b.uv_rects[0] && m->uvs[2 * 3 + 1] == b.uv_rects[1]);
    assert_true(m->uvs[2 * 1] == b.uv_rects[2] && m->uvs[2 * 1 + 1] == b.uv_rects[3]);
    /* The two charts do not overlap. */
    const float *r0 = b.uv_rects, *r1 = b.uv_rects + 4;
    assert_true(r0[2] <= r1[0] || r1[2] <= r0[0] || r0[3] <= r1[1] || r1[3] <= r0[1]);
    sv_baked_lod_free(&b);
    sv_baked_lod_free(&b); /* freeing twice (zeroed) is fine */
    scene_free(&s);
}

static void supersampling_follows_the_smallest_faces_within_the_cap(void **state)
{
    (void)state;
    rect rs[2] = {{-1, 1, -1, 1, 0, 0}, {0.2, 0.205, 0.2, 0.205, 0.01, 0}}; /* a tiny leaf */
    scene s = make_scene(rs, 2);
    sv_quad q;
    sv_lod_plan lod = one_quad(&q, 0.1);
    sv_bake_options o;
    bake_options(&o);
    o.max_supersample = 16;
    sv_baked_lod b;
    assert_int_equal(sv_bake_lod(s.r, s.g, s.m, &lod, NULL, &o, &b, NULL), SV_OK);
    /* faces: 2 of sqrt(area) ~1.41 and 2 of ~0.0035; p5 → the tiny ones, texel 1/32 */
    assert_int_equal(b.supersample, 9);
    sv_baked_lod_free(&b);
    o.max_supersample = 3;
    assert_int_equal(sv_bake_lod(s.r, s.g, s.m, &lod, NULL, &o, &b, NULL), SV_OK);
    assert_int_equal(b.supersample, 3);
    sv_baked_lod_free(&b);
    scene_free(&s);
}

static void bake_is_byte_identical_across_runs(void **state)
{
    (void)state;
    rect rs[3] = {{-1, 1, -1, 1, 0, 0},
                  {-0.5, 0.7, -0.8, 0.3, 0.02, 0.03},
                  {0.1, 0.9, 0.1, 0.6, -0.05, -0.04}};
    sv_baked_lod b[2];
    for (int run = 0; run < 2; run++) {
        scene s = make_scene(rs, 3);
        sv_quad q;
        sv_lod_plan lod = one_quad(&q, 0.1);
        sv_bake_options o;
        bake_options(&o);
        o.normal_map = o.depth_map = o.ao_map = true;
        o.max_supersample = 4;
        assert_int_equal(sv_bake_lod(s.r, s.g, s.m, &lod, s.m, &o, &b[run], NULL), SV_OK);
        scene_free(&s);
    }
    size_t px = (size_t)b[0].albedo.width * b[0].albedo.height;
    assert_int_equal(b[0].albedo.width, b[1].albedo.width);
    assert_memory_equal(b[0].albedo.data, b[1].albedo.data, px * 4);
    assert_memory_equal(b[0].normal.data, b[1].normal.data, px * 3);
    assert_memory_equal(b[0].ao.data, b[1].ao.data, px);
    assert_memory_equal(b[0].depth.data, b[1].depth.data, px * 2);
    assert_memory_equal(b[0].mesh->uvs, b[1].mesh->uvs,
                        b[0].mesh->vertex_count * 2 * sizeof(float));
    assert_memory_equal(b[0].uv_rects, b[1].uv_rects, 4 * sizeof(float));
    sv_baked_lod_free(&b[0]);
    sv_baked_lod_free(&b[1]);
}

#include "import.h"
#include "image_io.h"

/* 20 quads over the real oak: 12 vertical planes through the trunk axis and 8
 * horizontal slices; foliage only. Prints the timing for the report. */
static void oak_bakes_twenty_quads_into_binary_alpha_atlases(void **state)
{
    (void)state;
    const char *data = sv_test_data("the oak timing");
    char path[1024];
    snprintf(path, sizeof path, "%s/eztree_oak_large/oak_large.glb", data);
    size_t size = 0;
    uint8_t *bytes = sv_test_read_all(path, &size);
    if (!bytes) fail_msg("cannot read %s", path);
    sv_file file = {"oak_large.glb", bytes, size};
    sv_mesh *m = NULL;
    sv_error err = {0};
    double t0 = sv_now();
    if (sv_import(&file, 1, NULL, &m, NULL, &err) != SV_OK) fail_msg("import: %s", err.message);
    free(bytes);
    sv_classification cls;
    if (sv_classify(m, NULL, &cls, &err) != SV_OK) fail_msg("classify: %s", err.message);
    double c[3], rad;
    sv_mesh_sphere(m, c, &rad);
    double mn[3], mx[3];
    sv_mesh_bounds(m, mn, mx);
    sv_quad qs[20];
    memset(qs, 0, sizeof qs);
    for (int i = 0; i < 20; i++) {
        sv_quad *q = &qs[i];
        q->parts = SV_PARTS_FOLIAGE;
        q->group = q->parent = -1;
        if (i < 12) {
            double a = M_PI * i / 12;
            double n[3] = {cos(a), 0, sin(a)};
            memcpy(q->normal, n, sizeof n);
            q->axis_u[0] = -sin(a);
            q->axis_u[2] = cos(a);
            q->axis_v[1] = 1;
            q->half_u = rad;
            q->half_v = 0.5 * (mx[1] - mn[1]);
            q->slab = rad / 12;
        } else {
            double y = mn[1] + (mx[1] - mn[1]) * (i - 11.5) / 8;
            q->normal[1] = 1;
            q->axis_u[0] = 1;
            q->axis_v[2] = -1; /* u × v = +y */
            q->half_u = 0.5 * (mx[0] - mn[0]);
            q->half_v = 0.5 * (mx[2] - mn[2]);
            q->slab = (mx[1] - mn[1]) / 16;
            c[1] = y;
        }
        memcpy(q->centre, c, sizeof c);
        q->d = -(q->normal[0] * c[0] + q->normal[1] * c[1] + q->normal[2] * c[2]);
        c[1] = 0.5 * (mn[1] + mx[1]);
    }
    sv_lod_plan lod = {.quads = qs, .quad_count = 20};
    strcpy(lod.name, "oak20");
    sv_renderer *r = NULL;
    assert_int_equal(sv_renderer_create(4096, &r, NULL), SV_OK);
    sv_gpu_mesh *g = NULL;
    double t1 = sv_now();
    assert_int_equal(sv_gpu_mesh_upload(r, m, &g, NULL), SV_OK);
    double t2 = sv_now();
    sv_bake_options o;
    sv_bake_options_init(&o);
    o.tri_part = cls.tri_part;
    o.normal_map = true;
    o.max_atlas = 1024; /* keeps the sanitizer run short; 2048 takes ~1.2 s at -O2 */
    sv_baked_lod b;
    if (sv_bake_lod(r, g, m, &lod, NULL, &o, &b, &err) != SV_OK) fail_msg("bake: %s", err.message);
    double t3 = sv_now();
    size_t px = (size_t)b.albedo.width * b.albedo.height, opaque = 0;
    const uint8_t *p = b.albedo.data;
    for (size_t i = 0; i < px; i++) {
        assert_true(p[4 * i + 3] == 0 || p[4 * i + 3] == 255);
        opaque += p[4 * i + 3] != 0;
    }
    printf("oak: %u triangles (%u foliage); import+classify %.2f s, upload %.2f s; "
           "bake of 20 quads (albedo+normal) %.2f s (render %.2f, pack %.3f): atlas %ux%u, "
           "texel %.4f m, supersample %u, %.1f%% opaque\n",
           m->triangle_count, cls.foliage_triangles, t1 - t0, t2 - t1, t3 - t2, b.seconds_render,
           b.seconds_pack, b.albedo.width, b.albedo.height, b.texel_size, b.supersample,
           100.0 * (double)opaque / (double)px);
    const char *dump = getenv("SYLVA_BAKE_DUMP"); /* optional: look at the atlases */
    if (dump) {
        char f[1200];
        snprintf(f, sizeof f, "%s/oak20_albedo.png", dump);
        sv_image_write_png(&b.albedo, f, NULL);
        snprintf(f, sizeof f, "%s/oak20_normal.png", dump);
        sv_image_write_png(&b.normal, f, NULL);
    }
    printf("oak bounds: %.2f..%.2f x %.2f..%.2f x %.2f..%.2f\n", mn[0], mx[0], mn[1], mx[1], mn[2],
           mx[2]);
    /* Leaves, not cards: a good part of each chart but far from all of it. */
    assert_true(opaque > px / 50);
    assert_true(opaque < px * 3 / 4);
    sv_baked_lod_free(&b);
    sv_gpu_mesh_free(g);
    sv_renderer_destroy(r);
    sv_classification_free(&cls);
    sv_mesh_destroy(m);
}

/* A mesh level's brightness match (svp_scale_mesh_colour): a material
 * takes the scale in its factor while that stays within 1; a texture one
 * of its materials cannot take it in the factor is scaled in linear light
 * instead (alpha kept, new pixels: a copy held elsewhere keeps its own),
 * and the materials sampling it keep their factors. */
static void mesh_level_colour_is_scaled_in_factors_or_textures(void **state)
{
    (void)state;
    sv_mesh *m = sv_mesh_create(3, 1, 3, 1);
    assert_non_null(m);
    assert_int_equal(sv_image_alloc(&m->images[0], 2, 1, 4, 8, NULL), SV_OK);
    uint8_t *px = m->images[0].data;
    const uint8_t src[8] = {40, 120, 250, 255, 200, 10, 90, 0};
    memcpy(px, src, sizeof src);
    const float factor[3] = {0.5f, 1.0f, 0.6f};
    for (int i = 0; i < 3; i++) {
        for (int k = 0; k < 3; k++) m->materials[i].base_color[k] = factor[i];
        m->materials[i].base_texture = i < 2 ? 0 : -1;
    }
    sv_image held;
    assert_int_equal(sv_image_copy(&m->images[0], &held, NULL), SV_OK);
    /* 0.5: every factor takes it, the texture is the same pixels */
    assert_int_equal(svp_scale_mesh_colour(m, 0.5, NULL), SV_OK);
    assert_ptr_equal(m->images[0].data, held.data);
    for (int i = 0; i < 3; i++) assert_float_equal(m->materials[i].base_color[0], factor[i] * 0.5, 1e-6);
    /* back, then 1.5: material 1 (factor 1) cannot, so texture 0 is scaled
     * and materials 0 and 1 keep their factors; material 2 takes 0.9 */
    for (int i = 0; i < 3; i++)
        for (int k = 0; k < 3; k++) m->materials[i].base_color[k] = factor[i];
    assert_int_equal(svp_scale_mesh_colour(m, 1.5, NULL), SV_OK);
    assert_float_equal(m->materials[0].base_color[1], 0.5, 1e-6);
    assert_float_equal(m->materials[1].base_color[1], 1.0, 1e-6);
    assert_float_equal(m->materials[2].base_color[1], 0.9, 1e-6);
    assert_ptr_not_equal(m->images[0].data, held.data);
    assert_memory_equal(held.data, src, sizeof src); /* the held copy keeps its pixels */
    const uint8_t *o = m->images[0].data;
    for (int t = 0; t < 2; t++) {
        for (int k = 0; k < 3; k++)
            assert_int_equal(o[4 * t + k], sv_srgb_encode8(fmin(1.0, sv_srgb_decode8(src[4 * t + k]) * 1.5)));
        assert_int_equal(o[4 * t + 3], src[4 * t + 3]);
    }
    sv_image_free(&held);
    sv_mesh_destroy(m);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(baked_albedo_matches_the_source_texture_where_covered),
        cmocka_unit_test(baked_colour_is_the_linear_factor_times_the_decoded_texel),
        cmocka_unit_test(transparent_texels_get_dilated_leaf_colour),
        cmocka_unit_test(both_sides_of_a_two_layer_leaf_are_blended_in_linear_light),
        cmocka_unit_test(face_outside_the_slab_is_not_baked),
        cmocka_unit_test(clip_mode_keeps_only_the_part_of_a_face_inside_the_slab),
        cmocka_unit_test(quads_bake_only_faces_of_their_parts),
        cmocka_unit_test(normal_map_of_a_plane_facing_the_quad_is_straight_up),
        cmocka_unit_test(ambient_occlusion_darkens_texels_under_a_roof),
        cmocka_unit_test(result_mesh_has_two_triangles_per_quad_then_the_kept_mesh),
        cmocka_unit_test(supersampling_follows_the_smallest_faces_within_the_cap),
        cmocka_unit_test(bake_is_byte_identical_across_runs),
        cmocka_unit_test(mesh_level_colour_is_scaled_in_factors_or_textures),
        cmocka_unit_test(oak_bakes_twenty_quads_into_binary_alpha_atlases),
    };
    return sv_test_exit(cmocka_run_group_tests(tests, NULL, NULL));
}
