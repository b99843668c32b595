/* test_bbcloud.c — billboard-cloud plane selection (core/methods/billboard_cloud/greedy_planes.c).
 * Synthetic geometry only: boxes, faces on known planes, the Fig. 4b box,
 * layered foliage, degenerate faces. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "planes.h"
#include "classify.h"

/* ---------------------------------------------------------------- geometry builder */

typedef struct geo {
    double *pos;
    uint32_t nv, cv;
    uint32_t *idx;
    uint32_t nt, ct;
    uint32_t *etris, *efirst;
    uint8_t *epart;
    uint32_t ne, ce;
    uint32_t open_first; /* first triangle of the element being built */
} geo;

static void geo_free(geo *g)
{
    free(g->pos);
    free(g->idx);
    free(g->etris);
    free(g->efirst);
    free(g->epart);
    memset(g, 0, sizeof *g);
}

static uint32_t geo_vertex(geo *g, double x, double y, double z)
{
    if (g->nv == g->cv) {
        g->cv = g->cv ? 2 * g->cv : 64;
        g->pos = realloc(g->pos, (size_t)g->cv * 3 * sizeof(double));
        assert_non_null(g->pos);
    }
    g->pos[3 * g->nv] = x;
    g->pos[3 * g->nv + 1] = y;
    g->pos[3 * g->nv + 2] = z;
    return g->nv++;
}

static uint32_t geo_tri(geo *g, uint32_t a, uint32_t b, uint32_t c)
{
    if (g->nt == g->ct) {
        g->ct = g->ct ? 2 * g->ct : 64;
        g->idx = realloc(g->idx, (size_t)g->ct * 3 * sizeof(uint32_t));
        g->etris = realloc(g->etris, (size_t)g->ct * sizeof(uint32_t));
        assert_non_null(g->idx);
        assert_non_null(g->etris);
    }
    g->idx[3 * g->nt] = a;
    g->idx[3 * g->nt + 1] = b;
    g->idx[3 * g->nt + 2] = c;
    g->etris[g->nt] = g->nt; /* elements list triangles in creation order */
    return g->nt++;
}

/* Closes the triangles added since the last call into one element. */
static void geo_element(geo *g, uint8_t part)
{
    if (g->ne + 2 > g->ce) {
        g->ce = g->ce ? 2 * g->ce : 64;
        g->efirst = realloc(g->efirst, (size_t)(g->ce + 1) * sizeof(uint32_t));
        g->epart = realloc(g->epart, (size_t)g->ce);
        assert_non_null(g->efirst);
        assert_non_null(g->epart);
    }
    g->efirst[g->ne] = g->open_first;
    g->epart[g->ne] = part;
    g->ne++;
    g->efirst[g->ne] = g->nt;
    g->open_first = g->nt;
}

/* Adds a triangle as its own element. */
static void geo_single(geo *g, const double a[3], const double b[3], const double c[3],
                       uint8_t part)
{
    uint32_t i = geo_vertex(g, a[0], a[1], a[2]);
    uint32_t j = geo_vertex(g, b[0], b[1], b[2]);
    uint32_t k = geo_vertex(g, c[0], c[1], c[2]);
    geo_tri(g, i, j, k);
    geo_element(g, part);
}

/* Square [-h,h]² of plane (origin o, axes u, v), split into s×s cells of 2
 * triangles each, every triangle its own element. */
static void geo_square(geo *g, const double o[3], const double u[3], const double v[3], double h,
                       int s, uint8_t part)
{
    for (int a = 0; a < s; a++)
        for (int b = 0; b < s; b++) {
            double x0 = -h + 2 * h * a / s, x1 = -h + 2 * h * (a + 1) / s;
            double y0 = -h + 2 * h * b / s, y1 = -h + 2 * h * (b + 1) / s;
            double p[4][3];
            const double xs[4] = {x0, x1, x1, x0}, ys[4] = {y0, y0, y1, y1};
            for (int k = 0; k < 4; k++)
                for (int c = 0; c < 3; c++) p[k][c] = o[c] + xs[k] * u[c] + ys[k] * v[c];
            geo_single(g, p[0], p[1], p[2], part);
            geo_single(g, p[0], p[2], p[3], part);
        }
}

static void geo_input(const geo *g, sv_bbc_input *in)
{
    memset(in, 0, sizeof *in);
    in->positions = g->pos;
    in->vertex_count = g->nv;
    in->indices = g->idx;
    in->triangle_count = g->nt;
    in->elem_tris = g->etris;
    in->elem_first = g->efirst;
    in->elem_part = g->epart;
    in->elem_count = g->ne;
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (uint32_t v = 0; v < g->nv; v++)
        for (int c = 0; c < 3; c++) {
            lo[c] = fmin(lo[c], g->pos[3 * v + c]);
            hi[c] = fmax(hi[c], g->pos[3 * v + c]);
        }
    double r2 = 0;
    for (int c = 0; c < 3; c++) {
        in->centre[c] = 0.5 * (lo[c] + hi[c]);
        r2 += 0.25 * (hi[c] - lo[c]) * (hi[c] - lo[c]);
    }
    in->radius = sqrt(r2);
}

/* Deterministic LCG in [0, 1). */
static double rnd(uint64_t *s)
{
    *s = *s * 6364136223846793005ULL + 1442695040888963407ULL;
    return (double)(*s >> 11) / 9007199254740992.0;
}

static void rnd_unit(uint64_t *s, double n[3])
{
    for (;;) {
        for (int c = 0; c < 3; c++) n[c] = 2 * rnd(s) - 1;
        double l = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        if (l > 0.1 && l <= 1) {
            for (int c = 0; c < 3; c++) n[c] /= l;
            return;
        }
    }
}

