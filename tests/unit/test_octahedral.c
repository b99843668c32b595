/* sylva-test: cost=6 (tests/run.sh starts the longest first) */
/* test_octahedral.c — octahedral impostors (octahedral.h): the mapping and
 * its inverse, frame bases, the three-frame selection, docs/runtime.md's
 * worked example, Castaño mips, and
 * (with the OSMesa renderer) a baked impostor drawn by the C reference
 * runtime against the original from a frame's own direction and from
 * between frames. */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <cmocka.h>
#include "test_skip.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "evaluate.h"
#include "octahedral.h"

static double rnd(uint64_t *s)
{
    *s ^= *s >> 12;
    *s ^= *s << 25;
    *s ^= *s >> 27;
    return (double)((*s * 2685821657736338717ull) >> 11) * (1.0 / 9007199254740992.0);
}

static void random_dir(uint64_t *s, double d[3])
{
    double r2;
    do {
        for (int k = 0; k < 3; k++) d[k] = rnd(s) * 2 - 1;
        r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
    } while (r2 > 1 || r2 < 1e-4);
    for (int k = 0; k < 3; k++) d[k] /= sqrt(r2);
}

/* ---- pure ---------------------------------------------------------------- */

static void decode_inverts_encode(void **state)
{
    (void)state;
    uint64_t s = 3;
    static const double scales[3] = {1.0, 0.5, 0.2};
    for (int k3 = 0; k3 < 3; k3++)
        for (int hemi = 0; hemi < 2; hemi++)
            for (int i = 0; i < 2000; i++) {
                double d[3], uv[2], back[3];
                random_dir(&s, d);
                if (hemi) d[1] = fabs(d[1]);
                sv_octa_encode(hemi, scales[k3], d, uv);
                assert_true(fabs(uv[0]) <= 1 + 1e-12 && fabs(uv[1]) <= 1 + 1e-12);
                sv_octa_decode(hemi, scales[k3], uv, back);
                for (int k = 0; k < 3; k++) assert_true(fabs(back[k] - d[k]) < 1e-9);
            }
    /* hemi: a view from below is seen as from the horizon */
    double below[3] = {0.6, -0.8, 0}, uv[2], back[3];
    sv_octa_encode(true, 1.0, below, uv);
    sv_octa_decode(true, 1.0, uv, back);
    assert_true(fabs(back[0] - 1) < 1e-12 && fabs(back[1]) < 1e-12);
    /* the elevation scale moves hemi 8×8's second ring from 22° to 11° (on
     * the diagonal frame (6, 6)), and keeps the horizon and the zenith */
    sv_octa_grid g = {.n = 8, .hemi = true, .elev_scale = 1.0};
    double f[3];
    sv_octa_frame_dir(&g, 6, 6, f);
    assert_true(fabs(asin(f[1]) * 180 / M_PI - 21.80) < 0.01);
    g.elev_scale = 0.5;
    sv_octa_frame_dir(&g, 6, 6, f);
    assert_true(fabs(asin(f[1]) * 180 / M_PI - 11.31) < 0.01);
    sv_octa_frame_dir(&g, 7, 7, f);
    assert_true(fabs(f[1]) < 1e-12);
    /* and a frame's own direction selects that frame alone */
    sv_octa_frame_dir(&g, 6, 5, f);
    uint32_t fr[3][2];
    double w[3];
    sv_octa_select(&g, f, fr, w);
    int one = -1;
    for (int k = 0; k < 3; k++)
        if (w[k] > 0.999) one = k;
    assert_true(one >= 0 && fr[one][0] == 6 && fr[one][1] == 5);
}

static void frame_bases_are_right_handed_and_orthonormal(void **state)
{
    (void)state;
    uint64_t s = 5;
    for (int i = 0; i < 500; i++) {
        double d[3], r[3], u[3];
        random_dir(&s, d);
        if (i == 0) d[0] = 0, d[1] = 1, d[2] = 0;
        if (i == 1) d[0] = 0, d[1] = -1, d[2] = 0;
        sv_octa_frame_basis(d, r, u);
        double rr = r[0] * r[0] + r[1] * r[1] + r[2] * r[2];
        double uu = u[0] * u[0] + u[1] * u[1] + u[2] * u[2];
        double ru = r[0] * u[0] + r[1] * u[1] + r[2] * u[2];
        double c[3] = {r[1] * u[2] - r[2] * u[1], r[2] * u[0] - r[0] * u[2],
                       r[0] * u[1] - r[1] * u[0]};
        assert_true(fabs(rr - 1) < 1e-9 && fabs(uu - 1) < 1e-9 && fabs(ru) < 1e-9);
        for (int k = 0; k < 3; k++) assert_true(fabs(c[k] - d[k]) < 1e-9);
    }
    /* from the side, up is world up */
    double side[3] = {0, 0, 1}, r[3], u[3];
    sv_octa_frame_basis(side, r, u);
    assert_true(fabs(r[0] - 1) < 1e-12 && fabs(u[1] - 1) < 1e-12);
}

