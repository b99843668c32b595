/* test_stochastic.c — stochastic simplification (core/methods/stochastic/stochastic.c): the
 * formulas of Fichtner / Cook et al. against hand-computed values and limits,
 * the leaf order, levels built on a hand-made tree, and on a real tree (the
 * oak from SYLVA_DATA) the visible area of each level measured by rendering. */
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

#include "evaluate.h"
#include "import.h"
#include "level.h"
#include "render.h"
#include "stochastic.h"

#define CLOSE(a, b, tol) assert_true(fabs((a) - (b)) <= (tol))

/* ---- formulas ---- */

static void lambda_matches_hand_computed_values(void **state)
{
    (void)state;
    CLOSE(sv_stochastic_b(10, 20), 0.25, 1e-15);
    assert_true(sv_stochastic_b(10, 5) == 1.0);          /* nearer than d0: full detail */
    CLOSE(sv_stochastic_lambda(0.25, 0.5), 0.25, 1e-12); /* h = 1/2: λ = b */
    CLOSE(sv_stochastic_lambda(0.25, 0.25), 0.5, 1e-12); /* b = h: half the leaves */
    CLOSE(sv_stochastic_lambda(0.09, 0.3), 0.25, 1e-12); /* 0.09 = 0.3²: λ = 0.5² */
    /* h = 0.7: λ = 0.04^(ln 0.5 / ln 0.7) = 0.04^1.94335 */
    CLOSE(sv_stochastic_lambda(0.04, 0.7), exp(log(0.04) * log(0.5) / log(0.7)), 1e-12);
    assert_true(sv_stochastic_lambda(1.0, 0.5) == 1.0);
    assert_true(sv_stochastic_lambda(7.0, 0.5) == 1.0);
    assert_true(sv_stochastic_lambda(0.0, 0.5) == 0.0);
    assert_true(sv_stochastic_motion_b(0) == 1.0);
    CLOSE(sv_stochastic_motion_b(3), 0.25, 1e-15);
}

static void motion_term_applies_only_with_camera_motion(void **state)
{
    (void)state;
    sv_stochastic_settings s;
    assert_int_equal(sv_stochastic_parse(NULL, &s, NULL), SV_OK);
    sv_scene sc;
    sv_scene_defaults(&sc);
    double still = sv_stochastic_lambda_at(&s, &sc, 20);
    CLOSE(still, 0.25, 1e-12); /* d0 = distance_min = 10, h = 0.5 */
    sc.camera_speed = 10;
    double moving = sv_stochastic_lambda_at(&s, &sc, 20);
    double m = 10 * (1.0 / 60) * sv_scene_pixels(&sc, 1.0, 20);
    CLOSE(moving, 0.25 / (1 + m), 1e-12);
    /* the inverse: the distance where λ falls to 0.25 with no motion is 20 m */
    sc.camera_speed = 0;
    CLOSE(sv_stochastic_distance_for_lambda(&s, &sc, 0.25), 20, 1e-6);
    assert_true(sv_stochastic_distance_for_lambda(&s, &sc, 1.0) == 0);
}

static void area_scale_matches_hand_values(void **state)
{
    (void)state;
    CLOSE(sv_stochastic_area_scale(0.5, 0.5), 1.5, 1e-12); /* (1 − 0.25)/0.5 */
    CLOSE(sv_stochastic_area_scale(0.2, 0.25), (1 - pow(0.8, 4)) / 0.2, 1e-12);
    CLOSE(sv_stochastic_area_scale(1e-4, 0.1), (1 - pow(1 - 1e-4, 10)) / 1e-4, 1e-9);
}

static void area_scale_is_one_at_full_detail_and_bounded_when_small(void **state)
{
    (void)state;
    const double rs[] = {0, 1e-300, 1e-12, 1e-4, 0.5, 1 - 1e-16, 1, 2};
    const double ls[] = {0, 1e-300, 1e-9, 1e-3, 0.1, 0.5, 0.999999, 1, 1.5};
    for (size_t i = 0; i < sizeof rs / sizeof rs[0]; i++)
        for (size_t j = 0; j < sizeof ls / sizeof ls[0]; j++) {
            double s = sv_stochastic_area_scale(rs[i], ls[j]);
            assert_true(isfinite(s));
            assert_true(s >= 1.0);
            double l = ls[j] > 1e-9 ? fmin(ls[j], 1.0) : 1e-9;
            if (rs[i] > 0) assert_true(s <= fmin(1.0 / l, 1.0 / fmin(rs[i], 1)) * (1 + 1e-12));
            if (ls[j] >= 1) assert_true(s == 1.0);
        }
    /* λ → 1: s → 1 continuously */
    CLOSE(sv_stochastic_area_scale(1e-3, 1 - 1e-9), 1.0, 1e-6);
    /* r → 0: s → 1/λ (no overlap to compensate) */
    CLOSE(sv_stochastic_area_scale(1e-300, 0.1), 10.0, 1e-9);
    /* λ → 0: s → 1/r */
    CLOSE(sv_stochastic_area_scale(0.01, 1e-6), 100.0, 1e-6);
    /* r = 1: one leaf covers everything, no scaling */
    assert_true(sv_stochastic_area_scale(1.0, 0.1) == 1.0);
}

static void contrast_moves_colour_towards_the_mean_by_sqrt_lambda(void **state)
{
    (void)state;
    CLOSE(sv_stochastic_contrast(0.8, 0.5, 0.25), 0.65, 1e-15);
    CLOSE(sv_stochastic_contrast(0.2, 0.5, 0.04), 0.44, 1e-15);
    assert_true(sv_stochastic_contrast(0.8, 0.5, 1.0) == 0.8);
    assert_true(sv_stochastic_contrast(0.8, 0.5, 0.0) == 0.5);
    assert_true(sv_stochastic_contrast(0.8, 0.5, 2.0) == 0.8);
}

static void fade_window_is_centred_on_lambda_and_closed_at_one(void **state)
{
    (void)state;
    double lo, hi;
    sv_stochastic_fade(0.5, 0.1, &lo, &hi);
    CLOSE(lo, 0.4, 1e-15);
    CLOSE(hi, 0.6, 1e-15);
    sv_stochastic_fade(0.95, 0.1, &lo, &hi);
    CLOSE(lo, 0.9, 1e-12);
    CLOSE(hi, 1.0, 1e-12);
    sv_stochastic_fade(1.0, 0.1, &lo, &hi);
    assert_true(lo == 1.0 && hi == 1.0);
    sv_stochastic_fade(0.05, 0.1, &lo, &hi);
    assert_true(lo == 0.0);
}

static void ratio_from_coverage_inverts_cooks_model(void **state)
{
    (void)state;
    const double rs[] = {1e-5, 1e-4, 1e-3, 0.2};
    const uint32_t ns_[] = {500, 500, 500, 2}, n_[] = {5000, 5000, 5000, 20};
    for (size_t i = 0; i < 4; i++) {
        double r = rs[i];
        uint32_t n = n_[i], ns = ns_[i];
        double q = (1 - pow(1 - r, ns)) / (1 - pow(1 - r, n));
        double got = sv_stochastic_ratio_from_coverage(q, ns, n);
        assert_true(fabs(got - r) <= 1e-3 * r);
    }
    assert_true(sv_stochastic_ratio_from_coverage(0.05, 10, 100) == 0.0); /* q <= n_sub/n */
    assert_true(sv_stochastic_ratio_from_coverage(1.0, 10, 100) == 1.0);
    assert_true(sv_stochastic_ratio_from_coverage(NAN, 10, 100) == 0.0);
    assert_true(sv_stochastic_count(0.1, 5280) == 528);
    assert_true(sv_stochastic_count(0.001, 10) == 1);
    assert_true(sv_stochastic_count(1, 10) == 10);
}

/* ---- a hand-made tree ---- */

typedef struct toy {
    sv_mesh *mesh;
    sv_classification cls;
    sv_leaves leaves;
    sv_scene scene;
    sv_method_input in;
} toy;

/* n square leaves (2 triangles, 4 vertices each) on a grid; leaves with odd
 * index use material 1 (dark), even material 0 (bright); untextured. */
/* What both toys share: the mesh and the leaf arrays for n leaves of k
 * triangles each (leaf i owns triangles k·i .. k·i + k − 1, all foliage). */
static uint32_t toy_images; /* images the next toy's mesh has room for */