static void basis(const double n[3], double u[3], double v[3])
{
    double a[3] = {0, 0, 0};
    int k = fabs(n[0]) < 0.6 ? 0 : (fabs(n[1]) < 0.6 ? 1 : 2);
    a[k] = 1;
    u[0] = n[1] * a[2] - n[2] * a[1];
    u[1] = n[2] * a[0] - n[0] * a[2];
    u[2] = n[0] * a[1] - n[1] * a[0];
    double l = sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
    for (int c = 0; c < 3; c++) u[c] /= l;
    v[0] = n[1] * u[2] - n[2] * u[1];
    v[1] = n[2] * u[0] - n[0] * u[2];
    v[2] = n[0] * u[1] - n[1] * u[0];
}

/* Leaf: a small quad (2 triangles, one element) at centre c with normal n. */
static void geo_leaf(geo *g, const double c[3], const double n[3], double size, uint8_t part)
{
    double u[3], v[3];
    basis(n, u, v);
    uint32_t ids[4];
    const double xs[4] = {-1, 1, 1, -1}, ys[4] = {-0.5, -0.5, 0.5, 0.5};
    for (int k = 0; k < 4; k++)
        ids[k] = geo_vertex(g, c[0] + size * (xs[k] * u[0] + ys[k] * v[0]),
                            c[1] + size * (xs[k] * u[1] + ys[k] * v[1]),
                            c[2] + size * (xs[k] * u[2] + ys[k] * v[2]));
    geo_tri(g, ids[0], ids[1], ids[2]);
    geo_tri(g, ids[0], ids[2], ids[3]);
    geo_element(g, part);
}

/* A random crown: n leaves in a ball of radius 1 with random orientations. */
static void geo_crown(geo *g, uint64_t seed, int n)
{
    uint64_t s = seed;
    for (int i = 0; i < n; i++) {
        double c[3], d[3];
        rnd_unit(&s, c);
        double r = cbrt(rnd(&s));
        for (int k = 0; k < 3; k++) c[k] *= r;
        rnd_unit(&s, d);
        geo_leaf(g, c, d, 0.04, SV_PART_FOLIAGE);
    }
}

/* ---------------------------------------------------------------- checks */

static sv_bbc_options opts(double eps)
{
    sv_bbc_options o;
    sv_bbc_options_init(&o);
    o.epsilon = eps;
    return o;
}

/* Every triangle of every element is in exactly one primary plane, and every
 * assigned triangle is within ε of its plane. */
static void check_partition(const geo *g, const sv_bbc_result *r, double eps)
{
    uint32_t *cnt = calloc(g->nt ? g->nt : 1, sizeof *cnt);
    assert_non_null(cnt);
    for (uint32_t k = 0; k < r->plane_count; k++) {
        const sv_bbc_plane *p = &r->planes[k];
        double len = sqrt(p->normal[0] * p->normal[0] + p->normal[1] * p->normal[1] +
                          p->normal[2] * p->normal[2]);
        assert_true(fabs(len - 1) < 1e-9);
        if (p->cardboard_of >= 0) continue;
        for (uint32_t i = 0; i < p->count; i++) {
            uint32_t t = r->tris[p->first + i];
            assert_true(t < g->nt);
            cnt[t]++;
            for (int v = 0; v < 3; v++) {
                const double *x = &g->pos[3 * g->idx[3 * t + v]];
                double d = p->normal[0] * x[0] + p->normal[1] * x[1] + p->normal[2] * x[2] + p->d;
                assert_true(fabs(d) <= eps * (1 + 1e-6) + 1e-9);
            }
        }
    }
    for (uint32_t t = 0; t < g->nt; t++) assert_int_equal(cnt[t], 1);
    free(cnt);
}

static uint32_t primaries(const sv_bbc_result *r)
{
    uint32_t n = 0;
    for (uint32_t k = 0; k < r->plane_count; k++) n += r->planes[k].cardboard_of < 0;
    return n;
}

/* Index of the plane (n, d) or (−n, −d) in r within tolerances, or -1. */
static int find_plane(const sv_bbc_result *r, const double n[3], double d, double tn, double td)
{
    for (uint32_t k = 0; k < r->plane_count; k++) {
        const sv_bbc_plane *p = &r->planes[k];
        for (int s = -1; s <= 1; s += 2) {
            double e = 0;
            for (int c = 0; c < 3; c++) e = fmax(e, fabs(s * p->normal[c] - n[c]));
            if (e <= tn && fabs(s * p->d - d) <= td) return (int)k;
        }
    }
    return -1;
}

/* ---------------------------------------------------------------- tests */