static void selection_weights_are_barycentric(void **state)
{
    (void)state;
    uint64_t s = 9;
    for (int hemi = 0; hemi < 2; hemi++) {
        sv_octa_grid g = {.n = hemi ? 8 : 12, .hemi = hemi};
        /* at a frame's own direction that frame has all the weight */
        for (uint32_t j = 0; j < g.n; j++)
            for (uint32_t i = 0; i < g.n; i++) {
                double d[3], w[3];
                uint32_t f[3][2];
                sv_octa_frame_dir(&g, i, j, d);
                sv_octa_select(&g, d, f, w);
                double at = 0;
                for (int k = 0; k < 3; k++)
                    if (f[k][0] == i && f[k][1] == j) at += w[k];
                /* the full octahedron's border frames repeat a direction:
                 * then the twin frame may hold it */
                if (hemi || (i > 0 && j > 0 && i + 1 < g.n && j + 1 < g.n))
                    assert_true(at > 1 - 1e-9);
            }
        for (int t = 0; t < 1000; t++) {
            double d[3], w[3];
            uint32_t f[3][2];
            random_dir(&s, d);
            sv_octa_select(&g, d, f, w);
            double sum = 0;
            for (int k = 0; k < 3; k++) {
                assert_true(w[k] >= -1e-12);
                assert_true(f[k][0] < g.n && f[k][1] < g.n);
                sum += w[k];
            }
            assert_true(fabs(sum - 1) < 1e-9);
            /* the heaviest frame is within one grid step of the view */
            int b = 0;
            for (int k = 1; k < 3; k++)
                if (w[k] > w[b]) b = k;
            double fd[3];
            sv_octa_frame_dir(&g, f[b][0], f[b][1], fd);
            double dd[3] = {d[0], hemi && d[1] < 0 ? 0 : d[1], d[2]};
            double n = sqrt(dd[0] * dd[0] + dd[1] * dd[1] + dd[2] * dd[2]);
            double c = (fd[0] * dd[0] + fd[1] * dd[1] + fd[2] * dd[2]) / n;
            assert_true(c > cos(M_PI / (g.n - 1) * 1.5));
        }
    }
}

/* The worked example of docs/runtime.md ("A worked example"): the frames,
 * weights, directions and bases printed there, to 6 places. */
