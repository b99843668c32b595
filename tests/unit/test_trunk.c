/* test_trunk.c — trunk kept as a mesh and simplified with meshoptimizer (core/trunk.c),
 * and the mesh helpers it builds on (core/mesh.c). */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "trunk.h"

/* A cylinder of `seg` segments and `rings` rings with per-face (unshared)
 * vertices, as OBJ exporters write them; material 0 "bark". Plus one leaf
 * triangle (material 1) that must never appear in the trunk. */
static sv_mesh *cylinder(int seg, int rings, uint8_t **parts)
{
    uint32_t nt = (uint32_t)(seg * rings * 2 + 1);
    sv_mesh *m = sv_mesh_create(nt * 3, nt, 2, 0);
    assert_non_null(m);
    *parts = calloc(nt, 1);
    uint32_t v = 0, t = 0;
    for (int r = 0; r < rings; r++)
        for (int s = 0; s < seg; s++) {
            double a0 = 2 * M_PI * s / seg, a1 = 2 * M_PI * (s + 1) / seg;
            double p[4][3] = {{cos(a0), r, sin(a0)}, {cos(a1), r, sin(a1)},
                              {cos(a1), r + 1, sin(a1)}, {cos(a0), r + 1, sin(a0)}};
            double uv[4][2] = {{(double)s / seg, (double)r / rings},
                               {(double)(s + 1) / seg, (double)r / rings},
                               {(double)(s + 1) / seg, (double)(r + 1) / rings},
                               {(double)s / seg, (double)(r + 1) / rings}};
            int tri[2][3] = {{0, 2, 1}, {0, 3, 2}};
            for (int h = 0; h < 2; h++) {
                for (int j = 0; j < 3; j++) {
                    int c = tri[h][j];
                    for (int k = 0; k < 3; k++) m->positions[3 * v + k] = (float)p[c][k];
                    m->uvs[2 * v] = (float)uv[c][0];
                    m->uvs[2 * v + 1] = (float)uv[c][1];
                    m->indices[3 * t + j] = v++;
                }
                (*parts)[t] = SV_PART_TRUNK;
                m->tri_material[t++] = 0;
            }
        }
    for (int j = 0; j < 3; j++) {
        m->positions[3 * v] = (float)j;
        m->positions[3 * v + 1] = 50;
        m->indices[3 * t + j] = v++;
    }
    (*parts)[t] = SV_PART_FOLIAGE;
    m->tri_material[t++] = 1;
    sv_mesh_compute_normals(m);
    return m;
}

static void trunk_keeps_only_trunk_triangles_at_ratio_one(void **state)
{
    (void)state;
    uint8_t *parts;
    sv_mesh *m = cylinder(16, 8, &parts), *t = NULL;
    sv_error e = {0};
    assert_int_equal(sv_trunk_mesh(m, parts, 1.0, 0, &t, &e), SV_OK);
    assert_non_null(t);
    assert_int_equal(t->triangle_count, m->triangle_count - 1);
    for (uint32_t v = 0; v < t->vertex_count; v++) assert_true(t->positions[3 * v + 1] <= 8.0f);
    sv_mesh_destroy(t);
    sv_mesh_destroy(m);
    free(parts);
}

static void trunk_simplification_reduces_unwelded_meshes(void **state)
{
    (void)state;
    uint8_t *parts;
    sv_mesh *m = cylinder(32, 32, &parts), *t = NULL;
    sv_error e = {0};
    uint32_t full = m->triangle_count - 1;
    assert_int_equal(sv_trunk_mesh(m, parts, 0.25, 0, &t, &e), SV_OK);
    assert_non_null(t);
    assert_true(t->triangle_count <= full / 2);
    assert_true(t->triangle_count >= 8);
    /* still a cylinder: every vertex within the original bounds */
    for (uint32_t v = 0; v < t->vertex_count; v++) {
        assert_true(t->positions[3 * v + 1] >= 0 && t->positions[3 * v + 1] <= 32.0f);
        double r = hypot(t->positions[3 * v], t->positions[3 * v + 2]);
        assert_true(r <= 1.0001);
    }
    sv_mesh_destroy(t);
    sv_mesh_destroy(m);
    free(parts);
}

static void trunk_is_null_without_trunk_triangles(void **state)
{
    (void)state;
    uint8_t *parts;
    sv_mesh *m = cylinder(4, 1, &parts), *t = (sv_mesh *)1;
    memset(parts, SV_PART_FOLIAGE, m->triangle_count);
    sv_error e = {0};
    assert_int_equal(sv_trunk_mesh(m, parts, 0.5, 0, &t, &e), SV_OK);
    assert_null(t);
    sv_mesh_destroy(m);
    free(parts);
}

static void mesh_merge_offsets_indices_materials_and_images(void **state)
{
    (void)state;
    sv_mesh *a = sv_mesh_create(3, 1, 1, 1), *b = sv_mesh_create(3, 1, 2, 1), *m = NULL;
    assert_non_null(a);
    assert_non_null(b);
    for (int i = 0; i < 3; i++) a->indices[i] = b->indices[i] = (uint32_t)i;
    b->tri_material[0] = 1;
    b->materials[1].base_texture = 0;
    sv_error e = {0};
    assert_int_equal(sv_image_alloc(&a->images[0], 2, 2, 4, 8, &e), SV_OK);
    assert_int_equal(sv_image_alloc(&b->images[0], 4, 4, 4, 8, &e), SV_OK);
    assert_int_equal(sv_mesh_merge(a, b, &m, &e), SV_OK);
    assert_int_equal(m->triangle_count, 2);
    assert_int_equal(m->vertex_count, 6);
    assert_int_equal(m->indices[3], 3);
    assert_int_equal(m->tri_material[1], 2);
    assert_int_equal(m->materials[2].base_texture, 1);
    assert_int_equal(m->images[1].width, 4);
    sv_mesh_destroy(m);
    assert_int_equal(sv_mesh_merge(NULL, b, &m, &e), SV_OK);
    assert_int_equal(m->triangle_count, 1);
    sv_mesh_destroy(m);
    sv_mesh_destroy(a);
    sv_mesh_destroy(b);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(trunk_keeps_only_trunk_triangles_at_ratio_one),
        cmocka_unit_test(trunk_simplification_reduces_unwelded_meshes),
        cmocka_unit_test(trunk_is_null_without_trunk_triangles),
        cmocka_unit_test(mesh_merge_offsets_indices_materials_and_images),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