static void add_box(geo *g, double h, int s, uint8_t part)
{
    const double ax[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    for (int a = 0; a < 3; a++)
        for (int sg = -1; sg <= 1; sg += 2) {
            double o[3] = {0, 0, 0};
            o[a] = sg * h;
            geo_square(g, o, ax[(a + 1) % 3], ax[(a + 2) % 3], h, s, part);
        }
}

static void box_gives_its_six_face_planes(void **state)
{
    (void)state;
    geo g = {0};
    add_box(&g, 0.5, 3, SV_PART_FOLIAGE);
    sv_bbc_input in;
    geo_input(&g, &in);
    sv_bbc_options o = opts(0.05 * in.radius);
    sv_bbc_result r;
    sv_error err = {0};
    assert_int_equal(sv_bbc_select(&in, &o, &r, &err), SV_OK);
    assert_int_equal(r.plane_count, 6);
    for (int a = 0; a < 3; a++)
        for (int sg = -1; sg <= 1; sg += 2) {
            double n[3] = {0, 0, 0};
            n[a] = 1;
            int k = find_plane(&r, n, -sg * 0.5, 1e-9, 1e-9);
            assert_true(k >= 0);
            assert_int_equal(r.planes[k].count, 18); /* its 3×3×2 triangles */
        }
    check_partition(&g, &r, o.epsilon);
    sv_bbc_result_free(&r);
    geo_free(&g);
}

/* k planes in general position, far enough apart that no plane can take
 * another's faces. */
static void make_known_planes(geo *g, double planes[][4], int k, uint64_t seed)
{
    uint64_t s = seed;
    for (int i = 0; i < k; i++) {
        double n[3], u[3], v[3], o[3];
        rnd_unit(&s, n);
        basis(n, u, v);
        for (int c = 0; c < 3; c++) o[c] = 2.5 * (i - k / 2) * (c == 0) + 0.3 * (2 * rnd(&s) - 1);
        o[1] += 2.0 * (i % 2);
        geo_square(g, o, u, v, 0.5, 2, SV_PART_FOLIAGE);
        for (int c = 0; c < 3; c++) planes[i][c] = n[c];
        planes[i][3] = -(n[0] * o[0] + n[1] * o[1] + n[2] * o[2]);
    }
}

static void faces_on_k_known_planes_give_those_k_planes(void **state)
{
    (void)state;
    enum { K = 5 };
    double pl[K][4];
    geo g = {0};
    make_known_planes(&g, pl, K, 7);
    sv_bbc_input in;
    geo_input(&g, &in);
    sv_bbc_options o = opts(0.01 * in.radius);
    sv_bbc_result r;
    assert_int_equal(sv_bbc_select(&in, &o, &r, NULL), SV_OK);
    assert_int_equal(r.plane_count, K);
    for (int i = 0; i < K; i++) {
        int k = find_plane(&r, pl[i], pl[i][3], 1e-9, 1e-9);
        assert_true(k >= 0);
        assert_int_equal(r.planes[k].count, 8);
    }
    check_partition(&g, &r, o.epsilon);
    sv_bbc_result_free(&r);
    geo_free(&g);
}

/* Fig. 4b: a flat box (2 × 0.2 × 2): with ε = the half height the dominant
 * top and bottom planes are valid for the two strips of each side face. */
static void make_fig4b(geo *g)
{
    const double X[3] = {1, 0, 0}, Y[3] = {0, 1, 0}, Z[3] = {0, 0, 1};
    double top[3] = {0, 0.1, 0}, bot[3] = {0, -0.1, 0};
    geo_square(g, top, Z, X, 1.0, 4, SV_PART_FOLIAGE);
    geo_square(g, bot, X, Z, 1.0, 4, SV_PART_FOLIAGE);
    /* four side faces, each 2 wide and 0.2 high, two strips each */
    const double *side_n[4] = {X, X, Z, Z};
    const int sg[4] = {1, -1, 1, -1};
    for (int f = 0; f < 4; f++) {
        const double *n = side_n[f];
        const double *w = n == X ? Z : X;
        for (int strip = 0; strip < 2; strip++) {
            double y0 = strip ? 0 : -0.1, y1 = strip ? 0.1 : 0;
            double p[4][3];
            for (int k = 0; k < 4; k++) {
                double a = (k == 0 || k == 3) ? -1 : 1, y = k < 2 ? y0 : y1;
                for (int c = 0; c < 3; c++) p[k][c] = sg[f] * n[c] + a * w[c] + y * Y[c];
            }
            geo_single(g, p[0], p[1], p[2], SV_PART_FOLIAGE);
            geo_single(g, p[0], p[2], p[3], SV_PART_FOLIAGE);
        }
    }
}

/* How many side-face triangles (the last 16) went to a near-vertical plane. */
static uint32_t sides_on_vertical_planes(const sv_bbc_result *r, uint32_t first_side)
{
    uint32_t n = 0;
    for (uint32_t k = 0; k < r->plane_count; k++) {
        const sv_bbc_plane *p = &r->planes[k];
        if (p->cardboard_of >= 0 || fabs(p->normal[1]) > 0.5) continue;
        for (uint32_t i = 0; i < p->count; i++) n += r->tris[p->first + i] >= first_side;
    }
    return n;
}

static void fig4b_dominant_planes_swallow_side_faces_without_the_angle_limit(void **state)
{
    (void)state;
    geo g = {0};
    make_fig4b(&g);
    uint32_t first_side = g.nt - 16;
    sv_bbc_input in;
    geo_input(&g, &in);
    sv_bbc_options o = opts(0.1 + 1e-9);
    o.max_angle_deg = 90; /* the papers' plain validity rule */
    sv_bbc_result r;
    assert_int_equal(sv_bbc_select(&in, &o, &r, NULL), SV_OK);
    /* The paper's artifact: top and bottom take every side strip. */
    assert_int_equal(primaries(&r), 2);
    assert_int_equal(sides_on_vertical_planes(&r, first_side), 0);
    check_partition(&g, &r, o.epsilon);
    sv_bbc_result_free(&r);
    geo_free(&g);
}

static void fig4b_angle_limit_gives_side_faces_their_own_planes(void **state)
{
    (void)state;
    geo g = {0};
    make_fig4b(&g);
    uint32_t first_side = g.nt - 16;
    sv_bbc_input in;
    geo_input(&g, &in);
    sv_bbc_options o = opts(0.1 + 1e-9); /* default max_angle_deg = 75 */
    sv_bbc_result r;
    assert_int_equal(sv_bbc_select(&in, &o, &r, NULL), SV_OK);
    assert_int_equal(sides_on_vertical_planes(&r, first_side), 16);
    assert_int_equal(primaries(&r), 6);
    check_partition(&g, &r, o.epsilon);
    sv_bbc_result_free(&r);
    geo_free(&g);
}

/* Foliage in four horizontal layers, random leaf orientations. */
static void make_layers(geo *g, uint64_t seed)
{
    uint64_t s = seed;
    for (int layer = 0; layer < 4; layer++)
        for (int i = 0; i < 300; i++) {
            double c[3], d[3];
            double a = 2 * M_PI * rnd(&s), r = sqrt(rnd(&s));
            c[0] = r * cos(a);
            c[2] = r * sin(a);
            c[1] = -0.6 + 0.4 * layer + 0.04 * (rnd(&s) - 0.5);
            /* mostly flat leaves: tilt up to 40° */
            double tilt = 40 * M_PI / 180 * rnd(&s), az = 2 * M_PI * rnd(&s);
            d[0] = sin(tilt) * cos(az);
            d[1] = cos(tilt);
            d[2] = sin(tilt) * sin(az);
            geo_leaf(g, c, d, 0.03, SV_PART_FOLIAGE);
        }
}

static double horizontal_share(const sv_bbc_result *r)
{
    uint32_t h = 0, n = 0;
    for (uint32_t k = 0; k < r->plane_count; k++) {
        if (r->planes[k].cardboard_of >= 0) continue;
        n++;
        h += fabs(r->planes[k].normal[1]) > cos(30 * M_PI / 180); /* within 30° of horizontal */
    }
    return n ? (double)h / n : 0;
}

static void horizontal_penalty_lowers_share_of_near_horizontal_planes(void **state)
{
    (void)state;
    geo g = {0};
    make_layers(&g, 11);
    sv_bbc_input in;
    geo_input(&g, &in);
    sv_bbc_options o = opts(0.08 * in.radius);
    sv_bbc_result off, on;
    assert_int_equal(sv_bbc_select(&in, &o, &off, NULL), SV_OK);
    o.horizontal_penalty = true;
    assert_int_equal(sv_bbc_select(&in, &o, &on, NULL), SV_OK);
    double s_off = horizontal_share(&off), s_on = horizontal_share(&on);
    print_message("near-horizontal share: %.2f without, %.2f with the penalty (%u / %u planes)\n",
                  s_off, s_on, primaries(&off), primaries(&on));
    assert_true(s_off >= 0.3);
    assert_true(s_on < s_off - 0.1);
    check_partition(&g, &on, o.epsilon);
    sv_bbc_result_free(&off);
    sv_bbc_result_free(&on);
    geo_free(&g);
}

static void tiny_epsilon_terminates_through_failsafe_with_every_face_simplified(void **state)
{
    (void)state;
    geo g = {0};
    uint64_t s = 3;
    for (int i = 0; i < 60; i++) {
        double a[3], b[3], c[3];
        rnd_unit(&s, a);
        rnd_unit(&s, b);
        rnd_unit(&s, c);
        geo_single(&g, a, b, c, SV_PART_FOLIAGE);
    }
    sv_bbc_input in;
    geo_input(&g, &in);
    sv_bbc_options o = opts(1e-12 * in.radius);
    sv_bbc_result r;
    assert_int_equal(sv_bbc_select(&in, &o, &r, NULL), SV_OK);
    assert_int_equal(r.plane_count, 60); /* random triangles: one plane each */
    assert_true(r.stats.failsafe_planes > 0);
    check_partition(&g, &r, 1e-9 * in.radius);
    sv_bbc_result_free(&r);
    /* ε = 0 as well */
    o.epsilon = 0;
    assert_int_equal(sv_bbc_select(&in, &o, &r, NULL), SV_OK);
    assert_int_equal(r.plane_count, 60);
    sv_bbc_result_free(&r);
    geo_free(&g);
}

static void horizontal_faces_at_the_poles_give_exactly_horizontal_planes(void **state)
{
    (void)state;
    geo g = {0};
    const double X[3] = {1, 0, 0}, Z[3] = {0, 0, 1};
    for (int l = 0; l < 3; l++) {
        double o[3] = {0.1, -0.7 + 0.7 * l, 0.2};
        geo_square(&g, o, l == 1 ? X : Z, l == 1 ? Z : X, 1.0, 3, SV_PART_FOLIAGE);
    }
    sv_bbc_input in;
    geo_input(&g, &in);
    sv_bbc_options o = opts(0.02 * in.radius);
    sv_bbc_result r;
    assert_int_equal(sv_bbc_select(&in, &o, &r, NULL), SV_OK);
    assert_int_equal(r.plane_count, 3);
    for (uint32_t k = 0; k < 3; k++) {
        assert_true(fabs(fabs(r.planes[k].normal[1]) - 1) < 1e-12);
        assert_int_equal(r.planes[k].count, 18);
    }
    for (int l = 0; l < 3; l++) {
        const double up[3] = {0, 1, 0};
        assert_true(find_plane(&r, up, 0.7 - 0.7 * l, 1e-12, 1e-9) >= 0);
    }
    check_partition(&g, &r, o.epsilon);
    sv_bbc_result_free(&r);
    /* the same with the horizontal penalty on: still found, still exact */
    o.horizontal_penalty = true;
    assert_int_equal(sv_bbc_select(&in, &o, &r, NULL), SV_OK);
    assert_int_equal(r.plane_count, 3);
    for (uint32_t k = 0; k < 3; k++) assert_true(fabs(fabs(r.planes[k].normal[1]) - 1) < 1e-12);
    sv_bbc_result_free(&r);
    geo_free(&g);
}

static void degenerate_faces_are_each_simplified_once(void **state)
{
    (void)state;
    geo g = {0};
    add_box(&g, 0.5, 1, SV_PART_FOLIAGE);
    const double a[3] = {0.1, 0.2, 0.3}, b[3] = {0.2, 0.3, 0.4}, c[3] = {0.3, 0.4, 0.5};
    geo_single(&g, a, b, c, SV_PART_FOLIAGE); /* collinear */
    geo_single(&g, a, a, a, SV_PART_FOLIAGE); /* a point */
    geo_single(&g, b, b, c, SV_PART_TRUNK);   /* a segment, alone in its pass */
    const double far[3] = {0.45, 0.45, 0.45};
    geo_single(&g, far, far, far, SV_PART_FOLIAGE); /* a point near a corner */
    sv_bbc_input in;
    geo_input(&g, &in);
    sv_bbc_options o = opts(0.02 * in.radius);
    sv_bbc_result r;
    assert_int_equal(sv_bbc_select(&in, &o, &r, NULL), SV_OK);
    check_partition(&g, &r, o.epsilon);
    assert_true(find_plane(&r, (double[3]){1, 0, 0}, -0.5, 1e-9, 1e-9) >= 0);
    for (uint32_t k = 0; k < r.plane_count; k++) {
        assert_true(isfinite(r.planes[k].d));
        for (int c2 = 0; c2 < 3; c2++) assert_true(isfinite(r.planes[k].normal[c2]));
    }
    sv_bbc_result_free(&r);
    geo_free(&g);
}

static void rotate(const double m[3][3], const double p[3], double o[3])
{
    for (int i = 0; i < 3; i++) o[i] = m[i][0] * p[0] + m[i][1] * p[1] + m[i][2] * p[2];
}

static void planes_move_with_translated_scaled_rotated_input(void **state)
{
    (void)state;
    enum { K = 5 };
    double pl[K][4];
    geo g = {0};
    make_known_planes(&g, pl, K, 21);
    /* rotation: 37° about a skew axis (Rodrigues) */
    double ax[3] = {0.3, 0.8, -0.52}, l = sqrt(0.09 + 0.64 + 0.2704);
    for (int c = 0; c < 3; c++) ax[c] /= l;
    double th = 37 * M_PI / 180, cs = cos(th), sn = sin(th), m[3][3];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            double k = (i == j) ? cs : 0;
            k += (1 - cs) * ax[i] * ax[j];
            if ((i + 1) % 3 == j) k -= sn * ax[(i + 2) % 3];
            if ((j + 1) % 3 == i) k += sn * ax[(i + 1) % 3];
            m[i][j] = k;
        }
    const double scale = 1e-3, shift[3] = {1000, -500, 250};
    geo h = {0};
    h = g;
    h.pos = malloc((size_t)g.nv * 3 * sizeof(double));
    assert_non_null(h.pos);
    for (uint32_t v = 0; v < g.nv; v++) {
        double q[3];
        rotate(m, &g.pos[3 * v], q);
        for (int c = 0; c < 3; c++) h.pos[3 * v + c] = scale * q[c] + shift[c];
    }
    sv_bbc_input in;
    geo_input(&h, &in);
    sv_bbc_options o = opts(0.01 * in.radius);
    sv_bbc_result r;
    assert_int_equal(sv_bbc_select(&in, &o, &r, NULL), SV_OK);
    assert_int_equal(r.plane_count, K);
    for (int i = 0; i < K; i++) {
        double n[3];
        rotate(m, pl[i], n);
        /* n·(s R x + t) − s n·R x − n·t: d' = s d − n'·t */
        double d = scale * pl[i][3] - (n[0] * shift[0] + n[1] * shift[1] + n[2] * shift[2]);
        int k = find_plane(&r, n, d, 1e-7, 1e-7 * 1000);
        assert_true(k >= 0);
        assert_int_equal(r.planes[k].count, 8);
    }
    check_partition(&h, &r, o.epsilon * (1 + 1e-6) + 1e-9);
    sv_bbc_result_free(&r);
    free(h.pos);
    geo_free(&g);
}