static sv_mesh *toy_alloc(toy *t, uint32_t vertices, uint32_t n, uint32_t k, uint32_t materials)
{
    memset(t, 0, sizeof *t);
    t->mesh = sv_mesh_create(vertices, k * n, materials, toy_images);
    assert_non_null(t->mesh);
    t->cls.tri_part = calloc(k * n, 1);
    t->leaves.leaves = calloc(n, sizeof(sv_leaf));
    t->leaves.tris = calloc(k * n, sizeof(uint32_t));
    assert_true(t->cls.tri_part && t->leaves.leaves && t->leaves.tris);
    t->leaves.count = n;
    t->leaves.tri_count = k * n;
    for (uint32_t j = 0; j < k * n; j++) {
        t->cls.tri_part[j] = SV_PART_FOLIAGE;
        t->leaves.tris[j] = j;
    }
    t->cls.foliage_triangles = k * n;
    return t->mesh;
}

/* Leaf i of k triangles: a square 0.4 m across facing +z, centred at
 * (i mod 10, i / 10, 0.1 (i mod 3)). Returns its centre in c. */
static void toy_leaf(toy *t, uint32_t i, uint32_t k, double c[3])
{
    c[0] = (double)(i % 10), c[1] = (double)(i / 10), c[2] = 0.1 * (i % 3);
    sv_leaf *l = &t->leaves.leaves[i];
    memcpy(l->centre, c, sizeof l->centre);
    l->normal[2] = 1;
    l->area = 0.16;
    l->radius = 0.2 * sqrt(2);
    l->first = k * i;
    l->count = k;
}

/* The method input over the toy's mesh, scene defaults, seed 7. */
static void toy_finish(toy *t)
{
    sv_scene_defaults(&t->scene);
    t->in.mesh = t->mesh;
    t->in.cls = &t->cls;
    t->in.leaves = &t->leaves;
    sv_mesh_sphere(t->mesh, t->in.centre, &t->in.radius);
    t->in.scene = &t->scene;
    t->in.seed = 7;
}

static void toy_make(toy *t, uint32_t n)
{
    sv_mesh *m = toy_alloc(t, 4 * n, n, 2, 2);
    m->materials[0].base_color[0] = 0.8f;
    m->materials[0].base_color[1] = 0.8f;
    m->materials[0].base_color[2] = 0.8f;
    m->materials[1].base_color[0] = 0.2f;
    m->materials[1].base_color[1] = 0.2f;
    m->materials[1].base_color[2] = 0.2f;
    for (uint32_t i = 0; i < n; i++) {
        double c[3];
        toy_leaf(t, i, 2, c);
        const double du[4] = {-0.2, 0.2, 0.2, -0.2}, dv[4] = {-0.2, -0.2, 0.2, 0.2};
        for (int k = 0; k < 4; k++) {
            m->positions[3 * (4 * i + k)] = (float)(c[0] + du[k]);
            m->positions[3 * (4 * i + k) + 1] = (float)(c[1] + dv[k]);
            m->positions[3 * (4 * i + k) + 2] = (float)c[2];
            m->normals[3 * (4 * i + k) + 2] = 1;
        }
        const uint32_t ix[6] = {0, 1, 2, 0, 2, 3};
        for (int k = 0; k < 6; k++) m->indices[6 * i + k] = 4 * i + ix[k];
        m->tri_material[2 * i] = m->tri_material[2 * i + 1] = i % 2;
    }
    toy_finish(t);
}

static void toy_free(toy *t)
{
    sv_mesh_destroy(t->mesh);
    free(t->cls.tri_part);
    free(t->leaves.leaves);
    free(t->leaves.tris);
}

static void order_is_a_deterministic_permutation_for_a_seed(void **state)
{
    (void)state;
    toy t;
    toy_make(&t, 200);
    uint32_t a[200], b[200], c[200], d[200];
    for (int mode = 0; mode < 2; mode++) {
        assert_int_equal(sv_stochastic_order(&t.leaves, 7, (sv_stoch_order_mode)mode, a, NULL),
                         SV_OK);
        assert_int_equal(sv_stochastic_order(&t.leaves, 7, (sv_stoch_order_mode)mode, b, NULL),
                         SV_OK);
        assert_int_equal(sv_stochastic_order(&t.leaves, 8, (sv_stoch_order_mode)mode, c, NULL),
                         SV_OK);
        assert_memory_equal(a, b, sizeof a);
        assert_memory_not_equal(a, c, sizeof a);
        memset(d, 0, sizeof d);
        for (int i = 0; i < 200; i++) {
            assert_true(a[i] < 200);
            d[a[i]]++;
        }
        for (int i = 0; i < 200; i++) assert_int_equal(d[i], 1);
        /* not the identity: the order is shuffled */
        int fixed = 0;
        for (int i = 0; i < 200; i++) fixed += a[i] == (uint32_t)i;
        assert_true(fixed < 20);
    }
    toy_free(&t);
}

static void area_order_puts_larger_leaves_first_on_average(void **state)
{
    (void)state;
    toy t;
    toy_make(&t, 200);
    for (uint32_t i = 0; i < 200; i++) t.leaves.leaves[i].area = i < 100 ? 1.0 : 0.01;
    uint32_t o[200];
    assert_int_equal(sv_stochastic_order(&t.leaves, 3, SV_STOCH_ORDER_AREA, o, NULL), SV_OK);
    int big_first = 0;
    for (int i = 0; i < 50; i++) big_first += o[i] < 100;
    assert_true(big_first >= 45);
    toy_free(&t);
}

static void every_prefix_is_a_valid_mesh_with_leaves_scaled_about_their_centres(void **state)
{
    (void)state;
    toy t;
    toy_make(&t, 100);
    sv_stochastic_settings s;
    cJSON *j = cJSON_Parse("{\"levels\": [1, 0.5, 0.25, 0.1, 0.01]}");
    assert_int_equal(sv_stochastic_parse(j, &s, NULL), SV_OK);
    cJSON_Delete(j);
    sv_stoch_result res;
    sv_error err = {0};
    assert_int_equal(sv_stochastic_build(&t.in, &s, 0.01, NULL, &res, &err), SV_OK);
    assert_int_equal(res.level_count, 5);
    for (uint32_t k = 0; k < res.level_count; k++) {
        const sv_stoch_level *L = &res.levels[k];
        const sv_mesh *g = L->geometry;
        assert_int_equal(L->leaves, sv_stochastic_count(L->lambda, 100));
        assert_int_equal(g->triangle_count, 2 * L->leaves);
        assert_int_equal(g->vertex_count, 4 * L->leaves);
        for (uint32_t i = 0; i < 3 * g->triangle_count; i++)
            assert_true(g->indices[i] < g->vertex_count);
        for (uint32_t i = 0; i < g->triangle_count; i++)
            assert_true(g->tri_material[i] < g->material_count);
        CLOSE(L->area_scale, sv_stochastic_area_scale(0.01, L->lambda), 1e-12);
        double g2 = sqrt(L->area_scale);
        for (uint32_t v = 0; v < g->vertex_count; v++) {
            /* each vertex lies √s × its original offset from its leaf centre */
            uint32_t leaf = res.order[v / 4];
            const double *c = t.leaves.leaves[leaf].centre;
            const float *p = &g->positions[3 * v], *c2 = &L->leaf_centre[3 * v];
            double dd = 0;
            for (int a = 0; a < 3; a++) {
                assert_true(fabs(c2[a] - c[a]) < 1e-5);
                dd += (p[a] - c[a]) * (p[a] - c[a]);
            }
            CLOSE(sqrt(dd), g2 * 0.2 * sqrt(2), 1e-4);
            CLOSE(L->leaf_order[v], ((v / 4) + 0.5) / 100.0, 1e-6);
        }
        /* the prefix follows the order */
        for (uint32_t i = 0; i < L->leaves; i++)
            CLOSE(g->positions[12 * i] - t.leaves.leaves[res.order[i]].centre[0], -0.2 * g2, 1e-4);
    }
    /* λ = 1 is the full reordered mesh: unchanged leaves, no contrast copies */
    assert_true(res.levels[0].area_scale == 1.0);
    assert_int_equal(res.levels[0].contrast_materials, 0);
    sv_stoch_result_free(&res);
    sv_stoch_result_free(NULL);
    toy_free(&t);
}

/* n flat square leaves 0.4 m across, each a 4×4 grid (32 triangles, 25
 * shared vertices), 1 m apart; one material. */
