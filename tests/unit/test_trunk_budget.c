/* test_trunk_budget.c — the trunk held to a triangle budget (core/geom/trunk.c,
 * sv_trunk_mesh_budget): the cap wins over the error bound, the shape stays
 * where the trunk was, foliage never enters, and no budget means no change;
 * a quad level's trunk (sv_trunk_mesh_parts) keeps the stem of a trunk made
 * of many separate branches and shares the budget between parts; the twigs a
 * kept trunk leaves out are grouped by cell (sv_twig_groups). */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <cmocka.h>
#include "test_skip.h"
#include "test_data.h"

#include <math.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>

#include "classify.h"
#include "import.h"
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

/* Open tubes (radius r, from y0 to y0 + h, axis at (x, z)), each welded,
 * all trunk, material 0: a trunk as sapling writes it, one separate part
 * per branch. */
typedef struct tubes {
    float pos[3 * 40000];
    uint32_t idx[3 * 40000];
    uint32_t nv, nt;
} tubes;

static void add_tube(tubes *b, double x, double z, double y0, double h, double r, int seg,
                     int rings)
{
    uint32_t base = b->nv;
    for (int k = 0; k <= rings; k++)
        for (int s = 0; s < seg; s++) {
            double a = 2 * M_PI * s / seg;
            float *p = &b->pos[3 * (size_t)b->nv++];
            p[0] = (float)(x + r * cos(a)), p[1] = (float)(y0 + h * k / rings),
            p[2] = (float)(z + r * sin(a));
        }
    for (int k = 0; k < rings; k++)
        for (int s = 0; s < seg; s++) {
            uint32_t a = base + (uint32_t)(k * seg + s),
                     bb = base + (uint32_t)(k * seg + (s + 1) % seg);
            uint32_t c = a + (uint32_t)seg, d = bb + (uint32_t)seg;
            uint32_t q[6] = {a, d, bb, a, c, d};
            memcpy(&b->idx[3 * (size_t)b->nt], q, sizeof q);
            b->nt += 2;
        }
}

static sv_mesh *tubes_mesh(const tubes *b, uint8_t **parts)
{
    sv_mesh *m = sv_mesh_create(b->nv, b->nt, 1, 0);
    assert_non_null(m);
    memcpy(m->positions, b->pos, 3 * (size_t)b->nv * sizeof(float));
    memcpy(m->indices, b->idx, 3 * (size_t)b->nt * sizeof(uint32_t));
    *parts = malloc(b->nt);
    assert_non_null(*parts);
    memset(*parts, SV_PART_TRUNK, b->nt);
    sv_mesh_compute_normals(m);
    return m;
}

/* The stem's four height quarters (0..4 m) that output triangles on the
 * stem (every corner within its radius of the axis at (0, 0)) reach across
 * (a straight tube simplifies to triangles spanning its whole length). */
static int stem_quarters(const sv_mesh *o, double r)
{
    int seen[4] = {0, 0, 0, 0};
    for (uint32_t t = 0; t < o->triangle_count; t++) {
        double lo = INFINITY, hi = -INFINITY;
        bool on = true;
        for (int v = 0; v < 3; v++) {
            const float *p = &o->positions[3 * (size_t)o->indices[3 * (size_t)t + v]];
            on = on && hypot(p[0], p[2]) <= r * 1.001;
            lo = fmin(lo, p[1]), hi = fmax(hi, p[1]);
        }
        for (int q = 0; q < 4 && on; q++) seen[q] |= lo <= q + 0.5 && hi >= q + 0.5;
    }
    return seen[0] + seen[1] + seen[2] + seen[3];
}

/* A stem (radius 0.15 m, 4 m, 128 triangles) under 300 thin twigs (2 cm,
 * 48 triangles each, in a crown 12 m across above 4 m): 14,528 triangles
 * for a budget of 100. The stem is what shows under the crown; it must be there, from the
 * ground up, and the twigs (the quads' to draw) may go. The unbounded
 * whole-trunk collapse and the vertex clustering after it dissolved the
 * sapling maple's stem into scattered triangles. */
