/* test_crossed_quads.c — the crossed-quads ("cardboard") method
 * (core/methods/crossed_quads/crossed_quads.c) and the strict settings helpers (core/methods/method_settings.c). */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "methods/crossed_quads/crossed_quads.h"

/* A tree: trunk box around (tx, tz) from y 0..4 (material "bark"), and a crown
 * of leaf triangles (material "leaves") off to one side between y 3 and 6. */
static sv_mesh *make_tree(double tx, double tz, bool with_trunk)
{
    const uint32_t leaves = 40;
    uint32_t nv = (with_trunk ? 8 : 0) + 3 * leaves, nt = (with_trunk ? 12 : 0) + leaves;
    sv_mesh *m = sv_mesh_create(nv, nt, 2, 0);
    assert_non_null(m);
    snprintf(m->materials[0].name, sizeof m->materials[0].name, "bark");
    snprintf(m->materials[1].name, sizeof m->materials[1].name, "leaves");
    uint32_t v = 0, t = 0;
    if (with_trunk) {
        for (int k = 0; k < 8; k++) {
            m->positions[3 * v] = (float)(tx + ((k & 1) ? 0.2 : -0.2));
            m->positions[3 * v + 1] = (float)((k & 2) ? 4 : 0);
            m->positions[3 * v + 2] = (float)(tz + ((k & 4) ? 0.2 : -0.2));
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
    }
    for (uint32_t i = 0; i < leaves; i++) {
        double a = 0.7 * i, r = 1 + 0.05 * i, y = 3 + 0.075 * i;
        double cx = tx + 1.0 + r * cos(a), cz = tz + r * sin(a); /* crown offset by +1 in x */
        const double d[3][3] = {{0, 0, 0}, {0.2, 0.05, 0}, {0, 0.1, 0.2}};
        for (int j = 0; j < 3; j++) {
            m->positions[3 * v] = (float)(cx + d[j][0]);
            m->positions[3 * v + 1] = (float)(y + d[j][1]);
            m->positions[3 * v + 2] = (float)(cz + d[j][2]);
            m->indices[3 * t + j] = v++;
        }
        m->tri_material[t++] = 1;
    }
    return m;
}

typedef struct run_ctx {
    sv_mesh *mesh;
    sv_classification cls;
    sv_method_input in;
    sv_stand_in out;
} run_ctx;

static sv_status run(run_ctx *r, sv_mesh *m, const char *settings_json, sv_error *err)
{
    memset(r, 0, sizeof *r);
    r->mesh = m;
    assert_int_equal(sv_classify(m, NULL, &r->cls, NULL), SV_OK);
    r->in.mesh = m;
    r->in.cls = &r->cls;
    sv_mesh_sphere(m, r->in.centre, &r->in.radius);
    r->in.seed = 1;
    cJSON *s = settings_json ? cJSON_Parse(settings_json) : NULL;
    if (settings_json) assert_non_null(s);
    sv_status st = sv_method_crossed_quads_ops.run(&r->in, s, &r->out, err);
    cJSON_Delete(s);
    return st;
}

static void run_done(run_ctx *r)
{
    sv_stand_in_free(&r->out);
    sv_classification_free(&r->cls);
    sv_mesh_destroy(r->mesh);
}

static double dot(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

/* Every vertex lies inside the quad's rectangle (projected) and its slab. */
static void assert_quad_shows_whole_tree(const sv_mesh *m, const sv_quad *q)
{
    for (uint32_t v = 0; v < m->vertex_count; v++) {
        double p[3] = {m->positions[3 * v], m->positions[3 * v + 1], m->positions[3 * v + 2]};
        double d[3] = {p[0] - q->centre[0], p[1] - q->centre[1], p[2] - q->centre[2]};
        assert_true(fabs(dot(d, q->axis_u)) <= q->half_u + 1e-9);
        assert_true(fabs(dot(d, q->axis_v)) <= q->half_v + 1e-9);
        assert_true(fabs(dot(q->normal, p) + q->d) <= q->slab);
    }
    assert_int_equal(q->face_count, m->triangle_count);
    for (uint32_t t = 0; t < m->triangle_count; t++) assert_int_equal(q->faces[t], t);
    assert_null(q->bake_faces);
    assert_int_equal(q->parts, SV_PARTS_TRUNK | SV_PARTS_FOLIAGE);
    assert_false(q->clip);
    double c[3] = {q->axis_u[1] * q->axis_v[2] - q->axis_u[2] * q->axis_v[1],
                   q->axis_u[2] * q->axis_v[0] - q->axis_u[0] * q->axis_v[2],
                   q->axis_u[0] * q->axis_v[1] - q->axis_u[1] * q->axis_v[0]};
    assert_true(dot(c, q->normal) > 1 - 1e-12);
}

static void method_is_registered_under_its_name(void **state)
{
    (void)state;
    assert_ptr_equal(sv_method_find("crossed_quads"), &sv_method_crossed_quads);
    assert_string_equal(sv_method_crossed_quads.name, "crossed_quads");
    assert_non_null(sv_method_crossed_quads.summary);
}

static void default_gives_two_vertical_quads_through_the_trunk_axis(void **state)
{
    (void)state;
    run_ctx r;
    assert_int_equal(run(&r, make_tree(5, -3, true), NULL, NULL), SV_OK);
    assert_string_equal(r.out.method, "crossed_quads");
    assert_int_equal(r.out.lod_count, 1);
    const sv_lod_plan *lod = &r.out.lods[0];
    assert_string_equal(lod->name, "crossed");
    assert_int_equal(lod->trunk, SV_TRUNK_NONE);
    assert_int_equal(lod->quad_count, 2);
    const double n0[3] = {0, 0, 1}, n1[3] = {1, 0, 0}, axis[3] = {5, 123, -3};
    assert_true(dot(lod->quads[0].normal, n0) > 1 - 1e-12);
    assert_true(dot(lod->quads[1].normal, n1) > 1 - 1e-12);
    for (uint32_t i = 0; i < 2; i++) {
        const sv_quad *q = &lod->quads[i];
        assert_true(q->axis_v[1] == 1 && q->axis_v[0] == 0 && q->axis_v[2] == 0);
        /* the plane contains the trunk axis (x = 5, z = -3), not the crown's centre */
        assert_true(fabs(dot(q->normal, axis) + q->d) < 1e-5);
        assert_quad_shows_whole_tree(r.mesh, q);
    }
    /* the rectangle is tight: the tree spans y 0 .. 6.x */
    assert_true(fabs(lod->quads[0].half_v - 0.5 * (3 + 0.075 * 39 + 0.1)) < 1e-5);
    run_done(&r);
}

static void three_planes_are_sixty_degrees_apart_and_horizontal_sits_mid_crown(void **state)
{
    (void)state;
    run_ctx r;
    assert_int_equal(run(&r, make_tree(0, 0, true), "{\"planes\":3,\"horizontal\":true}", NULL),
                     SV_OK);
    const sv_lod_plan *lod = &r.out.lods[0];
    assert_int_equal(lod->quad_count, 4);
    for (uint32_t i = 0; i < 3; i++) {
        const sv_quad *a = &lod->quads[i], *b = &lod->quads[(i + 1) % 3];
        assert_true(fabs(fabs(dot(a->normal, b->normal)) - 0.5) < 1e-12);
        assert_true(a->normal[1] == 0);
        assert_quad_shows_whole_tree(r.mesh, a);
    }
    const sv_quad *h = &lod->quads[3];
    assert_true(h->normal[1] == 1);
    double ymin = INFINITY, ymax = -INFINITY;
    for (uint32_t v = 8; v < r.mesh->vertex_count; v++) { /* foliage vertices */
        double y = r.mesh->positions[3 * v + 1];
        if (y < ymin) ymin = y;
        if (y > ymax) ymax = y;
    }
    assert_true(fabs(-h->d - 0.5 * (ymin + ymax)) < 1e-9);
    assert_quad_shows_whole_tree(r.mesh, h);
    run_done(&r);
}

static void tree_without_trunk_uses_the_bounding_box_centre(void **state)
{
    (void)state;
    run_ctx r;
    assert_int_equal(run(&r, make_tree(2, 2, false), NULL, NULL), SV_OK);
    const sv_quad *q = &r.out.lods[0].quads[0];
    assert_true(fabs(dot(q->normal, r.in.centre) + q->d) < 1e-9);
    assert_quad_shows_whole_tree(r.mesh, q);
    run_done(&r);
}

static void two_runs_give_identical_quads(void **state)
{
    (void)state;
    run_ctx a, b;
    assert_int_equal(run(&a, make_tree(1, 1, true), "{\"horizontal\":true}", NULL), SV_OK);
    assert_int_equal(run(&b, make_tree(1, 1, true), "{\"horizontal\":true}", NULL), SV_OK);
    assert_int_equal(a.out.lods[0].quad_count, b.out.lods[0].quad_count);
    for (uint32_t i = 0; i < a.out.lods[0].quad_count; i++) {
        const sv_quad *p = &a.out.lods[0].quads[i], *q = &b.out.lods[0].quads[i];
        assert_memory_equal(p->normal, q->normal, sizeof p->normal);
        assert_memory_equal(p->centre, q->centre, sizeof p->centre);
        assert_memory_equal(p->axis_u, q->axis_u, sizeof p->axis_u);
        assert_true(p->d == q->d && p->half_u == q->half_u && p->half_v == q->half_v &&
                    p->slab == q->slab);
    }
    run_done(&a);
    run_done(&b);
}

static void bad_settings_fail_naming_the_key(void **state)
{
    (void)state;
    const char *bad[][2] = {
        {"{\"planes\":4}", "crossed_quads.planes"},
        {"{\"planes\":2.5}", "crossed_quads.planes"},
        {"{\"planes\":\"2\"}", "crossed_quads.planes"},
        {"{\"horizontal\":1}", "crossed_quads.horizontal"},
        {"{\"plane\":2}", "crossed_quads.plane"},
        {"[2]", "crossed_quads"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        cJSON *s = cJSON_Parse(bad[i][0]);
        assert_non_null(s);
        sv_error e = {0};
        assert_int_equal(sv_method_crossed_quads.check(s, &e), SV_ERR_SPEC);
        assert_non_null(strstr(e.message, bad[i][1]));
        cJSON_Delete(s);
        /* run refuses the same settings and leaves nothing behind */
        run_ctx r;
        assert_int_equal(run(&r, make_tree(0, 0, true), bad[i][0], &e), SV_ERR_SPEC);
        assert_int_equal(r.out.lod_count, 0);
        run_done(&r);
    }
    assert_int_equal(sv_method_crossed_quads.check(NULL, NULL), SV_OK);
    cJSON *ok = cJSON_Parse("{\"planes\":3,\"horizontal\":false}");
    assert_int_equal(sv_method_crossed_quads.check(ok, NULL), SV_OK);
    cJSON_Delete(ok);
}

static void setting_helpers_keep_defaults_and_check_ranges(void **state)
{
    (void)state;
    cJSON *o = cJSON_Parse("{\"x\":1.5,\"n\":7,\"b\":true,\"big\":1e300,\"neg\":-3}");
    assert_non_null(o);
    double x = 9;
    long n = 9;
    bool b = false;
    sv_error e = {0};
    assert_int_equal(sv_setting_number(o, "m", "missing", 0, 1, &x, &e), SV_OK);
    assert_true(x == 9);
    assert_int_equal(sv_setting_number(NULL, "m", "x", 0, 1, &x, &e), SV_OK);
    assert_int_equal(sv_setting_number(o, "m", "x", 0, 2, &x, &e), SV_OK);
    assert_true(x == 1.5);
    assert_int_equal(sv_setting_number(o, "m", "x", 0, 1, &x, &e), SV_ERR_SPEC);
    assert_non_null(strstr(e.message, "m.x"));
    assert_int_equal(sv_setting_int(o, "m", "n", 0, 10, &n, &e), SV_OK);
    assert_int_equal(n, 7);
    assert_int_equal(sv_setting_int(o, "m", "x", 0, 10, &n, &e), SV_ERR_SPEC);
    assert_int_equal(sv_setting_int(o, "m", "big", 0, 10, &n, &e), SV_ERR_SPEC);
    assert_int_equal(sv_setting_int(o, "m", "neg", 0, 10, &n, &e), SV_ERR_SPEC);
    assert_int_equal(n, 7);
    assert_int_equal(sv_setting_bool(o, "m", "b", &b, &e), SV_OK);
    assert_true(b);
    assert_int_equal(sv_setting_bool(o, "m", "n", &b, &e), SV_ERR_SPEC);
    assert_non_null(strstr(e.message, "m.n"));
    const char *known[] = {"x", "n", "b", "big", NULL};
    assert_int_equal(sv_setting_only(o, "m", known, &e), SV_ERR_SPEC);
    assert_non_null(strstr(e.message, "m.neg"));
    const char *all[] = {"x", "n", "b", "big", "neg", NULL};
    assert_int_equal(sv_setting_only(o, "m", all, &e), SV_OK);
    assert_int_equal(sv_setting_only(NULL, "m", all, &e), SV_OK);
    cJSON_Delete(o);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(method_is_registered_under_its_name),
        cmocka_unit_test(default_gives_two_vertical_quads_through_the_trunk_axis),
        cmocka_unit_test(three_planes_are_sixty_degrees_apart_and_horizontal_sits_mid_crown),
        cmocka_unit_test(tree_without_trunk_uses_the_bounding_box_centre),
        cmocka_unit_test(two_runs_give_identical_quads),
        cmocka_unit_test(bad_settings_fail_naming_the_key),
        cmocka_unit_test(setting_helpers_keep_defaults_and_check_ranges),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