static void toy_make_tessellated(toy *t, uint32_t n)
{
    sv_mesh *m = toy_alloc(t, 25 * n, n, 32, 1);
    for (int c = 0; c < 3; c++) m->materials[0].base_color[c] = 0.5f;
    for (uint32_t i = 0; i < n; i++) {
        double c[3];
        toy_leaf(t, i, 32, c);
        for (uint32_t y = 0; y < 5; y++)
            for (uint32_t x = 0; x < 5; x++) {
                uint32_t v = 25 * i + 5 * y + x;
                m->positions[3 * v] = (float)(c[0] - 0.2 + 0.1 * x);
                m->positions[3 * v + 1] = (float)(c[1] - 0.2 + 0.1 * y);
                m->positions[3 * v + 2] = (float)c[2];
                m->normals[3 * v + 2] = 1;
                m->uvs[2 * v] = 0.25f * (float)x;
                m->uvs[2 * v + 1] = 0.25f * (float)y;
            }
        uint32_t k = 32 * i;
        for (uint32_t y = 0; y < 4; y++)
            for (uint32_t x = 0; x < 4; x++) {
                uint32_t a = 25 * i + 5 * y + x, q[6] = {a, a + 1, a + 6, a, a + 6, a + 5};
                for (int j = 0; j < 6; j++) m->indices[3 * (size_t)k + (size_t)j] = q[j];
                k += 2;
            }
    }
    toy_finish(t);
}

static double mesh_area(const sv_mesh *g)
{
    double a = 0;
    for (uint32_t t = 0; t < g->triangle_count; t++) a += sv_tri_area(g, t);
    return a;
}

/* Below λ = 1 a leaf modelled with many triangles is simplified to the
 * level's error before leaves are dropped: the budget (λ × the foliage
 * triangles) then holds more leaves (μ > λ), each keeping its modelled area;
 * with simplify_leaves off, μ = λ and every leaf keeps its 32 triangles. */
static void simplified_leaves_fit_more_of_the_tree_in_the_budget(void **state)
{
    (void)state;
    toy t;
    toy_make_tessellated(&t, 100);
    sv_stochastic_settings s;
    cJSON *j = cJSON_Parse("{\"levels\": [1, 0.5, 0.1]}");
    assert_int_equal(sv_stochastic_parse(j, &s, NULL), SV_OK);
    cJSON_Delete(j);
    assert_true(s.simplify_leaves);
    sv_stoch_result a, b, off;
    sv_error err = {0};
    assert_int_equal(sv_stochastic_build(&t.in, &s, 0.01, NULL, &a, &err), SV_OK);
    assert_int_equal(sv_stochastic_build(&t.in, &s, 0.01, NULL, &b, &err), SV_OK);
    /* λ = 1: as modelled */
    assert_true(a.levels[0].leaf_error == 0);
    assert_int_equal(a.levels[0].geometry->triangle_count, 3200);
    for (uint32_t k = 1; k < 3; k++) {
        const sv_stoch_level *L = &a.levels[k];
        assert_true(L->leaf_error > 0);
        CLOSE(L->leaf_error, sv_stochastic_level_error(&s, &t.scene, t.in.radius, L->lambda),
              1e-12);
        /* a flat grid simplifies to its two corner triangles: every leaf fits */
        assert_true(L->leaf_triangles <= (uint64_t)(L->lambda * 3200 + 0.5));
        assert_int_equal(L->leaves, 100);
        assert_true(L->leaf_fraction == 1.0);
        assert_true(L->area_scale == 1.0);
        assert_int_equal(L->geometry->triangle_count, 200);
        CLOSE(mesh_area(L->geometry), 100 * 0.16, 1e-4);
        /* deterministic */
        assert_int_equal(b.levels[k].geometry->vertex_count, L->geometry->vertex_count);
        assert_memory_equal(b.levels[k].geometry->positions, L->geometry->positions,
                            3 * sizeof(float) * L->geometry->vertex_count);
        assert_memory_equal(b.levels[k].geometry->indices, L->geometry->indices,
                            3 * sizeof(uint32_t) * L->geometry->triangle_count);
    }
    s.simplify_leaves = false;
    assert_int_equal(sv_stochastic_build(&t.in, &s, 0.01, NULL, &off, &err), SV_OK);
    for (uint32_t k = 1; k < 3; k++) {
        const sv_stoch_level *L = &off.levels[k];
        assert_true(L->leaf_error == 0);
        assert_int_equal(L->leaves, sv_stochastic_count(L->lambda, 100));
        CLOSE(L->leaf_fraction, L->lambda, 1e-12);
        assert_int_equal(L->geometry->triangle_count, 32 * L->leaves);
    }
    sv_stoch_result_free(&a);
    sv_stoch_result_free(&b);
    sv_stoch_result_free(&off);
    toy_free(&t);
}

/* n twigs of 16 triangles: a thin stem (0.16 × 0.004 m, 4 quads) with four
 * 0.04 m square leaves joined to it on alternate sides, all one element
 * (leaf i as toy_leaf places it). Simplified as one piece to a level's error
 * such a twig collapses towards its stem. */
static void toy_make_twigs(toy *t, uint32_t n)
{
    sv_mesh *m = toy_alloc(t, 18 * n, n, 16, 1);
    for (int c = 0; c < 3; c++) m->materials[0].base_color[c] = 0.4f;
    for (uint32_t i = 0; i < n; i++) {
        double c[3];
        toy_leaf(t, i, 16, c);
        float *p = &m->positions[3 * (size_t)(18 * i)];
        for (uint32_t r = 0; r < 2; r++) /* stem: vertices 0-4 below, 5-9 above */
            for (uint32_t x = 0; x < 5; x++) {
                float *q = p + 3 * (5 * r + x);
                q[0] = (float)(c[0] - 0.08 + 0.04 * x);
                q[1] = (float)(c[1] + (r ? 0.002 : -0.002));
                q[2] = (float)c[2];
            }
        for (uint32_t j = 0; j < 4; j++) { /* leaf j's outer corners: 10 + 2j, 11 + 2j */
            double side = j % 2 ? 1 : -1;
            for (uint32_t e = 0; e < 2; e++) {
                float *q = p + 3 * (10 + 2 * j + e);
                q[0] = (float)(c[0] - 0.08 + 0.04 * (j + e));
                q[1] = (float)(c[1] + side * 0.042);
                q[2] = (float)c[2];
            }
        }
        for (uint32_t v = 0; v < 18; v++) m->normals[3 * (size_t)(18 * i + v) + 2] = 1;
        uint32_t *ix = &m->indices[3 * (size_t)(16 * i)], b = 18 * i;
        for (uint32_t x = 0; x < 4; x++) {
            uint32_t q[6] = {b + x, b + x + 1, b + 6 + x, b + x, b + 6 + x, b + 5 + x};
            memcpy(ix + 6 * x, q, sizeof q);
        }
        for (uint32_t j = 0; j < 4; j++) {
            uint32_t in0 = j % 2 ? b + 5 + j : b + j, in1 = in0 + 1;
            uint32_t o0 = b + 10 + 2 * j, o1 = o0 + 1;
            uint32_t q[6] = {in0, in1, o1, in0, o1, o0};
            memcpy(ix + 24 + 6 * j, q, sizeof q);
        }
    }
    for (uint32_t i = 0; i < n; i++) t->leaves.leaves[i].area = 0.004 * 0.16 + 4 * 0.04 * 0.04;
    toy_finish(t);
}

/* Each drawn leaf's area in level L, by its order position (_LEAF_ORDER). */
static void level_leaf_areas(const sv_stoch_result *res, const sv_stoch_level *L, double *area)
{
    const sv_mesh *g = L->geometry;
    uint32_t N = res->leaf_count;
    for (uint32_t i = 0; i < N; i++) area[i] = 0;
    for (uint32_t t = L->trunk_triangles; t < g->triangle_count; t++) {
        uint32_t v = g->indices[3 * (size_t)t] - L->trunk_vertices;
        uint32_t pos = (uint32_t)floor(L->leaf_order[v] * N);
        area[res->order[pos]] += sv_tri_area(g, t);
    }
}

/* A kept leaf is never slivered: every leaf a level draws covers at least
 * half of its modelled area (beyond the level's area scaling s^γ), so the
 * budget is met by dropping twigs whole, not by thinning them; and the twigs
 * this toy collapses are drawn as modelled (leaves_whole). */