static bool same_result(const sv_bbc_result *a, const sv_bbc_result *b)
{
    if (a->plane_count != b->plane_count || a->tri_count != b->tri_count) return false;
    for (uint32_t k = 0; k < a->plane_count; k++) {
        const sv_bbc_plane *p = &a->planes[k], *q = &b->planes[k];
        if (memcmp(p->normal, q->normal, sizeof p->normal) || memcmp(&p->d, &q->d, sizeof p->d) ||
            p->first != q->first || p->count != q->count || p->cardboard_of != q->cardboard_of ||
            p->origin != q->origin || p->tweaked != q->tweaked)
            return false;
    }
    return memcmp(a->tris, b->tris, a->tri_count * sizeof *a->tris) == 0;
}

static void planes_are_byte_identical_across_runs_and_thread_counts(void **state)
{
    (void)state;
    geo g = {0};
    geo_crown(&g, 5, 1500);
    sv_bbc_input in;
    geo_input(&g, &in);
    sv_bbc_options o = opts(0.1 * in.radius);
    o.cardboard = true;
    o.cardboard_coverage = 0.05;
    sv_bbc_result a, b, c;
    o.threads = 1;
    assert_int_equal(sv_bbc_select(&in, &o, &a, NULL), SV_OK);
    o.threads = 2;
    assert_int_equal(sv_bbc_select(&in, &o, &b, NULL), SV_OK);
    o.threads = 3;
    assert_int_equal(sv_bbc_select(&in, &o, &c, NULL), SV_OK);
    assert_true(a.plane_count > 3);
    assert_true(same_result(&a, &b));
    assert_true(same_result(&a, &c));
    sv_bbc_result_free(&b);
    o.threads = 2;
    assert_int_equal(sv_bbc_select(&in, &o, &b, NULL), SV_OK);
    assert_true(same_result(&a, &b));
    sv_bbc_result_free(&a);
    sv_bbc_result_free(&b);
    sv_bbc_result_free(&c);
    geo_free(&g);
}

