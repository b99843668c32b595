/* test_cluster.c — k-means over planes and the merge hierarchy (core/geom/cluster.c).
 * Leaf sets are written by hand as sv_leaf arrays; nothing here needs a mesh.
 * Tolerances: planes recovered to 1e-6 (coplanar input), transformed inputs
 * give planes within 1e-9 relative to the tree size (1e-8 at 1e6 offset) and
 * normalised error E/(W·R²) within 1e-8 relative. */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "cluster.h"

/* ---- helpers ---- */

static uint64_t rng_next(uint64_t *s)
{
    uint64_t z = (*s += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}
static double urand(uint64_t *s)
{
    return (double)(rng_next(s) >> 11) * 0x1.0p-53 * 2.0 - 1.0;
}

static void normalize(double v[3])
{
    double l = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    for (int j = 0; j < 3; j++) v[j] /= l;
}

static double dot(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static void set_leaf(sv_leaf *l, double x, double y, double z, double nx, double ny, double nz,
                     double area)
{
    memset(l, 0, sizeof *l);
    l->centre[0] = x, l->centre[1] = y, l->centre[2] = z;
    l->normal[0] = nx, l->normal[1] = ny, l->normal[2] = nz;
    normalize(l->normal);
    l->area = area;
    l->radius = sqrt(area);
    l->count = 1;
}

/* Two in-plane unit axes for normal n. */
static void plane_axes(const double n[3], double u[3], double v[3])
{
    double a[3] = {1, 0, 0};
    if (fabs(n[0]) > 0.9) a[0] = 0, a[1] = 1;
    u[0] = n[1] * a[2] - n[2] * a[1];
    u[1] = n[2] * a[0] - n[0] * a[2];
    u[2] = n[0] * a[1] - n[1] * a[0];
    normalize(u);
    v[0] = n[1] * u[2] - n[2] * u[1];
    v[1] = n[2] * u[0] - n[0] * u[2];
    v[2] = n[0] * u[1] - n[1] * u[0];
}

/* A random "crown": n leaves in a ball of radius 1 around (0, 2, 0), normals
 * biased upward like real foliage, areas varying. */
static sv_leaf *crown_bias(uint32_t n, uint64_t seed, double bias)
{
    sv_leaf *l = calloc(n, sizeof *l);
    uint64_t s = seed;
    for (uint32_t i = 0; i < n; i++) {
        double p[3];
        do {
            p[0] = urand(&s), p[1] = urand(&s), p[2] = urand(&s);
        } while (dot(p, p) > 1);
        double nn[3] = {urand(&s), urand(&s) + bias, urand(&s)};
        set_leaf(&l[i], p[0], p[1] + 2, p[2], nn[0], nn[1], nn[2], 0.001 * (1.5 + urand(&s)));
    }
    return l;
}

static sv_leaf *crown(uint32_t n, uint64_t seed)
{
    return crown_bias(n, seed, 0.8);
}

static void assert_finite_unit_planes(const sv_clusters *c)
{
    for (uint32_t l = 0; l < c->level_count; l++)
        for (uint32_t k = 0; k < c->levels[l].count; k++) {
            const sv_cluster_plane *p = &c->levels[l].planes[k];
            for (int j = 0; j < 3; j++) assert_true(isfinite(p->normal[j]));
            assert_true(isfinite(p->d) && isfinite(p->error) && isfinite(p->weight));
            assert_true(fabs(dot(p->normal, p->normal) - 1) < 1e-12);
            assert_true(p->error >= 0);
            assert_true(p->leaves >= 1);
        }
}

/* Parent links agree with the leaf assignments on every level. */
static void assert_hierarchy_consistent(const sv_clusters *c)
{
    for (uint32_t l = 0; l < c->level_count; l++) {
        const sv_cluster_level *lv = &c->levels[l];
        uint32_t total = 0;
        for (uint32_t k = 0; k < lv->count; k++) total += lv->planes[k].leaves;
        assert_int_equal(total, c->leaf_count);
        for (uint32_t i = 0; i < c->leaf_count; i++) assert_true(lv->assign[i] < lv->count);
        if (l + 1 == c->level_count) {
            for (uint32_t k = 0; k < lv->count; k++) assert_int_equal(lv->parent[k], -1);
        } else {
            const sv_cluster_level *up = &c->levels[l + 1];
            for (uint32_t i = 0; i < c->leaf_count; i++)
                assert_int_equal((uint32_t)lv->parent[lv->assign[i]], up->assign[i]);
            assert_true(up->error >= lv->error * (1 - 1e-12) - 1e-300);
        }
    }
}

static sv_clusters run(const sv_leaf *leaves, uint32_t n, const uint32_t *levels, uint32_t nlev,
                       double alpha, uint64_t seed)
{
    sv_cluster_options o = {.levels = levels, .level_count = nlev, .alpha = alpha, .seed = seed};
    sv_clusters c;
    sv_error e = {0};
    sv_status st = sv_cluster_build(leaves, n, &o, &c, &e);
    if (st != SV_OK) print_error("sv_cluster_build: %s\n", e.message);
    assert_int_equal(st, SV_OK);
    return c;
}

/* ---- behaviours ---- */

static void cluster_keeps_coplanar_leaves_in_one_plane(void **state)
{
    (void)state;
    double n0[3] = {0.3, 0.8, -0.2}, u[3], v[3];
    normalize(n0);
    plane_axes(n0, u, v);
    double d0 = -2.5; /* plane n0·x = 2.5: the origin is behind it */
    sv_leaf l[200];
    uint64_t s = 1;
    for (int i = 0; i < 200; i++) {
        double a = urand(&s) * 3, b = urand(&s) * 3, sg = (i % 3 == 0) ? -1 : 1;
        double p[3];
        for (int j = 0; j < 3; j++) p[j] = -d0 * n0[j] + a * u[j] + b * v[j];
        set_leaf(&l[i], p[0], p[1], p[2], sg * n0[0], sg * n0[1], sg * n0[2], 0.01);
    }
    const uint32_t levels[] = {1};
    double origin[3] = {0, 0, 0};
    sv_cluster_options o = {.levels = levels, .level_count = 1, .alpha = 0.01, .centre = origin};
    sv_clusters c;
    assert_int_equal(sv_cluster_build(l, 200, &o, &c, NULL), SV_OK);
    assert_int_equal(c.levels[0].count, 1);
    const sv_cluster_plane *p = &c.levels[0].planes[0];
    for (int j = 0; j < 3; j++) assert_true(fabs(p->normal[j] - n0[j]) < 1e-6);
    assert_true(fabs(p->d - d0) < 1e-6);
    assert_true(p->error < 1e-20);
    sv_clusters_free(&c);

    /* the same plane at 1e6 from the origin, fitted directly */
    for (int i = 0; i < 200; i++) l[i].centre[0] += 1e6;
    double nn[3], d, e;
    assert_int_equal(sv_cluster_fit_plane(l, NULL, 200, 0.01, false, origin, nn, &d, &e, NULL),
                     SV_OK);
    for (int j = 0; j < 3; j++) assert_true(fabs(nn[j] - n0[j]) < 1e-6);
    assert_true(fabs(d - (d0 - 1e6 * n0[0])) < 1e-6);
}

static void single_leaf_gives_its_own_plane_on_every_level(void **state)
{
    (void)state;
    sv_leaf l;
    set_leaf(&l, 1, 2, 3, 0, 0, 1, 0.5);
    sv_clusters c = run(&l, 1, NULL, 0, 0.01, 1);
    assert_int_equal(c.level_count, 3);
    for (uint32_t k = 0; k < 3; k++) {
        assert_int_equal(c.levels[k].count, 1);
        const sv_cluster_plane *p = &c.levels[k].planes[0];
        assert_true(fabs(fabs(p->normal[2]) - 1) < 1e-15);
        assert_true(fabs(dot(p->normal, l.centre) + p->d) < 1e-12);
        assert_true(p->error < 1e-24);
    }
    assert_int_equal(c.levels[0].parent[0], 0);
    assert_int_equal(c.levels[2].parent[0], -1);
    assert_hierarchy_consistent(&c);
    sv_clusters_free(&c);
}

static void two_leaves_split_then_merge(void **state)
{
    (void)state;
    sv_leaf l[2];
    set_leaf(&l[0], 0, 0, 0, 0, 1, 0, 1);
    set_leaf(&l[1], 5, 1, 0, 1, 0, 0, 1);
    const uint32_t levels[] = {2, 1};
    sv_clusters c = run(l, 2, levels, 2, 0.01, 3);
    assert_int_equal(c.levels[0].count, 2);
    assert_true(c.levels[0].error < 1e-24);
    assert_int_equal(c.levels[0].assign[0], 0);
    assert_int_equal(c.levels[0].assign[1], 1);
    assert_int_equal(c.levels[1].count, 1);
    assert_true(c.levels[1].error > 0);
    assert_finite_unit_planes(&c);
    assert_hierarchy_consistent(&c);
    sv_clusters_free(&c);
}

static void more_clusters_than_leaves_gives_one_cluster_per_leaf(void **state)
{
    (void)state;
    sv_leaf l[5];
    for (int i = 0; i < 5; i++) set_leaf(&l[i], i, i * i * 0.1, -i, 0.1 * i, 1, 0.3 - 0.2 * i, 0.1);
    sv_clusters c = run(l, 5, NULL, 0, 0.01, 9); /* 32, 16, 8 */
    for (uint32_t k = 0; k < 3; k++) {
        assert_int_equal(c.levels[k].count, 5);
        assert_true(c.levels[k].error < 1e-24);
    }
    for (int i = 0; i < 5; i++) assert_int_equal(c.levels[0].assign[i], (uint32_t)i);
    for (int k = 0; k < 5; k++) assert_int_equal(c.levels[0].parent[k], k);
    assert_finite_unit_planes(&c);
    assert_hierarchy_consistent(&c);
    sv_clusters_free(&c);
}

static void identical_leaves_collapse_into_one_cluster(void **state)
{
    (void)state;
    sv_leaf l[10];
    for (int i = 0; i < 10; i++) set_leaf(&l[i], 1, 1, 1, 0, 1, 1, 0.1);
    sv_clusters c = run(l, 10, NULL, 0, 0.01, 1);
    assert_int_equal(c.levels[0].count, 1);
    assert_int_equal(c.levels[0].planes[0].leaves, 10);
    assert_finite_unit_planes(&c);
    sv_clusters_free(&c);
}

static void back_to_back_leaves_stay_in_one_plane(void **state)
{
    (void)state;
    /* 30 two-sided leaves (pairs with opposite normals) on each of two planes */
    sv_leaf l[120];
    uint64_t s = 5;
    for (int i = 0; i < 30; i++) {
        double a = urand(&s), b = urand(&s);
        set_leaf(&l[4 * i + 0], a, 3, b, 0, 1, 0, 0.01);
        set_leaf(&l[4 * i + 1], a, 3, b, 0, -1, 0, 0.01);
        set_leaf(&l[4 * i + 2], 2, 3 + a, b, 1, 0, 0, 0.01);
        set_leaf(&l[4 * i + 3], 2, 3 + a, b, -1, 0, 0, 0.01);
    }
    const uint32_t levels[] = {2};
    sv_clusters c = run(l, 120, levels, 1, 0.01, 11);
    assert_int_equal(c.levels[0].count, 2);
    for (int i = 0; i < 30; i++) {
        assert_int_equal(c.levels[0].assign[4 * i], c.levels[0].assign[4 * i + 1]);
        assert_int_equal(c.levels[0].assign[4 * i + 2], c.levels[0].assign[4 * i + 3]);
        assert_int_not_equal(c.levels[0].assign[4 * i], c.levels[0].assign[4 * i + 2]);
    }
    const sv_cluster_plane *p0 = &c.levels[0].planes[c.levels[0].assign[0]];
    const sv_cluster_plane *p1 = &c.levels[0].planes[c.levels[0].assign[2]];
    assert_true(fabs(fabs(p0->normal[1]) - 1) < 1e-12 && fabs(fabs(p1->normal[0]) - 1) < 1e-12);
    assert_true(c.levels[0].error < 1e-20);
    sv_clusters_free(&c);
}

static void leaves_on_a_sphere_give_finite_unit_normals(void **state)
{
    (void)state;
    /* Fibonacci sphere, radial normals: isotropic scatter and normal sums,
     * so A ≈ cI has a triple eigenvalue. */
    enum { N = 400 };
    sv_leaf l[N];
    for (int i = 0; i < N; i++) {
        double z = 1 - (2.0 * i + 1) / N, r = sqrt(1 - z * z), ph = i * 2.399963229728653;
        set_leaf(&l[i], r * cos(ph), r * sin(ph), z, r * cos(ph), r * sin(ph), z, 0.01);
    }
    const uint32_t one[] = {1};
    for (int a = 0; a < 3; a++) {
        double alpha = a == 0 ? 0.0 : a == 1 ? 0.01 : 1.0;
        sv_clusters c = run(l, N, one, 1, alpha, 1);
        assert_finite_unit_planes(&c);
        sv_clusters_free(&c);
        c = run(l, N, NULL, 0, alpha, 1);
        assert_finite_unit_planes(&c);
        assert_hierarchy_consistent(&c);
        sv_clusters_free(&c);
    }
}

static void leaves_on_a_line_and_isotropic_clouds_give_finite_unit_normals(void **state)
{
    (void)state;
    enum { N = 100 };
    sv_leaf l[N];
    uint64_t s = 17;
    const uint32_t one[] = {1};
    for (int kind = 0; kind < 4; kind++) {
        for (int i = 0; i < N; i++) {
            double t = i * 0.01;
            switch (kind) {
            case 0:
                set_leaf(&l[i], t, 2 * t, -t, 0, 0, 1, 0.01);
                break; /* line, one normal */
            case 1:
                set_leaf(&l[i], t, 2 * t, -t, urand(&s), urand(&s), urand(&s), 0.01);
                break;
            case 2:
                set_leaf(&l[i], urand(&s), urand(&s), urand(&s), urand(&s), urand(&s), urand(&s),
                         0.01);
                break;
            default:
                set_leaf(&l[i], t, 0, 0, 1, 2, 0, 0.01);
                break; /* normals along... */
            }
        }
        for (int a = 0; a < 2; a++) {
            sv_clusters c = run(l, N, one, 1, a ? 0.01 : 0.0, 5);
            assert_finite_unit_planes(&c);
            sv_clusters_free(&c);
            c = run(l, N, NULL, 0, a ? 0.01 : 0.0, 5);
            assert_finite_unit_planes(&c);
            assert_hierarchy_consistent(&c);
            sv_clusters_free(&c);
        }
    }
}

static void exactly_horizontal_and_vertical_planes_are_recovered_to_rounding(void **state)
{
    (void)state;
    sv_leaf l[80];
    uint64_t s = 23;
    for (int i = 0; i < 40; i++) {
        set_leaf(&l[i], urand(&s), 2.0, urand(&s), 0, 1, 0, 0.01);                /* y = 2 */
        set_leaf(&l[40 + i], -1.5, 3 + urand(&s), 2 + urand(&s), -1, 0, 0, 0.01); /* x = -1.5 */
    }
    const uint32_t levels[] = {2};
    double origin[3] = {0, 0, 0};
    sv_cluster_options o = {
        .levels = levels, .level_count = 1, .alpha = 0.01, .seed = 2, .centre = origin};
    sv_clusters c;
    assert_int_equal(sv_cluster_build(l, 80, &o, &c, NULL), SV_OK);
    assert_int_equal(c.levels[0].count, 2);
    const sv_cluster_plane *h = &c.levels[0].planes[c.levels[0].assign[0]];
    const sv_cluster_plane *v = &c.levels[0].planes[c.levels[0].assign[40]];
    /* outward from the origin: y = 2 has n = +y; x = -1.5 has n = -x */
    assert_true(fabs(h->normal[0]) < 1e-15 && h->normal[1] == 1 && fabs(h->normal[2]) < 1e-15);
    assert_true(fabs(h->d + 2) < 1e-15);
    assert_true(v->normal[0] == -1 && fabs(v->normal[1]) < 1e-15 && fabs(v->normal[2]) < 1e-15);
    assert_true(fabs(v->d + 1.5) < 1e-15);
    sv_clusters_free(&c);
}

static void alpha_trades_position_against_orientation(void **state)
{
    (void)state;
    /* Leaves spread on y = 0 but all tilted by 30°: distance alone picks the
     * y plane, a large α picks the leaves' own orientation. */
    sv_leaf l[50];
    uint64_t s = 29;
    for (int i = 0; i < 50; i++)
        set_leaf(&l[i], 2 * urand(&s), 0, 2 * urand(&s), 0, cos(M_PI / 6), sin(M_PI / 6), 0.01);
    double n[3], d;
    assert_int_equal(sv_cluster_fit_plane(l, NULL, 50, 0.0, false, NULL, n, &d, NULL, NULL), SV_OK);
    assert_true(fabs(fabs(n[1]) - 1) < 1e-12);
    /* the in-plane scatter (~4/3 per leaf) tilts it by ~1.3/α rad */
    assert_int_equal(sv_cluster_fit_plane(l, NULL, 50, 1e4, false, NULL, n, &d, NULL, NULL), SV_OK);
    assert_true(fabs(fabs(dot(n, l[0].normal)) - 1) < 1e-6);
}

static void area_weighting_pulls_the_plane_towards_big_leaves(void **state)
{
    (void)state;
    sv_leaf l[21];
    for (int i = 0; i < 20; i++) set_leaf(&l[i], (i % 5) - 2, 0, (i / 5) - 1.5, 0, 1, 0, 0.01);
    set_leaf(&l[20], 0, 1, 0, 0, 1, 0, 10.0); /* one huge leaf above */
    double n[3], d_plain, d_area;
    assert_int_equal(sv_cluster_fit_plane(l, NULL, 21, 0.01, false, NULL, n, &d_plain, NULL, NULL),
                     SV_OK);
    double h_plain = fabs(d_plain);
    assert_int_equal(sv_cluster_fit_plane(l, NULL, 21, 0.01, true, NULL, n, &d_area, NULL, NULL),
                     SV_OK);
    double h_area = fabs(d_area);
    assert_true(fabs(h_plain - 1.0 / 21) < 1e-12);
    assert_true(h_area > 0.9); /* centroid near the big leaf */
}

static void well_separated_planes_are_found_by_kmeans(void **state)
{
    (void)state;
    const double normals[4][3] = {{0, 1, 0}, {1, 0, 0}, {0.6, 0, 0.8}, {0, -0.6, 0.8}};
    const double offs[4] = {0, 3, -2, 5};
    enum { PER = 60 };
    sv_leaf l[4 * PER];
    uint64_t s = 31;
    for (int g = 0; g < 4; g++) {
        double u[3], v[3];
        plane_axes(normals[g], u, v);
        for (int i = 0; i < PER; i++) {
            double a = urand(&s), b = urand(&s), noise = 0.002 * urand(&s), p[3];
            for (int j = 0; j < 3; j++)
                p[j] = (offs[g] + noise) * normals[g][j] + a * u[j] + b * v[j] + g * 4.0 * (j == 2);
            set_leaf(&l[g * PER + i], p[0], p[1], p[2], normals[g][0] + 0.01 * urand(&s),
                     normals[g][1] + 0.01 * urand(&s), normals[g][2], 0.01);
        }
    }
    const uint32_t levels[] = {4};
    sv_clusters c = run(l, 4 * PER, levels, 1, 0.01, 77);
    assert_int_equal(c.levels[0].count, 4);
    for (int g = 0; g < 4; g++) {
        uint32_t k = c.levels[0].assign[g * PER];
        for (int i = 1; i < PER; i++) assert_int_equal(c.levels[0].assign[g * PER + i], k);
        assert_true(fabs(fabs(dot(c.levels[0].planes[k].normal, normals[g])) - 1) < 1e-3);
    }
    sv_clusters_free(&c);
}

static void merge_joins_the_pair_that_raises_error_least(void **state)
{
    (void)state;
    /* groups A (y = 0) and B (y = 0.05) far apart in x, C on a vertical plane:
     * merging A and B costs ~20·0.025², any merge with C at least α·10 */
    sv_leaf l[30];
    uint64_t s = 37;
    for (int i = 0; i < 10; i++) {
        set_leaf(&l[i], urand(&s), 0, urand(&s), 0, 1, 0, 0.01);
        set_leaf(&l[10 + i], 6 + urand(&s), 0.05, urand(&s), 0, 1, 0, 0.01);
        set_leaf(&l[20 + i], 3, 2 + urand(&s), urand(&s), 1, 0, 0, 0.01);
    }
    const uint32_t levels[] = {3, 2};
    sv_clusters c = run(l, 30, levels, 2, 0.01, 41);
    assert_int_equal(c.levels[0].count, 3);
    assert_int_equal(c.levels[1].count, 2);
    const sv_cluster_level *f = &c.levels[0];
    assert_int_equal(f->parent[f->assign[0]], f->parent[f->assign[10]]);
    assert_int_not_equal(f->parent[f->assign[0]], f->parent[f->assign[20]]);
    assert_true(c.levels[0].error < 1e-20);
    assert_true(c.levels[1].error < 20 * 0.025 * 0.025 * 1.0001);
    assert_hierarchy_consistent(&c);
    sv_clusters_free(&c);
}

static void hierarchy_has_requested_counts_and_consistent_parents(void **state)
{
    (void)state;
    sv_leaf *l = crown(700, 3);
    sv_clusters c = run(l, 700, NULL, 0, 0.01 * 1.0, 1);
    assert_int_equal(c.level_count, 3);
    assert_int_equal(c.levels[0].count, 32);
    assert_int_equal(c.levels[1].count, 16);
    assert_int_equal(c.levels[2].count, 8);
    assert_true(c.iterations >= 2);
    assert_finite_unit_planes(&c);
    assert_hierarchy_consistent(&c);
    /* reported errors are the sums of eq. 1 over the members */
    for (uint32_t lv = 0; lv < 3; lv++) {
        double sum = 0;
        for (uint32_t i = 0; i < 700; i++) {
            const sv_cluster_plane *p = &c.levels[lv].planes[c.levels[lv].assign[i]];
            sum += sv_cluster_leaf_error(&l[i], p->normal, p->d, c.alpha);
        }
        assert_true(fabs(sum - c.levels[lv].error) <= 1e-9 * sum);
    }
    sv_clusters_free(&c);
    free(l);
}

static void empty_cluster_is_reseeded_and_every_cluster_kept(void **state)
{
    (void)state;
    /* Configurations found by search in which a cluster loses all its leaves
     * during k-means (rare: seeds are leaves' own planes). The empty cluster
     * must be refilled, so all K clusters survive. */
    const struct {
        uint32_t n;
        uint64_t crown, seed;
        uint32_t k;
    } cases[] = {{52, 2, 0, 24}, {52, 3, 12, 21}, {60, 2, 8, 33}};
    uint32_t reseeds = 0;
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        sv_leaf *l = crown_bias(cases[i].n, cases[i].crown, 0.1);
        const uint32_t lev[] = {cases[i].k};
        sv_clusters c = run(l, cases[i].n, lev, 1, 0.01, cases[i].seed);
        assert_int_equal(c.levels[0].count, cases[i].k);
        assert_finite_unit_planes(&c);
        reseeds += c.reseeds;
        sv_clusters_free(&c);
        free(l);
    }
    assert_true(reseeds >= 1); /* the path was really taken */
}

static void kmeans_fills_every_cluster_and_beats_one_plane(void **state)
{
    (void)state;
    /* Over many seeds, every one of K clusters ends non-empty and the error
     * is far below one plane's. */
    sv_leaf *l = crown(150, 8);
    const uint32_t one[] = {1}, many[] = {40};
    sv_clusters c1 = run(l, 150, one, 1, 0.01, 1);
    for (uint64_t seed = 0; seed < 20; seed++) {
        sv_clusters c = run(l, 150, many, 1, 0.01, seed);
        assert_int_equal(c.levels[0].count, 40);
        assert_true(c.levels[0].error < 0.2 * c1.levels[0].error);
        sv_clusters_free(&c);
    }
    sv_clusters_free(&c1);
    free(l);
}

static void same_seed_gives_byte_identical_planes(void **state)
{
    (void)state;
    sv_leaf *l = crown(500, 4);
    sv_clusters a = run(l, 500, NULL, 0, 0.01, 1234), b = run(l, 500, NULL, 0, 0.01, 1234);
    bool differs = false;
    for (uint32_t lv = 0; lv < 3; lv++) {
        assert_int_equal(a.levels[lv].count, b.levels[lv].count);
        assert_memory_equal(a.levels[lv].planes, b.levels[lv].planes,
                            a.levels[lv].count * sizeof(sv_cluster_plane));
        assert_memory_equal(a.levels[lv].assign, b.levels[lv].assign, 500 * sizeof(uint32_t));
        assert_memory_equal(a.levels[lv].parent, b.levels[lv].parent,
                            a.levels[lv].count * sizeof(int32_t));
    }
    for (uint64_t seed = 0; seed < 4 && !differs; seed++) {
        sv_clusters c = run(l, 500, NULL, 0, 0.01, seed);
        differs = memcmp(c.levels[0].assign, a.levels[0].assign, 500 * sizeof(uint32_t)) != 0;
        sv_clusters_free(&c);
    }
    assert_true(differs); /* the seed is really used */
    sv_clusters_free(&a);
    sv_clusters_free(&b);
    free(l);
}

/* x' = s·R·x + t for every leaf; compares planes and normalised errors. */
static void check_transform(double scale, const double rot[3][3], const double t[3], double dtol)
{
    enum { N = 500 };
    sv_leaf *l = crown(N, 6), *m = calloc(N, sizeof *m);
    for (int i = 0; i < N; i++) {
        m[i] = l[i];
        for (int r = 0; r < 3; r++) {
            m[i].centre[r] = t[r] + scale * dot(rot[r], l[i].centre);
            m[i].normal[r] = dot(rot[r], l[i].normal);
        }
        m[i].area = l[i].area * scale * scale;
    }
    double c0[3] = {0, 2, 0}, c1[3];
    for (int r = 0; r < 3; r++) c1[r] = t[r] + scale * dot(rot[r], c0);
    double R = 1.0, alpha_rel = 0.01;
    for (int aw = 0; aw < 2; aw++) {
        sv_cluster_options oa = {
            .alpha = alpha_rel * R * R, .area_weighted = aw, .seed = 5, .centre = c0};
        sv_cluster_options ob = oa;
        ob.alpha = alpha_rel * (scale * R) * (scale * R);
        ob.centre = c1;
        sv_clusters a, b;
        assert_int_equal(sv_cluster_build(l, N, &oa, &a, NULL), SV_OK);
        assert_int_equal(sv_cluster_build(m, N, &ob, &b, NULL), SV_OK);
        for (uint32_t lv = 0; lv < 3; lv++) {
            assert_int_equal(a.levels[lv].count, b.levels[lv].count);
            assert_memory_equal(a.levels[lv].assign, b.levels[lv].assign, N * sizeof(uint32_t));
            double ea = a.levels[lv].error / (a.weight * R * R);
            double eb = b.levels[lv].error / (b.weight * scale * scale * R * R);
            assert_true(fabs(ea - eb) <= 1e-8 * ea);
            for (uint32_t k = 0; k < a.levels[lv].count; k++) {
                const sv_cluster_plane *pa = &a.levels[lv].planes[k], *pb = &b.levels[lv].planes[k];
                double rn[3];
                for (int r = 0; r < 3; r++) rn[r] = dot(rot[r], pa->normal);
                for (int r = 0; r < 3; r++) assert_true(fabs(rn[r] - pb->normal[r]) < 1e-9);
                /* plane moved: the tree centre keeps its (scaled) distance
                 * to it. (Comparing d itself at 1e6 would test the
                 * conditioning of d = −n·c, not the clustering.) */
                double da = dot(pa->normal, c0) + pa->d, db = dot(pb->normal, c1) + pb->d;
                assert_true(fabs(scale * da - db) <= dtol * scale * R);
            }
        }
        sv_clusters_free(&a);
        sv_clusters_free(&b);
    }
    free(l);
    free(m);
}

static const double ident[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
static const double zero3[3] = {0, 0, 0};

static void translated_by_1e6_planes_move_with_the_tree(void **state)
{
    (void)state;
    const double t[3] = {1e6, -1e6, 1e6};
    check_transform(1.0, ident, t, 1e-8);
}

static void scaled_by_1e_minus_4_and_1e4_planes_scale_with_the_tree(void **state)
{
    (void)state;
    check_transform(1e-4, ident, zero3, 1e-9);
    check_transform(1e4, ident, zero3, 1e-9);
}

static void rotated_tree_gives_rotated_planes(void **state)
{
    (void)state;
    double q[4] = {0.9, 0.2, -0.3, 0.25}, n = 0;
    for (int i = 0; i < 4; i++) n += q[i] * q[i];
    n = sqrt(n);
    double w = q[0] / n, x = q[1] / n, y = q[2] / n, z = q[3] / n;
    const double r[3][3] = {{1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)},
                            {2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)},
                            {2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)}};
    const double t[3] = {3, -7, 11};
    check_transform(1.0, r, t, 1e-9);
}