static void no_drawn_leaf_is_a_sliver(void **state)
{
    (void)state;
    toy t;
    toy_make_twigs(&t, 100);
    sv_stochastic_settings s;
    cJSON *j = cJSON_Parse("{\"levels\": [1, 0.5, 0.25, 0.1]}");
    assert_int_equal(sv_stochastic_parse(j, &s, NULL), SV_OK);
    cJSON_Delete(j);
    sv_stoch_result a;
    sv_error err = {0};
    assert_int_equal(sv_stochastic_build(&t.in, &s, 0.01, NULL, &a, &err), SV_OK);
    double area[100], whole = 0.004 * 0.16 + 4 * 0.04 * 0.04;
    uint32_t guarded = 0;
    for (uint32_t k = 1; k < a.level_count; k++) {
        const sv_stoch_level *L = &a.levels[k];
        assert_true(L->leaf_error > 0);
        level_leaf_areas(&a, L, area);
        double s_gamma = pow(L->area_scale, L->area_gamma);
        uint32_t drawn = 0;
        for (uint32_t i = 0; i < 100; i++) {
            if (area[i] == 0) continue;
            drawn++;
            double ratio = area[i] / (whole * s_gamma);
            if (ratio < 0.5)
                fail_msg("level %g: leaf %u drawn at %.3f of its area", L->lambda, i, ratio);
        }
        assert_int_equal(drawn, L->leaves);
        assert_int_equal(L->leaves_whole + L->leaves_simplified, L->leaves);
        assert_true(L->leaf_cover_min >= SV_STOCH_MIN_COVER);
        guarded += L->leaves_whole;
        assert_true(L->leaf_triangles <= (uint64_t)ceil(L->lambda * 1600) || L->leaves == 1);
    }
    assert_true(guarded > 0);
    sv_stoch_result_free(&a);
    toy_free(&t);
}

/* Leaf i of the twig toy moved onto leaf i − 1 (odd i), offset by d. */
static void toy_twin_leaves(toy *t, const double d[3])
{
    sv_mesh *m = t->mesh;
    for (uint32_t i = 1; i < 100; i += 2) {
        for (uint32_t v = 0; v < 18; v++)
            for (int a = 0; a < 3; a++)
                m->positions[3 * (size_t)(18 * i + v) + (size_t)a] =
                    m->positions[3 * (size_t)(18 * (i - 1) + v) + (size_t)a] + (float)d[a];
        sv_leaf *l = &t->leaves.leaves[i];
        for (int a = 0; a < 3; a++) l->centre[a] = t->leaves.leaves[i - 1].centre[a] + d[a];
    }
}

/* A leaf modelled as two cards a hair apart (upper side, underside) is one
 * leaf to the method: its layers come next to each other in the order, so a
 * level draws both or neither, and they are simplified to one outline with
 * one gain, so neither shows past the other's edge. Leaves a metre apart,
 * or side by side less than their width apart (a frond's leaflets), are not
 * layers. */
static void a_leafs_layers_go_and_simplify_together(void **state)
{
    (void)state;
    toy t;
    toy_make_twigs(&t, 100);
    toy_twin_leaves(&t, (const double[3]){0, 0, 0.0005}); /* a twig 12 mm wide */
    uint32_t o[100], at[100];
    assert_int_equal(sv_stochastic_order(&t.leaves, 7, SV_STOCH_ORDER_RANDOM, o, NULL), SV_OK);
    for (uint32_t k = 0; k < 100; k++) at[o[k]] = k;
    for (uint32_t i = 0; i < 100; i += 2) assert_int_equal(abs((int)at[i] - (int)at[i + 1]), 1);
    sv_stochastic_settings s;
    cJSON *j = cJSON_Parse("{\"levels\": [0.5, 0.25, 0.1]}");
    assert_int_equal(sv_stochastic_parse(j, &s, NULL), SV_OK);
    cJSON_Delete(j);
    sv_stoch_result a;
    sv_error err = {0};
    assert_int_equal(sv_stochastic_build(&t.in, &s, 0.01, NULL, &a, &err), SV_OK);
    assert_int_equal(a.layered_leaves, 100);
    uint32_t simplified = 0, dropped = 0;
    double area[100];
    for (uint32_t k = 0; k < a.level_count; k++) {
        const sv_stoch_level *L = &a.levels[k];
        simplified += L->leaves_simplified;
        dropped += L->leaves < 100;
        print_message("level %g: %u leaves, %u simplified\n", L->lambda, L->leaves,
                      L->leaves_simplified);
        level_leaf_areas(&a, L, area);
        for (uint32_t i = 0; i < 100; i += 2) {
            assert_true((area[i] > 0) == (area[i + 1] > 0));
            if (fabs(area[i] - area[i + 1]) > 1e-4 * area[i])
                fail_msg("level %g: leaf %u drawn at %g, its layer at %g", L->lambda, i, area[i],
                         area[i + 1]);
        }
    }
    assert_true(simplified > 0 && dropped > 0);
    sv_stoch_result_free(&a);
    toy_free(&t);
    toy_make_twigs(&t, 100);
    assert_int_equal(sv_stochastic_build(&t.in, &s, 0.01, NULL, &a, &err), SV_OK);
    assert_int_equal(a.layered_leaves, 0);
    sv_stoch_result_free(&a);
    toy_free(&t);
    toy_make_twigs(&t, 100);
    toy_twin_leaves(&t, (const double[3]){0, 0.01, 0});
    assert_int_equal(sv_stochastic_build(&t.in, &s, 0.01, NULL, &a, &err), SV_OK);
    assert_int_equal(a.layered_leaves, 0);
    sv_stoch_result_free(&a);
    toy_free(&t);
}

/* Fewer triangles score higher: the opposite of every real tree. */
static sv_status score_fewer_triangles(void *user, const sv_mesh *g, double *score, sv_error *err)
{
    (void)user, (void)err;
    *score = 1.0 / (1.0 + g->triangle_count);
    return SV_OK;
}

/* No level scores below a coarser one: when every candidate of a finer
 * level scores below a coarser level, it becomes a copy of that level. */
static void a_level_never_scores_below_a_coarser_one(void **state)
{
    (void)state;
    toy t;
    toy_make_twigs(&t, 100);
    sv_stochastic_settings s;
    cJSON *j = cJSON_Parse("{\"levels\": [0.5, 0.25, 0.1]}");
    assert_int_equal(sv_stochastic_parse(j, &s, NULL), SV_OK);
    cJSON_Delete(j);
    sv_stoch_result a;
    sv_error err = {0};
    sv_stoch_scorer sc = {score_fewer_triangles, NULL};
    assert_int_equal(sv_stochastic_build(&t.in, &s, 0.01, &sc, &a, &err), SV_OK);
    assert_int_equal(a.level_count, 3);
    const sv_stoch_level *c = &a.levels[2];
    assert_int_equal(c->same_as, -1);
    uint32_t copies = 0;
    for (uint32_t k = 0; k < 2; k++) {
        const sv_stoch_level *L = &a.levels[k];
        for (uint32_t m = k + 1; m < 3; m++) assert_true(L->score >= a.levels[m].score - 1e-4);
        if (L->same_as >= 0) {
            copies++;
            assert_true(L->same_as > (int)k);
            const sv_stoch_level *o = &a.levels[L->same_as];
            assert_int_equal(L->geometry->triangle_count, o->geometry->triangle_count);
            assert_memory_equal(L->geometry->positions, o->geometry->positions,
                                3 * sizeof(float) * o->geometry->vertex_count);
            CLOSE(L->lambda, s.levels[k], 0);
        }
    }
    assert_true(copies > 0);
    sv_stoch_result_free(&a);
    toy_free(&t);
}

/* The trunk first: below λ = 1 it is simplified within the level error and
 * leads the geometry, and the leaves get λ × all triangles minus its share. */