/* A target search's ladder of plane budgets through one memo (planes.h
 * sv_bbc_memo) gives the bytes each budget gives alone, with fewer greedy
 * runs: the runs known to exceed a budget are not made again. A memo of
 * another input (the crown moved) or with cardboard planes is not used. */
static void eps_memo_keeps_results_and_skips_known_runs(void **state)
{
    (void)state;
    geo g = {0};
    geo_crown(&g, 7, 1200);
    sv_bbc_input in;
    geo_input(&g, &in);
    sv_bbc_options o = opts(0.002 * in.radius);
    sv_bbc_memo *memo = sv_bbc_memo_create();
    assert_non_null(memo);
    static const uint32_t ladder[] = {24, 8, 12, 16, 24};
    uint32_t plain_runs = 0, memo_runs = 0;
    for (size_t i = 0; i < sizeof ladder / sizeof ladder[0]; i++) {
        sv_bbc_result a, b;
        o.max_planes = ladder[i];
        o.memo = NULL;
        assert_int_equal(sv_bbc_select(&in, &o, &a, NULL), SV_OK);
        o.memo = memo;
        assert_int_equal(sv_bbc_select(&in, &o, &b, NULL), SV_OK);
        assert_true(a.stats.runs > 1); /* the budget made ε rise */
        assert_true(same_result(&a, &b));
        assert_memory_equal(&a.stats.epsilon, &b.stats.epsilon, sizeof a.stats.epsilon);
        plain_runs += a.stats.runs;
        memo_runs += b.stats.runs;
        if (i == 0) assert_int_equal(a.stats.runs, b.stats.runs); /* nothing known yet */
        if (i == 1) assert_true(b.stats.runs < a.stats.runs); /* 24's exceeded runs exceed 8 */
        if (i == 4) assert_int_equal(b.stats.runs, 1); /* only the run it keeps */
        sv_bbc_result_free(&a);
        sv_bbc_result_free(&b);
    }
    assert_true(memo_runs < plain_runs);
    /* another input: nothing known of it */
    for (uint32_t v = 0; v < g.nv; v++) g.pos[3 * v] += 1.0;
    geo_input(&g, &in);
    sv_bbc_result a, b;
    o.max_planes = 8;
    o.memo = NULL;
    assert_int_equal(sv_bbc_select(&in, &o, &a, NULL), SV_OK);
    o.memo = memo;
    assert_int_equal(sv_bbc_select(&in, &o, &b, NULL), SV_OK);
    assert_true(same_result(&a, &b));
    assert_int_equal(a.stats.runs, b.stats.runs);
    sv_bbc_result_free(&a);
    sv_bbc_result_free(&b);
    sv_bbc_memo_free(memo);
    geo_free(&g);
}