static void parts_keep_the_stem_under_many_twigs(void **state)
{
    (void)state;
    static tubes b;
    memset(&b, 0, sizeof b);
    add_tube(&b, 0, 0, 0, 4, 0.15, 8, 8);
    for (int k = 0; k < 2000; k++)
        add_tube(&b, -6 + 0.2 * (k % 60), -3 + 0.2 * (k / 60), 4.5 + 0.7 * (k % 7), 1.0, 0.01, 4,
                 2);
    uint8_t *parts = NULL;
    sv_mesh *m = tubes_mesh(&b, &parts);
    sv_mesh *o = NULL;
    assert_int_equal(sv_trunk_mesh_parts(m, parts, 1.0, 100, &o, NULL), SV_OK);
    assert_non_null(o);
    assert_true(o->triangle_count <= 100);
    assert_int_equal(stem_quarters(o, 0.15), 4);
    sv_mesh_destroy(o);
    sv_mesh_destroy(m);
    free(parts);
}

/* A pot (a dense tube 1 m across, 3,200 triangles, most of the area) beside
 * the stem: at the finest bound the pot alone fills a 150-triangle budget;
 * the choice must still draw the stem (the bonsai lost its trunk). */
static void parts_share_the_budget_between_a_pot_and_the_stem(void **state)
{
    (void)state;
    static tubes b;
    memset(&b, 0, sizeof b);
    add_tube(&b, 0, 0, 0, 4, 0.3, 16, 4);
    add_tube(&b, 3, 0, 0, 1, 1.0, 64, 25);
    uint8_t *parts = NULL;
    sv_mesh *m = tubes_mesh(&b, &parts);
    sv_mesh *o = NULL;
    assert_int_equal(sv_trunk_mesh_parts(m, parts, 1.0, 150, &o, NULL), SV_OK);
    assert_non_null(o);
    assert_true(o->triangle_count <= 150);
    assert_true(stem_quarters(o, 0.3) >= 3);
    bool pot = false;
    for (uint32_t v = 0; v < o->vertex_count; v++) pot |= o->positions[3 * (size_t)v] > 1.5f;
    assert_true(pot);
    sv_mesh_destroy(o);
    sv_mesh_destroy(m);
    free(parts);
}

#ifndef __SANITIZE_ADDRESS__
/* (not in the ASan build: 13 s of CI there for the C paths the cases above
 * run on small trunks; the plain pass runs it) */
/* The sapling maple (SYLVA_DATA): 117,328 bark triangles in 3,121 separate
 * branches, held to 200. Its stem is what shows under the crown: the kept
 * trunk must draw the lowest 15 % of the trunk's height (at least a third of
 * the area the original has there). The whole-trunk collapse kept 190
 * triangles, none below 2 m. */
static void the_maple_keeps_its_stem_at_200_triangles(void **state)
{
    (void)state;
    const char *data = sv_test_data("the maple's trunk");
    size_t n_obj = 0, n_mtl = 0;
    uint8_t *b_obj = sv_test_read_data(data, "sapling_small_maple/sapling_small_maple_rect.obj",
                                       &n_obj);
    uint8_t *b_mtl = sv_test_read_data(data, "sapling_small_maple/sapling_small_maple_rect.mtl",
                                       &n_mtl);
    if (!b_obj || !b_mtl) {
        free(b_obj), free(b_mtl);
        fail_msg("cannot read the sapling maple's .obj or .mtl under %s", data);
    }
    sv_file files[2] = {{"sapling_small_maple_rect.obj", b_obj, n_obj},
                        {"sapling_small_maple_rect.mtl", b_mtl, n_mtl}};
    sv_import_options io = {.unit_scale = 1.0};
    sv_mesh *m = NULL;
    sv_error e = {0};
    assert_int_equal(sv_import(files, 2, &io, &m, NULL, &e), SV_OK);
    free(b_obj), free(b_mtl);
    sv_classification cls;
    assert_int_equal(sv_classify(m, NULL, &cls, &e), SV_OK);
    double y0 = INFINITY, y1 = -INFINITY;
    for (uint32_t t = 0; t < m->triangle_count; t++)
        for (int v = 0; v < 3 && cls.tri_part[t] == SV_PART_TRUNK; v++) {
            double y = m->positions[3 * (size_t)m->indices[3 * (size_t)t + v] + 1];
            y0 = fmin(y0, y), y1 = fmax(y1, y);
        }
    double band = y0 + 0.15 * (y1 - y0), orig = 0, kept = 0;
    for (uint32_t t = 0; t < m->triangle_count; t++) {
        if (cls.tri_part[t] != SV_PART_TRUNK) continue;
        double y = INFINITY;
        for (int v = 0; v < 3; v++)
            y = fmin(y, m->positions[3 * (size_t)m->indices[3 * (size_t)t + v] + 1]);
        if (y < band) orig += sv_tri_area(m, t);
    }
    sv_mesh *o = NULL;
    assert_int_equal(sv_trunk_mesh_parts(m, cls.tri_part, 0.5, 200, &o, &e), SV_OK);
    assert_non_null(o);
    assert_true(o->triangle_count <= 200);
    for (uint32_t t = 0; t < o->triangle_count; t++) {
        double y = INFINITY;
        for (int v = 0; v < 3; v++)
            y = fmin(y, o->positions[3 * (size_t)o->indices[3 * (size_t)t + v] + 1]);
        if (y < band) kept += sv_tri_area(o, t);
    }
    print_message("maple stem: %u triangles; below %.2f m %.3f m2 kept of %.3f\n",
                  o->triangle_count, band, kept, orig);
    assert_true(orig > 0);
    assert_true(kept >= orig / 3);
    sv_mesh_destroy(o);
    sv_classification_free(&cls);
    sv_mesh_destroy(m);
}
#endif