static void the_trunk_is_built_first_and_the_leaves_get_the_rest(void **state)
{
    (void)state;
    toy t;
    toy_make_tessellated(&t, 100);
    /* the last 20 grids become trunk: 80 leaves (2560 triangles), 640 trunk */
    for (uint32_t k = 80 * 32; k < 100 * 32; k++) t.cls.tri_part[k] = SV_PART_TRUNK;
    t.leaves.count = 80;
    t.leaves.tri_count = 80 * 32;
    sv_stochastic_settings s;
    cJSON *j = cJSON_Parse("{\"levels\": [1, 0.1, {\"triangles\": 100}]}");
    assert_int_equal(sv_stochastic_parse(j, &s, NULL), SV_OK);
    cJSON_Delete(j);
    assert_int_equal(sv_stochastic_resolve(&s, t.mesh->triangle_count, NULL), SV_OK);
    sv_stoch_result res;
    sv_error err = {0};
    assert_int_equal(sv_stochastic_build(&t.in, &s, 0.01, NULL, &res, &err), SV_OK);
    assert_false(res.levels[0].trunk_in_geometry); /* λ = 1: the pipeline keeps the trunk whole */
    for (uint32_t k = 1; k < 3; k++) {
        const sv_stoch_level *L = &res.levels[k];
        const sv_mesh *g = L->geometry;
        assert_true(L->trunk_in_geometry);
        /* flat grids: the trunk goes to two triangles a grid, far below 640 */
        assert_true(L->trunk_triangles > 0 && L->trunk_triangles <= 64);
        assert_int_equal(g->triangle_count, L->trunk_triangles + L->leaf_triangles);
        /* the trunk's vertices lead: every trunk triangle uses only them */
        for (uint32_t tr = 0; tr < L->trunk_triangles; tr++)
            for (int c = 0; c < 3; c++) assert_true(g->indices[3 * tr + c] < L->trunk_vertices);
        for (uint32_t tr = L->trunk_triangles; tr < g->triangle_count; tr++)
            for (int c = 0; c < 3; c++) assert_true(g->indices[3 * tr + c] >= L->trunk_vertices);
    }
    /* λ = 0.1 of 3200 = 320 triangles: the trunk's few leave room for every leaf */
    assert_int_equal(res.levels[1].leaves, 80);
    assert_true(res.levels[1].geometry->triangle_count <= 320);
    /* {"triangles": 100}: within 100, trunk included */
    assert_true(res.levels[2].geometry->triangle_count <= 100);
    assert_true(res.levels[2].leaves < 80);
    sv_stoch_result_free(&res);
    toy_free(&t);
}

static sv_status score_small_area(void *user, const sv_mesh *g, double *score, sv_error *err)
{
    (void)err;
    (*(int *)user)++;
    *score = -mesh_area(g);
    return SV_OK;
}

static sv_status score_large_area(void *user, const sv_mesh *g, double *score, sv_error *err)
{
    (void)err;
    (*(int *)user)++;
    *score = mesh_area(g);
    return SV_OK;
}

/* With a scorer the candidates compete: gentler area scaling (γ 0.85, 0.7)
 * wins only when the score says so; the paper's γ = 1 otherwise. */
static void a_scorer_chooses_the_area_scaling(void **state)
{
    (void)state;
    toy t;
    toy_make(&t, 100);
    sv_stochastic_settings s;
    cJSON *j = cJSON_Parse("{\"levels\": [1, 0.25]}");
    assert_int_equal(sv_stochastic_parse(j, &s, NULL), SV_OK);
    cJSON_Delete(j);
    int calls = 0;
    sv_stoch_scorer small = {score_small_area, &calls}, large = {score_large_area, &calls};
    sv_stoch_result a, b, none;
    assert_int_equal(sv_stochastic_build(&t.in, &s, 0.01, &small, &a, NULL), SV_OK);
    assert_true(calls >= 3); /* λ = 1 is not scored; 0.25: trunkless, then two γ */
    assert_true(a.levels[0].area_gamma == 1.0);
    assert_true(a.levels[1].area_gamma == 0.7);
    assert_true(a.levels[1].area_scale > 1.5);
    assert_int_equal(sv_stochastic_build(&t.in, &s, 0.01, &large, &b, NULL), SV_OK);
    assert_true(b.levels[1].area_gamma == 1.0);
    assert_int_equal(sv_stochastic_build(&t.in, &s, 0.01, NULL, &none, NULL), SV_OK);
    assert_true(none.levels[1].area_gamma == 1.0);
    /* γ = 0.7 leaves are smaller: (s)^(0.35) vs √s about the same centres */
    CLOSE(mesh_area(a.levels[1].geometry) / mesh_area(none.levels[1].geometry),
          pow(a.levels[1].area_scale, 0.7 - 1.0), 1e-3);
    sv_stoch_result_free(&a);
    sv_stoch_result_free(&b);
    sv_stoch_result_free(&none);
    toy_free(&t);
}

/* n foliage masses: closed UV spheres of radius 0.6 m (16 segments × 8
 * rings, 224 triangles each), one connected element each, side by side
 * 0.8 m apart so they overlap into one crown (a Scopia-style cypress, not
 * leaf cards). Facets of a sphere that round cannot be merged within a
 * level's pixel error, so the masses cannot be simplified by error alone. */
#define MASS_SEG 16
#define MASS_RING 8
#define MASS_TRIS (2 * MASS_SEG * (MASS_RING - 1))
static void toy_make_masses(toy *t, uint32_t n)
{
    const uint32_t nv = MASS_SEG * (MASS_RING + 1);
    sv_mesh *m = toy_alloc(t, nv * n, n, MASS_TRIS, 1);
    for (int c = 0; c < 3; c++) m->materials[0].base_color[c] = 0.3f;
    for (uint32_t i = 0; i < n; i++) {
        double c[3] = {0.8 * (i % 3), 0, 0.8 * (i / 3)};
        sv_leaf *l = &t->leaves.leaves[i];
        memcpy(l->centre, c, sizeof l->centre);
        l->normal[2] = 1;
        l->area = 4 * M_PI * 0.36;
        l->radius = 0.6;
        l->first = MASS_TRIS * i;
        l->count = MASS_TRIS;
        for (uint32_t r = 0; r <= MASS_RING; r++)
            for (uint32_t k = 0; k < MASS_SEG; k++) {
                double th = M_PI * r / MASS_RING, ph = 2 * M_PI * k / MASS_SEG;
                double d[3] = {sin(th) * cos(ph), sin(th) * sin(ph), cos(th)};
                if (r == 0 || r == MASS_RING) d[0] = d[1] = 0; /* one pole vertex */
                uint32_t v = nv * i + r * MASS_SEG + k;
                for (int a = 0; a < 3; a++) {
                    m->positions[3 * v + a] = (float)(c[a] + 0.6 * d[a]);
                    m->normals[3 * v + a] = (float)d[a];
                }
                m->uvs[2 * v] = (float)k / MASS_SEG;
                m->uvs[2 * v + 1] = (float)r / MASS_RING;
            }
        uint32_t *ix = &m->indices[3 * MASS_TRIS * i], q = 0;
        for (uint32_t r = 0; r < MASS_RING; r++)
            for (uint32_t k = 0; k < MASS_SEG; k++) {
                uint32_t a = nv * i + r * MASS_SEG + k,
                         b = nv * i + r * MASS_SEG + (k + 1) % MASS_SEG;
                if (r > 0) ix[q++] = a, ix[q++] = b, ix[q++] = a + MASS_SEG;
                if (r + 1 < MASS_RING) ix[q++] = b, ix[q++] = b + MASS_SEG, ix[q++] = a + MASS_SEG;
            }
        assert_int_equal(q, 3 * MASS_TRIS);
    }
    toy_finish(t);
}

#define COVER_PX 64
typedef struct cover_scorer {
    const sv_mesh *original;
    double lo[3], span;
} cover_scorer;

/* Marks the pixels of a COVER_PX² grid that g covers seen along axis `ax`
 * (orthographic, over the original's bounding cube). */
static void cover_raster(const cover_scorer *c, const sv_mesh *g, int ax, uint8_t *px)
{
    int ua = (ax + 1) % 3, va = (ax + 2) % 3;
    memset(px, 0, COVER_PX * COVER_PX);
    for (uint32_t t = 0; t < g->triangle_count; t++) {
        double x[3], y[3];
        for (int j = 0; j < 3; j++) {
            const float *p = &g->positions[3 * g->indices[3 * t + j]];
            x[j] = (p[ua] - c->lo[ua]) / c->span * COVER_PX;
            y[j] = (p[va] - c->lo[va]) / c->span * COVER_PX;
        }
        double det = (x[1] - x[0]) * (y[2] - y[0]) - (x[2] - x[0]) * (y[1] - y[0]);
        if (!(fabs(det) > 0)) continue;
        for (int py = 0; py < COVER_PX; py++)
            for (int pxx = 0; pxx < COVER_PX; pxx++) {
                double X = pxx + 0.5, Y = py + 0.5;
                double b1 = ((X - x[0]) * (y[2] - y[0]) - (x[2] - x[0]) * (Y - y[0])) / det;
                double b2 = ((x[1] - x[0]) * (Y - y[0]) - (X - x[0]) * (y[1] - y[0])) / det;
                if (b1 >= 0 && b2 >= 0 && b1 + b2 <= 1) px[py * COVER_PX + pxx] = 1;
            }
    }
}

