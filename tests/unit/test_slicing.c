/* sylva-test: cost=15 (tests/run.sh starts the longest first) */
/* test_slicing.c — slicings (core/methods/slicing/slicing.c, core/methods/slicing/slicing.h): clipping
 * arithmetic, slab boundaries, the blending rule, the method's quads, and a
 * render test (a planar crown seen along a slicing keeps its silhouette). */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bake.h"
#include "evaluate.h"
#include "method_ops.h"
#include "render.h"
#include "slicing.h"

/* ---------- helpers ---------- */

/* Deterministic uniform numbers in [0, 1) (splitmix64). */
static double rnd(uint64_t *s)
{
    uint64_t z = (*s += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    z ^= z >> 31;
    return (double)(z >> 11) / 9007199254740992.0;
}

static double dot(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static double tri_area3(const double t[3][3])
{
    return sv_polygon_area(t, 3);
}

/* A tree: a trunk box (material "bark") from y 0..3 and a crown of `leaves`
 * random leaf triangles (material "leaves") in an ellipsoid around y = 4.5,
 * denser near its centre (so equal-foliage slabs differ from uniform ones). */
static sv_mesh *make_tree(uint32_t leaves, uint64_t seed)
{
    uint32_t nv = 8 + 3 * leaves, nt = 12 + leaves;
    sv_mesh *m = sv_mesh_create(nv, nt, 2, 0);
    assert_non_null(m);
    snprintf(m->materials[0].name, sizeof m->materials[0].name, "bark");
    snprintf(m->materials[1].name, sizeof m->materials[1].name, "leaves");
    m->materials[1].base_color[0] = 0.2f;
    m->materials[1].base_color[2] = 0.1f;
    uint32_t v = 0, t = 0;
    for (int k = 0; k < 8; k++) {
        m->positions[3 * v] = (float)((k & 1) ? 0.15 : -0.15);
        m->positions[3 * v + 1] = (float)((k & 2) ? 3 : 0);
        m->positions[3 * v + 2] = (float)((k & 4) ? 0.15 : -0.15);
        v++;
    }
    static const int f[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                                {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
    for (int i = 0; i < 6; i++) {
        const int tri2[2][3] = {{0, 1, 2}, {0, 2, 3}};
        for (int h = 0; h < 2; h++) {
            for (int j = 0; j < 3; j++) m->indices[3 * t + j] = (uint32_t)f[i][tri2[h][j]];
            m->tri_material[t++] = 0;
        }
    }
    uint64_t s = seed;
    for (uint32_t i = 0; i < leaves; i++) {
        /* centre: radius² of a uniform point concentrates towards the middle */
        double c[3];
        do {
            for (int k = 0; k < 3; k++) c[k] = 2 * rnd(&s) - 1;
        } while (dot(c, c) > 1);
        double r = rnd(&s);
        c[0] *= 2.0 * r;
        c[1] = 4.5 + 1.5 * r * c[1];
        c[2] *= 1.6 * r;
        for (int j = 0; j < 3; j++) {
            for (int k = 0; k < 3; k++)
                m->positions[3 * v + k] = (float)(c[k] + 0.25 * (rnd(&s) - 0.5));
            m->indices[3 * t + j] = v++;
        }
        m->tri_material[t++] = 1;
    }
    sv_mesh_compute_normals(m);
    return m;
}

typedef struct run_ctx {
    sv_mesh *mesh;
    sv_classification cls;
    sv_scene scene;
    sv_method_input in;
    sv_stand_in out;
} run_ctx;

static sv_status run(run_ctx *r, sv_mesh *m, const char *settings_json, sv_viewer viewer,
                     sv_error *err)
{
    memset(r, 0, sizeof *r);
    r->mesh = m;
    assert_int_equal(sv_classify(m, NULL, &r->cls, NULL), SV_OK);
    sv_scene_defaults(&r->scene);
    r->scene.viewer = viewer;
    r->in.mesh = m;
    r->in.cls = &r->cls;
    r->in.scene = &r->scene;
    sv_mesh_sphere(m, r->in.centre, &r->in.radius);
    r->in.seed = 1;
    cJSON *s = settings_json ? cJSON_Parse(settings_json) : NULL;
    if (settings_json) assert_non_null(s);
    sv_status st = sv_method_slicing_ops.run(&r->in, s, &r->out, err);
    cJSON_Delete(s);
    return st;
}

static void run_done(run_ctx *r)
{
    sv_stand_in_free(&r->out);
    sv_classification_free(&r->cls);
    sv_mesh_destroy(r->mesh);
}

static void tri_of(const sv_mesh *m, uint32_t t, double p[3][3])
{
    for (int j = 0; j < 3; j++)
        for (int k = 0; k < 3; k++)
            p[j][k] = m->positions[3 * (size_t)m->indices[3 * (size_t)t + j] + k];
}

/* ---------- clipping and slab boundaries ---------- */

static void clipped_pieces_of_a_triangle_sum_to_its_area(void **state)
{
    (void)state;
    uint64_t s = 7;
    for (int trial = 0; trial < 2000; trial++) {
        double t[3][3], n[3];
        for (int j = 0; j < 3; j++)
            for (int k = 0; k < 3; k++) t[j][k] = 4 * rnd(&s) - 2;
        for (int k = 0; k < 3; k++) n[k] = rnd(&s) - 0.5;
        double len = sqrt(dot(n, n));
        for (int k = 0; k < 3; k++) n[k] /= len;
        /* random cuts over the triangle's extent, plus one through a vertex */
        double lo = fmin(dot(n, t[0]), fmin(dot(n, t[1]), dot(n, t[2]))) - 0.1;
        double hi = fmax(dot(n, t[0]), fmax(dot(n, t[1]), dot(n, t[2]))) + 0.1;
        double b[8];
        uint32_t K = 1 + trial % 7;
        sv_slab_bounds_uniform(lo, hi, K, b);
        if (K > 2) { /* a boundary exactly through a vertex */
            double x = dot(n, t[trial % 3]);
            uint32_t k = 1;
            while (k + 1 < K && b[k + 1] <= x) k++;
            b[k] = x;
        }
        double sum = 0;
        for (uint32_t k = 0; k < K; k++) {
            double poly[5][3];
            uint32_t c = sv_slab_clip_triangle((const double(*)[3])t, n, b[k], b[k + 1], poly);
            assert_true(c == 0 || (c >= 3 && c <= 5));
            for (uint32_t j = 0; j < c; j++) { /* every piece lies inside its slab */
                double x = dot(n, poly[j]);
                assert_true(x >= b[k] - 1e-12 && x <= b[k + 1] + 1e-12);
            }
            sum += sv_polygon_area((const double(*)[3])poly, c);
        }
        double a = tri_area3((const double(*)[3])t);
        assert_true(fabs(sum - a) <= 1e-12 * (1 + a));
    }
}

static void triangle_outside_the_slab_clips_to_nothing(void **state)
{
    (void)state;
    const double t[3][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
    const double n[3] = {1, 0, 0};
    double poly[5][3];
    assert_int_equal(sv_slab_clip_triangle(t, n, 1.5, 2.0, poly), 0);
    assert_int_equal(sv_slab_clip_triangle(t, n, -2.0, -0.5, poly), 0);
    /* touching the slab at one vertex only: nothing of positive area */
    assert_int_equal(sv_slab_clip_triangle(t, n, 1.0, 2.0, poly), 0);
    /* fully inside: the triangle itself */
    assert_int_equal(sv_slab_clip_triangle(t, n, -1.0, 2.0, poly), 3);
    /* cut through the middle: half the area on each side of x = 0.5 is not
     * equal, but the left piece is the trapezoid of area 0.375 */
    uint32_t c = sv_slab_clip_triangle(t, n, -1.0, 0.5, poly);
    assert_int_equal(c, 4);
    assert_true(fabs(sv_polygon_area((const double(*)[3])poly, c) - 0.375) < 1e-15);
}

static void uniform_slabs_have_equal_thickness_and_exact_ends(void **state)
{
    (void)state;
    double b[6];
    sv_slab_bounds_uniform(-0.3, 0.7, 5, b);
    assert_true(b[0] == -0.3 && b[5] == 0.7);
    for (int k = 0; k < 5; k++) assert_true(fabs((b[k + 1] - b[k]) - 0.2) < 1e-15);
}

static void foliage_spacing_gives_each_slab_an_equal_share_of_leaf_area(void **state)
{
    (void)state;
    sv_mesh *m = make_tree(3000, 11);
    uint32_t n = 3000, first = 12;
    double *proj = calloc(3 * n, sizeof *proj), *area = calloc(n, sizeof *area);
    assert_non_null(proj);
    assert_non_null(area);
    const double dir[3] = {0.6, 0, 0.8};
    double lo = INFINITY, hi = -INFINITY, total = 0;
    for (uint32_t i = 0; i < n; i++) {
        double p[3][3];
        tri_of(m, first + i, p);
        for (int j = 0; j < 3; j++) {
            proj[3 * i + j] = dot(dir, p[j]);
            lo = fmin(lo, proj[3 * i + j]);
            hi = fmax(hi, proj[3 * i + j]);
        }
        area[i] = tri_area3((const double(*)[3])p);
        total += area[i];
    }
    const uint32_t K = 5;
    double b[K + 1], u[K + 1];
    assert_int_equal(sv_slab_bounds_foliage(proj, area, n, lo, hi, K, b, NULL), SV_OK);
    sv_slab_bounds_uniform(lo, hi, K, u);
    assert_true(b[0] == lo && b[K] == hi);
    /* the share of each slab, measured independently by clipping */
    for (uint32_t k = 0; k < K; k++) {
        assert_true(b[k + 1] > b[k]);
        double a = 0;
        for (uint32_t i = 0; i < n; i++) {
            double p[3][3], poly[5][3];
            tri_of(m, first + i, p);
            uint32_t c = sv_slab_clip_triangle((const double(*)[3])p, dir, b[k], b[k + 1], poly);
            a += sv_polygon_area((const double(*)[3])poly, c);
        }
        assert_true(fabs(a - total / K) < 2e-3 * total);
    }
    /* the crown is denser in the middle: its slab is thinner than uniform */
    assert_true(b[3] - b[2] < 0.8 * (u[3] - u[2]));
    free(proj);
    free(area);
    sv_mesh_destroy(m);
}

static void foliage_spacing_keeps_slabs_thick_when_leaves_are_coplanar(void **state)
{
    (void)state;
    /* every leaf at projection 0.25: all the area is in one plane */
    double proj[12] = {0.25, 0.25, 0.25, 0.25, 0.25, 0.25, 0.25, 0.25, 0.25, 0.25, 0.25, 0.25};
    double area[4] = {1, 2, 3, 4};
    double b[6];
    assert_int_equal(sv_slab_bounds_foliage(proj, area, 4, 0, 1, 5, b, NULL), SV_OK);
    for (int k = 0; k < 5; k++) assert_true(b[k + 1] - b[k] >= 1.0 / 500 - 1e-12);
    assert_true(b[0] == 0 && b[5] == 1);
    sv_error e = {0};
    assert_int_equal(sv_slab_bounds_foliage(proj, area, 4, 1, 1, 5, b, &e), SV_ERR_INVALID);
    assert_non_null(strstr(e.message, "slab range"));
}

/* ---------- blending rule ---------- */

static void dir_at(double az_deg, double el_deg, double v[3])
{
    double a = az_deg * M_PI / 180, e = el_deg * M_PI / 180;
    v[0] = cos(e) * sin(a);
    v[1] = sin(e);
    v[2] = cos(e) * cos(a);
}

static void blend_picks_one_slicing_at_its_own_direction(void **state)
{
    (void)state;
    for (uint32_t j = 0; j < 6; j++) {
        double n[3], minus[3];
        sv_slicing_direction(j, 6, n);
        for (int k = 0; k < 3; k++) minus[k] = -n[k];
        uint32_t idx[3];
        double w[3];
        assert_int_equal(sv_slicing_blend(6, false, n, idx, w), 1);
        assert_int_equal(idx[0], j);
        assert_true(w[0] == 1);
        /* the opposite view uses the same slicing (shared planes) */
        assert_int_equal(sv_slicing_blend(6, false, minus, idx, w), 1);
        assert_int_equal(idx[0], j);
    }
}

static void blend_weights_between_directions_are_linear_in_azimuth(void **state)
{
    (void)state;
    uint32_t idx[3];
    double w[3], v[3];
    dir_at(15, 0, v); /* halfway between slicing 0 (0°) and 1 (30°) */
    assert_int_equal(sv_slicing_blend(6, false, v, idx, w), 2);
    assert_int_equal(idx[0], 0);
    assert_int_equal(idx[1], 1);
    assert_true(fabs(w[0] - 0.5) < 1e-12 && fabs(w[1] - 0.5) < 1e-12);
    dir_at(97.5, 10, v); /* a quarter of the way from slicing 3 (90°) to 4 (120°) */
    assert_int_equal(sv_slicing_blend(6, false, v, idx, w), 2);
    assert_int_equal(idx[0], 3);
    assert_int_equal(idx[1], 4);
    assert_true(fabs(w[0] - 0.75) < 1e-12 && fabs(w[1] - 0.25) < 1e-12);
    dir_at(170, 0, v); /* wraps: between slicing 5 (150°) and 0 (180° ≡ 0°) */
    assert_int_equal(sv_slicing_blend(6, false, v, idx, w), 2);
    assert_int_equal(idx[0], 0);
    assert_int_equal(idx[1], 5);
    assert_true(fabs(w[0] - 2.0 / 3) < 1e-12 && fabs(w[1] - 1.0 / 3) < 1e-12);
    dir_at(-10, 0, v); /* -10° ≡ 170° */
    assert_int_equal(sv_slicing_blend(6, false, v, idx, w), 2);
    assert_true(idx[0] == 0 && idx[1] == 5 && fabs(w[0] - 2.0 / 3) < 1e-12);
    /* straight down without a top slicing: slicing 0 */
    const double down[3] = {0, -1, 0};
    assert_int_equal(sv_slicing_blend(6, false, down, idx, w), 1);
    assert_true(idx[0] == 0 && w[0] == 1);
    /* one slicing: always itself */
    dir_at(40, 0, v);
    assert_int_equal(sv_slicing_blend(1, false, v, idx, w), 1);
    assert_true(idx[0] == 0 && fabs(w[0] - 1) < 1e-15);
}

static void top_slicing_takes_the_elevation_share(void **state)
{
    (void)state;
    uint32_t idx[3];
    double w[3], v[3];
    const double up[3] = {0, 1, 0};
    assert_int_equal(sv_slicing_blend(6, true, up, idx, w), 1);
    assert_true(idx[0] == 6 && w[0] == 1);
    dir_at(15, 45, v);
    assert_int_equal(sv_slicing_blend(6, true, v, idx, w), 3);
    assert_true(idx[0] == 0 && idx[1] == 1 && idx[2] == 6);
    assert_true(fabs(w[0] - 0.25) < 1e-12 && fabs(w[1] - 0.25) < 1e-12 && fabs(w[2] - 0.5) < 1e-12);
    dir_at(60, -30, v); /* from below: the top slicing seen from beneath */
    assert_int_equal(sv_slicing_blend(6, true, v, idx, w), 2);
    assert_true(idx[0] == 2 && idx[1] == 6);
    assert_true(fabs(w[1] - 1.0 / 3) < 1e-12);
}

static void blend_weights_sum_to_one_for_every_direction(void **state)
{
    (void)state;
    uint64_t s = 3;
    for (int i = 0; i < 5000; i++) {
        double v[3];
        dir_at(720 * rnd(&s) - 360, 180 * rnd(&s) - 90, v);
        uint32_t S = 1 + (uint32_t)(rnd(&s) * 12);
        bool top = i & 1;
        uint32_t idx[3];
        double w[3];
        uint32_t n = sv_slicing_blend(S, top, v, idx, w);
        assert_true(n >= 1 && n <= 3);
        double sum = 0;
        for (uint32_t k = 0; k < n; k++) {
            assert_true(w[k] > 0);
            assert_true(idx[k] < S || (top && idx[k] == S));
            if (k) assert_true(idx[k] > idx[k - 1]);
            sum += w[k];
        }
        assert_true(fabs(sum - 1) < 1e-12);
        /* the azimuthal slicings chosen are neighbours that bracket the view */
        uint32_t az[2], na = 0;
        for (uint32_t k = 0; k < n; k++)
            if (idx[k] < S) az[na++] = idx[k];
        if (na == 2) assert_true(az[1] - az[0] == 1 || (az[0] == 0 && az[1] == S - 1));
    }
}

/* ---------- the method ---------- */

static void method_is_registered_under_its_name(void **state)
{
    (void)state;
    assert_ptr_equal(sv_method_find("slicing"), &sv_method_slicing);
    assert_non_null(sv_method_slicing.summary);
}

/* Quads of group g, and each quad's slab [lo, hi] along its normal. */
static void slabs_partition_foliage_in(const run_ctx *r, uint32_t spacing_check)
{
    const sv_lod_plan *lod = &r->out.lods[0];
    const sv_mesh *m = r->mesh;
    int32_t groups = 0;
    for (uint32_t q = 0; q < lod->quad_count; q++)
        if (lod->quads[q].group + 1 > groups) groups = lod->quads[q].group + 1;
    for (int32_t g = 0; g < groups; g++) {
        double group_area = 0, foliage_area = 0;
        for (uint32_t t = 0; t < m->triangle_count; t++) {
            bool foliage = r->cls.tri_part[t] == SV_PART_FOLIAGE;
            double p[3][3];
            tri_of(m, t, p);
            double a = tri_area3((const double(*)[3])p), sum = 0;
            uint32_t listed = 0, pieces = 0;
            for (uint32_t q = 0; q < lod->quad_count; q++) {
                const sv_quad *qu = &lod->quads[q];
                if (qu->group != g) continue;
                assert_true(qu->clip);
                assert_int_equal(qu->parts, SV_PARTS_FOLIAGE);
                double lo = -qu->d - qu->slab, hi = -qu->d + qu->slab, poly[5][3];
                uint32_t c = sv_slab_clip_triangle((const double(*)[3])p, qu->normal, lo, hi, poly);
                double pa = sv_polygon_area((const double(*)[3])poly, c);
                sum += pa;
                if (c) pieces++;
                bool in_list = false;
                for (uint32_t i = 0; i < qu->face_count; i++) in_list |= qu->faces[i] == t;
                listed += in_list;
                /* every foliage piece lies inside the quad's rectangle */
                for (uint32_t j = 0; foliage && j < c; j++) {
                    double d[3] = {poly[j][0] - qu->centre[0], poly[j][1] - qu->centre[1],
                                   poly[j][2] - qu->centre[2]};
                    assert_true(fabs(dot(d, qu->axis_u)) <= qu->half_u + 1e-9);
                    assert_true(fabs(dot(d, qu->axis_v)) <= qu->half_v + 1e-9);
                }
            }
            if (foliage) {
                /* not lost, not doubled: the pieces add up to the triangle */
                assert_true(fabs(sum - a) <= 1e-9 * a + 1e-12);
                assert_true(pieces >= 1);
                assert_int_equal(listed, pieces);
                foliage_area += a;
            } else {
                assert_int_equal(listed, 0); /* the trunk stays a mesh */
            }
        }
        for (uint32_t q = 0; q < lod->quad_count; q++)
            if (lod->quads[q].group == g) group_area += lod->quads[q].face_area;
        assert_true(fabs(group_area - foliage_area) < 1e-6 * foliage_area);
    }
    (void)spacing_check;
}

static void slabs_partition_the_foliage_in_every_slicing(void **state)
{
    (void)state;
    const char *specs[] = {NULL, "{\"spacing\":\"uniform\",\"top\":true}",
                           "{\"slicings\":4,\"slices\":9,\"spacing\":\"foliage\"}"};
    for (size_t i = 0; i < sizeof specs / sizeof specs[0]; i++) {
        run_ctx r;
        assert_int_equal(run(&r, make_tree(400, 5 + i), specs[i], SV_VIEWER_ORBIT, NULL), SV_OK);
        assert_int_equal(r.out.lod_count, 1);
        slabs_partition_foliage_in(&r, 0);
        run_done(&r);
    }
}

static void default_gives_six_slicings_of_five_slices_thirty_degrees_apart(void **state)
{
    (void)state;
    run_ctx r;
    assert_int_equal(run(&r, make_tree(400, 1), NULL, SV_VIEWER_ORBIT, NULL), SV_OK);
    assert_string_equal(r.out.method, "slicing");
    const sv_lod_plan *lod = &r.out.lods[0];
    assert_int_equal(lod->quad_count, 30);
    assert_int_equal(lod->trunk, SV_TRUNK_SIMPLIFIED);
    assert_true(lod->trunk_ratio == 0.25);
    assert_non_null(lod->select);
    for (uint32_t q = 0; q < 30; q++) {
        const sv_quad *a = &lod->quads[q];
        assert_int_equal(a->group, (int32_t)(q / 5));
        double n[3];
        sv_slicing_direction(q / 5, 6, n);
        assert_true(dot(a->normal, n) > 1 - 1e-15);
        assert_true(a->axis_v[1] == 1);
        /* u × v = n */
        double c[3] = {a->axis_u[1] * a->axis_v[2] - a->axis_u[2] * a->axis_v[1],
                       a->axis_u[2] * a->axis_v[0] - a->axis_u[0] * a->axis_v[2],
                       a->axis_u[0] * a->axis_v[1] - a->axis_u[1] * a->axis_v[0]};
        assert_true(dot(c, a->normal) > 1 - 1e-12);
        if (q % 5) { /* consecutive slabs: parallel planes, touching */
            const sv_quad *b = &lod->quads[q - 1];
            assert_true(fabs((-a->d - a->slab) - (-b->d + b->slab)) < 1e-9);
        }
    }
    /* neighbouring slicings are 30° apart */
    assert_true(fabs(dot(lod->quads[0].normal, lod->quads[5].normal) - cos(M_PI / 6)) < 1e-12);
    run_done(&r);
}

static void top_slicing_follows_the_aerial_viewer_unless_set(void **state)
{
    (void)state;
    struct {
        const char *spec;
        sv_viewer viewer;
        uint32_t quads;
    } c[] = {{NULL, SV_VIEWER_AERIAL, 35},
             {NULL, SV_VIEWER_GROUND, 30},
             {"{\"top\":null}", SV_VIEWER_AERIAL, 35},
             {"{\"top\":false}", SV_VIEWER_AERIAL, 30},
             {"{\"top\":true}", SV_VIEWER_ORBIT, 35}};
    for (size_t i = 0; i < sizeof c / sizeof c[0]; i++) {
        run_ctx r;
        assert_int_equal(run(&r, make_tree(300, 2), c[i].spec, c[i].viewer, NULL), SV_OK);
        const sv_lod_plan *lod = &r.out.lods[0];
        assert_int_equal(lod->quad_count, c[i].quads);
        if (c[i].quads == 35) {
            const sv_quad *t = &lod->quads[30];
            assert_int_equal(t->group, 6);
            assert_true(t->normal[1] == 1 && t->axis_u[0] == 1 && t->axis_v[2] == -1);
        }
        run_done(&r);
    }
}

static void selector_draws_the_quads_of_the_blended_slicings(void **state)
{
    (void)state;
    run_ctx r;
    assert_int_equal(run(&r, make_tree(300, 3), "{\"top\":true}", SV_VIEWER_ORBIT, NULL), SV_OK);
    const sv_lod_plan *lod = &r.out.lods[0];
    uint32_t buf[SV_MAX_VIEW_SETS][64];
    uint32_t *const sets[SV_MAX_VIEW_SETS] = {buf[0], buf[1], buf[2], buf[3]};
    uint32_t counts[SV_MAX_VIEW_SETS];
    double w[SV_MAX_VIEW_SETS], v[3];
    dir_at(45, 45, v); /* between slicings 1 and 2, half from above */
    assert_int_equal(lod->select(lod, v, sets, counts, w), 3);
    int32_t want[3] = {1, 2, 6};
    for (int k = 0; k < 3; k++) {
        assert_int_equal(counts[k], 5);
        for (uint32_t i = 0; i < counts[k]; i++)
            assert_int_equal(lod->quads[sets[k][i]].group, want[k]);
    }
    assert_true(fabs(w[0] - 0.25) < 1e-12 && fabs(w[2] - 0.5) < 1e-12);
    run_done(&r);
}

static void planes_description_names_directions_quads_and_rule(void **state)
{
    (void)state;
    run_ctx r;
    assert_int_equal(run(&r, make_tree(300, 4), "{\"slicings\":3}", SV_VIEWER_ORBIT, NULL), SV_OK);
    const sv_lod_plan *lod = &r.out.lods[0];
    cJSON *j = sv_slicing_describe(lod);
    assert_non_null(j);
    assert_true(cJSON_GetObjectItem(j, "azimuth_step_deg")->valuedouble == 60);
    assert_non_null(strstr(cJSON_GetObjectItem(j, "blending")->valuestring, "atan2"));
    cJSON *arr = cJSON_GetObjectItem(j, "slicings");
    assert_int_equal(cJSON_GetArraySize(arr), 3);
    for (int s = 0; s < 3; s++) {
        cJSON *e = cJSON_GetArrayItem(arr, s);
        cJSON *d = cJSON_GetObjectItem(e, "direction");
        double n[3], got[3];
        sv_slicing_direction((uint32_t)s, 3, n);
        for (int k = 0; k < 3; k++) got[k] = cJSON_GetArrayItem(d, k)->valuedouble;
        assert_true(dot(n, got) > 1 - 1e-12);
        cJSON *qa = cJSON_GetObjectItem(e, "quads");
        assert_int_equal(cJSON_GetArraySize(qa), 5);
        for (int i = 0; i < 5; i++)
            assert_int_equal(lod->quads[cJSON_GetArrayItem(qa, i)->valueint].group, s);
        assert_int_equal(cJSON_GetArraySize(cJSON_GetObjectItem(e, "slab_bounds")), 6);
    }
    cJSON_Delete(j);
    /* not a slicing LOD: nothing */
    sv_lod_plan other;
    memset(&other, 0, sizeof other);
    assert_null(sv_slicing_describe(&other));
    assert_null(sv_slicing_describe(NULL));
    run_done(&r);
}

static void two_runs_give_identical_quads(void **state)
{
    (void)state;
    run_ctx a, b;
    assert_int_equal(run(&a, make_tree(500, 9), NULL, SV_VIEWER_AERIAL, NULL), SV_OK);
    assert_int_equal(run(&b, make_tree(500, 9), NULL, SV_VIEWER_AERIAL, NULL), SV_OK);
    const sv_lod_plan *la = &a.out.lods[0], *lb = &b.out.lods[0];
    assert_int_equal(la->quad_count, lb->quad_count);
    for (uint32_t i = 0; i < la->quad_count; i++) {
        const sv_quad *p = &la->quads[i], *q = &lb->quads[i];
        assert_memory_equal(p->normal, q->normal, sizeof p->normal);
        assert_memory_equal(p->centre, q->centre, sizeof p->centre);
        assert_true(p->d == q->d && p->half_u == q->half_u && p->half_v == q->half_v &&
                    p->slab == q->slab && p->face_count == q->face_count);
        assert_memory_equal(p->faces, q->faces, p->face_count * sizeof *p->faces);
    }
    run_done(&a);
    run_done(&b);
}

static void bad_settings_fail_naming_the_key(void **state)
{
    (void)state;
    const char *bad[][2] = {
        {"{\"slicings\":0}", "slicing.slicings"},
        {"{\"slicings\":33}", "slicing.slicings"},
        {"{\"slices\":2.5}", "slicing.slices"},
        {"{\"slices\":65}", "slicing.slices"},
        {"{\"spacing\":\"even\"}", "slicing.spacing"},
        {"{\"spacing\":1}", "slicing.spacing"},
        {"{\"top\":\"yes\"}", "slicing.top"},
        {"{\"trunk_ratio\":0}", "slicing.trunk_ratio"},
        {"{\"trunk_ratio\":1.5}", "slicing.trunk_ratio"},
        {"{\"slice\":5}", "slicing.slice"},
        {"[6]", "slicing"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        cJSON *s = cJSON_Parse(bad[i][0]);
        assert_non_null(s);
        sv_error e = {0};
        assert_int_equal(sv_method_slicing.check(s, &e), SV_ERR_SPEC);
        assert_non_null(strstr(e.message, bad[i][1]));
        cJSON_Delete(s);
        run_ctx r;
        assert_int_equal(run(&r, make_tree(50, 1), bad[i][0], SV_VIEWER_ORBIT, &e), SV_ERR_SPEC);
        assert_int_equal(r.out.lod_count, 0);
        run_done(&r);
    }
    assert_int_equal(sv_method_slicing.check(NULL, NULL), SV_OK);
    cJSON *ok = cJSON_Parse("{\"slicings\":32,\"slices\":64,\"spacing\":\"uniform\","
                            "\"top\":null,\"trunk_ratio\":1}");
    assert_int_equal(sv_method_slicing.check(ok, NULL), SV_OK);
    cJSON_Delete(ok);
}

static void tree_without_foliage_is_unbakeable(void **state)
{
    (void)state;
    sv_mesh *m = make_tree(5, 1);
    for (uint32_t t = 12; t < m->triangle_count; t++) m->tri_material[t] = 0; /* all bark */
    run_ctx r;
    sv_error e = {0};
    assert_int_equal(run(&r, m, NULL, SV_VIEWER_ORBIT, &e), SV_ERR_UNBAKEABLE);
    assert_non_null(strstr(e.message, "foliage"));
    assert_int_equal(r.out.lod_count, 0);
    run_done(&r);
}

/* ---------- render: a planar crown seen along a slicing ---------- */

/* Leaves (material "leaves", opaque green) scattered in a plane through
 * `origin` spanned by unit a and b. */
static sv_mesh *make_leaf_plane(const double origin[3], const double a[3], const double b[3])
{
    const uint32_t leaves = 300;
    sv_mesh *m = sv_mesh_create(3 * leaves, leaves, 1, 0);
    assert_non_null(m);
    snprintf(m->materials[0].name, sizeof m->materials[0].name, "leaves");
    m->materials[0].base_color[0] = 0.2f;
    m->materials[0].base_color[1] = 0.7f;
    m->materials[0].base_color[2] = 0.1f;
    m->materials[0].double_sided = true;
    uint64_t s = 99;
    for (uint32_t i = 0; i < leaves; i++) {
        /* well-shaped leaves: equilateral, 0.3 across, randomly turned */
        double cx = 3 * rnd(&s) - 1.5, cy = 2 * rnd(&s) - 1, rot = 2 * M_PI * rnd(&s);
        for (int j = 0; j < 3; j++) {
            double x = cx + 0.17 * cos(rot + 2 * M_PI * j / 3);
            double y = cy + 0.17 * sin(rot + 2 * M_PI * j / 3);
            for (int k = 0; k < 3; k++)
                m->positions[9 * i + 3 * j + k] = (float)(origin[k] + x * a[k] + y * b[k]);
            m->indices[3 * i + j] = 3 * i + j;
        }
        m->tri_material[i] = 0;
    }
    sv_mesh_compute_normals(m);
    return m;
}

/* Coverage IoU of the original and the slicing drawn for `view` (towards the
 * viewer), rendered at 1024² and box-filtered to 256² as the evaluator does. */
static double planar_crown_iou(sv_mesh *m, uint32_t slicing, const char *spec)
{
    run_ctx r;
    assert_int_equal(run(&r, m, spec, SV_VIEWER_ORBIT, NULL), SV_OK);
    const sv_lod_plan *lod = &r.out.lods[0];
    sv_renderer *ren = NULL;
    sv_gpu_mesh *gsrc = NULL, *gres = NULL;
    sv_error err = {0};
    if (sv_renderer_create(2048, &ren, &err) != SV_OK) fail_msg("renderer: %s", err.message);
    assert_int_equal(sv_gpu_mesh_upload(ren, m, &gsrc, NULL), SV_OK);
    sv_bake_options bo;
    sv_bake_options_init(&bo);
    bo.tri_part = r.cls.tri_part;
    sv_baked_lod baked;
    if (sv_bake_lod(ren, gsrc, m, lod, NULL, &bo, &baked, &err) != SV_OK)
        fail_msg("bake: %s", err.message);
    assert_int_equal(sv_gpu_mesh_upload(ren, baked.mesh, &gres, NULL), SV_OK);

    double view[3];
    sv_slicing_direction(slicing, 6, view);
    uint32_t buf[SV_MAX_VIEW_SETS][64], counts[SV_MAX_VIEW_SETS];
    uint32_t *const sets[SV_MAX_VIEW_SETS] = {buf[0], buf[1], buf[2], buf[3]};
    double w[SV_MAX_VIEW_SETS];
    assert_int_equal(lod->select(lod, view, sets, counts, w), 1);
    uint32_t tris[128], nt = 0;
    for (uint32_t i = 0; i < counts[0]; i++) {
        assert_int_equal(lod->quads[sets[0][i]].group, (int32_t)slicing);
        tris[nt++] = 2 * sets[0][i];
        tris[nt++] = 2 * sets[0][i] + 1;
    }
    sv_camera cam;
    sv_eval_camera(r.in.centre, r.in.radius, view, &cam);
    sv_image a, b;
    assert_int_equal(sv_render(ren, gsrc, NULL, 0, &cam, NULL, 1024, 1024, &a, NULL, NULL), SV_OK);
    assert_int_equal(sv_render(ren, gres, tris, nt, &cam, NULL, 1024, 1024, &b, NULL, NULL), SV_OK);
    sv_eval_image ia, ib, fa, fb;
    assert_int_equal(sv_eval_image_from_render(&a, NULL, &ia, NULL), SV_OK);
    assert_int_equal(sv_eval_image_from_render(&b, NULL, &ib, NULL), SV_OK);
    assert_int_equal(sv_eval_image_downsample(&ia, 256, 256, &fa, NULL), SV_OK);
    assert_int_equal(sv_eval_image_downsample(&ib, 256, 256, &fb, NULL), SV_OK);
    double covered = 0;
    for (size_t i = 0; i < 256 * 256; i++) covered += fa.coverage[i];
    assert_true(covered > 0.2 * 256 * 256); /* the crown fills a good part of the frame */
    double iou = sv_eval_compare(&fa, &fb, r.in.radius).iou;
    sv_eval_image_free(&ia);
    sv_eval_image_free(&ib);
    sv_eval_image_free(&fa);
    sv_eval_image_free(&fb);
    sv_image_free(&a);
    sv_image_free(&b);
    sv_gpu_mesh_free(gres);
    sv_baked_lod_free(&baked);
    sv_gpu_mesh_free(gsrc);
    sv_renderer_destroy(ren);
    r.mesh = NULL; /* the caller owns m */
    run_done(&r);
    return iou;
}

static void planar_crown_seen_along_a_slicing_keeps_its_silhouette(void **state)
{
    (void)state;
    const char *specs[] = {NULL, "{\"spacing\":\"uniform\"}"};
    for (int i = 0; i < 2; i++) {
        /* facing slicing 0 (+Z), off the origin */
        const double o[3] = {3.0, 7.0, -2.25}, a[3] = {1, 0, 0}, b[3] = {0, 1, 0};
        sv_mesh *m = make_leaf_plane(o, a, b);
        double iou = planar_crown_iou(m, 0, specs[i]);
        print_message("planar crown, slicing 0, %s: IoU %.4f\n", specs[i] ? specs[i] : "defaults",
                      iou);
        assert_true(iou >= 0.99);
        sv_mesh_destroy(m);
        /* facing slicing 2 (60°) */
        double n[3];
        sv_slicing_direction(2, 6, n);
        const double a2[3] = {n[2], 0, -n[0]};
        m = make_leaf_plane(o, a2, b);
        iou = planar_crown_iou(m, 2, specs[i]);
        print_message("planar crown, slicing 2, %s: IoU %.4f\n", specs[i] ? specs[i] : "defaults",
                      iou);
        assert_true(iou >= 0.99);
        sv_mesh_destroy(m);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(clipped_pieces_of_a_triangle_sum_to_its_area),
        cmocka_unit_test(triangle_outside_the_slab_clips_to_nothing),
        cmocka_unit_test(uniform_slabs_have_equal_thickness_and_exact_ends),
        cmocka_unit_test(foliage_spacing_gives_each_slab_an_equal_share_of_leaf_area),
        cmocka_unit_test(foliage_spacing_keeps_slabs_thick_when_leaves_are_coplanar),
        cmocka_unit_test(blend_picks_one_slicing_at_its_own_direction),
        cmocka_unit_test(blend_weights_between_directions_are_linear_in_azimuth),
        cmocka_unit_test(top_slicing_takes_the_elevation_share),
        cmocka_unit_test(blend_weights_sum_to_one_for_every_direction),
        cmocka_unit_test(method_is_registered_under_its_name),
        cmocka_unit_test(slabs_partition_the_foliage_in_every_slicing),
        cmocka_unit_test(default_gives_six_slicings_of_five_slices_thirty_degrees_apart),
        cmocka_unit_test(top_slicing_follows_the_aerial_viewer_unless_set),
        cmocka_unit_test(selector_draws_the_quads_of_the_blended_slicings),
        cmocka_unit_test(planes_description_names_directions_quads_and_rule),
        cmocka_unit_test(two_runs_give_identical_quads),
        cmocka_unit_test(bad_settings_fail_naming_the_key),
        cmocka_unit_test(tree_without_foliage_is_unbakeable),
        cmocka_unit_test(planar_crown_seen_along_a_slicing_keeps_its_silhouette),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
