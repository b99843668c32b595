/* test_trunk_budget.c — the trunk held to a triangle budget (core/trunk.c,
 * sv_trunk_mesh_budget): the cap wins over the error bound, the shape stays
 * where the trunk was, foliage never enters, and no budget means no change. */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "trunk.h"

/* A welded cylinder (radius 1, height `rings`) of seg × rings quads, material
 * 0, plus one foliage triangle far above it (material 1). */
static sv_mesh *tube(int seg, int rings, uint8_t **parts)
{
    uint32_t nv = (uint32_t)(seg * (rings + 1) + 3), nt = (uint32_t)(seg * rings * 2 + 1);
    sv_mesh *m = sv_mesh_create(nv, nt, 2, 0);
    assert_non_null(m);
    *parts = calloc(nt, 1);
    assert_non_null(*parts);
    for (int r = 0; r <= rings; r++)
        for (int s = 0; s < seg; s++) {
            double a = 2 * M_PI * s / seg;
            float *p = &m->positions[3 * (size_t)(r * seg + s)];
            p[0] = (float)cos(a), p[1] = (float)r, p[2] = (float)sin(a);
        }
    uint32_t t = 0;
    for (int r = 0; r < rings; r++)
        for (int s = 0; s < seg; s++) {
            uint32_t a = (uint32_t)(r * seg + s), b = (uint32_t)(r * seg + (s + 1) % seg);
            uint32_t c = a + (uint32_t)seg, d = b + (uint32_t)seg;
            uint32_t q[2][3] = {{a, d, b}, {a, c, d}};
            for (int h = 0; h < 2; h++, t++) {
                memcpy(&m->indices[3 * t], q[h], sizeof q[h]);
                (*parts)[t] = SV_PART_TRUNK;
                m->tri_material[t] = 0;
            }
        }
    uint32_t v = (uint32_t)(seg * (rings + 1));
    for (int j = 0; j < 3; j++) {
        m->positions[3 * (v + j)] = (float)j;
        m->positions[3 * (v + j) + 1] = 500;
        m->indices[3 * t + j] = v + j;
    }
    (*parts)[t] = SV_PART_FOLIAGE;
    m->tri_material[t] = 1;
    sv_mesh_compute_normals(m);
    return m;
}

static void budget_caps_the_trunk_even_against_a_tight_error_bound(void **state)
{
    (void)state;
    uint8_t *parts = NULL;
    sv_mesh *m = tube(48, 40, &parts); /* 3840 trunk triangles */
    sv_mesh *out = NULL;
    /* an error bound of 1e-6 lets meshopt_simplify remove almost nothing */
    assert_int_equal(sv_trunk_mesh_budget(m, parts, 1.0, 100, 1e-6, &out, NULL), SV_OK);
    assert_non_null(out);
    assert_true(out->triangle_count <= 100);
    assert_true(out->triangle_count >= 10);
    for (uint32_t v = 0; v < out->vertex_count; v++) {
        const float *p = &out->positions[3 * v];
        assert_true(p[1] >= -1e-3f && p[1] <= 40.001f); /* never the foliage at y = 500 */
        assert_true(hypot(p[0], p[2]) <= 1.001);
    }
    for (uint32_t t = 0; t < out->triangle_count; t++) assert_int_equal(out->tri_material[t], 0);
    sv_mesh_destroy(out);
    sv_mesh_destroy(m);
    free(parts);
}

static void budget_above_the_count_keeps_the_trunk_as_it_is(void **state)
{
    (void)state;
    uint8_t *parts = NULL;
    sv_mesh *m = tube(16, 4, &parts); /* 128 trunk triangles */
    sv_mesh *out = NULL;
    assert_int_equal(sv_trunk_mesh_budget(m, parts, 1.0, 1000, 0, &out, NULL), SV_OK);
    assert_non_null(out);
    assert_int_equal(out->triangle_count, 128);
    sv_mesh_destroy(out);
    /* no cap: the ratio alone, as sv_trunk_mesh */
    assert_int_equal(sv_trunk_mesh_budget(m, parts, 1.0, 0, 0, &out, NULL), SV_OK);
    assert_int_equal(out->triangle_count, 128);
    sv_mesh_destroy(out);
    sv_mesh_destroy(m);
    free(parts);
}