static void runtime_md_worked_example(void **state)
{
    (void)state;
    const double eps = 1e-6;
    sv_octa_grid g = {.n = 8, .hemi = true, .elev_scale = 0.5};
    double D[3] = {0.5, 0.2, 0.84}, uv[2], w[3];
    double n = sqrt(D[0] * D[0] + D[1] * D[1] + D[2] * D[2]);
    for (int k = 0; k < 3; k++) D[k] /= n;
    uint32_t f[3][2];
    sv_octa_encode(true, 0.5, D, uv);
    assert_true(fabs(uv[0] - 0.770115) < eps && fabs(uv[1] + 0.195402) < eps);
    sv_octa_select(&g, D, f, w);
    const uint32_t want_f[3][2] = {{7, 3}, {7, 2}, {6, 3}};
    const double want_w[3] = {0.011494, 0.183908, 0.804598};
    for (int k = 0; k < 3; k++) {
        assert_int_equal(f[k][0], want_f[k][0]);
        assert_int_equal(f[k][1], want_f[k][1]);
        assert_true(fabs(w[k] - want_w[k]) < eps);
    }
    double d[3], r[3], u[3];
    sv_octa_frame_dir(&g, 6, 3, d);
    sv_octa_frame_basis(d, r, u);
    const double wd[3] = {0.534522, 0.267261, 0.801784}, wr[3] = {0.832050, 0, -0.554700},
                 wu[3] = {-0.148250, 0.963624, -0.222375};
    for (int k = 0; k < 3; k++)
        assert_true(fabs(d[k] - wd[k]) < eps && fabs(r[k] - wr[k]) < eps &&
                    fabs(u[k] - wu[k]) < eps);
    /* the ray through (1, 7, 0), centre (0, 6, 0), half 5, F 256: texel (149.8312, 105.2185) */
    double q[3] = {1, 1, 0}, dd = D[0] * d[0] + D[1] * d[1] + D[2] * d[2];
    double t = (q[0] * d[0] + q[1] * d[1] + q[2] * d[2]) / dd, P[3];
    for (int k = 0; k < 3; k++) P[k] = q[k] - t * D[k];
    double s = (P[0] * r[0] + P[1] * r[1] + P[2] * r[2]) / 5 * 0.5 + 0.5;
    double tt = 0.5 - (P[0] * u[0] + P[1] * u[1] + P[2] * u[2]) / 5 * 0.5;
    assert_true(fabs(s * 256 - 0.5 - 149.8312) < 1e-4 && fabs(tt * 256 - 0.5 - 105.2185) < 1e-4);
    /* below the horizon: hemi clamps, the full octahedron folds */
    double B[3] = {-0.3, -0.5, 0.81};
    n = sqrt(B[0] * B[0] + B[1] * B[1] + B[2] * B[2]);
    for (int k = 0; k < 3; k++) B[k] /= n;
    sv_octa_select(&g, B, f, w);
    assert_true(f[0][0] == 5 && f[0][1] == 0 && fabs(w[0] - 0.891892) < eps);
    sv_octa_grid full = {.n = 12, .hemi = false, .elev_scale = 1};
    sv_octa_encode(false, 1, B, uv);
    assert_true(fabs(uv[0] + 0.496894) < eps && fabs(uv[1] - 0.813665) < eps);
    sv_octa_select(&full, B, f, w);
    const uint32_t want_b[3][2] = {{3, 10}, {3, 9}, {2, 10}};
    const double want_bw[3] = {0.742236, 0.024845, 0.232919};
    for (int k = 0; k < 3; k++) {
        assert_int_equal(f[k][0], want_b[k][0]);
        assert_int_equal(f[k][1], want_b[k][1]);
        assert_true(fabs(w[k] - want_bw[k]) < eps);
    }
    /* the poles' bases */
    const double up_y[3] = {0, 1, 0}, dn_y[3] = {0, -1, 0};
    sv_octa_frame_basis(up_y, r, u);
    assert_true(fabs(r[0] - 1) < eps && fabs(u[2] + 1) < eps);
    sv_octa_frame_basis(dn_y, r, u);
    assert_true(fabs(r[0] - 1) < eps && fabs(u[2] - 1) < eps);
}

static void mips_keep_each_frames_tested_coverage(void **state)
{
    (void)state;
    sv_octa_grid g = {.n = 2, .hemi = true, .frame_pixels = 64};
    sv_image a = {0};
    assert_int_equal(sv_image_alloc(&a, 128, 128, 4, 8, NULL), SV_OK);
    uint8_t *p = a.data;
    uint64_t s = 11;
    /* sparse "leaves": isolated texels of alpha 200 (they vanish under a
     * plain average) in frame (0,0); a solid disc in frame (1,1) */
    for (uint32_t y = 0; y < 128; y++)
        for (uint32_t x = 0; x < 128; x++) {
            uint8_t *q = p + 4 * ((size_t)y * 128 + x);
            q[0] = 40, q[1] = 160, q[2] = 30;
            if (x < 64 && y < 64) q[3] = rnd(&s) < 0.2 ? 200 : 0;
            else if (x >= 64 && y >= 64)
                q[3] = (x - 96.0) * (x - 96.0) + (y - 96.0) * (y - 96.0) < 400 ? 255 : 0;
            else q[3] = 0;
        }
    sv_image m1 = {0}, m2 = {0};
    assert_int_equal(sv_octa_mip(&g, &a, &a, &m1, NULL), SV_OK);
    assert_int_equal(m1.width, 64u);
    assert_int_equal(sv_octa_mip(&g, &a, &m1, &m2, NULL), SV_OK);
    const sv_image *lv[3] = {&a, &m1, &m2};
    double cov[3][2];
    for (int l = 0; l < 3; l++) {
        uint32_t F = lv[l]->width / 2;
        for (int f = 0; f < 2; f++) {
            size_t pass = 0;
            for (uint32_t y = 0; y < F; y++)
                for (uint32_t x = 0; x < F; x++) {
                    const uint8_t *q = (const uint8_t *)lv[l]->data +
                                       4 * ((size_t)(y + f * F) * lv[l]->width + x + f * F);
                    pass += q[3] >= 128;
                }
            cov[l][f] = (double)pass / ((double)F * F);
        }
    }
    for (int l = 0; l < 3; l++) printf("level %d: coverage %.4f %.4f\n", l, cov[l][0], cov[l][1]);
    for (int l = 1; l < 3; l++)
        for (int f = 0; f < 2; f++) assert_true(fabs(cov[l][f] - cov[0][f]) < 0.03);
    /* empty frames stay empty */
    const uint8_t *q = (const uint8_t *)m2.data + 4 * (size_t)(0 * 32 + 20);
    assert_int_equal(q[3], 0);
    sv_image_free(&a);
    sv_image_free(&m1);
    sv_image_free(&m2);
}