/* sv_twig_groups: only trunk triangles not skipped, one group per cell their
 * centroid falls in (a group's centroids span less than a cell on every
 * axis), index order within a group, each triangle once, several groups and
 * fewer than triangles on the tube (radius 1, height 4) in cells of 1.5, and
 * the same call gives the same order. */
static void twigs_are_grouped_by_cell_once_each(void **state)
{
    (void)state;
    uint8_t *parts = NULL;
    sv_mesh *m = tube(8, 4, &parts);
    uint32_t nt = m->triangle_count;
    uint8_t *skip = calloc(nt, 1);
    assert_non_null(skip);
    skip[0] = skip[5] = 1; /* drawn by the kept trunk */
    const double centre[3] = {0, 2, 0};
    sv_twigs tw;
    assert_int_equal(sv_twig_groups(m, parts, skip, centre, 3.0, 0.5, &tw, NULL), SV_OK);
    const uint32_t *tris = tw.tris, *first = tw.first, n = tw.count, g = tw.groups;
    assert_int_equal(n, nt - 1 - 2); /* not the foliage triangle, not the two skipped */
    assert_true(g > 1 && g < n);
    assert_int_equal(first[0], 0);
    assert_int_equal(first[g], n);
    uint8_t *seen = calloc(nt, 1);
    assert_non_null(seen);
    for (uint32_t k = 0; k < g; k++) {
        assert_true(first[k] < first[k + 1]);
        double lo[3] = {1e9, 1e9, 1e9}, hi[3] = {-1e9, -1e9, -1e9};
        for (uint32_t j = first[k]; j < first[k + 1]; j++) {
            uint32_t t = tris[j];
            assert_true(t < nt);
            assert_int_equal(parts[t], SV_PART_TRUNK);
            assert_false(skip[t]);
            assert_false(seen[t]);
            seen[t] = 1;
            if (j > first[k]) assert_true(tris[j - 1] < t);
            for (int i = 0; i < 3; i++) {
                double c = 0;
                for (int v = 0; v < 3; v++) c += m->positions[3 * m->indices[3 * t + v] + i] / 3.0;
                lo[i] = fmin(lo[i], c), hi[i] = fmax(hi[i], c);
            }
        }
        /* one cell: the centroids span less than a cell (1.5) on every axis */
        for (int i = 0; i < 3; i++) assert_true(hi[i] - lo[i] < 1.5);
    }
    sv_twigs tw2;
    assert_int_equal(sv_twig_groups(m, parts, skip, centre, 3.0, 0.5, &tw2, NULL), SV_OK);
    assert_int_equal(tw2.count, n);
    assert_int_equal(tw2.groups, g);
    assert_memory_equal(tw2.tris, tris, n * sizeof *tris);
    assert_memory_equal(tw2.first, first, (g + 1) * sizeof *first);
    sv_twigs_free(&tw2);
    free(seen);
    sv_twigs_free(&tw);
    free(skip);
    free(parts);
    sv_mesh_destroy(m);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(budget_caps_the_trunk_even_against_a_tight_error_bound),
        cmocka_unit_test(budget_above_the_count_keeps_the_trunk_as_it_is),
        cmocka_unit_test(no_cap_goes_below_what_topology_holds_within_the_bound),
        cmocka_unit_test(parts_keep_the_stem_under_many_twigs),
        cmocka_unit_test(parts_share_the_budget_between_a_pot_and_the_stem),
#ifndef __SANITIZE_ADDRESS__
        cmocka_unit_test(the_maple_keeps_its_stem_at_200_triangles),
#endif
        cmocka_unit_test(twigs_are_grouped_by_cell_once_each),
    };
    return sv_test_exit(cmocka_run_group_tests(tests, NULL, NULL));
}