/* The mean coverage IoU of g against the original along the three axes. */
static sv_status score_cover(void *user, const sv_mesh *g, double *score, sv_error *err)
{
    (void)err;
    const cover_scorer *c = user;
    static uint8_t a[COVER_PX * COVER_PX], b[COVER_PX * COVER_PX];
    double sum = 0;
    for (int ax = 0; ax < 3; ax++) {
        cover_raster(c, c->original, ax, a);
        cover_raster(c, g, ax, b);
        uint32_t in = 0, un = 0;
        for (int k = 0; k < COVER_PX * COVER_PX; k++) in += a[k] && b[k], un += a[k] || b[k];
        sum += un ? (double)in / un : 1.0;
    }
    *score = sum / 3;
    return SV_OK;
}

/* A crown of six foliage masses at λ = 0.1: a leaf card dropped whole loses
 * one of thousands, a mass dropped whole loses a sixth of the crown, and a
 * mass cannot be simplified within the level's error. The spread candidate
 * keeps every mass, the foliage simplified as one mesh to the budget, and
 * covers the crown where dropping masses left one of them. */
static void foliage_masses_are_thinned_not_dropped(void **state)
{
    (void)state;
    toy t;
    toy_make_masses(&t, 6);
    cover_scorer c = {.original = t.mesh};
    double hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (int a = 0; a < 3; a++) c.lo[a] = INFINITY;
    for (uint32_t v = 0; v < t.mesh->vertex_count; v++)
        for (int a = 0; a < 3; a++) {
            c.lo[a] = fmin(c.lo[a], t.mesh->positions[3 * v + a]);
            hi[a] = fmax(hi[a], t.mesh->positions[3 * v + a]);
        }
    c.span = fmax(hi[0] - c.lo[0], fmax(hi[1] - c.lo[1], hi[2] - c.lo[2]));
    sv_stochastic_settings s;
    cJSON *j = cJSON_Parse("{\"levels\": [1, 0.1]}");
    assert_int_equal(sv_stochastic_parse(j, &s, NULL), SV_OK);
    cJSON_Delete(j);
    sv_stoch_scorer sc = {score_cover, &c};
    sv_stoch_result res;
    sv_error err = {0};
    assert_int_equal(sv_stochastic_build(&t.in, &s, 0.5, &sc, &res, &err), SV_OK);
    const sv_stoch_level *L = &res.levels[1];
    /* dropping masses keeps one of six (0.42); all six thinned: 0.86 */
    assert_true(L->score >= 0.8);
    assert_int_equal(L->leaves, 6);
    assert_true(L->spread);
    /* within the level's budget: a tenth of the tree's triangles */
    assert_true(L->geometry->triangle_count <= 6 * MASS_TRIS / 10);
    sv_stoch_result_free(&res);
    toy_free(&t);
}

/* The level error: one pixel at the level's Cook distance, or one pixel of
 * a tree drawn 512 px tall at d0 and shrunk by d0/d, whichever is larger. */
static void level_error_is_a_pixel_at_the_level_distance(void **state)
{
    (void)state;
    sv_stochastic_settings s;
    assert_int_equal(sv_stochastic_parse(NULL, &s, NULL), SV_OK);
    sv_scene sc;
    sv_scene_defaults(&sc); /* d0 = distance_min = 10 m, h = 0.5: λ 0.25 at 20 m */
    double px20 = sv_scene_pixels(&sc, 1.0, 20);
    assert_true(sv_stochastic_level_error(&s, &sc, 1.0, 1.0) == 0);
    CLOSE(sv_stochastic_level_error(&s, &sc, 0.5, 0.25), 1.0 / px20, 1e-9);
    /* a 400 m tree: its own 512 px rule wins */
    CLOSE(sv_stochastic_level_error(&s, &sc, 200, 0.25), 400.0 / (512 * 0.5), 1e-6);
    assert_true(sv_stochastic_level_error(&s, NULL, 1.0, 0.25) == 0);
}

static double lum(const float *c)
{
    return 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
}

static void contrast_bins_pull_leaf_luminance_towards_the_mean(void **state)
{
    (void)state;
    toy t;
    toy_make(&t, 100);
    /* darken both so brightening the dark leaves has headroom */
    for (int m = 0; m < 2; m++)
        for (int c = 0; c < 3; c++) t.mesh->materials[m].base_color[c] *= 0.5f;
    sv_stochastic_settings s;
    assert_int_equal(sv_stochastic_parse(NULL, &s, NULL), SV_OK);
    sv_stoch_result res;
    assert_int_equal(sv_stochastic_build(&t.in, &s, 0.01, NULL, &res, NULL), SV_OK);
    double mean = 0.5 * (0.4 + 0.1); /* equal areas */
    CLOSE(res.mean_color[0], mean, 1e-6);
    const sv_stoch_level *L = &res.levels[2]; /* λ = 0.25 */
    assert_true(L->contrast_materials >= 2);
    for (uint32_t i = 0; i < L->geometry->triangle_count; i++) {
        const sv_material *m = &L->geometry->materials[L->geometry->tri_material[i]];
        double y0 = lum(t.mesh->materials[i / 2 < L->leaves ? res.order[i / 2] % 2 : 0].base_color);
        double want = sv_stochastic_contrast(y0, mean, 0.25);
        /* quantised in steps of 2^(1/16): within half a step */
        assert_true(fabs(log2(lum(m->base_color) / want)) <= 1.0 / 32 + 1e-6);
    }
    /* switched off: the source materials only */
    s.contrast_preservation = false;
    sv_stoch_result r2;
    assert_int_equal(sv_stochastic_build(&t.in, &s, 0.01, NULL, &r2, NULL), SV_OK);
    assert_int_equal(r2.levels[2].contrast_materials, 0);
    sv_stoch_result_free(&r2);
    sv_stoch_result_free(&res);
    toy_free(&t);
}

/* A leaf whose factor would pass 1 (glTF keeps baseColorFactor in [0, 1])
 * draws a copy of its texture brightened in linear light, so it still gets
 * the luminance it needs: here a dark textured material (factor 1, texel 0.2
 * linear) is pulled to the mean by contrast preservation. */
static void a_factor_past_one_brightens_a_copy_of_the_texture(void **state)
{
    (void)state;
    toy t;
    toy_images = 1;
    toy_make(&t, 100);
    toy_images = 0;
    sv_image *im = &t.mesh->images[0];
    assert_int_equal(sv_image_alloc(im, 1, 1, 3, 8, NULL), SV_OK);
    uint8_t code = sv_srgb_encode8(0.2);
    memset(im->data, code, 3);
    double y1 = sv_srgb_decode8(code);
    for (int c = 0; c < 3; c++) t.mesh->materials[1].base_color[c] = 1.0f;
    t.mesh->materials[1].base_texture = 0;
    sv_stochastic_settings s;
    assert_int_equal(sv_stochastic_parse(NULL, &s, NULL), SV_OK);
    sv_stoch_result res;
    assert_int_equal(sv_stochastic_build(&t.in, &s, 0.01, NULL, &res, NULL), SV_OK);
    double mean = 0.5 * (0.8 + y1);
    const sv_stoch_level *L = &res.levels[2]; /* λ = 0.25 */
    assert_true(L->brightened_textures >= 1);
    assert_int_equal(L->contrast_capped, 0);
    const sv_mesh *g = L->geometry;
    uint32_t bright = 0;
    for (uint32_t i = 0; i < g->triangle_count; i++) {
        const sv_material *m = &g->materials[g->tri_material[i]];
        double y = lum(m->base_color);
        assert_true(y <= 1.0 + 1e-6);
        if (m->base_texture >= 0) {
            const uint8_t *px = g->images[m->base_texture].data;
            y *= sv_srgb_decode8(px[0]);
            bright += m->base_texture >= 1;
        }
        uint32_t src = i / 2 < L->leaves ? res.order[i / 2] % 2 : 0;
        double want = sv_stochastic_contrast(src ? y1 : 0.8, mean, 0.25);
        /* quantised in steps of 2^(1/16), and an 8-bit texel */
        if (fabs(log2(y / want)) > 1.0 / 32 + 0.02)
            fail_msg("triangle %u: luminance %.4f, wanted %.4f", i, y, want);
    }
    assert_true(bright > 0);
    sv_stoch_result_free(&res);
    toy_free(&t);
}

