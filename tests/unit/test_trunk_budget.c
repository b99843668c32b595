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

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(budget_caps_the_trunk_even_against_a_tight_error_bound),
        cmocka_unit_test(budget_above_the_count_keeps_the_trunk_as_it_is),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