/* ---- with the renderer ---------------------------------------------------- */

/* A synthetic tree: small leaf quads of random orientation in an ellipsoidal
 * crown around (0, 2, 0) on a thin trunk; two colours. */
static sv_mesh *tree(uint32_t leaves)
{
    sv_mesh *m = sv_mesh_create(4 * leaves + 4, 2 * leaves + 2, 2, 0);
    assert_non_null(m);
    uint64_t s = 42;
    const double h = 0.06;
    for (uint32_t l = 0; l < leaves; l++) {
        double c[3], r2;
        do {
            for (int k = 0; k < 3; k++) c[k] = rnd(&s) * 2 - 1;
            r2 = c[0] * c[0] + c[1] * c[1] + c[2] * c[2];
        } while (r2 > 1);
        c[0] *= 1.2, c[1] = 2.0 + 0.8 * c[1];
        double a = rnd(&s) * 2 * M_PI, b = rnd(&s) * M_PI;
        double u[3] = {cos(a) * h, 0, sin(a) * h};
        double v[3] = {-sin(a) * cos(b) * h, sin(b) * h, cos(a) * cos(b) * h};
        static const double q[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
        for (int i = 0; i < 4; i++)
            for (int k = 0; k < 3; k++)
                m->positions[3 * (4 * l + i) + k] = (float)(c[k] + q[i][0] * u[k] + q[i][1] * v[k]);
        uint32_t o = 4 * l, *t = &m->indices[6 * l];
        t[0] = o, t[1] = o + 1, t[2] = o + 2, t[3] = o, t[4] = o + 2, t[5] = o + 3;
        m->tri_material[2 * l] = m->tri_material[2 * l + 1] = 0;
    }
    uint32_t o = 4 * leaves;
    static const double tq[4][2] = {{-0.08, 0}, {0.08, 0}, {0.08, 1.6}, {-0.08, 1.6}};
    for (int i = 0; i < 4; i++) {
        m->positions[3 * (o + i)] = (float)tq[i][0];
        m->positions[3 * (o + i) + 1] = (float)tq[i][1];
        m->positions[3 * (o + i) + 2] = 0.3f;
    }
    uint32_t *t = &m->indices[6 * leaves];
    t[0] = o, t[1] = o + 1, t[2] = o + 2, t[3] = o, t[4] = o + 2, t[5] = o + 3;
    m->tri_material[2 * leaves] = m->tri_material[2 * leaves + 1] = 1;
    static const float col[2][3] = {{0.2f, 0.6f, 0.1f}, {0.4f, 0.25f, 0.1f}};
    for (int i = 0; i < 2; i++) {
        memcpy(m->materials[i].base_color, col[i], sizeof col[i]);
        m->materials[i].double_sided = true;
    }
    sv_mesh_compute_normals(m);
    return m;
}

/* Coverage IoU at 64 px of the original and the impostor seen from d
 * (evaluator's camera framing the bounding sphere, 256 px renders). */
static double iou_from(sv_renderer *r, const sv_gpu_mesh *g, const sv_mesh *m,
                       const sv_octa_grid *grid, const sv_baked_lod *b, const double d[3],
                       double *depth_err)
{
    double c[3], rad;
    sv_mesh_frame_sphere(m, c, &rad);
    sv_camera cam;
    sv_eval_camera(c, rad, d, &cam);
    sv_image o = {0}, i = {0};
    float *od = calloc(256 * 256, sizeof *od), *id = calloc(256 * 256, sizeof *id);
    assert_non_null(od);
    assert_non_null(id);
    assert_int_equal(sv_render(r, g, NULL, 0, &cam, NULL, 256, 256, &o, od, NULL), SV_OK);
    assert_int_equal(sv_octa_render(grid, &b->albedo, b->depth.data ? &b->depth : NULL, &cam, 256,
                                    256, &i, id, NULL),
                     SV_OK);
    sv_eval_image a = {0}, bb = {0};
    assert_int_equal(sv_eval_image_from_render_filtered(&o, od, 64, 64, &a, NULL), SV_OK);
    assert_int_equal(sv_eval_image_from_render_filtered(&i, id, 64, 64, &bb, NULL), SV_OK);
    sv_eval_metrics mt = sv_eval_compare(&a, &bb, rad);
    if (depth_err) *depth_err = mt.depth_error;
    sv_eval_image_free(&a);
    sv_eval_image_free(&bb);
    sv_image_free(&o);
    sv_image_free(&i);
    free(od);
    free(id);
    return mt.iou;
}

static void baked_impostor_matches_the_tree(void **state)
{
    (void)state;
    sv_renderer *r = NULL;
    sv_error err = {0};
    /* no OSMesa context is a failure (libosmesa6 is a dependency), not a skip */
    assert_int_equal(sv_renderer_create(1024, &r, &err), SV_OK);
    sv_mesh *m = tree(3000);
    sv_gpu_mesh *g = NULL;
    assert_int_equal(sv_gpu_mesh_upload(r, m, &g, &err), SV_OK);
    for (int hemi = 0; hemi < 2; hemi++) {
        sv_octa_grid grid;
        assert_int_equal(sv_octa_fit(m, 8, hemi, 1.0, &grid, &err), SV_OK);
        grid.frame_pixels = 128;
        sv_bake_options bo;
        sv_bake_options_init(&bo);
        bo.depth_map = true;
        sv_baked_lod b;
        assert_int_equal(sv_octa_bake(r, g, m, &grid, &bo, 4, &b, &err), SV_OK);
        assert_int_equal(b.albedo.width, 8u * 128u);
        assert_int_equal(b.mesh->triangle_count, 2u * SV_OCTA_PROXY_QUADS); /* the proxy */
        double de = 0;
        /* from a frame's own direction: the frame itself */
        double d[3];
        sv_octa_frame_dir(&grid, 3, 5, d);
        double at = iou_from(r, g, m, &grid, &b, d, &de);
        printf("hemi %d: at frame (3,5): IoU %.3f depth %.3f\n", hemi, at, de);
        assert_true(at > 0.93);
        assert_true(de < 0.05);
        /* between frames (the middle of a grid cell), and from the side */
        double uv[2] = {2.0 * 3.4 / 7 - 1, 2.0 * 4.3 / 7 - 1}, mid[3];
        sv_octa_decode(hemi, 1.0, uv, mid);
        double between = iou_from(r, g, m, &grid, &b, mid, NULL);
        printf("hemi %d: between frames: IoU %.3f\n", hemi, between);
        assert_true(between > 0.85);
        /* a wrong frame (seen from behind) must not pass: the check can fail */
        sv_octa_grid wrong = grid;
        wrong.centre[0] += 0.6;
        double off = iou_from(r, g, m, &wrong, &b, d, NULL);
        printf("hemi %d: shifted centre: IoU %.3f\n", hemi, off);
        assert_true(off < at - 0.2);
        sv_baked_lod_free(&b);
    }
    sv_gpu_mesh_free(g);
    sv_mesh_destroy(m);
    sv_renderer_destroy(r);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(decode_inverts_encode),
        cmocka_unit_test(frame_bases_are_right_handed_and_orthonormal),
        cmocka_unit_test(selection_weights_are_barycentric),
        cmocka_unit_test(runtime_md_worked_example),
        cmocka_unit_test(mips_keep_each_frames_tested_coverage),
        cmocka_unit_test(baked_impostor_matches_the_tree),
    };
    return sv_test_exit(cmocka_run_group_tests(tests, NULL, NULL));
}
