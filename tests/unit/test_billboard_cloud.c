/* sylva-test: cost=6 (tests/run.sh starts the longest first) */
/* test_billboard_cloud.c — the billboard_cloud method (core/methods/billboard_cloud/billboard_cloud.c):
 * settings, LOD chain, quads, scene-driven horizontal penalty, determinism,
 * and (with SYLVA_DATA) real trees. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>
#include "test_data.h"
#include "test_skip.h"

#include "classify.h"
#include "import.h"
#include "methods/billboard_cloud/billboard_cloud.h"

#define BC (&sv_method_billboard_cloud_ops)

/* ---------------------------------------------------------------- a synthetic tree */

typedef struct tree {
    sv_mesh *mesh;
    sv_classification cls;
    sv_leaves leaves;
    sv_method_input in;
    sv_scene scene;
} tree;

static double rnd(uint64_t *s)
{
    *s = *s * 6364136223846793005ULL + 1442695040888963407ULL;
    return (double)(*s >> 11) / 9007199254740992.0;
}

/* nleaves two-triangle leaves in a crown (layered when `layers`), and a
 * square trunk of 8 triangles from y = -1 to 0. */
static void tree_make(tree *t, int nleaves, uint64_t seed, bool layers)
{
    memset(t, 0, sizeof *t);
    uint32_t nv = 4 * nleaves + 8, nt = 2 * nleaves + 8;
    t->mesh = sv_mesh_create(nv, nt, 1, 0);
    assert_non_null(t->mesh);
    float *P = t->mesh->positions;
    uint32_t *I = t->mesh->indices;
    uint64_t s = seed;
    for (int l = 0; l < nleaves; l++) {
        double c[3], n[3];
        if (layers) {
            double a = 2 * M_PI * rnd(&s), r = sqrt(rnd(&s));
            c[0] = r * cos(a);
            c[2] = r * sin(a);
            c[1] = 0.3 + 0.35 * (l % 4) + 0.03 * (rnd(&s) - 0.5);
            double tilt = 40 * M_PI / 180 * rnd(&s), az = 2 * M_PI * rnd(&s);
            n[0] = sin(tilt) * cos(az);
            n[1] = cos(tilt);
            n[2] = sin(tilt) * sin(az);
        } else {
            double l2;
            do {
                for (int k = 0; k < 3; k++) c[k] = 2 * rnd(&s) - 1;
                l2 = c[0] * c[0] + c[1] * c[1] + c[2] * c[2];
            } while (l2 > 1);
            c[1] = 0.8 + 0.8 * c[1];
            do {
                for (int k = 0; k < 3; k++) n[k] = 2 * rnd(&s) - 1;
                l2 = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
            } while (l2 < 0.1 || l2 > 1);
            for (int k = 0; k < 3; k++) n[k] /= l2;
        }
        double a[3] = {0, 0, 0}, u[3], v[3];
        a[fabs(n[0]) < 0.6 ? 0 : 1] = 1;
        u[0] = n[1] * a[2] - n[2] * a[1];
        u[1] = n[2] * a[0] - n[0] * a[2];
        u[2] = n[0] * a[1] - n[1] * a[0];
        double lu = sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
        for (int k = 0; k < 3; k++) u[k] /= lu;
        v[0] = n[1] * u[2] - n[2] * u[1];
        v[1] = n[2] * u[0] - n[0] * u[2];
        v[2] = n[0] * u[1] - n[1] * u[0];
        const double xs[4] = {-1, 1, 1, -1}, ys[4] = {-0.5, -0.5, 0.5, 0.5};
        for (int k = 0; k < 4; k++)
            for (int d = 0; d < 3; d++)
                P[3 * (4 * l + k) + d] = (float)(c[d] + 0.05 * (xs[k] * u[d] + ys[k] * v[d]));
        const uint32_t tri[6] = {0, 1, 2, 0, 2, 3};
        for (int k = 0; k < 6; k++) I[6 * l + k] = 4 * l + tri[k];
    }
    /* trunk: a square tube, 4 sides × 2 triangles */
    uint32_t b = 4 * nleaves;
    const double cx[4] = {-0.05, 0.05, 0.05, -0.05}, cz[4] = {-0.05, -0.05, 0.05, 0.05};
    for (int k = 0; k < 4; k++) {
        P[3 * (b + k)] = (float)cx[k];
        P[3 * (b + k) + 1] = -1;
        P[3 * (b + k) + 2] = (float)cz[k];
        P[3 * (b + 4 + k)] = (float)cx[k];
        P[3 * (b + 4 + k) + 1] = 0.2f;
        P[3 * (b + 4 + k) + 2] = (float)cz[k];
    }
    for (int k = 0; k < 4; k++) {
        uint32_t a0 = b + k, a1 = b + (k + 1) % 4, t0 = 2 * nleaves + 2 * k;
        I[3 * t0] = a0;
        I[3 * t0 + 1] = a1;
        I[3 * t0 + 2] = a1 + 4;
        I[3 * t0 + 3] = a0;
        I[3 * t0 + 4] = a1 + 4;
        I[3 * t0 + 5] = a0 + 4;
    }
    sv_mesh_compute_normals(t->mesh);
    t->cls.tri_part = calloc(nt, 1);
    assert_non_null(t->cls.tri_part);
    for (uint32_t k = 0; k < nt; k++)
        t->cls.tri_part[k] = k < 2u * nleaves ? SV_PART_FOLIAGE : SV_PART_TRUNK;
    t->cls.foliage_triangles = 2 * nleaves;
    t->cls.trunk_triangles = 8;
    t->leaves.leaves = calloc(nleaves, sizeof *t->leaves.leaves);
    t->leaves.tris = calloc(2 * nleaves, sizeof *t->leaves.tris);
    assert_non_null(t->leaves.leaves);
    assert_non_null(t->leaves.tris);
    for (int l = 0; l < nleaves; l++) {
        t->leaves.leaves[l].first = 2 * l;
        t->leaves.leaves[l].count = 2;
        t->leaves.tris[2 * l] = 2 * l;
        t->leaves.tris[2 * l + 1] = 2 * l + 1;
    }
    t->leaves.count = nleaves;
    t->leaves.tri_count = 2 * nleaves;
    sv_scene_defaults(&t->scene);
    t->in.mesh = t->mesh;
    t->in.cls = &t->cls;
    t->in.leaves = &t->leaves;
    sv_mesh_sphere(t->mesh, t->in.centre, &t->in.radius);
    t->in.scene = &t->scene;
    t->in.seed = 1;
}