static void settings_are_strict_and_the_method_needs_r(void **state)
{
    (void)state;
    sv_stochastic_settings s;
    sv_error err = {0};
    const char *bad[] = {"{\"levels\": [0.5, 0.7]}",
                         "{\"levels\": [0]}",
                         "{\"h\": 1}",
                         "{\"order\": \"best\"}",
                         "{\"bogus\": 1}",
                         "{\"levels\": []}",
                         "{\"levels\": [{\"triangles\": 0}]}",
                         "{\"levels\": [1, {\"triangles\": 2.5}]}",
                         "{\"levels\": [{\"triangles\": 9, \"lambda\": 1}]}",
                         "{\"simplify_leaves\": 1}"};
    const char *key[] = {"levels[1]", "levels[0]",         "stochastic.h", "stochastic.order",
                         "bogus",     "stochastic.levels", "levels[0]",    "levels[1]",
                         "levels[0]", "simplify_leaves"};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        cJSON *j = cJSON_Parse(bad[i]);
        assert_int_equal(sv_stochastic_parse(j, &s, &err), SV_ERR_SPEC);
        assert_non_null(strstr(err.message, key[i]));
        cJSON_Delete(j);
    }
    assert_int_equal(sv_stochastic_parse(NULL, &s, NULL), SV_OK);
    assert_int_equal(s.level_count, 4);
    assert_true(s.levels[0] == 1 && s.levels[3] == 0.1 && s.h == 0.5);

    toy t;
    toy_make(&t, 40);
    const sv_method_ops *m = sv_method_ops_find("stochastic");
    assert_non_null(m);
    sv_stand_in si = {0};
    assert_int_equal(m->run(&t.in, NULL, &si, &err), SV_ERR_INVALID);
    assert_non_null(strstr(err.message, "visible_ratio"));
    cJSON *j = cJSON_Parse("{\"visible_ratio\": 0.01}");
    assert_int_equal(m->run(&t.in, j, &si, &err), SV_OK);
    cJSON_Delete(j);
    assert_int_equal(si.lod_count, 4);
    assert_string_equal(si.lods[0].name, "full");
    assert_string_equal(si.lods[1].name, "stochastic50");
    assert_int_equal(si.lods[0].trunk, SV_TRUNK_MESH);
    /* below λ = 1 the trunk is built first, into the geometry (none here) */
    assert_int_equal(si.lods[3].trunk, SV_TRUNK_NONE);
    assert_int_equal(si.lods[3].geometry->triangle_count, 2 * 4);
    assert_int_equal(si.lods[0].quad_count, 0);
    assert_int_equal(si.lods[3].trunk_max_triangles, 0); /* a λ level: no cap */
    sv_stand_in_free(&si);

    /* levels by triangles: λ = N / the tree's triangles (80 here), resolved
     * once the tree is known; the trunk gets what the leaves leave of N */
    j = cJSON_Parse("{\"visible_ratio\": 0.01, \"levels\": [1, {\"triangles\": 40}, 0.25, "
                    "{\"triangles\": 8}]}");
    assert_int_equal(sv_stochastic_parse(j, &s, &err), SV_OK);
    assert_int_equal(s.level_triangles[1], 40);
    assert_true(s.levels[1] == 0);
    assert_int_equal(sv_stochastic_resolve(&s, 80, &err), SV_OK);
    CLOSE(s.levels[1], 0.5, 1e-12);
    CLOSE(s.levels[3], 0.1, 1e-12);
    assert_int_equal(m->run(&t.in, j, &si, &err), SV_OK);
    cJSON_Delete(j);
    assert_string_equal(si.lods[1].name, "stochastic50");
    assert_string_equal(si.lods[3].name, "stochastic10");
    assert_int_equal(si.lods[1].geometry->triangle_count, 40);
    assert_int_equal(si.lods[1].trunk_max_triangles, 1); /* the leaves took all 40 */
    assert_int_equal(si.lods[2].trunk_max_triangles, 0);
    sv_stand_in_free(&si);
    sv_stoch_level L = {.leaf_triangles = 6};
    assert_int_equal(sv_stochastic_trunk_cap(&s, 3, &L), 2);
    assert_int_equal(sv_stochastic_trunk_cap(&s, 2, &L), 0);
    /* a count that does not fall below the level before it names both */
    j = cJSON_Parse("{\"levels\": [0.5, {\"triangles\": 60}]}");
    assert_int_equal(sv_stochastic_parse(j, &s, &err), SV_OK);
    cJSON_Delete(j);
    assert_int_equal(sv_stochastic_resolve(&s, 80, &err), SV_ERR_SPEC);
    assert_non_null(strstr(err.message, "levels[1]"));
    assert_non_null(strstr(err.message, "80 triangles"));
    toy_free(&t);
}

/* ---- a real tree: visible area by rendering ---- */

typedef struct cover {
    sv_renderer *ren;
    sv_gpu_mesh *g;
    double centre[3], radius;
} cover;

#define VIEWS 6
#define SIZE 384

static sv_status count_pixels(void *user, const uint32_t *tris, uint32_t n, double *covered,
                              sv_error *err)
{
    cover *c = user;
    double dirs[3 * VIEWS];
    sv_eval_place_views(SV_VIEWER_ORBIT, VIEWS, dirs);
    *covered = 0;
    for (int v = 0; v < VIEWS; v++) {
        sv_camera cam;
        sv_eval_camera(c->centre, c->radius, &dirs[3 * v], &cam);
        sv_render_options ro = {0};
        sv_image img = {0};
        sv_status st = sv_render(c->ren, c->g, tris, n, &cam, &ro, SIZE, SIZE, &img, NULL, err);
        if (st) return st;
        for (size_t i = 0; i < (size_t)SIZE * SIZE; i++)
            *covered += ((uint8_t *)img.data)[4 * i + 3] >= 128;
        sv_image_free(&img);
    }
    return SV_OK;
}

/* Visible (covered) area of each level's geometry relative to the full
 * tree's foliage, with and without area preservation. */
static void area_preservation_keeps_the_visible_area_of_a_real_tree(void **state)
{
    (void)state;
    const char *dir = sv_test_data("the real-tree visible area");
    char path[1024];
    snprintf(path, sizeof path, "%s/eztree_oak_large/oak_large.glb", dir);
    size_t n = 0;
    uint8_t *data = sv_test_read_all(path, &n);
    if (!data) fail_msg("cannot read %s", path);
    sv_file f = {"oak_large.glb", data, n};
    sv_error err = {0};
    sv_mesh *m = NULL;
    assert_int_equal(sv_import(&f, 1, NULL, &m, NULL, &err), SV_OK);
    sv_classification cls;
    sv_leaves lv;
    assert_int_equal(sv_classify(m, NULL, &cls, &err), SV_OK);
    assert_int_equal(sv_leaves_build(m, &cls, &lv, &err), SV_OK);
    sv_renderer *ren = NULL;
    if (sv_renderer_create(SIZE, &ren, &err) != SV_OK)
        fail_msg("no OSMesa context: %s", err.message);
    cover c = {ren, NULL, {0, 0, 0}, 0};
    sv_mesh_sphere(m, c.centre, &c.radius);
    assert_int_equal(sv_gpu_mesh_upload(ren, m, &c.g, &err), SV_OK);
    sv_scene sc;
    sv_scene_defaults(&sc);
    sv_method_input in = {m, &cls, &lv, {c.centre[0], c.centre[1], c.centre[2]}, c.radius, &sc, 1, NULL};
    sv_stochastic_settings s;
    /* the paper's method (leaves as modelled, a leaf count): what is measured
     * here is eq. 3 itself */
    cJSON *j = cJSON_Parse("{\"levels\": [1, 0.5, 0.25, 0.1], \"simplify_leaves\": false}");
    assert_int_equal(sv_stochastic_parse(j, &s, NULL), SV_OK);
    cJSON_Delete(j);
    uint32_t *order = calloc(lv.count, sizeof *order);
    assert_int_equal(sv_stochastic_order(&lv, 1, s.order, order, NULL), SV_OK);
    sv_stoch_ratio ratio;
    assert_int_equal(sv_stochastic_measure_ratio(&lv, order, 0.1, count_pixels, &c, &ratio, &err),
                     SV_OK);
    free(order);
    assert_true(ratio.r > 0 && ratio.r < 0.05);
    double rel[2][4];
    for (int pres = 1; pres >= 0; pres--) {
        s.area_preservation = pres;
        sv_stoch_result res;
        assert_int_equal(sv_stochastic_build(&in, &s, ratio.r, NULL, &res, &err), SV_OK);
        double full = 0;
        for (uint32_t k = 0; k < res.level_count; k++) {
            sv_gpu_mesh *gg = NULL;
            assert_int_equal(sv_gpu_mesh_upload(ren, res.levels[k].geometry, &gg, &err), SV_OK);
            cover cl = c;
            cl.g = gg;
            double a = 0;
            assert_int_equal(count_pixels(&cl, NULL, 0, &a, &err), SV_OK);
            sv_gpu_mesh_free(gg);
            if (k == 0) full = a;
            rel[pres][k] = a / full;
        }
        sv_stoch_result_free(&res);
    }
    print_message(
        "oak: r = %.3g; visible area / full at λ = 1, .5, .25, .1: preserved %.3f %.3f %.3f "
        "%.3f, not preserved %.3f %.3f %.3f %.3f\n",
        ratio.r, rel[1][0], rel[1][1], rel[1][2], rel[1][3], rel[0][0], rel[0][1], rel[0][2],
        rel[0][3]);
    /* Stated tolerance: within 30% of the full tree's visible area at every
     * level down to λ = 0.1 (measured: +6%, +13%, +25% — √s-scaled leaves at
     * the crown's edge widen the silhouette, which Cook's fixed-region model
     * ignores), and at every λ < 1 less than half the error without it. */
    for (int k = 0; k < 4; k++) assert_true(fabs(rel[1][k] - 1.0) <= 0.30);
    for (int k = 1; k < 4; k++) assert_true(fabs(rel[1][k] - 1.0) < 0.5 * fabs(rel[0][k] - 1.0));
    /* without area preservation λ = 0.1 loses far more than the tolerance */
    assert_true(rel[0][3] < 0.6);
    sv_gpu_mesh_free(c.g);
    sv_renderer_destroy(ren);
    sv_leaves_free(&lv);
    sv_classification_free(&cls);
    sv_mesh_destroy(m);
    free(data);
}

