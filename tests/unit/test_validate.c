/* test_validate.c — mesh validation and repair (core/geom/validate.c). */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "validate.h"

/* A strip of n separate right triangles along +X, each with its own vertices,
 * with normals +Z. */
static sv_mesh *strip(uint32_t n)
{
    sv_mesh *m = sv_mesh_create(3 * n, n, 1, 0);
    assert_non_null(m);
    for (uint32_t t = 0; t < n; t++) {
        const float p[9] = {(float)t, 0, 0, (float)t + 1, 0, 0, (float)t, 1, 0};
        memcpy(&m->positions[9 * (size_t)t], p, sizeof p);
        for (int j = 0; j < 3; j++) {
            m->indices[3 * (size_t)t + j] = 3 * t + (uint32_t)j;
            m->normals[3 * (3 * (size_t)t + j) + 2] = 1;
        }
    }
    return m;
}

static void expect_invalid(sv_mesh *m, sv_status want, const char *message)
{
    sv_error err = {0};
    sv_status st = sv_validate(m, NULL, NULL, &err);
    if (st != want || strcmp(err.message, message) != 0)
        print_error("got %s '%s'\n", sv_status_code(st), err.message);
    assert_int_equal(st, want);
    assert_string_equal(err.message, message);
}

static void valid_mesh_passes_unchanged(void **state)
{
    (void)state;
    sv_mesh *m = strip(4);
    sv_validate_report r;
    assert_int_equal(sv_validate(m, NULL, &r, NULL), SV_OK);
    assert_int_equal(m->triangle_count, 4);
    assert_int_equal(
        r.removed_degenerate + r.removed_duplicate + r.fixed_normals + r.unused_vertices, 0);
    sv_mesh_destroy(m);
}

static void nan_vertex_is_rejected_by_number(void **state)
{
    (void)state;
    sv_mesh *m = strip(3);
    m->positions[3 * 5 + 1] = NAN;
    expect_invalid(m, SV_ERR_INVALID, "vertex 5 has a NaN coordinate");
    sv_mesh_destroy(m);
}

static void infinite_vertex_is_rejected_by_number(void **state)
{
    (void)state;
    sv_mesh *m = strip(3);
    m->positions[3 * 7 + 2] = -INFINITY;
    expect_invalid(m, SV_ERR_INVALID, "vertex 7 has an infinite coordinate");
    sv_mesh_destroy(m);
}

static void out_of_range_index_names_triangle_and_vertex(void **state)
{
    (void)state;
    sv_mesh *m = strip(30000); /* 90000 vertices */
    m->indices[3 * 17 + 1] = 90001;
    expect_invalid(m, SV_ERR_INVALID, "triangle 17 refers to vertex 90001 of 90000");
    sv_mesh_destroy(m);
}

static void out_of_range_material_is_rejected(void **state)
{
    (void)state;
    sv_mesh *m = strip(3);
    m->tri_material[2] = 4;
    expect_invalid(m, SV_ERR_INVALID, "triangle 2 refers to material 4 of 1");
    sv_mesh_destroy(m);
}

static void material_texture_beyond_the_images_is_rejected(void **state)
{
    (void)state;
    sv_mesh *m = strip(1);
    m->materials[0].base_texture = 0; /* no images */
    snprintf(m->materials[0].name, sizeof m->materials[0].name, "leaf");
    expect_invalid(m, SV_ERR_INVALID, "material 0 ('leaf') refers to image 0 of 0");
    sv_mesh_destroy(m);
}

static void empty_mesh_is_rejected(void **state)
{
    (void)state;
    sv_mesh *m = sv_mesh_create(0, 0, 0, 0);
    expect_invalid(m, SV_ERR_INVALID, "mesh has no triangles");
    sv_mesh_destroy(m);
}

static void zero_area_triangles_are_removed_and_counted(void **state)
{
    (void)state;
    sv_mesh *m = strip(4);
    m->indices[3 * 1 + 2] = m->indices[3 * 1 + 1]; /* repeated corner */
    /* collinear corners: (2,0,0) (3,0,0) (2.5,0,0) */
    m->positions[3 * 8 + 0] = 2.5f;
    m->positions[3 * 8 + 1] = 0.0f;
    m->tri_material[3] = 0;
    sv_validate_report r;
    assert_int_equal(sv_validate(m, NULL, &r, NULL), SV_OK);
    assert_int_equal(r.removed_degenerate, 2);
    assert_int_equal(m->triangle_count, 2);
    /* order kept: triangles 0 and 3 remain */
    assert_int_equal(m->indices[0], 0);
    assert_int_equal(m->indices[3], 9);
    /* the vertices of the removed triangles are now unused (kept, reported) */
    assert_int_equal(r.unused_vertices, 6);
    sv_mesh_destroy(m);
}

static void a_thin_but_real_triangle_is_kept(void **state)
{
    (void)state;
    sv_mesh *m = strip(1);
    m->positions[3 * 2 + 1] = 1e-4f; /* height 1e-4 of length 1 */
    sv_validate_report r;
    assert_int_equal(sv_validate(m, NULL, &r, NULL), SV_OK);
    assert_int_equal(r.removed_degenerate, 0);
    sv_mesh_destroy(m);
}