/* k-planes (kplanes.c) on a crown large enough for its threaded
 * steps (assignment, moments, areas): the same bytes on every run, and every
 * triangle still in exactly one primary plane. */
static void kplanes_is_byte_identical_across_runs(void **state)
{
    (void)state;
    geo g = {0};
    geo_crown(&g, 11, 3000);
    sv_bbc_input in;
    geo_input(&g, &in);
    sv_bbc_options o = opts(0.15 * in.radius);
    o.max_planes = 12;
    sv_bbc_result a, b;
    assert_int_equal(sv_bbc_select(&in, &o, &a, NULL), SV_OK);
    assert_int_equal(sv_bbc_select(&in, &o, &b, NULL), SV_OK);
    assert_true(in.triangle_count >= 4096);
    assert_int_equal(sv_bbc_kplanes(&in, 16, 24, &a, NULL), SV_OK);
    assert_int_equal(sv_bbc_kplanes(&in, 16, 24, &b, NULL), SV_OK);
    assert_true(a.plane_count > 12);
    assert_true(same_result(&a, &b));
    for (uint32_t k = 0; k < a.plane_count; k++)
        assert_memory_equal(&a.planes[k].area, &b.planes[k].area, sizeof a.planes[k].area);
    uint32_t *cnt = calloc(g.nt, sizeof *cnt);
    assert_non_null(cnt);
    for (uint32_t k = 0; k < a.plane_count; k++)
        for (uint32_t i = 0; i < a.planes[k].count; i++) cnt[a.tris[a.planes[k].first + i]]++;
    for (uint32_t t = 0; t < g.nt; t++) assert_int_equal(cnt[t], 1);
    free(cnt);
    sv_bbc_result_free(&a);
    sv_bbc_result_free(&b);
    geo_free(&g);
}

static void every_face_is_simplified_by_exactly_one_plane(void **state)
{
    (void)state;
    geo g = {0};
    geo_crown(&g, 9, 2000);
    add_box(&g, 0.2, 2, SV_PART_TRUNK);
    sv_bbc_input in;
    geo_input(&g, &in);
    sv_bbc_options o = opts(0.06 * in.radius);
    sv_bbc_result r;
    assert_int_equal(sv_bbc_select(&in, &o, &r, NULL), SV_OK);
    /* welding (trunk) moves vertices up to ε before later planes test them */
    check_partition(&g, &r, 2 * o.epsilon);
    /* trunk planes first and only trunk faces in them */
    bool seen_foliage = false;
    for (uint32_t k = 0; k < r.plane_count; k++) {
        if (r.planes[k].part == SV_PART_FOLIAGE) seen_foliage = true;
        else assert_false(seen_foliage);
        for (uint32_t i = 0; i < r.planes[k].count; i++) {
            uint32_t t = r.tris[r.planes[k].first + i];
            assert_int_equal(t >= 4000, r.planes[k].part == SV_PART_TRUNK);
        }
    }
    print_message(
        "crown of 2000 leaves + box trunk at eps 6%%: %u planes, %.3f s (grid %.3f, refine %.3f)\n",
        r.plane_count, r.stats.seconds_total, r.stats.seconds_grid, r.stats.seconds_refine);
    sv_bbc_result_free(&r);
    geo_free(&g);
}