/* ---- the chain hook ---- */

/* The pipeline's cover callback, stood in for by Cook's model: each leaf
 * (2 triangles) covers 5 % of a 1000-pixel image at random. */
static sv_status cover_by_model(void *user, const uint32_t *tris, uint32_t count, double *covered,
                                sv_error *err)
{
    (void)tris, (void)err;
    ++*(int *)user;
    *covered = 1000.0 * (1.0 - pow(0.95, count / 2.0));
    return SV_OK;
}

static sv_status score_counting(void *user, const sv_mesh *g, double *score, sv_error *err)
{
    (void)err;
    ++*(int *)user;
    *score = -(double)g->triangle_count;
    return SV_OK;
}

/* The chain's levels come through the method's chain hook: r measured by the
 * pipeline's cover callback (r of the model), candidates scored by its score
 * callback; each level carries its place in the schedule and a payload whose
 * hooks give its glTF attributes (trunk vertices before the leaves: their own
 * position, order 0) and its report fields. Without build, only the settings
 * are checked. */
static void chain_hook_builds_levels_through_the_pipelines_callbacks(void **state)
{
    (void)state;
    toy t;
    toy_make(&t, 100);
    const sv_method_ops *m = sv_method_ops_find(sv_method_chain_levels()->name);
    assert_non_null(m);
    assert_non_null(m->chain);
    cJSON *set = cJSON_Parse("{\"levels\": [1, 0.5, 0.25]}");
    int covers = 0, scores = 0;
    sv_chain_in ci = {&t.in,   set, true, false,          cover_by_model,
                      &covers, 3,   128,  score_counting, &scores};
    sv_chain_out out = {0};
    sv_error err = {0};
    assert_int_equal(m->chain(&ci, &out, &err), SV_OK);
    assert_int_equal(out.levels.lod_count, 0);
    assert_int_equal(covers + scores, 0);
    sv_chain_out_free(&out);

    ci.build = true;
    assert_int_equal(m->chain(&ci, &out, &err), SV_OK);
    assert_int_equal(out.levels.lod_count, 3);
    assert_true(covers >= 2);
    assert_true(scores > 0);
    const cJSON *vr = cJSON_GetObjectItem(out.report, "visible_ratio");
    assert_float_equal(cJSON_GetObjectItem(vr, "r")->valuedouble, 0.05, 0.01);
    assert_int_equal(cJSON_GetObjectItem(vr, "views")->valueint, 3);
    assert_int_equal(cJSON_GetObjectItem(vr, "pixels")->valueint, 128);
    const double lambdas[3] = {1, 0.5, 0.25};
    int scored = 0;
    for (uint32_t k = 0; k < 3; k++) {
        sv_lod_plan *lp = &out.levels.lods[k];
        assert_string_equal(out.place[k].source, "stochastic");
        assert_float_equal(out.place[k].lambda, lambdas[k], 1e-12);
        assert_non_null(lp->payload);
        assert_non_null(lp->ops);
        assert_non_null(lp->geometry);
        /* a bake: two trunk vertices, then the level's geometry */
        uint32_t gv = lp->geometry->vertex_count;
        sv_baked_lod bk = {0};
        bk.mesh = sv_mesh_create(2 + gv, 0, 1, 0);
        assert_non_null(bk.mesh);
        for (uint32_t i = 0; i < 3 * (2 + gv); i++) bk.mesh->positions[i] = (float)i;
        sv_level_gltf g = {0};
        assert_int_equal(lp->ops->gltf(lp, &bk, &g, &err), SV_OK);
        assert_int_equal(g.attr_count, 2);
        assert_string_equal(g.attr[0].name, "_LEAF_CENTRE");
        assert_string_equal(g.attr[1].name, "_LEAF_ORDER");
        for (uint32_t i = 0; i < 6; i++) assert_float_equal(g.attr[0].data[i], (float)i, 0);
        assert_float_equal(g.attr[1].data[0], 0, 0);
        assert_float_equal(g.attr[1].data[1], 0, 0);
        for (uint32_t i = 2; i < 2 + gv; i++)
            assert_true(g.attr[1].data[i] > 0 && g.attr[1].data[i] < 1);
        const cJSON *x = cJSON_GetObjectItem(g.extras, "sylva_stochastic");
        assert_float_equal(cJSON_GetObjectItem(x, "lambda")->valuedouble, lambdas[k], 1e-12);
        sv_level_gltf_free(&g);
        sv_mesh_destroy(bk.mesh);
        cJSON *o = cJSON_CreateObject();
        lp->ops->report(lp, o);
        assert_float_equal(cJSON_GetObjectItem(o, "lambda")->valuedouble, lambdas[k], 1e-12);
        assert_true(cJSON_GetObjectItem(o, "leaves")->valueint > 0);
        scored += cJSON_IsNumber(cJSON_GetObjectItem(o, "candidate_iou"));
        cJSON_Delete(o);
    }
    assert_true(scored > 0); /* the score callback's figure is reported */
    sv_chain_out_free(&out);
    cJSON_Delete(set);
    toy_free(&t);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(lambda_matches_hand_computed_values),
        cmocka_unit_test(motion_term_applies_only_with_camera_motion),
        cmocka_unit_test(area_scale_matches_hand_values),
        cmocka_unit_test(area_scale_is_one_at_full_detail_and_bounded_when_small),
        cmocka_unit_test(contrast_moves_colour_towards_the_mean_by_sqrt_lambda),
        cmocka_unit_test(fade_window_is_centred_on_lambda_and_closed_at_one),
        cmocka_unit_test(ratio_from_coverage_inverts_cooks_model),
        cmocka_unit_test(order_is_a_deterministic_permutation_for_a_seed),
        cmocka_unit_test(area_order_puts_larger_leaves_first_on_average),
        cmocka_unit_test(every_prefix_is_a_valid_mesh_with_leaves_scaled_about_their_centres),
        cmocka_unit_test(simplified_leaves_fit_more_of_the_tree_in_the_budget),
        cmocka_unit_test(no_drawn_leaf_is_a_sliver),
        cmocka_unit_test(a_leafs_layers_go_and_simplify_together),
        cmocka_unit_test(a_level_never_scores_below_a_coarser_one),
        cmocka_unit_test(level_error_is_a_pixel_at_the_level_distance),
        cmocka_unit_test(the_trunk_is_built_first_and_the_leaves_get_the_rest),
        cmocka_unit_test(a_scorer_chooses_the_area_scaling),
        cmocka_unit_test(foliage_masses_are_thinned_not_dropped),
        cmocka_unit_test(contrast_bins_pull_leaf_luminance_towards_the_mean),
        cmocka_unit_test(a_factor_past_one_brightens_a_copy_of_the_texture),
        cmocka_unit_test(settings_are_strict_and_the_method_needs_r),
        cmocka_unit_test(area_preservation_keeps_the_visible_area_of_a_real_tree),
        cmocka_unit_test(chain_hook_builds_levels_through_the_pipelines_callbacks),
    };
    return sv_test_exit(cmocka_run_group_tests(tests, NULL, NULL));
}