static void tree_free(tree *t)
{
    sv_mesh_destroy(t->mesh);
    free(t->cls.tri_part);
    free(t->leaves.leaves);
    free(t->leaves.tris);
}

static cJSON *json(const char *s)
{
    cJSON *j = cJSON_Parse(s);
    assert_non_null(j);
    return j;
}

/* ---------------------------------------------------------------- checks */

/* Each LOD: every triangle simplified by exactly one quad; the quad's slab
 * holds its faces; its rectangle holds their projections; parts match. */
static void check_stand_in(const sv_mesh *m, const uint8_t *part, const sv_stand_in *s)
{
    assert_string_equal(s->method, "billboard_cloud");
    uint32_t *cnt = calloc(m->triangle_count, sizeof *cnt);
    assert_non_null(cnt);
    for (uint32_t L = 0; L < s->lod_count; L++) {
        const sv_lod_plan *l = &s->lods[L];
        /* the trunk kept as the level's geometry (the default, capped) or on
         * planes ("trunk": "planes"); the pipeline adds no trunk of its own */
        assert_int_equal(l->trunk, SV_TRUNK_NONE);
        bool trunk_mesh = l->geometry != NULL;
        memset(cnt, 0, m->triangle_count * sizeof *cnt);
        for (uint32_t k = 0; k < l->quad_count; k++) {
            const sv_quad *q = &l->quads[k];
            assert_false(q->clip);
            if (L + 1 < s->lod_count) {
                assert_true(q->parent >= 0);
                assert_true((uint32_t)q->parent < s->lods[L + 1].quad_count);
            } else {
                assert_int_equal(q->parent, -1);
            }
            const uint32_t *f = q->faces ? q->faces : q->bake_faces;
            uint32_t nf = q->faces ? q->face_count : q->bake_face_count;
            /* refined planes bake exactly the faces they simplify */
            if (q->faces && q->bake_faces) {
                assert_int_equal(q->bake_face_count, q->face_count);
                assert_memory_equal(q->bake_faces, q->faces, q->face_count * sizeof *q->faces);
            }
            for (uint32_t i = 0; i < nf; i++) {
                uint32_t t = f[i];
                assert_true(t < m->triangle_count);
                if (q->faces) cnt[t]++;
                /* with a kept trunk, the branches it cannot hold are foliage elements */
                if (!trunk_mesh)
                    assert_int_equal(q->parts,
                                     part[t] == SV_PART_TRUNK ? SV_PARTS_TRUNK : SV_PARTS_FOLIAGE);
                for (int v = 0; v < 3; v++) {
                    const float *x = &m->positions[3 * m->indices[3 * t + v]];
                    double p[3] = {x[0] - q->centre[0], x[1] - q->centre[1], x[2] - q->centre[2]};
                    double dn = p[0] * q->normal[0] + p[1] * q->normal[1] + p[2] * q->normal[2];
                    double du = p[0] * q->axis_u[0] + p[1] * q->axis_u[1] + p[2] * q->axis_u[2];
                    double dv = p[0] * q->axis_v[0] + p[1] * q->axis_v[1] + p[2] * q->axis_v[2];
                    assert_true(fabs(dn) <= q->slab);
                    assert_true(fabs(du) <= q->half_u * (1 + 1e-6) + 1e-6);
                    assert_true(fabs(dv) <= q->half_v * (1 + 1e-6) + 1e-6);
                }
            }
        }
        /* every leaf on exactly one plane; a trunk triangle on one plane, or
         * on none when the kept trunk draws it */
        for (uint32_t t = 0; t < m->triangle_count; t++)
            if (trunk_mesh && part[t] == SV_PART_TRUNK) assert_true(cnt[t] <= 1);
            else assert_int_equal(cnt[t], 1);
    }
    free(cnt);
}