static void max_planes_raises_epsilon_until_the_planes_fit(void **state)
{
    (void)state;
    geo g = {0};
    geo_crown(&g, 13, 1500);
    sv_bbc_input in;
    geo_input(&g, &in);
    sv_bbc_options o = opts(0.03 * in.radius);
    sv_bbc_result free_run, capped;
    assert_int_equal(sv_bbc_select(&in, &o, &free_run, NULL), SV_OK);
    assert_true(primaries(&free_run) > 8);
    o.max_planes = 8;
    assert_int_equal(sv_bbc_select(&in, &o, &capped, NULL), SV_OK);
    assert_true(capped.plane_count <= 8);
    assert_true(capped.stats.epsilon > o.epsilon);
    assert_true(capped.stats.runs > 1);
    check_partition(&g, &capped, capped.stats.epsilon);
    sv_bbc_result_free(&capped);
    /* two passes cannot fit in one plane */
    add_box(&g, 0.2, 1, SV_PART_TRUNK);
    geo_input(&g, &in);
    o.max_planes = 1;
    sv_error err = {0};
    assert_int_equal(sv_bbc_select(&in, &o, &capped, &err), SV_ERR_LIMIT);
    assert_non_null(strstr(err.message, "max_planes"));
    sv_bbc_result_free(&free_run);
    geo_free(&g);
}

/* Faces on a plane whose normal lies between grid directions: the refined
 * plane is only near it; tweaking (§3.3.3) makes it exact. */
static void tweaking_aligns_the_plane_with_its_faces(void **state)
{
    (void)state;
    geo g = {0};
    double n[3] = {0.31, 0.62, -0.72}, u[3], v[3], o[3] = {0.2, 0.1, -0.1};
    double l = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    for (int c = 0; c < 3; c++) n[c] /= l;
    basis(n, u, v);
    geo_square(&g, o, u, v, 1.0, 4, SV_PART_FOLIAGE);
    /* something far off the plane, so the sphere is not the square's */
    double far[3], f2[3], f3[3];
    for (int c = 0; c < 3; c++) {
        far[c] = o[c] + 1.2 * n[c];
        f2[c] = far[c] + 0.1 * u[c];
        f3[c] = far[c] + 0.1 * v[c];
    }
    geo_single(&g, far, f2, f3, SV_PART_FOLIAGE);
    sv_bbc_input in;
    geo_input(&g, &in);
    double d = -(n[0] * o[0] + n[1] * o[1] + n[2] * o[2]);
    sv_bbc_options opt = opts(0.05 * in.radius);
    sv_bbc_result r;
    assert_int_equal(sv_bbc_select(&in, &opt, &r, NULL), SV_OK);
    int k = find_plane(&r, n, d, 1e-9, 1e-9);
    assert_true(k >= 0);
    assert_true(r.planes[k].tweaked);
    sv_bbc_result_free(&r);
    opt.tweak = false;
    assert_int_equal(sv_bbc_select(&in, &opt, &r, NULL), SV_OK);
    assert_true(find_plane(&r, n, d, 1e-6, 1e-6) < 0);
    check_partition(&g, &r, opt.epsilon);
    sv_bbc_result_free(&r);
    geo_free(&g);
}

/* A thin cylinder (the stem of Fig. 8) gets a cardboard plane. */
static void thin_stem_gets_a_cardboard_plane(void **state)
{
    (void)state;
    geo g = {0};
    const int seg = 12, rings = 6;
    uint32_t base_v = 0;
    for (int r = 0; r <= rings; r++)
        for (int s = 0; s < seg; s++) {
            double a = 2 * M_PI * s / seg;
            uint32_t id = geo_vertex(&g, 0.03 * cos(a), -1 + 2.0 * r / rings, 0.03 * sin(a));
            if (r == 0 && s == 0) base_v = id;
        }
    for (int r = 0; r < rings; r++)
        for (int s = 0; s < seg; s++) {
            uint32_t a = base_v + r * seg + s, b = base_v + r * seg + (s + 1) % seg;
            geo_tri(&g, a, b, a + seg);
            geo_element(&g, SV_PART_TRUNK);
            geo_tri(&g, b, b + seg, a + seg);
            geo_element(&g, SV_PART_TRUNK);
        }
    sv_bbc_input in;
    geo_input(&g, &in);
    sv_bbc_options o = opts(0.05 * in.radius);
    o.cardboard = true;
    o.max_angle_deg = 90; /* one plane takes the whole stem, as in the paper */
    sv_bbc_result r;
    assert_int_equal(sv_bbc_select(&in, &o, &r, NULL), SV_OK);
    assert_int_equal(primaries(&r), 1);
    assert_int_equal(r.plane_count, 2);
    const sv_bbc_plane *p = &r.planes[0], *c = &r.planes[1];
    assert_int_equal(c->cardboard_of, 0);
    assert_int_equal(c->origin, SV_BBC_CARDBOARD);
    assert_true(c->coverage >= 0.8);
    double dp = fabs(p->normal[0] * c->normal[0] + p->normal[1] * c->normal[1] +
                     p->normal[2] * c->normal[2]);
    assert_true(dp < 1e-9);                 /* perpendicular */
    assert_true(fabs(c->normal[1]) < 1e-9); /* along the stem */
    check_partition(&g, &r, o.epsilon);
    sv_bbc_result_free(&r);
    o.cardboard = false;
    assert_int_equal(sv_bbc_select(&in, &o, &r, NULL), SV_OK);
    assert_int_equal(r.plane_count, 1);
    sv_bbc_result_free(&r);
    geo_free(&g);
}

/* Welding moves the shared vertices of a bent strip onto the first plane;
 * without it the second plane is free to leave a gap. */