/* 200 thin separate twigs (closed boxes 2 cm across and 1 m long, 1 m
 * apart) mapped face by face (24 vertices, 12 triangles each: every edge is a
 * UV seam, as in many bark exports): shape-preserving simplification welded
 * by position and UV cannot take them apart, so without a cap the trunk
 * stops far above ratio × n even where the error bound allows the twigs to
 * go. */
static sv_mesh *twigs(uint8_t **parts)
{
    static const uint8_t face[6][4] = {{0, 1, 3, 2}, {4, 6, 7, 5}, {0, 4, 5, 1},
                                       {2, 3, 7, 6}, {0, 2, 6, 4}, {1, 5, 7, 3}};
    uint32_t n = 200;
    sv_mesh *m = sv_mesh_create(24 * n, 12 * n, 1, 0);
    assert_non_null(m);
    *parts = calloc(12 * n, 1);
    for (uint32_t k = 0; k < n; k++)
        for (uint32_t f = 0; f < 6; f++) {
            for (uint32_t c = 0; c < 4; c++) {
                uint32_t v = face[f][c], w = 24 * k + 4 * f + c;
                float *p = &m->positions[3 * (size_t)w];
                p[0] = 0.02f * (float)(v & 1) + (float)(k % 20);
                p[1] = 0.02f * (float)((v >> 1) & 1) + (float)(k / 20);
                p[2] = (float)(v >> 2);
                m->uvs[2 * (size_t)w] = 0.1f * (float)f + 0.05f * (float)(c == 1 || c == 2);
                m->uvs[2 * (size_t)w + 1] = (float)(c >= 2);
            }
            uint32_t b = 24 * k + 4 * f, t = 12 * k + 2 * f;
            uint32_t q[6] = {b, b + 1, b + 2, b, b + 2, b + 3};
            memcpy(&m->indices[3 * (size_t)t], q, sizeof q);
            (*parts)[t] = (*parts)[t + 1] = SV_PART_TRUNK;
        }
    sv_mesh_compute_normals(m);
    return m;
}

static void no_cap_goes_below_what_topology_holds_within_the_bound(void **state)
{
    (void)state;
    uint8_t *parts = NULL;
    sv_mesh *m = twigs(&parts); /* 2400 triangles */
    sv_mesh *plain = NULL, *bounded = NULL, *tight = NULL;
    /* bound 5 cm: a twig 2 cm across may collapse to nothing */
    assert_int_equal(sv_trunk_mesh(m, parts, 0.05, 0.05, &plain, NULL), SV_OK);
    assert_int_equal(sv_trunk_mesh_budget(m, parts, 0.05, 0, 0.05, &bounded, NULL), SV_OK);
    assert_non_null(plain);
    assert_true(plain->triangle_count >= 800); /* the seams lock them */
    assert_true(!bounded || bounded->triangle_count < plain->triangle_count / 2);
    /* a bound far below the twigs' width keeps what sv_trunk_mesh keeps */
    sv_mesh_destroy(plain);
    assert_int_equal(sv_trunk_mesh(m, parts, 0.05, 1e-5, &plain, NULL), SV_OK);
    assert_int_equal(sv_trunk_mesh_budget(m, parts, 0.05, 0, 1e-5, &tight, NULL), SV_OK);
    assert_true(tight->triangle_count >= plain->triangle_count * 9 / 10);
    sv_mesh_destroy(plain);
    sv_mesh_destroy(bounded);
    sv_mesh_destroy(tight);
    sv_mesh_destroy(m);
    free(parts);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(budget_caps_the_trunk_even_against_a_tight_error_bound),
        cmocka_unit_test(budget_above_the_count_keeps_the_trunk_as_it_is),
        cmocka_unit_test(no_cap_goes_below_what_topology_holds_within_the_bound),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