static void duplicate_triangles_are_removed_in_any_rotation_but_reversed_kept(void **state)
{
    (void)state;
    sv_mesh *m = strip(5);
    /* triangle 2: the same positions as triangle 0, rotated by one */
    const float t0[9] = {1, 0, 0, 0, 1, 0, 0, 0, 0};
    memcpy(&m->positions[9 * 2], t0, sizeof t0);
    /* triangle 3: triangle 0 reversed (back face of a two-sided leaf) */
    const float rev[9] = {0, 0, 0, 0, 1, 0, 1, 0, 0};
    memcpy(&m->positions[9 * 3], rev, sizeof rev);
    /* triangle 4: shares triangle 0's vertex indices exactly, -0.0 for 0.0 */
    m->indices[12] = 0, m->indices[13] = 1, m->indices[14] = 2;
    m->positions[0] = -0.0f;
    sv_validate_report r;
    assert_int_equal(sv_validate(m, NULL, &r, NULL), SV_OK);
    assert_int_equal(r.removed_duplicate, 2);
    assert_int_equal(m->triangle_count, 3);
    assert_int_equal(m->indices[3 * 1], 3); /* triangle 1 kept in place */
    assert_int_equal(m->indices[3 * 2], 9); /* the reversed one kept */
    sv_mesh_destroy(m);
}

static void all_degenerate_mesh_is_rejected_after_repair(void **state)
{
    (void)state;
    sv_mesh *m = strip(2);
    for (uint32_t t = 0; t < 2; t++) m->indices[3 * t + 1] = m->indices[3 * t];
    expect_invalid(m, SV_ERR_INVALID,
                   "mesh has no triangles left after removing 2 zero-area and 0 duplicate ones");
    sv_mesh_destroy(m);
}

static void counts_over_limits_are_refused(void **state)
{
    (void)state;
    sv_mesh *m = strip(10);
    sv_limits lim = {.max_triangles = 9};
    sv_error err = {0};
    assert_int_equal(sv_validate(m, &lim, NULL, &err), SV_ERR_LIMIT);
    assert_string_equal(err.message, "mesh has 10 triangles (limit 9)");
    lim = (sv_limits){.max_vertices = 29};
    assert_int_equal(sv_validate(m, &lim, NULL, &err), SV_ERR_LIMIT);
    assert_string_equal(err.message, "mesh has 30 vertices (limit 29)");
    sv_mesh_destroy(m);
    /* the default texture limit is 16384 per side */
    m = sv_mesh_create(3, 1, 1, 1);
    m->positions[3] = 1, m->positions[7] = 1;
    m->indices[1] = 1, m->indices[2] = 2;
    m->images[0] = (sv_image){.width = 16385, .height = 1, .channels = 4, .bits = 8};
    assert_int_equal(sv_validate(m, NULL, NULL, &err), SV_ERR_LIMIT);
    assert_string_equal(err.message, "image 0 is 16385x1 (limit 16384 per side)");
    m->images[0].width = 16384;
    assert_int_equal(sv_validate(m, NULL, NULL, &err), SV_OK);
    m->images[0] = (sv_image){0}; /* no data was allocated */
    sv_mesh_destroy(m);
}

static void bad_normals_are_recomputed_and_others_normalised(void **state)
{
    (void)state;
    sv_mesh *m = strip(2);
    m->normals[0] = NAN;
    m->normals[3 * 1 + 2] = 0; /* zero */
    m->normals[3 * 3 + 2] = 5; /* not unit */
    sv_validate_report r;
    assert_int_equal(sv_validate(m, NULL, &r, NULL), SV_OK);
    assert_int_equal(r.fixed_normals, 2);
    for (int v = 0; v < 4; v++) {
        assert_float_equal(m->normals[3 * v + 0], 0, 1e-6);
        assert_float_equal(m->normals[3 * v + 1], 0, 1e-6);
        assert_float_equal(m->normals[3 * v + 2], 1, 1e-6);
    }
    sv_mesh_destroy(m);
}

static void many_duplicates_are_found_in_linear_time(void **state)
{
    (void)state;
    /* 200,000 triangles, every other one a copy of its predecessor through other
     * vertices: a quadratic search would take minutes, the hash table a moment. */
    uint32_t n = 200000;
    sv_mesh *m = strip(n);
    for (uint32_t t = 1; t < n; t += 2)
        memcpy(&m->positions[9 * (size_t)t], &m->positions[9 * (size_t)(t - 1)], 9 * sizeof(float));
    sv_validate_report r;
    assert_int_equal(sv_validate(m, NULL, &r, NULL), SV_OK);
    assert_int_equal(r.removed_duplicate, n / 2);
    assert_int_equal(m->triangle_count, n / 2);
    sv_mesh_destroy(m);
}

static void null_mesh_is_an_error_not_a_crash(void **state)
{
    (void)state;
    sv_error err = {0};
    assert_int_equal(sv_validate(NULL, NULL, NULL, &err), SV_ERR_INTERNAL);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(valid_mesh_passes_unchanged),
        cmocka_unit_test(nan_vertex_is_rejected_by_number),
        cmocka_unit_test(infinite_vertex_is_rejected_by_number),
        cmocka_unit_test(out_of_range_index_names_triangle_and_vertex),
        cmocka_unit_test(out_of_range_material_is_rejected),
        cmocka_unit_test(material_texture_beyond_the_images_is_rejected),
        cmocka_unit_test(empty_mesh_is_rejected),
        cmocka_unit_test(zero_area_triangles_are_removed_and_counted),
        cmocka_unit_test(a_thin_but_real_triangle_is_kept),
        cmocka_unit_test(duplicate_triangles_are_removed_in_any_rotation_but_reversed_kept),
        cmocka_unit_test(all_degenerate_mesh_is_rejected_after_repair),
        cmocka_unit_test(counts_over_limits_are_refused),
        cmocka_unit_test(bad_normals_are_recomputed_and_others_normalised),
        cmocka_unit_test(many_duplicates_are_found_in_linear_time),
        cmocka_unit_test(null_mesh_is_an_error_not_a_crash),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
