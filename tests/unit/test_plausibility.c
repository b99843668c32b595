/* test_plausibility.c — the up-axis detector and the size warnings
 * (plausibility.h): a synthetic Y-up tree is left alone, the same tree turned
 * Z-up (and upside down along Z) is recognised and turned back upright; a
 * Y-up weeping tree whose branches hang below its base and the tree flattened
 * to z = 0 (a cut-out) are not taken for Z-up; a trunk whose axis cannot be
 * told keeps the file's axis with a warning; a rotation is always said. */
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
    char w[1024] = "";
    sv_plausibility_warnings(&g, g.height, false, w, sizeof w);
    assert_non_null(strstr(w, "looks Z-up"));
    assert_non_null(strstr(w, "import.up"));
    /* rotated: said, not warned as lying down; the tree stands as it was built */
    w[0] = 0;
    sv_plausibility_warnings(&g, g.height, true, w, sizeof w);
    assert_null(strstr(w, "would bake lying down"));
    assert_non_null(strstr(w, "rotated the tree upright"));
    float before[3];
    memcpy(before, m->positions, sizeof before);
    sv_mesh_rotate_up(m, g.z_up);
    for (uint32_t i = 0; i < 3 * m->vertex_count; i++)
        assert_float_equal(m->positions[i], ref->positions[i], 1e-6);
    /* the local frame's origin turns as the vertices do */
    for (int s = -1; s <= 1; s += 2) {
        double p[3] = {before[0], before[1], before[2]};
        float q[3] = {before[0], before[1], before[2]};
        sv_point_rotate_up(p, s);
        sv_mesh *one = sv_mesh_create(1, 0, 1, 0);
        assert_non_null(one);
        memcpy(one->positions, q, sizeof q);
        sv_mesh_rotate_up(one, s);
        for (int k = 0; k < 3; k++) assert_float_equal(p[k], one->positions[k], 1e-6);
        sv_mesh_destroy(one);
    }
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

/* The synthetic tree's leaves as sv_leaves_build would count them: LEAVES
 * cards of two triangles, 0.2 x 0.2 m (scaled by s). */
static sv_leaves cards(double s)
{
    sv_leaves l = {0};
    l.count = LEAVES;
    l.tri_count = 2 * LEAVES;
    l.median_area = l.max_area = 0.04 * s * s;
    return l;
}

static void scale_mesh(sv_mesh *m, double s)
{
    for (uint32_t v = 0; v < 3 * m->vertex_count; v++)
        m->positions[v] = (float)(s * m->positions[v]);
}

/* The units check: a 3.5 m tree with a 0.3 m trunk and 0.2 m cards is
 * plausible in metres; the same numbers read in centimetres (a file in m
 * given "cm") and in metres from a file in mm (x1000) are not, and each
 * names the unit that makes them a tree again; a leaf card of 20 m^2 is
 * implausible however tall the tree; the report reads the figures. */