static void welding_moves_shared_vertices_onto_the_first_plane(void **state)
{
    (void)state;
    geo g = {0};
    /* a cylinder too wide for one plane */
    const int seg = 16;
    uint32_t v0 = g.nv;
    for (int r = 0; r <= 1; r++)
        for (int s = 0; s < seg; s++) {
            double a = 2 * M_PI * s / seg;
            geo_vertex(&g, cos(a), 2.0 * r, sin(a));
        }
    for (int s = 0; s < seg; s++) {
        uint32_t a = v0 + s, b = v0 + (s + 1) % seg;
        geo_tri(&g, a, b, a + seg);
        geo_element(&g, SV_PART_TRUNK);
        geo_tri(&g, b, b + seg, a + seg);
        geo_element(&g, SV_PART_TRUNK);
    }
    sv_bbc_input in;
    geo_input(&g, &in);
    sv_bbc_options o = opts(0.1 * in.radius);
    sv_bbc_result w, nw;
    assert_int_equal(sv_bbc_select(&in, &o, &w, NULL), SV_OK);
    assert_true(w.stats.welded_vertices > 0);
    check_partition(&g, &w, 2 * o.epsilon); /* original positions: within 2ε */
    o.weld = false;
    assert_int_equal(sv_bbc_select(&in, &o, &nw, NULL), SV_OK);
    assert_int_equal(nw.stats.welded_vertices, 0);
    check_partition(&g, &nw, o.epsilon);
    print_message("cylinder: %u planes welded, %u not\n", w.plane_count, nw.plane_count);
    sv_bbc_result_free(&w);
    sv_bbc_result_free(&nw);
    geo_free(&g);
}

static void projection_puts_every_face_on_its_plane(void **state)
{
    (void)state;
    geo g = {0};
    geo_crown(&g, 17, 600);
    sv_bbc_input in;
    geo_input(&g, &in);
    sv_bbc_options o = opts(0.08 * in.radius);
    sv_bbc_result r;
    assert_int_equal(sv_bbc_select(&in, &o, &r, NULL), SV_OK);
    double *pos = NULL;
    uint32_t *idx = NULL, nv = 0;
    assert_int_equal(sv_bbc_project(&in, &r, &pos, &idx, &nv, NULL), SV_OK);
    assert_int_equal(nv, 3 * g.nt);
    for (uint32_t k = 0; k < r.plane_count; k++) {
        const sv_bbc_plane *p = &r.planes[k];
        for (uint32_t i = 0; i < p->count; i++)
            for (int v = 0; v < 3; v++) {
                const double *x = &pos[3 * idx[3 * r.tris[p->first + i] + v]];
                double d = p->normal[0] * x[0] + p->normal[1] * x[1] + p->normal[2] * x[2] + p->d;
                assert_true(fabs(d) < 1e-9);
            }
    }
    /* the next LOD from the projection, with a larger ε: fewer planes */
    sv_bbc_input in2 = in;
    in2.positions = pos;
    in2.indices = idx;
    in2.vertex_count = nv;
    o.epsilon *= 2;
    sv_bbc_result r2;
    assert_int_equal(sv_bbc_select(&in2, &o, &r2, NULL), SV_OK);
    assert_true(r2.plane_count < r.plane_count);
    sv_bbc_result_free(&r2);
    free(pos);
    free(idx);
    sv_bbc_result_free(&r);
    geo_free(&g);
}

static void bad_input_is_refused_with_a_message(void **state)
{
    (void)state;
    geo g = {0};
    add_box(&g, 0.5, 1, SV_PART_FOLIAGE);
    sv_bbc_input in;
    geo_input(&g, &in);
    sv_bbc_options o = opts(0.01);
    sv_bbc_result r;
    sv_error err = {0};
    g.idx[4] = 999;
    assert_int_equal(sv_bbc_select(&in, &o, &r, &err), SV_ERR_INVALID);
    assert_non_null(strstr(err.message, "999"));
    assert_null(r.planes);
    g.idx[4] = 0;
    in.radius = 0;
    assert_int_equal(sv_bbc_select(&in, &o, &r, &err), SV_ERR_INVALID);
    geo_input(&g, &in);
    g.etris[1] = 0; /* triangle 0 in elements 0 and 1 */
    assert_int_equal(sv_bbc_select(&in, &o, &r, &err), SV_ERR_INVALID);
    assert_non_null(strstr(err.message, "two elements"));
    g.etris[1] = 1;
    o.epsilon = NAN;
    assert_int_equal(sv_bbc_select(&in, &o, &r, &err), SV_ERR_INVALID);
    sv_bbc_result_free(NULL);
    geo_free(&g);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(box_gives_its_six_face_planes),
        cmocka_unit_test(faces_on_k_known_planes_give_those_k_planes),
        cmocka_unit_test(fig4b_dominant_planes_swallow_side_faces_without_the_angle_limit),
        cmocka_unit_test(fig4b_angle_limit_gives_side_faces_their_own_planes),
        cmocka_unit_test(horizontal_penalty_lowers_share_of_near_horizontal_planes),
        cmocka_unit_test(tiny_epsilon_terminates_through_failsafe_with_every_face_simplified),
        cmocka_unit_test(horizontal_faces_at_the_poles_give_exactly_horizontal_planes),
        cmocka_unit_test(degenerate_faces_are_each_simplified_once),
        cmocka_unit_test(planes_move_with_translated_scaled_rotated_input),
        cmocka_unit_test(planes_are_byte_identical_across_runs_and_thread_counts),
        cmocka_unit_test(kplanes_is_byte_identical_across_runs),
        cmocka_unit_test(every_face_is_simplified_by_exactly_one_plane),
        cmocka_unit_test(max_planes_raises_epsilon_until_the_planes_fit),
        cmocka_unit_test(tweaking_aligns_the_plane_with_its_faces),
        cmocka_unit_test(thin_stem_gets_a_cardboard_plane),
        cmocka_unit_test(welding_moves_shared_vertices_onto_the_first_plane),
        cmocka_unit_test(projection_puts_every_face_on_its_plane),
        cmocka_unit_test(bad_input_is_refused_with_a_message),
        cmocka_unit_test(eps_memo_keeps_results_and_skips_known_runs),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