static void invalid_leaves_and_options_fail_naming_the_problem(void **state)
{
    (void)state;
    sv_leaf l[3];
    for (int i = 0; i < 3; i++) set_leaf(&l[i], i, 0, 0, 0, 1, 0, 0.1);
    sv_clusters c;
    sv_error e = {0};
    l[1].centre[2] = NAN;
    assert_int_equal(sv_cluster_build(l, 3, NULL, &c, &e), SV_ERR_INVALID);
    assert_non_null(strstr(e.message, "leaf 1"));
    assert_null(c.levels);
    l[1].centre[2] = 0;
    l[2].normal[0] = l[2].normal[1] = l[2].normal[2] = 0;
    assert_int_equal(sv_cluster_build(l, 3, NULL, &c, &e), SV_ERR_INVALID);
    assert_non_null(strstr(e.message, "leaf 2"));
    l[2].normal[1] = 1;
    l[0].area = -1;
    sv_cluster_options o = {.area_weighted = true};
    assert_int_equal(sv_cluster_build(l, 3, &o, &c, &e), SV_ERR_INVALID);
    assert_non_null(strstr(e.message, "area"));
    o.area_weighted = false;
    assert_int_equal(sv_cluster_build(l, 3, &o, &c, &e), SV_OK); /* area unused */
    sv_clusters_free(&c);
    l[0].area = 0; /* zero area is floored, not refused */
    o.area_weighted = true;
    assert_int_equal(sv_cluster_build(l, 3, &o, &c, &e), SV_OK);
    assert_finite_unit_planes(&c);
    sv_clusters_free(&c);
    o.area_weighted = false;
    const uint32_t bad[] = {8, 8};
    o.levels = bad;
    o.level_count = 2;
    assert_int_equal(sv_cluster_build(l, 3, &o, &c, &e), SV_ERR_INVALID);
    assert_non_null(strstr(e.message, "decrease"));
    assert_int_equal(sv_cluster_build(l, 0, NULL, &c, &e), SV_ERR_INVALID);
    o.levels = NULL;
    o.alpha = -1;
    assert_int_equal(sv_cluster_build(l, 3, &o, &c, &e), SV_ERR_INVALID);
    assert_non_null(strstr(e.message, "alpha"));
    sv_clusters_free(NULL);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(cluster_keeps_coplanar_leaves_in_one_plane),
        cmocka_unit_test(single_leaf_gives_its_own_plane_on_every_level),
        cmocka_unit_test(two_leaves_split_then_merge),
        cmocka_unit_test(more_clusters_than_leaves_gives_one_cluster_per_leaf),
        cmocka_unit_test(identical_leaves_collapse_into_one_cluster),
        cmocka_unit_test(back_to_back_leaves_stay_in_one_plane),
        cmocka_unit_test(leaves_on_a_sphere_give_finite_unit_normals),
        cmocka_unit_test(leaves_on_a_line_and_isotropic_clouds_give_finite_unit_normals),
        cmocka_unit_test(exactly_horizontal_and_vertical_planes_are_recovered_to_rounding),
        cmocka_unit_test(alpha_trades_position_against_orientation),
        cmocka_unit_test(area_weighting_pulls_the_plane_towards_big_leaves),
        cmocka_unit_test(well_separated_planes_are_found_by_kmeans),
        cmocka_unit_test(merge_joins_the_pair_that_raises_error_least),
        cmocka_unit_test(hierarchy_has_requested_counts_and_consistent_parents),
        cmocka_unit_test(kmeans_fills_every_cluster_and_beats_one_plane),
        cmocka_unit_test(empty_cluster_is_reseeded_and_every_cluster_kept),
        cmocka_unit_test(same_seed_gives_byte_identical_planes),
        cmocka_unit_test(translated_by_1e6_planes_move_with_the_tree),
        cmocka_unit_test(scaled_by_1e_minus_4_and_1e4_planes_scale_with_the_tree),
        cmocka_unit_test(rotated_tree_gives_rotated_planes),
        cmocka_unit_test(invalid_leaves_and_options_fail_naming_the_problem),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