static uint32_t quads_of(const sv_stand_in *s, uint32_t L)
{
    return L < s->lod_count ? s->lods[L].quad_count : 0;
}

/* ---------------------------------------------------------------- settings */

static void settings_defaults_and_every_documented_key_are_accepted(void **state)
{
    (void)state;
    sv_error err = {0};
    assert_int_equal(sv_method_billboard_cloud.check(NULL, &err), SV_OK);
    cJSON *j = json(
        "{\"epsilon\": 0.05, \"max_planes\": 30, \"lods\": [30, {\"epsilon\": 0.2},"
        " {\"max_planes\": 5, \"epsilon\": 0.3}], \"grid\": [48, 24, 48],"
        " \"horizontal_penalty\": {\"enabled\": null, \"penalty\": 0.5, \"angle_deg\": 45},"
        " \"cardboard\": {\"enabled\": true, \"coverage\": 0.7}, \"tweak\": false,"
        " \"weld\": false, \"threads\": 1, \"miss_penalty\": 0, \"max_angle_deg\": 90}");
    assert_int_equal(sv_method_billboard_cloud.check(j, &err), SV_OK);
    cJSON_Delete(j);
    assert_string_equal(BC->method->name, "billboard_cloud");
}

static void settings_errors_name_the_key(void **state)
{
    (void)state;
    static const struct {
        const char *json, *key;
    } bad[] = {
        {"{\"epsilon\": \"x\"}", "billboard_cloud.epsilon"},
        {"{\"epsilon\": 0}", "billboard_cloud.epsilon"},
        {"{\"max_planes\": 1}", "billboard_cloud.max_planes"},
        {"{\"planes\": 3}", "billboard_cloud.planes"},
        {"{\"lods\": []}", "billboard_cloud.lods"},
        {"{\"lods\": [24, 1.5]}", "billboard_cloud.lods[1]"},
        {"{\"lods\": [{}]}", "billboard_cloud.lods[0]"},
        {"{\"lods\": [{\"eps\": 0.1}]}", "billboard_cloud.lods[0].eps"},
        {"{\"grid\": [63, 32, 64]}", "billboard_cloud.grid[0]"},
        {"{\"grid\": [64, 32]}", "billboard_cloud.grid"},
        {"{\"horizontal_penalty\": {\"enabled\": 1}}",
         "billboard_cloud.horizontal_penalty.enabled"},
        {"{\"horizontal_penalty\": {\"penalty\": 1.5}}",
         "billboard_cloud.horizontal_penalty.penalty"},
        {"{\"cardboard\": {\"coverage\": -1}}", "billboard_cloud.cardboard.coverage"},
        {"{\"threads\": 0}", "billboard_cloud.threads"},
        {"{\"tweak\": \"yes\"}", "billboard_cloud.tweak"},
        {"{\"refine\": -1}", "billboard_cloud.refine"},
        {"{\"trunk\": \"cards\"}", "billboard_cloud.trunk"},
        {"{\"trunk_max_triangles\": 0}", "billboard_cloud.trunk_max_triangles"},
        {"{\"trunk_max_triangles\": [200, 0]}", "billboard_cloud.trunk_max_triangles[1]"},
        {"[1]", "billboard_cloud"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        cJSON *j = json(bad[i].json);
        sv_error err = {0};
        assert_int_equal(sv_method_billboard_cloud.check(j, &err), SV_ERR_SPEC);
        if (!strstr(err.message, bad[i].key))
            fail_msg("%s: message '%s' lacks '%s'", bad[i].json, err.message, bad[i].key);
        cJSON_Delete(j);
    }
}

/* ---------------------------------------------------------------- runs */

static void default_run_gives_three_nested_lods_within_their_plane_limits(void **state)
{
    (void)state;
    tree t;
    tree_make(&t, 800, 3, false);
    sv_stand_in s;
    sv_error err = {0};
    assert_int_equal(BC->run(&t.in, NULL, &s, &err), SV_OK);
    assert_int_equal(s.lod_count, 3);
    assert_string_equal(s.lods[0].name, "lod0");
    assert_string_equal(s.lods[2].name, "lod2");
    assert_true(quads_of(&s, 0) <= 24);
    assert_true(quads_of(&s, 1) <= 12);
    assert_true(quads_of(&s, 2) <= 6);
    assert_true(quads_of(&s, 2) < quads_of(&s, 0));
    check_stand_in(t.mesh, t.cls.tri_part, &s);
    sv_stand_in_free(&s);
    sv_stand_in_free(&s); /* idempotent */
    tree_free(&t);
}

static void lods_given_as_epsilons_grow_coarser(void **state)
{
    (void)state;
    tree t;
    tree_make(&t, 600, 5, false);
    cJSON *j = json("{\"lods\": [{\"epsilon\": 0.05}, {\"epsilon\": 0.12}, {\"epsilon\": 0.3}]}");
    sv_stand_in s;
    assert_int_equal(BC->run(&t.in, j, &s, NULL), SV_OK);
    assert_int_equal(s.lod_count, 3);
    assert_true(quads_of(&s, 0) > quads_of(&s, 1));
    assert_true(quads_of(&s, 1) > quads_of(&s, 2));
    /* slabs grow with ε */
    assert_true(s.lods[2].quads[0].slab > s.lods[0].quads[0].slab);
    check_stand_in(t.mesh, t.cls.tri_part, &s);
    sv_stand_in_free(&s);
    cJSON_Delete(j);
    tree_free(&t);
}

static double horizontal_share(const sv_lod_plan *l)
{
    uint32_t h = 0;
    for (uint32_t k = 0; k < l->quad_count; k++)
        h += fabs(l->quads[k].normal[1]) > cos(30 * M_PI / 180);
    return l->quad_count ? (double)h / l->quad_count : 0;
}

static void ground_viewer_turns_the_horizontal_penalty_on(void **state)
{
    (void)state;
    tree t;
    tree_make(&t, 1200, 9, true);
    cJSON *j = json("{\"epsilon\": 0.06, \"lods\": [{\"epsilon\": 0.06}]}");
    sv_stand_in orbit, ground, forced_off;
    assert_int_equal(BC->run(&t.in, j, &orbit, NULL), SV_OK);
    t.scene.viewer = SV_VIEWER_GROUND;
    assert_int_equal(BC->run(&t.in, j, &ground, NULL), SV_OK);
    cJSON_Delete(j);
    j = json("{\"lods\": [{\"epsilon\": 0.06}], \"horizontal_penalty\": {\"enabled\": false}}");
    assert_int_equal(BC->run(&t.in, j, &forced_off, NULL), SV_OK);
    double so = horizontal_share(&orbit.lods[0]), sg = horizontal_share(&ground.lods[0]);
    print_message("near-horizontal share: orbit %.2f, ground %.2f\n", so, sg);
    assert_true(sg < so);
    assert_true(fabs(horizontal_share(&forced_off.lods[0]) - so) < 1e-12);
    check_stand_in(t.mesh, t.cls.tri_part, &ground);
    sv_stand_in_free(&orbit);
    sv_stand_in_free(&ground);
    sv_stand_in_free(&forced_off);
    cJSON_Delete(j);
    tree_free(&t);
}

static bool same_stand_in(const sv_stand_in *a, const sv_stand_in *b)
{
    if (a->lod_count != b->lod_count) return false;
    for (uint32_t L = 0; L < a->lod_count; L++) {
        const sv_lod_plan *x = &a->lods[L], *y = &b->lods[L];
        if (x->quad_count != y->quad_count) return false;
        for (uint32_t k = 0; k < x->quad_count; k++) {
            const sv_quad *p = &x->quads[k], *q = &y->quads[k];
            if (memcmp(p->normal, q->normal, sizeof p->normal) ||
                memcmp(&p->d, &q->d, sizeof p->d) ||
                memcmp(p->centre, q->centre, sizeof p->centre) ||
                memcmp(p->axis_u, q->axis_u, sizeof p->axis_u) ||
                memcmp(&p->half_u, &q->half_u, sizeof p->half_u) ||
                memcmp(&p->half_v, &q->half_v, sizeof p->half_v) ||
                memcmp(&p->slab, &q->slab, sizeof p->slab) || p->face_count != q->face_count ||
                p->parent != q->parent || p->group != q->group)
                return false;
            if (p->face_count && memcmp(p->faces, q->faces, p->face_count * sizeof *p->faces))
                return false;
        }
    }
    return true;
}

static void runs_are_byte_identical_with_one_or_two_threads(void **state)
{
    (void)state;
    tree t;
    tree_make(&t, 900, 21, false);
    cJSON *j1 = json("{\"threads\": 1, \"cardboard\": {\"enabled\": true, \"coverage\": 0.1}}");
    cJSON *j2 = json("{\"threads\": 2, \"cardboard\": {\"enabled\": true, \"coverage\": 0.1}}");
    sv_stand_in a, b, c;
    assert_int_equal(BC->run(&t.in, j1, &a, NULL), SV_OK);
    assert_int_equal(BC->run(&t.in, j2, &b, NULL), SV_OK);
    assert_int_equal(BC->run(&t.in, j2, &c, NULL), SV_OK);
    assert_true(same_stand_in(&a, &b));
    assert_true(same_stand_in(&b, &c));
    sv_stand_in_free(&a);
    sv_stand_in_free(&b);
    sv_stand_in_free(&c);
    cJSON_Delete(j1);
    cJSON_Delete(j2);
    tree_free(&t);
}

static void cardboard_planes_show_faces_but_simplify_none(void **state)
{
    (void)state;
    tree t;
    tree_make(&t, 300, 4, false);
    cJSON *j = json("{\"lods\": [{\"epsilon\": 0.1}], \"max_angle_deg\": 90, \"trunk\": \"planes\","
                    " \"cardboard\": {\"enabled\": true, \"coverage\": 0.5}}");
    sv_stand_in s;
    assert_int_equal(BC->run(&t.in, j, &s, NULL), SV_OK);
    uint32_t cards = 0;
    for (uint32_t k = 0; k < s.lods[0].quad_count; k++) {
        const sv_quad *q = &s.lods[0].quads[k];
        if (q->group < 0) continue;
        cards++;
        assert_int_equal(q->face_count, 0);
        assert_true(q->bake_face_count > 0);
        const sv_quad *p = &s.lods[0].quads[q->group];
        assert_true(p->group < 0);
        assert_true(fabs(p->normal[0] * q->normal[0] + p->normal[1] * q->normal[1] +
                         p->normal[2] * q->normal[2]) < 1e-9);
    }
    assert_true(cards >= 1); /* at least the trunk's */
    check_stand_in(t.mesh, t.cls.tri_part, &s);
    sv_stand_in_free(&s);
    cJSON_Delete(j);
    tree_free(&t);
}

/* Area-weighted mean squared distance of the foliage vertices from the plane
 * of the quad that simplifies them (what a viewer sees as leaves off their place). */
static double flattening_error(const sv_mesh *m, const sv_lod_plan *l)
{
    double sum = 0, w = 0;
    for (uint32_t k = 0; k < l->quad_count; k++) {
        const sv_quad *q = &l->quads[k];
        if (q->parts != SV_PARTS_FOLIAGE) continue;
        for (uint32_t i = 0; i < q->face_count; i++) {
            uint32_t t = q->faces[i];
            double a = sv_tri_area(m, t);
            for (int v = 0; v < 3; v++) {
                const float *x = &m->positions[3 * m->indices[3 * t + v]];
                double d = x[0] * q->normal[0] + x[1] * q->normal[1] + x[2] * q->normal[2] + q->d;
                sum += a * d * d;
                w += a;
            }
        }
    }
    return w > 0 ? sum / w : 0;
}

/* k-planes refinement (kplanes.c): at the same plane budget the leaves
 * end up nearer their planes than with the greedy selection alone, each leaf
 * is baked by its own plane only, and the trunk is kept as capped geometry. */
static void refinement_brings_leaves_nearer_their_planes(void **state)
{
    (void)state;
    tree t;
    tree_make(&t, 400, 9, false);
    cJSON *plain = json("{\"lods\": [8], \"refine\": 0}");
    cJSON *refined = json("{\"lods\": [8], \"trunk_max_triangles\": 3}");
    sv_stand_in a, b;
    assert_int_equal(BC->run(&t.in, plain, &a, NULL), SV_OK);
    assert_int_equal(BC->run(&t.in, refined, &b, NULL), SV_OK);
    check_stand_in(t.mesh, t.cls.tri_part, &a);
    check_stand_in(t.mesh, t.cls.tri_part, &b);
    double ea = flattening_error(t.mesh, &a.lods[0]), eb = flattening_error(t.mesh, &b.lods[0]);
    assert_true(ea > 0);
    assert_true(eb < 0.8 * ea);
    assert_true(b.lods[0].quad_count <= 8);
    assert_non_null(b.lods[0].geometry); /* the trunk, capped */
    assert_true(b.lods[0].geometry->triangle_count <= 3);
    for (uint32_t k = 0; k < b.lods[0].quad_count; k++) {
        const sv_quad *q = &b.lods[0].quads[k];
        assert_non_null(q->bake_faces); /* assigned faces only */
        for (uint32_t k2 = 0; k2 < a.lods[0].quad_count; k2++)
            assert_null(a.lods[0].quads[k2].bake_faces);
    }
    /* deterministic */
    sv_stand_in c;
    assert_int_equal(BC->run(&t.in, refined, &c, NULL), SV_OK);
    assert_int_equal(c.lods[0].quad_count, b.lods[0].quad_count);
    for (uint32_t k = 0; k < c.lods[0].quad_count; k++) {
        assert_memory_equal(c.lods[0].quads[k].normal, b.lods[0].quads[k].normal,
                            sizeof(double) * 3);
        assert_int_equal(c.lods[0].quads[k].face_count, b.lods[0].quads[k].face_count);
    }
    sv_stand_in_free(&a);
    sv_stand_in_free(&b);
    sv_stand_in_free(&c);
    cJSON_Delete(plain);
    cJSON_Delete(refined);
    tree_free(&t);
}

static void mesh_without_leaves_or_classification_still_runs(void **state)
{
    (void)state;
    tree t;
    tree_make(&t, 200, 8, false);
    t.in.leaves = NULL;
    t.in.cls = NULL;
    sv_stand_in s;
    assert_int_equal(BC->run(&t.in, NULL, &s, NULL), SV_OK);
    uint8_t *all = calloc(t.mesh->triangle_count, 1);
    assert_non_null(all);
    memset(all, SV_PART_FOLIAGE, t.mesh->triangle_count);
    check_stand_in(t.mesh, all, &s);
    free(all);
    sv_stand_in_free(&s);
    t.in.radius = 0;
    sv_error err = {0};
    assert_int_equal(BC->run(&t.in, NULL, &s, &err), SV_ERR_UNBAKEABLE);
    assert_non_null(strstr(err.message, "radius"));
    tree_free(&t);
}

/* ---------------------------------------------------------------- real trees */

static void run_real_tree(const char *rel, double unit_scale)
{
    const char *dir = sv_test_data("a real-tree billboard cloud");
    char path[1024];
    snprintf(path, sizeof path, "%s/%s", dir, rel);
    size_t n = 0;
    uint8_t *data = sv_test_read_all(path, &n);
    if (!data) fail_msg("cannot read %s", path);
    const char *base = strrchr(rel, '/') ? strrchr(rel, '/') + 1 : rel;
    sv_file f = {base, data, n};
    sv_import_options io = {0};
    io.unit_scale = unit_scale;
    sv_mesh *m = NULL;
    sv_error err = {0};
    assert_int_equal(sv_import(&f, 1, &io, &m, NULL, &err), SV_OK);
    sv_classification cls;
    sv_leaves lv;
    assert_int_equal(sv_classify(m, NULL, &cls, &err), SV_OK);
    assert_int_equal(sv_leaves_build(m, &cls, &lv, &err), SV_OK);
    sv_scene sc;
    sv_scene_defaults(&sc);
    sv_method_input in;
    memset(&in, 0, sizeof in);
    in.mesh = m;
    in.cls = &cls;
    in.leaves = &lv;
    in.scene = &sc;
    in.seed = 1;
    sv_mesh_sphere(m, in.centre, &in.radius);
    sv_stand_in s;
    double t0 = sv_now();
    assert_int_equal(BC->run(&in, NULL, &s, &err), SV_OK);
    double t1 = sv_now();
    print_message("%s: %u triangles, %u leaves: LOD quads %u/%u/%u in %.3f s\n", rel,
                  m->triangle_count, lv.count, quads_of(&s, 0), quads_of(&s, 1), quads_of(&s, 2),
                  t1 - t0);
    assert_int_equal(s.lod_count, 3);
    assert_true(quads_of(&s, 0) >= 2 && quads_of(&s, 0) <= 24);
    assert_true(quads_of(&s, 1) <= 12);
    assert_true(quads_of(&s, 2) <= 6);
    check_stand_in(m, cls.tri_part, &s);
    sv_stand_in_free(&s);
    sv_leaves_free(&lv);
    sv_classification_free(&cls);
    sv_mesh_destroy(m);
    free(data);
}

static void real_oak_bakes_within_the_plane_limits(void **state)
{
    (void)state;
    run_real_tree("eztree_oak_large/oak_large.glb", 1.0);
}

/* Not in the sanitizer build (not registered there, see main): the 119k
 * triangles take minutes under ASan and the oak covers the same paths. */
#if !defined(__SANITIZE_ADDRESS__)
static void real_ficus_bakes_within_the_plane_limits(void **state)
{
    (void)state;
    run_real_tree("scopia_ficusTree/ficusTree.glb", 0.01);
}
#endif

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(settings_defaults_and_every_documented_key_are_accepted),
        cmocka_unit_test(settings_errors_name_the_key),
        cmocka_unit_test(default_run_gives_three_nested_lods_within_their_plane_limits),
        cmocka_unit_test(lods_given_as_epsilons_grow_coarser),
        cmocka_unit_test(ground_viewer_turns_the_horizontal_penalty_on),
        cmocka_unit_test(runs_are_byte_identical_with_one_or_two_threads),
        cmocka_unit_test(cardboard_planes_show_faces_but_simplify_none),
        cmocka_unit_test(refinement_brings_leaves_nearer_their_planes),
        cmocka_unit_test(mesh_without_leaves_or_classification_still_runs),
        cmocka_unit_test(real_oak_bakes_within_the_plane_limits),
#if !defined(__SANITIZE_ADDRESS__)
        cmocka_unit_test(real_ficus_bakes_within_the_plane_limits),
#endif
    };
    return sv_test_exit(cmocka_run_group_tests(tests, NULL, NULL));
}