static void units_judged_from_height_leaves_and_trunk_together(void **state)
{
    (void)state;
    uint8_t *part;
    sv_mesh *m = tree(&part);
    sv_leaves l = cards(1);
    sv_units_guess u;
    sv_check_units(m, part, &l, 1.0, 3.5, &u);
    assert_false(u.implausible);
    assert_true(u.factor == 1);
    assert_true(fabs(u.trunk_diameter - 0.3) < 0.02); /* the cylinder's, 2 x 0.15 */
    assert_true(fabs(u.leaf_size - 0.2) < 1e-9);
    char w[1024] = "";
    sv_units_warning(&u, w, sizeof w);
    assert_string_equal(w, "");
    /* a file in m given "cm": 3.5 cm tall, 2 mm cards, a 3 mm trunk */
    scale_mesh(m, 0.01);
    l = cards(0.01);
    sv_check_units(m, part, &l, 0.01, 0.035, &u);
    assert_true(u.implausible);
    assert_string_equal(u.unit, "m");
    assert_true(fabs(u.factor - 100) < 1e-9);
    assert_true(fabs(u.metres_per_unit - 1) < 1e-12);
    sv_units_warning(&u, w, sizeof w);
    assert_non_null(strstr(w, "the units look wrong"));
    assert_non_null(strstr(w, "--units m (spec \"import\": {\"units\": \"m\"})"));
    /* a file in mm read as m: 3.5 km tall */
    scale_mesh(m, 1e5);
    l = cards(1000);
    sv_check_units(m, part, &l, 1.0, 3500, &u);
    assert_true(u.implausible);
    assert_string_equal(u.unit, "mm");
    assert_non_null(strstr(u.reason, "3.5e+03 m tall"));
    /* a 20 m^2 card on a tree of a plausible height: implausible still */
    scale_mesh(m, 1e-3);
    l = cards(1);
    l.median_area = 20;
    sv_check_units(m, part, &l, 1.0, 3.5, &u);
    assert_true(u.implausible);
    assert_non_null(strstr(u.reason, "4.47 m across its median leaf element"));
    /* no unit brings a 1 km tree with 1 mm leaves in range: said, no unit named */
    l.median_area = 1e-6;
    sv_check_units(NULL, NULL, &l, 1.0, 1000, &u);
    assert_true(u.implausible);
    assert_true(u.factor == 0);
    w[0] = 0;
    sv_units_warning(&u, w, sizeof w);
    assert_non_null(strstr(w, "no unit makes"));
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

/* A tube of SEG sides from a to b (radius r), its triangles marked trunk. */
static void add_tube(sv_mesh *m, uint8_t *part, uint32_t *nv, uint32_t *nt, const double a[3],
                     const double b[3], double r)
{
    double d[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    double l = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    for (int k = 0; k < 3; k++) d[k] /= l;
    double h[3] = {0, 1, 0};
    if (fabs(d[1]) > 0.9) h[0] = 1, h[1] = 0;
    double u[3] = {d[1] * h[2] - d[2] * h[1], d[2] * h[0] - d[0] * h[2], d[0] * h[1] - d[1] * h[0]};
    double lu = sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
    for (int k = 0; k < 3; k++) u[k] /= lu;
    double w[3] = {d[1] * u[2] - d[2] * u[1], d[2] * u[0] - d[0] * u[2], d[0] * u[1] - d[1] * u[0]};
    uint32_t v0 = *nv;
    for (int e = 0; e < 2; e++)
        for (uint32_t i = 0; i < SEG; i++) {
            double t = 2 * M_PI * i / SEG;
            float *p = &m->positions[3 * (*nv)++];
            for (int k = 0; k < 3; k++)
                p[k] = (float)((e ? b[k] : a[k]) + r * (cos(t) * u[k] + sin(t) * w[k]));
        }
    for (uint32_t i = 0; i < SEG; i++) {
        uint32_t j = (i + 1) % SEG, *t = &m->indices[3 * (size_t)*nt];
        t[0] = v0 + i, t[1] = v0 + j, t[2] = v0 + SEG + j;
        t[3] = v0 + i, t[4] = v0 + SEG + j, t[5] = v0 + SEG + i;
        part[*nt] = part[*nt + 1] = SV_PART_TRUNK;
        *nt += 2;
    }
}

#define WEEP 24

/* A Y-up weeping tree (tests/tools/willow_tree.py in C): a trunk from y 0 to
 * 3 and WEEP branches arching out from its top and hanging down past its
 * base to y = -0.6, on every side of it. Trunk only: leaves play no part. */
static sv_mesh *weeping_tree(uint8_t **part)
{
    uint32_t tubes = 1 + 4 * WEEP;
    sv_mesh *m = sv_mesh_create(2 * SEG * tubes, 2 * SEG * tubes, 1, 0);
    assert_non_null(m);
    *part = calloc(m->triangle_count, 1);
    assert_non_null(*part);
    uint32_t nv = 0, nt = 0;
    add_tube(m, *part, &nv, &nt, (double[3]){0, 0, 0}, (double[3]){0, 3, 0}, 0.17);
    for (uint32_t k = 0; k < WEEP; k++) {
        double a = 2 * M_PI * (k + 0.3 * sin(7.0 * k)) / WEEP, c = cos(a), s = sin(a);
        double reach = 2.0 + 0.4 * sin(3.0 * k);
        double pts[5][3] = {{0, 3, 0},
                            {0.5 * reach * c, 3.5, 0.5 * reach * s},
                            {reach * c, 3.3, reach * s},
                            {1.05 * reach * c, 1.5, 1.05 * reach * s},
                            {1.08 * reach * c, -0.6, 1.08 * reach * s}};
        for (int i = 0; i < 4; i++) add_tube(m, *part, &nv, &nt, pts[i], pts[i + 1], 0.04);
    }
    sv_mesh_compute_normals(m);
    return m;
}

static void weeping_tree_with_branches_below_its_base_is_y_up(void **state)
{
    (void)state;
    uint8_t *part;
    sv_mesh *m = weeping_tree(&part);
    double mn[3], mx[3];
    sv_mesh_bounds(m, mn, mx);
    assert_true(mn[1] < -0.5); /* the hanging tips, not the trunk, are the lowest Y */
    sv_up_guess g;
    sv_detect_up(m, part, &g);
    assert_int_equal(g.z_up, 0);
    assert_false(g.unsure);
    assert_float_equal(g.height, mx[1] - mn[1], 1e-9);
    char w[1024] = "";
    sv_plausibility_warnings(&g, g.height, false, w, sizeof w);
    assert_string_equal(w, "");
    sv_mesh_destroy(m);
    free(part);
}

static void flat_cut_out_tree_is_y_up_and_as_tall_as_it_is(void **state)
{
    (void)state;
    uint8_t *part;
    sv_mesh *m = tree(&part);
    for (uint32_t v = 0; v < m->vertex_count; v++) m->positions[3 * v + 2] = 0;
    sv_mesh_compute_normals(m);
    sv_up_guess g;
    sv_detect_up(m, part, &g);
    assert_int_equal(g.z_up, 0);
    assert_false(g.unsure);
    assert_true(g.height > 3.3 && g.height <= 3.6);
    sv_mesh_destroy(m);
    free(part);
}

static void unclear_trunk_keeps_the_axis_and_says_so(void **state)
{
    (void)state;
    /* a trunk along Z of the same thickness from end to end: its axis is
     * clear, its root is not */
    sv_mesh *m = sv_mesh_create(10 * 2 * SEG, 10 * 2 * SEG, 1, 0);
    assert_non_null(m);
    uint8_t *part = calloc(m->triangle_count, 1);
    assert_non_null(part);
    uint32_t nv = 0, nt = 0;
    for (int i = 0; i < 10; i++)
        add_tube(m, part, &nv, &nt, (double[3]){0, 0, 0.2 * i}, (double[3]){0, 0, 0.2 * (i + 1)},
                 0.1);
    sv_up_guess g;
    sv_detect_up(m, part, &g);
    assert_int_equal(g.z_up, 0);
    assert_true(g.unsure);
    char w[1024] = "";
    sv_plausibility_warnings(&g, 2, false, w, sizeof w);
    assert_non_null(strstr(w, "could not be told"));
    assert_non_null(strstr(w, "import.up"));
    sv_mesh_destroy(m);
    free(part);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(y_up_tree_is_left_alone),
        cmocka_unit_test(z_up_tree_is_found_and_turned_upright),
        cmocka_unit_test(tree_with_its_base_at_the_highest_z_is_turned_the_other_way),
        cmocka_unit_test(no_trunk_means_no_guess),
        cmocka_unit_test(heights_outside_5cm_to_150m_are_warned_about),
        cmocka_unit_test(units_judged_from_height_leaves_and_trunk_together),
        cmocka_unit_test(weeping_tree_with_branches_below_its_base_is_y_up),
        cmocka_unit_test(flat_cut_out_tree_is_y_up_and_as_tall_as_it_is),
        cmocka_unit_test(unclear_trunk_keeps_the_axis_and_says_so),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
