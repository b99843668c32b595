/* test_plausibility.c — the up-axis detector and the size warnings
 * (plausibility.h): a synthetic Y-up tree is left alone, the same tree turned
 * Z-up (and upside down along Z) is recognised and turned back upright. */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "classify.h"
#include "plausibility.h"

#define SEG 12
#define LEAVES 60

/* A Y-up tree: a trunk cylinder (radius 0.15, y 0..2, SEG segments) and
 * LEAVES leaf quads scattered in a crown 3 m wide at y 1.5..3.5. *part gets
 * the triangles' parts (trunk first). */
static sv_mesh *tree(uint8_t **part)
{
    uint32_t tv = 2 * SEG, tt = 2 * SEG;
    sv_mesh *m = sv_mesh_create(tv + 4 * LEAVES, tt + 2 * LEAVES, 1, 0);
    assert_non_null(m);
    *part = calloc(m->triangle_count, 1);
    assert_non_null(*part);
    for (uint32_t i = 0; i < SEG; i++) {
        double a = 2 * M_PI * i / SEG;
        for (int k = 0; k < 2; k++) {
            float *p = &m->positions[3 * (2 * i + k)];
            p[0] = (float)(0.15 * cos(a)), p[1] = (float)(2.0 * k), p[2] = (float)(0.15 * sin(a));
        }
        uint32_t a0 = 2 * i, a1 = a0 + 1, b0 = 2 * ((i + 1) % SEG), b1 = b0 + 1;
        uint32_t *t = &m->indices[6 * i];
        t[0] = a0, t[1] = b0, t[2] = b1, t[3] = a0, t[4] = b1, t[5] = a1;
        (*part)[2 * i] = (*part)[2 * i + 1] = SV_PART_TRUNK;
    }
    uint64_t s = 7;
    for (uint32_t l = 0; l < LEAVES; l++) {
        double c[3];
        for (int k = 0; k < 3; k++) {
            s = s * 6364136223846793005ull + 1442695040888963407ull;
            c[k] = (double)(s >> 11) / 9007199254740992.0;
        }
        double x = 3 * c[0] - 1.5, y = 1.5 + 2 * c[1], z = 3 * c[2] - 1.5;
        static const float q[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
        for (int i = 0; i < 4; i++) {
            float *p = &m->positions[3 * (tv + 4 * l + i)];
            p[0] = (float)(x + 0.1 * q[i][0]), p[1] = (float)(y + 0.1 * q[i][1]), p[2] = (float)z;
        }
        uint32_t b = tv + 4 * l, *t = &m->indices[3 * (tt + 2 * l)];
        t[0] = b, t[1] = b + 1, t[2] = b + 2, t[3] = b, t[4] = b + 2, t[5] = b + 3;
        (*part)[tt + 2 * l] = (*part)[tt + 2 * l + 1] = SV_PART_FOLIAGE;
    }
    sv_mesh_compute_normals(m);
    return m;
}

/* What a Z-up exporter writes, read as Y-up: (x, y, z) -> (x, -z, y). */
static void to_z_up(sv_mesh *m, float sign)
{
    for (uint32_t v = 0; v < m->vertex_count; v++) {
        float *p = &m->positions[3 * v], y = p[1], z = p[2];
        p[1] = -sign * z, p[2] = sign * y;
    }
}

static void y_up_tree_is_left_alone(void **state)
{
    (void)state;
    uint8_t *part;
    sv_mesh *m = tree(&part);
    sv_up_guess g;
    sv_detect_up(m, part, &g);
    assert_int_equal(g.z_up, 0);
    assert_true(g.height > 3.3 && g.height <= 3.6);
    char w[512] = "";
    sv_plausibility_warnings(&g, g.height, false, w, sizeof w);
    assert_string_equal(w, "");
    sv_mesh_destroy(m);
    free(part);
}

static void z_up_tree_is_found_and_turned_upright(void **state)
{
    (void)state;
    uint8_t *part, *part2;
    sv_mesh *m = tree(&part), *ref = tree(&part2);
    free(part2);
    to_z_up(m, 1);
    sv_up_guess g;
    sv_detect_up(m, part, &g);
    assert_int_equal(g.z_up, 1);
    assert_true(g.height > 3.3 && g.height <= 3.6);
    assert_non_null(strstr(g.reason, "lowest Z"));
    char w[512] = "";
    sv_plausibility_warnings(&g, g.height, false, w, sizeof w);
    assert_non_null(strstr(w, "looks Z-up"));
    assert_non_null(strstr(w, "import.up"));
    /* rotated: no warning, and the tree stands as it was built */
    w[0] = 0;
    sv_plausibility_warnings(&g, g.height, true, w, sizeof w);
    assert_string_equal(w, "");
    sv_mesh_rotate_up(m, g.z_up);
    for (uint32_t i = 0; i < 3 * m->vertex_count; i++)
        assert_float_equal(m->positions[i], ref->positions[i], 1e-6);
    sv_detect_up(m, part, &g);
    assert_int_equal(g.z_up, 0);
    sv_mesh_destroy(m);
    sv_mesh_destroy(ref);
    free(part);
}

static void tree_with_its_base_at_the_highest_z_is_turned_the_other_way(void **state)
{
    (void)state;
    uint8_t *part;
    sv_mesh *m = tree(&part);
    to_z_up(m, -1);
    sv_up_guess g;
    sv_detect_up(m, part, &g);
    assert_int_equal(g.z_up, -1);
    sv_mesh_rotate_up(m, g.z_up);
    double mn[3], mx[3];
    sv_mesh_bounds(m, mn, mx);
    assert_float_equal(mn[1], 0.0, 1e-6); /* trunk base back at the bottom */
    sv_detect_up(m, part, &g);
    assert_int_equal(g.z_up, 0);
    sv_mesh_destroy(m);
    free(part);
}

static void no_trunk_means_no_guess(void **state)
{
    (void)state;
    uint8_t *part;
    sv_mesh *m = tree(&part);
    to_z_up(m, 1);
    memset(part, SV_PART_FOLIAGE, m->triangle_count);
    sv_up_guess g;
    sv_detect_up(m, part, &g);
    assert_int_equal(g.z_up, 0);
    assert_non_null(strstr(g.reason, "no trunk"));
    sv_mesh_destroy(m);
    free(part);
}

static void heights_outside_5cm_to_150m_are_warned_about(void **state)
{
    (void)state;
    sv_up_guess g = {0};
    char w[512] = "";
    sv_plausibility_warnings(&g, 151, false, w, sizeof w);
    assert_non_null(strstr(w, "151 m tall"));
    assert_non_null(strstr(w, "import.units"));
    w[0] = 0;
    sv_plausibility_warnings(&g, 0.04, false, w, sizeof w);
    assert_non_null(strstr(w, "0.04 m tall"));
    w[0] = 0;
    sv_plausibility_warnings(&g, 0.05, false, w, sizeof w);
    sv_plausibility_warnings(&g, 150, false, w, sizeof w);
    assert_string_equal(w, "");
    /* appends after what is there, truncating rather than overflowing */
    char small[24] = "first";
    sv_plausibility_warnings(&g, 1000, false, small, sizeof small);
    assert_int_equal(strncmp(small, "first\nthe tree is", 17), 0);
    assert_int_equal(strlen(small), sizeof small - 1);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(y_up_tree_is_left_alone),
        cmocka_unit_test(z_up_tree_is_found_and_turned_upright),
        cmocka_unit_test(tree_with_its_base_at_the_highest_z_is_turned_the_other_way),
        cmocka_unit_test(no_trunk_means_no_guess),
        cmocka_unit_test(heights_outside_5cm_to_150m_are_warned_about),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
