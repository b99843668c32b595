/* test_stand_in.c — stand-in containers and quad geometry (core/stand_in.c). */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "stand_in.h"

static uint64_t rng_next(uint64_t *s)
{
    uint64_t z = (*s += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

static double rng_unit(uint64_t *s)
{
    return (double)(rng_next(s) >> 11) * 0x1.0p-53 * 2.0 - 1.0;
}

static double dot(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static sv_quad plane_quad(double nx, double ny, double nz, double d)
{
    sv_quad q;
    memset(&q, 0, sizeof q);
    double l = sqrt(nx * nx + ny * ny + nz * nz);
    q.normal[0] = nx / l;
    q.normal[1] = ny / l;
    q.normal[2] = nz / l;
    q.d = d;
    return q;
}

/* Frame invariants: unit orthogonal axes, u × v = n, centre on the plane, the
 * sign rule for u, and every point inside the rectangle (within tol). */
static void assert_encloses(const sv_quad *q, const double *pts, size_t n, double tol)
{
    assert_true(fabs(dot(q->axis_u, q->axis_u) - 1) < 1e-12);
    assert_true(fabs(dot(q->axis_v, q->axis_v) - 1) < 1e-12);
    assert_true(fabs(dot(q->axis_u, q->axis_v)) < 1e-12);
    double c[3] = {q->axis_u[1] * q->axis_v[2] - q->axis_u[2] * q->axis_v[1],
                   q->axis_u[2] * q->axis_v[0] - q->axis_u[0] * q->axis_v[2],
                   q->axis_u[0] * q->axis_v[1] - q->axis_u[1] * q->axis_v[0]};
    assert_true(dot(c, q->normal) > 1 - 1e-12);
    double scale = 1 + sqrt(dot(q->centre, q->centre));
    assert_true(fabs(dot(q->normal, q->centre) + q->d) < 1e-9 * scale);
    int big = 0;
    for (int k = 1; k < 3; k++)
        if (fabs(q->axis_u[k]) > fabs(q->axis_u[big])) big = k;
    assert_true(q->axis_u[big] > 0);
    assert_true(q->half_u >= q->half_v);
    for (size_t i = 0; i < n; i++) {
        double d[3] = {pts[3 * i] - q->centre[0], pts[3 * i + 1] - q->centre[1],
                       pts[3 * i + 2] - q->centre[2]};
        assert_true(fabs(dot(d, q->axis_u)) <= q->half_u + tol);
        assert_true(fabs(dot(d, q->axis_v)) <= q->half_v + tol);
    }
}

static void fit_points_square_in_xy_plane(void **state)
{
    (void)state;
    double pts[] = {-1, -1, 0, 1, -1, 0, 1, 1, 0, -1, 1, 0, 0, 0, 0};
    sv_quad q = plane_quad(0, 0, 1, 0);
    sv_quad_fit_points(&q, pts, 5);
    assert_true(fabs(q.half_u - 1) < 1e-12 && fabs(q.half_v - 1) < 1e-12);
    assert_true(fabs(q.centre[0]) < 1e-12 && fabs(q.centre[1]) < 1e-12);
    assert_encloses(&q, pts, 5, 1e-9);
}

static void fit_points_finds_rotated_rectangle(void **state)
{
    (void)state;
    /* A 4 × 1 rectangle turned by 30° about z, with interior points. */
    double a = M_PI / 6, ux = cos(a), uy = sin(a), pts[3 * 9];
    const double su[9] = {-2, 2, 2, -2, 0, 1, -1, 0.5, 1.9};
    const double sv[9] = {-0.5, -0.5, 0.5, 0.5, 0, 0.2, -0.3, 0.4, -0.1};
    for (int i = 0; i < 9; i++) {
        pts[3 * i] = 3 + su[i] * ux - sv[i] * uy;
        pts[3 * i + 1] = -1 + su[i] * uy + sv[i] * ux;
        pts[3 * i + 2] = 7;
    }
    sv_quad q = plane_quad(0, 0, 1, -7);
    sv_quad_fit_points(&q, pts, 9);
    assert_true(fabs(q.half_u - 2) < 1e-9);
    assert_true(fabs(q.half_v - 0.5) < 1e-9);
    assert_true(fabs(q.axis_u[0] - ux) < 1e-9 && fabs(q.axis_u[1] - uy) < 1e-9);
    assert_true(fabs(q.centre[0] - 3) < 1e-9 && fabs(q.centre[1] + 1) < 1e-9);
    assert_true(fabs(q.centre[2] - 7) < 1e-9);
    assert_encloses(&q, pts, 9, 1e-9);
}

/* The minimum-area rectangle has a side along some pair direction, so trying
 * every pair of points is an exact (slow) reference. */
static double brute_min_area(const double *p2, size_t n)
{
    double best = INFINITY;
    for (size_t i = 0; i < n; i++)
        for (size_t j = i + 1; j < n; j++) {
            double ex = p2[2 * j] - p2[2 * i], ey = p2[2 * j + 1] - p2[2 * i + 1];
            double l = sqrt(ex * ex + ey * ey);
            if (!(l > 0)) continue;
            ex /= l;
            ey /= l;
            double a0 = INFINITY, a1 = -INFINITY, b0 = INFINITY, b1 = -INFINITY;
            for (size_t k = 0; k < n; k++) {
                double a = p2[2 * k] * ex + p2[2 * k + 1] * ey;
                double b = -p2[2 * k] * ey + p2[2 * k + 1] * ex;
                if (a < a0) a0 = a;
                if (a > a1) a1 = a;
                if (b < b0) b0 = b;
                if (b > b1) b1 = b;
            }
            double area = (a1 - a0) * (b1 - b0);
            if (area < best) best = area;
        }
    return best;
}

static void fit_points_matches_brute_force_minimum_area(void **state)
{
    (void)state;
    uint64_t seed = 42;
    for (int trial = 0; trial < 40; trial++) {
        size_t n = 3 + (size_t)(rng_next(&seed) % 60);
        double pts[3 * 64], p2[2 * 64];
        double sx = 1 + 3 * fabs(rng_unit(&seed)), sy = 0.2 + fabs(rng_unit(&seed));
        for (size_t i = 0; i < n; i++) {
            p2[2 * i] = sx * rng_unit(&seed);
            p2[2 * i + 1] = sy * rng_unit(&seed);
            /* The plane y = 2 (normal +Y): x, z carry the 2D points. */
            pts[3 * i] = p2[2 * i];
            pts[3 * i + 1] = 2;
            pts[3 * i + 2] = p2[2 * i + 1];
        }
        sv_quad q = plane_quad(0, 1, 0, -2);
        sv_quad_fit_points(&q, pts, n);
        double ref = brute_min_area(p2, n);
        double got = 4 * q.half_u * q.half_v;
        assert_true(fabs(got - ref) <= 1e-9 * ref);
        assert_encloses(&q, pts, n, 1e-9);
    }
}

static void fit_points_one_point_gets_small_extent(void **state)
{
    (void)state;
    double pts[] = {10, 20, 30};
    sv_quad q = plane_quad(1, 0, 0, -10);
    sv_quad_fit_points(&q, pts, 1);
    double c = sqrt(10.0 * 10 + 20 * 20 + 30 * 30);
    assert_true(fabs(q.half_u - 1e-6 * c) < 1e-12 && fabs(q.half_v - 1e-6 * c) < 1e-12);
    assert_true(fabs(q.centre[1] - 20) < 1e-12 && fabs(q.centre[2] - 30) < 1e-12);
    assert_encloses(&q, pts, 1, 1e-12);
}

static void fit_points_duplicates_and_collinear_points_give_thin_rectangle(void **state)
{
    (void)state;
    /* Five points on a line (with duplicates), along (1,1,0)/√2 in z = 0. */
    double pts[] = {0, 0, 0, 1, 1, 0, 1, 1, 0, 2, 2, 0, 2, 2, 0, 0.5, 0.5, 0};
    sv_quad q = plane_quad(0, 0, 1, 0);
    sv_quad_fit_points(&q, pts, 6);
    assert_true(fabs(q.half_u - sqrt(2.0)) < 1e-12);
    assert_true(fabs(q.half_v - 1e-3 * sqrt(2.0)) < 1e-12);
    assert_true(fabs(q.axis_u[0] - q.axis_u[1]) < 1e-12 && q.axis_u[0] > 0);
    assert_encloses(&q, pts, 6, 1e-12);
    /* Two points only. */
    sv_quad q2 = plane_quad(0, 0, 1, 0);
    sv_quad_fit_points(&q2, pts, 2);
    assert_true(fabs(q2.half_u - sqrt(0.5)) < 1e-12);
    assert_true(q2.half_v > 0);
}

static void fit_points_all_coincident_points_stay_finite(void **state)
{
    (void)state;
    double pts[] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
    sv_quad q = plane_quad(0, 1, 0, 0);
    sv_quad_fit_points(&q, pts, 3);
    assert_true(q.half_u > 0 && q.half_v > 0 && isfinite(q.half_u));
    assert_encloses(&q, pts, 3, 1e-12);
}

static void fit_points_no_points_gives_zero_extent_on_plane(void **state)
{
    (void)state;
    sv_quad q = plane_quad(0, 0, 1, -3);
    sv_quad_fit_points(&q, NULL, 0);
    assert_true(q.half_u == 0 && q.half_v == 0);
    assert_true(fabs(q.centre[2] - 3) < 1e-12);
}

static void fit_points_is_invariant_to_offset_and_scale(void **state)
{
    (void)state;
    uint64_t seed = 7;
    double base[3 * 30], moved[3 * 30];
    for (int i = 0; i < 30; i++) {
        base[3 * i] = rng_unit(&seed);
        base[3 * i + 1] = 0.3 * rng_unit(&seed);
        base[3 * i + 2] = 0;
    }
    sv_quad q = plane_quad(0, 0, 1, 0);
    sv_quad_fit_points(&q, base, 30);
    const double off = 1e6, s = 1e-4;
    for (int i = 0; i < 30; i++) {
        moved[3 * i] = base[3 * i] * s + off;
        moved[3 * i + 1] = base[3 * i + 1] * s - off;
        moved[3 * i + 2] = off;
    }
    sv_quad m = plane_quad(0, 0, 1, -off);
    sv_quad_fit_points(&m, moved, 30);
    /* Doubles at 1e6 resolve ~1.2e-10, i.e. ~1e-6 of these 1e-4-sized extents. */
    assert_true(fabs(m.half_u - s * q.half_u) < 1e-5 * s);
    assert_true(fabs(m.half_v - s * q.half_v) < 1e-5 * s);
    for (int k = 0; k < 3; k++) assert_true(fabs(m.axis_u[k] - q.axis_u[k]) < 1e-4);
    assert_true(fabs(m.centre[0] - (q.centre[0] * s + off)) < 1e-5 * s);
    assert_encloses(&m, moved, 30, 1e-5 * s);
}

static void corners_run_counter_clockwise_from_minus_u_minus_v(void **state)
{
    (void)state;
    sv_quad q = plane_quad(0, 0, 1, 0);
    q.centre[0] = 1;
    q.axis_u[0] = 1;
    q.axis_v[1] = 1;
    q.half_u = 2;
    q.half_v = 1;
    double c[4][3];
    sv_quad_corners(&q, c);
    const double want[4][2] = {{-1, -1}, {3, -1}, {3, 1}, {-1, 1}};
    for (int i = 0; i < 4; i++) {
        assert_true(c[i][0] == want[i][0] && c[i][1] == want[i][1] && c[i][2] == 0);
    }
}

static void stand_in_grows_and_frees_lods_and_quads(void **state)
{
    (void)state;
    sv_stand_in s;
    memset(&s, 0, sizeof s);
    for (int l = 0; l < 5; l++) {
        char name[32];
        snprintf(name, sizeof name, "lod%d", l);
        sv_lod_plan *lod = sv_stand_in_add_lod(&s, name);
        assert_non_null(lod);
        assert_string_equal(lod->name, name);
        assert_int_equal(lod->trunk, SV_TRUNK_NONE);
        for (uint32_t i = 0; i < 37; i++) {
            sv_quad q;
            memset(&q, 0, sizeof q);
            q.group = (int32_t)i;
            q.faces = malloc(3 * sizeof *q.faces);
            q.face_count = 3;
            if (i % 2) q.bake_faces = malloc(sizeof *q.bake_faces);
            assert_int_equal(sv_lod_add_quad(lod, &q, NULL), SV_OK);
        }
    }
    assert_int_equal(s.lod_count, 5);
    for (int l = 0; l < 5; l++) {
        assert_int_equal(s.lods[l].quad_count, 37);
        for (int i = 0; i < 37; i++) assert_int_equal(s.lods[l].quads[i].group, i);
    }
    s.lods[2].geometry = sv_mesh_create(3, 1, 1, 0);
    sv_stand_in_free(&s); /* ASan reports any leak */
    assert_int_equal(s.lod_count, 0);
    assert_null(s.lods);
    sv_stand_in_free(NULL);
}

static void add_lod_truncates_long_names(void **state)
{
    (void)state;
    sv_stand_in s;
    memset(&s, 0, sizeof s);
    sv_lod_plan *lod = sv_stand_in_add_lod(&s, "a-very-long-lod-name-that-does-not-fit-in-32");
    assert_non_null(lod);
    assert_int_equal(strlen(lod->name), sizeof lod->name - 1);
    sv_stand_in_free(&s);
}

/* sv_lod_flatten: each quad's faces (bake_faces, else assigned faces) land on
 * its plane with their in-plane position, uvs, normals and material kept; a
 * face of two quads appears twice, a face of none not at all. */
static void flatten_projects_each_quads_faces_onto_its_plane(void **state)
{
    (void)state;
    sv_mesh *m = sv_mesh_create(12, 4, 2, 0);
    assert_non_null(m);
    uint64_t rs = 7;
    for (uint32_t v = 0; v < 12; v++) {
        for (int a = 0; a < 3; a++) m->positions[3 * v + a] = (float)(2.0 * rng_unit(&rs));
        m->normals[3 * v + 1] = 1;
        m->uvs[2 * v] = (float)v / 12.0f;
        m->uvs[2 * v + 1] = 1.0f - (float)v / 12.0f;
    }
    for (uint32_t i = 0; i < 12; i++) m->indices[i] = i;
    for (uint32_t t = 0; t < 4; t++) m->tri_material[t] = t % 2;
    m->materials[1].alpha_mode = SV_ALPHA_MASK;
    m->materials[1].alpha_cutoff = 0.3f;

    sv_stand_in si;
    memset(&si, 0, sizeof si);
    sv_lod_plan *lod = sv_stand_in_add_lod(&si, "lod0");
    assert_non_null(lod);
    sv_quad a = plane_quad(0, 1, 0, -0.5); /* y = 0.5, bakes faces 0 and 1 */
    a.bake_faces = malloc(2 * sizeof *a.bake_faces);
    a.faces = malloc(sizeof *a.faces); /* assigned faces are ignored with bake_faces */
    assert_true(a.bake_faces && a.faces);
    a.bake_faces[0] = 0, a.bake_faces[1] = 1, a.bake_face_count = 2;
    a.faces[0] = 3, a.face_count = 1;
    assert_int_equal(sv_lod_add_quad(lod, &a, NULL), SV_OK);
    sv_quad b = plane_quad(1, 1, 0, 0.25); /* oblique, no bake_faces: faces 1 and 2 */
    b.faces = malloc(2 * sizeof *b.faces);
    assert_non_null(b.faces);
    b.faces[0] = 1, b.faces[1] = 2, b.face_count = 2;
    assert_int_equal(sv_lod_add_quad(lod, &b, NULL), SV_OK);

    sv_mesh *f = NULL;
    sv_error err;
    assert_int_equal(sv_lod_flatten(m, lod, &f, &err), SV_OK);
    assert_non_null(f);
    const uint32_t src_face[4] = {0, 1, 1, 2};
    const int quad_of[4] = {0, 0, 1, 1};
    assert_int_equal(f->triangle_count, 4);
    assert_int_equal(f->vertex_count, 12);
    assert_int_equal(f->material_count, 2);
    assert_true(f->materials[1].alpha_mode == SV_ALPHA_MASK);
    for (uint32_t t = 0; t < 4; t++) {
        const sv_quad *q = &lod->quads[quad_of[t]];
        assert_int_equal(f->tri_material[t], m->tri_material[src_face[t]]);
        for (int c = 0; c < 3; c++) {
            uint32_t o = f->indices[3 * t + c], v = m->indices[3 * src_face[t] + c];
            double p[3], s[3], dp[3];
            for (int k = 0; k < 3; k++) {
                p[k] = f->positions[3 * o + k];
                s[k] = m->positions[3 * v + k];
                dp[k] = s[k] - p[k];
            }
            assert_true(fabs(dot(q->normal, p) + q->d) < 1e-6); /* on the plane */
            /* moved along the normal only: the in-plane position is kept */
            double along = dot(dp, q->normal);
            for (int k = 0; k < 3; k++) assert_true(fabs(dp[k] - along * q->normal[k]) < 1e-6);
            assert_true(f->uvs[2 * o] == m->uvs[2 * v] && f->uvs[2 * o + 1] == m->uvs[2 * v + 1]);
            assert_true(f->normals[3 * o + 1] == 1.0f);
        }
    }
    sv_mesh_destroy(f);

    sv_lod_plan *empty = sv_stand_in_add_lod(&si, "none");
    assert_non_null(empty);
    assert_int_equal(sv_lod_flatten(m, empty, &f, &err), SV_OK);
    assert_int_equal(f->triangle_count, 0);
    sv_mesh_destroy(f);
    sv_stand_in_free(&si);
    sv_mesh_destroy(m);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(fit_points_square_in_xy_plane),
        cmocka_unit_test(fit_points_finds_rotated_rectangle),
        cmocka_unit_test(fit_points_matches_brute_force_minimum_area),
        cmocka_unit_test(fit_points_one_point_gets_small_extent),
        cmocka_unit_test(fit_points_duplicates_and_collinear_points_give_thin_rectangle),
        cmocka_unit_test(fit_points_all_coincident_points_stay_finite),
        cmocka_unit_test(fit_points_no_points_gives_zero_extent_on_plane),
        cmocka_unit_test(fit_points_is_invariant_to_offset_and_scale),
        cmocka_unit_test(corners_run_counter_clockwise_from_minus_u_minus_v),
        cmocka_unit_test(stand_in_grows_and_frees_lods_and_quads),
        cmocka_unit_test(add_lod_truncates_long_names),
        cmocka_unit_test(flatten_projects_each_quads_faces_onto_its_plane),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
