/* test_leaf_clusters.c — the leaf_clusters method (core/methods/leaf_clusters/leaf_clusters.c):
 * settings, the stand-in it builds on a hand-made tree, and a real tree
 * (ficus, or the aspen under SYLVA_TREES=small, through sv_import +
 * sv_classify + sv_leaves_build) when SYLVA_DATA is set. */
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

#include "cluster.h"
#include "import.h"
#include "methods/billboard_cloud/billboard_cloud.h"
#include "methods/leaf_clusters/leaf_clusters.h"

extern const sv_method sv_method_leaf_clusters;

/* ---- a hand-made tree: square leaves (2 triangles) + a trunk ---- */

typedef struct toy {
    sv_mesh *mesh;
    sv_classification cls;
    sv_leaves leaves;
    sv_method_input in;
    sv_scene scene;
} toy;

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

static double dot(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static void normalize(double v[3])
{
    double l = sqrt(dot(v, v));
    for (int j = 0; j < 3; j++) v[j] /= l;
}

/* nleaves leaves of side 0.1 in a crown around (0, 2, 0), each on one of four
 * tilted layers, plus 4 trunk triangles; leaf i uses triangles 2i, 2i+1. */
static void toy_make(toy *t, uint32_t nleaves, uint64_t seed)
{
    memset(t, 0, sizeof *t);
    uint32_t ntri = 2 * nleaves + 4, nvert = 4 * nleaves + 6;
    t->mesh = sv_mesh_create(nvert, ntri, 2, 0);
    assert_non_null(t->mesh);
    t->cls.tri_part = calloc(ntri, 1);
    t->leaves.leaves = calloc(nleaves, sizeof(sv_leaf));
    t->leaves.tris = calloc(2 * nleaves, sizeof(uint32_t));
    t->leaves.count = nleaves;
    t->leaves.tri_count = 2 * nleaves;
    uint64_t s = seed;
    float *P = t->mesh->positions;
    uint32_t *I = t->mesh->indices;
    for (uint32_t i = 0; i < nleaves; i++) {
        int layer = (int)(i % 4);
        double n[3] = {0.3 * (layer - 1.5), 1, 0.2 * (layer % 2)}, u[3], v[3];
        normalize(n);
        double a[3] = {1, 0, 0};
        u[0] = n[1] * a[2] - n[2] * a[1], u[1] = n[2] * a[0] - n[0] * a[2],
        u[2] = n[0] * a[1] - n[1] * a[0];
        normalize(u);
        v[0] = n[1] * u[2] - n[2] * u[1], v[1] = n[2] * u[0] - n[0] * u[2],
        v[2] = n[0] * u[1] - n[1] * u[0];
        /* the leaf lies in its layer's plane (through (0, 1.5 + 0.6·layer, 0),
         * normal n), within ±0.01 */
        double a0 = 0.8 * urand(&s), b0 = 0.8 * urand(&s), off = 0.01 * urand(&s), c[3];
        for (int j = 0; j < 3; j++) c[j] = a0 * u[j] + b0 * v[j] + off * n[j];
        c[1] += 1.5 + 0.6 * layer;
        const double cu[4] = {-0.05, 0.05, 0.05, -0.05}, cv[4] = {-0.05, -0.05, 0.05, 0.05};
        for (int k = 0; k < 4; k++)
            for (int j = 0; j < 3; j++)
                P[3 * (4 * i + k) + j] = (float)(c[j] + cu[k] * u[j] + cv[k] * v[j]);
        uint32_t b = 4 * i;
        uint32_t q[6] = {b, b + 1, b + 2, b, b + 2, b + 3};
        memcpy(&I[6 * i], q, sizeof q);
        t->cls.tri_part[2 * i] = t->cls.tri_part[2 * i + 1] = SV_PART_FOLIAGE;
        t->mesh->tri_material[2 * i] = t->mesh->tri_material[2 * i + 1] = 0;
        sv_leaf *l = &t->leaves.leaves[i];
        /* centre and normal from the float vertices, as classify would */
        for (int j = 0; j < 3; j++) {
            l->centre[j] = 0;
            for (int k = 0; k < 4; k++) l->centre[j] += 0.25 * P[3 * (4 * i + k) + j];
            l->normal[j] = n[j];
        }
        l->area = 0.01;
        l->radius = 0.0708;
        l->first = 2 * i;
        l->count = 2;
        t->leaves.tris[2 * i] = 2 * i;
        t->leaves.tris[2 * i + 1] = 2 * i + 1;
    }
    /* trunk: a thin vertical fin from y=0 to y=1.5 */
    uint32_t b = 4 * nleaves;
    const float tv[6][3] = {{-0.05f, 0, 0},    {0.05f, 0, 0},  {0.05f, 1.5f, 0},
                            {-0.05f, 1.5f, 0}, {0, 0, -0.05f}, {0, 1.5f, 0.05f}};
    for (int k = 0; k < 6; k++)
        for (int j = 0; j < 3; j++) P[3 * (b + k) + j] = tv[k][j];
    uint32_t tt[12] = {b, b + 1, b + 2, b, b + 2, b + 3, b + 4, b + 1, b + 5, b + 4, b + 5, b + 3};
    memcpy(&I[6 * nleaves], tt, sizeof tt);
    for (int k = 0; k < 4; k++) t->mesh->tri_material[2 * nleaves + k] = 1;
    sv_mesh_sphere(t->mesh, t->in.centre, &t->in.radius);
    sv_scene_defaults(&t->scene);
    t->in.mesh = t->mesh;
    t->in.cls = &t->cls;
    t->in.leaves = &t->leaves;
    t->in.scene = &t->scene;
    t->in.seed = 1;
}

static void toy_free(toy *t)
{
    sv_mesh_destroy(t->mesh);
    free(t->cls.tri_part);
    free(t->leaves.leaves);
    free(t->leaves.tris);
}

static cJSON *json(const char *text)
{
    cJSON *j = cJSON_Parse(text);
    assert_non_null(j);
    return j;
}

/* Every structural promise of the stand-in, checked on any tree. */
static void assert_stand_in_sound(const sv_stand_in *s, const sv_method_input *in,
                                  const uint32_t *levels, uint32_t nlev)
{
    const sv_mesh *m = in->mesh;
    const sv_leaves *lv = in->leaves;
    assert_string_equal(s->method, "leaf_clusters");
    assert_int_equal(s->lod_count, nlev);
    uint8_t *seen = calloc(m->triangle_count, 1);
    for (uint32_t l = 0; l < nlev; l++) {
        const sv_lod_plan *lod = &s->lods[l];
        char name[32];
        snprintf(name, sizeof name, "clusters%u", levels[l]);
        assert_string_equal(lod->name, name);
        /* the trunk is the level's own geometry, capped (default 200) */
        assert_int_equal(lod->trunk, SV_TRUNK_NONE);
        if (lod->geometry) assert_true(lod->geometry->triangle_count <= 200);
        assert_true(lod->quad_count >= 1 && lod->quad_count <= levels[l]);
        memset(seen, 0, m->triangle_count);
        uint32_t covered = 0;
        for (uint32_t k = 0; k < lod->quad_count; k++) {
            const sv_quad *q = &lod->quads[k];
            assert_true(fabs(dot(q->normal, q->normal) - 1) < 1e-12);
            assert_true(isfinite(q->d) && isfinite(q->half_u) && isfinite(q->half_v) &&
                        isfinite(q->slab));
            /* the tree centre is behind the plane: normal points outward */
            assert_true(dot(q->normal, in->centre) + q->d <= 1e-9 * in->radius);
            assert_int_equal(q->parts, SV_PARTS_FOLIAGE);
            assert_false(q->clip);
            assert_int_equal(q->group, (int32_t)l);
            if (l + 1 < nlev)
                assert_true(q->parent >= 0 && (uint32_t)q->parent < s->lods[l + 1].quad_count);
            else assert_int_equal(q->parent, -1);
            assert_int_equal(q->face_count, q->bake_face_count);
            assert_memory_equal(q->faces, q->bake_faces, q->face_count * sizeof(uint32_t));
            double slab = 0, area = 0;
            for (uint32_t f = 0; f < q->face_count; f++) {
                uint32_t t = q->faces[f];
                assert_true(t < m->triangle_count);
                assert_int_equal(seen[t], 0);
                seen[t] = 1;
                covered++;
                area += sv_tri_area(m, t);
                for (int v = 0; v < 3; v++) {
                    const float *p = &m->positions[3 * (size_t)m->indices[3 * (size_t)t + v]];
                    double x[3] = {p[0], p[1], p[2]}, r[3];
                    double dist = dot(q->normal, x) + q->d;
                    if (fabs(dist) > slab) slab = fabs(dist);
                    for (int j = 0; j < 3; j++) r[j] = x[j] - q->centre[j];
                    assert_true(fabs(dot(r, q->axis_u)) <=
                                q->half_u * (1 + 1e-9) + 1e-9 * in->radius);
                    assert_true(fabs(dot(r, q->axis_v)) <=
                                q->half_v * (1 + 1e-9) + 1e-9 * in->radius);
                }
            }
            assert_true(fabs(slab - q->slab) <= 1e-12 * in->radius);
            assert_true(fabs(area - q->face_area) <= 1e-9 * area);
            /* a coarse quad holds exactly the faces of its children */
            if (l > 0) {
                uint32_t child = 0;
                for (uint32_t c = 0; c < s->lods[l - 1].quad_count; c++)
                    if (s->lods[l - 1].quads[c].parent == (int32_t)k)
                        child += s->lods[l - 1].quads[c].face_count;
                assert_int_equal(child, q->face_count);
            }
        }
        /* every leaf triangle appears exactly once per level; anything else
         * on a quad is a trunk triangle the kept trunk does not draw */
        assert_true(covered >= lv->tri_count);
        for (uint32_t i = 0; i < lv->tri_count; i++) assert_int_equal(seen[lv->tris[i]], 1);
        uint32_t others = 0;
        for (uint32_t t = 0; t < m->triangle_count; t++) {
            bool leaf = false;
            for (uint32_t i = 0; i < lv->tri_count && !leaf; i++) leaf = lv->tris[i] == t;
            if (seen[t] && !leaf) {
                assert_int_equal(in->cls->tri_part[t], SV_PART_TRUNK);
                others++;
            }
        }
        assert_int_equal(covered, lv->tri_count + others);
    }
    free(seen);
}

/* ---- behaviours ---- */

static void default_settings_are_accepted(void **state)
{
    (void)state;
    assert_int_equal(sv_method_leaf_clusters.check(NULL, NULL), SV_OK);
    cJSON *j = json("{\"clusters\":[64,16,4,1],\"alpha_rel\":0.05,\"area_weighted\":false,"
                    "\"iterations\":10,\"seed_tries\":1,\"trunk_ratio\":[1,0.5,0.2,0.1]}");
    assert_int_equal(sv_method_leaf_clusters.check(j, NULL), SV_OK);
    cJSON_Delete(j);
    j = json("{\"clusters\":16}"); /* one integer: one level (sylva --set clusters=16) */
    assert_int_equal(sv_method_leaf_clusters.check(j, NULL), SV_OK);
    cJSON_Delete(j);
    assert_string_equal(sv_method_leaf_clusters.name, "leaf_clusters");
    assert_ptr_equal(sv_method_find("leaf_clusters"), &sv_method_leaf_clusters);
}

static void bad_settings_fail_naming_the_key(void **state)
{
    (void)state;
    const char *cases[][2] = {
        {"{\"clusterz\":[8]}", "leaf_clusters.clusterz"},
        {"{\"clusters\":[8,8]}", "leaf_clusters.clusters[1]"},
        {"{\"clusters\":[8,16]}", "leaf_clusters.clusters[1]"},
        {"{\"clusters\":[]}", "leaf_clusters.clusters"},
        {"{\"clusters\":\"32\"}", "leaf_clusters.clusters"},
        {"{\"clusters\":0}", "leaf_clusters.clusters[0]"},
        {"{\"clusters\":[0]}", "leaf_clusters.clusters[0]"},
        {"{\"clusters\":[2.5]}", "leaf_clusters.clusters[0]"},
        {"{\"clusters\":[5000]}", "leaf_clusters.clusters[0]"},
        {"{\"alpha_rel\":-0.1}", "leaf_clusters.alpha_rel"},
        {"{\"alpha_rel\":\"big\"}", "leaf_clusters.alpha_rel"},
        {"{\"area_weighted\":1}", "leaf_clusters.area_weighted"},
        {"{\"iterations\":0}", "leaf_clusters.iterations"},
        {"{\"seed_tries\":100}", "leaf_clusters.seed_tries"},
        {"{\"trunk_ratio\":[0.5,0.2]}", "leaf_clusters.trunk_ratio"},
        {"{\"trunk_ratio\":[0.5,0,0.1]}", "leaf_clusters.trunk_ratio[1]"},
        {"[1]", "leaf_clusters"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        cJSON *j = json(cases[i][0]);
        sv_error e = {0};
        assert_int_equal(sv_method_leaf_clusters.check(j, &e), SV_ERR_SPEC);
        if (!strstr(e.message, cases[i][1])) print_error("%s -> %s\n", cases[i][0], e.message);
        assert_non_null(strstr(e.message, cases[i][1]));
        cJSON_Delete(j);
    }
}

/* "twigs" (default true): trunk triangles the capped trunk does not draw go
 * onto the quads (each exactly once, checked by assert_stand_in_sound); with
 * "twigs": false they are only in the kept geometry. */
static void twigs_the_trunk_cap_drops_go_onto_the_quads(void **state)
{
    (void)state;
    toy t;
    toy_make(&t, 200, 5);
    const uint32_t levels[] = {8};
    uint32_t on_quads[2] = {0, 0};
    for (int k = 0; k < 2; k++) {
        cJSON *j = json(k ? "{\"clusters\":[8],\"trunk_max_triangles\":1}"
                          : "{\"clusters\":[8],\"twigs\":false,\"trunk_max_triangles\":1}");
        sv_stand_in s = {0};
        sv_error e = {0};
        assert_int_equal(sv_method_leaf_clusters_ops.run(&t.in, j, &s, &e), SV_OK);
        assert_stand_in_sound(&s, &t.in, levels, 1);
        for (uint32_t q = 0; q < s.lods[0].quad_count; q++)
            for (uint32_t f = 0; f < s.lods[0].quads[q].face_count; f++)
                on_quads[k] += t.cls.tri_part[s.lods[0].quads[q].faces[f]] == SV_PART_TRUNK;
        sv_stand_in_free(&s);
        cJSON_Delete(j);
    }
    assert_int_equal(on_quads[0], 0);
    assert_true(on_quads[1] > 0);
    toy_free(&t);
}

static void toy_tree_gives_one_lod_per_level_with_sound_quads(void **state)
{
    (void)state;
    toy t;
    toy_make(&t, 200, 3);
    sv_stand_in s = {0};
    sv_error e = {0};
    assert_int_equal(sv_method_leaf_clusters_ops.run(&t.in, NULL, &s, &e), SV_OK);
    const uint32_t levels[] = {32, 16, 8};
    assert_stand_in_sound(&s, &t.in, levels, 3);
    assert_int_equal(s.lods[0].quad_count, 32);
    assert_true(s.lods[0].trunk_ratio == 0.5 && s.lods[1].trunk_ratio == 0.25 &&
                s.lods[2].trunk_ratio == 0.1);
    sv_stand_in_free(&s);

    cJSON *j = json("{\"clusters\":[4,2,1],\"trunk_ratio\":[0.9,0.6,0.3]}");
    assert_int_equal(sv_method_leaf_clusters_ops.run(&t.in, j, &s, &e), SV_OK);
    const uint32_t small[] = {4, 2, 1};
    assert_stand_in_sound(&s, &t.in, small, 3);
    assert_true(s.lods[2].trunk_ratio == 0.3);
    /* four leaf layers, four clusters: each layer is one quad */
    for (uint32_t k = 0; k < s.lods[0].quad_count; k++) {
        const sv_quad *q = &s.lods[0].quads[k];
        uint32_t layer = (q->faces[0] / 2) % 4;
        for (uint32_t f = 0; f < q->face_count; f++) assert_int_equal((q->faces[f] / 2) % 4, layer);
    }
    cJSON_Delete(j);
    sv_stand_in_free(&s);
    toy_free(&t);
}

static void quads_are_planes_of_their_leaves(void **state)
{
    (void)state;
    /* with 4 layers and 4 clusters, each quad's plane is its layer's plane:
     * slabs are small against the tree (leaves only: no twigs on the quads) */
    toy t;
    toy_make(&t, 120, 9);
    cJSON *j = json("{\"clusters\":[4],\"twigs\":false}");
    sv_stand_in s = {0};
    assert_int_equal(sv_method_leaf_clusters_ops.run(&t.in, j, &s, NULL), SV_OK);
    assert_int_equal(s.lods[0].quad_count, 4);
    for (uint32_t k = 0; k < 4; k++) assert_true(s.lods[0].quads[k].slab < 0.03);
    cJSON_Delete(j);
    sv_stand_in_free(&s);
    toy_free(&t);
}

static void same_seed_gives_identical_stand_in_and_seed_matters(void **state)
{
    (void)state;
    toy t;
    toy_make(&t, 300, 5);
    sv_stand_in a = {0}, b = {0}, c = {0};
    assert_int_equal(sv_method_leaf_clusters_ops.run(&t.in, NULL, &a, NULL), SV_OK);
    assert_int_equal(sv_method_leaf_clusters_ops.run(&t.in, NULL, &b, NULL), SV_OK);
    for (uint32_t l = 0; l < a.lod_count; l++) {
        assert_int_equal(a.lods[l].quad_count, b.lods[l].quad_count);
        for (uint32_t k = 0; k < a.lods[l].quad_count; k++) {
            sv_quad qa = a.lods[l].quads[k], qb = b.lods[l].quads[k];
            assert_int_equal(qa.face_count, qb.face_count);
            assert_memory_equal(qa.faces, qb.faces, qa.face_count * sizeof(uint32_t));
            qa.faces = qb.faces = qa.bake_faces = qb.bake_faces = NULL;
            assert_memory_equal(&qa, &qb, sizeof qa);
        }
    }
    t.in.seed = 2;
    assert_int_equal(sv_method_leaf_clusters_ops.run(&t.in, NULL, &c, NULL), SV_OK);
    bool differs = false;
    for (uint32_t k = 0; k < a.lods[0].quad_count && !differs; k++)
        differs = memcmp(a.lods[0].quads[k].normal, c.lods[0].quads[k].normal, sizeof(double[3])) !=
                  0;
    assert_true(differs);
    sv_stand_in_free(&a);
    sv_stand_in_free(&b);
    sv_stand_in_free(&c);
    toy_free(&t);
}

static void tree_without_leaves_is_unbakeable(void **state)
{
    (void)state;
    toy t;
    toy_make(&t, 10, 1);
    t.leaves.count = 0;
    sv_stand_in s = {0};
    sv_error e = {0};
    assert_int_equal(sv_method_leaf_clusters_ops.run(&t.in, NULL, &s, &e), SV_ERR_UNBAKEABLE);
    assert_non_null(strstr(e.message, "leaf"));
    assert_int_equal(s.lod_count, 0);
    t.in.leaves = NULL;
    assert_int_equal(sv_method_leaf_clusters_ops.run(&t.in, NULL, &s, &e), SV_ERR_UNBAKEABLE);
    t.leaves.count = 10;
    toy_free(&t);
}

static void bad_settings_make_run_fail_too(void **state)
{
    (void)state;
    toy t;
    toy_make(&t, 10, 1);
    cJSON *j = json("{\"alpha_rel\":1000}");
    sv_stand_in s = {0};
    sv_error e = {0};
    assert_int_equal(sv_method_leaf_clusters_ops.run(&t.in, j, &s, &e), SV_ERR_SPEC);
    assert_int_equal(s.lod_count, 0);
    cJSON_Delete(j);
    toy_free(&t);
}

/* ---- a real tree ---- */

/* The ficus (119k triangles); under SYLVA_TREES=small (the sanitizer pass,
 * where the ficus cost 60 s) the aspen: the same path on a small real tree. */
static void real_tree_clusters_into_32_16_8_quads(void **state)
{
    (void)state;
    const char *data = sv_test_data("the real-tree clustering");
    const char *set = getenv("SYLVA_TREES");
    bool small = set && strcmp(set, "small") == 0;
    const char *obj = small ? "eztree_aspen_small/aspen_small.obj"
                            : "scopia_ficusTree/ficusTree.obj";
    const char *mtl = small ? "eztree_aspen_small/aspen_small.mtl"
                            : "scopia_ficusTree/ficusTree.mtl";
    size_t n_obj = 0, n_mtl = 0;
    uint8_t *b_obj = sv_test_read_data(data, obj, &n_obj);
    uint8_t *b_mtl = sv_test_read_data(data, mtl, &n_mtl);
    if (!b_obj) {
        free(b_mtl);
        fail_msg("cannot read %s under %s", obj, data);
    }
    sv_file files[2] = {{strrchr(obj, '/') + 1, b_obj, n_obj},
                        {strrchr(mtl, '/') + 1, b_mtl, n_mtl}};
    /* the .mtl names the materials (classification); its texture is not needed
     * for clustering and is left out, which import.missing_files "warn" allows */
    sv_import_options io = {.unit_scale = small ? 1.0 : 0.01, .missing_files_warn = true};
    sv_mesh *m = NULL;
    sv_error e = {0};
    sv_status st = sv_import(files, b_mtl ? 2 : 1, &io, &m, NULL, &e);
    if (st != SV_OK) print_error("import: %s\n", e.message);
    assert_int_equal(st, SV_OK);
    sv_classification cls;
    assert_int_equal(sv_classify(m, NULL, &cls, &e), SV_OK);
    sv_leaves lv;
    assert_int_equal(sv_leaves_build(m, &cls, &lv, &e), SV_OK);
    print_message("%s: %u leaf elements (%u split)\n", obj, lv.count, lv.split);
    assert_true(lv.count >= (small ? 200u : 1000u));
    sv_scene sc;
    sv_scene_defaults(&sc);
    sv_method_input in = {.mesh = m, .cls = &cls, .leaves = &lv, .scene = &sc, .seed = 1};
    sv_mesh_sphere(m, in.centre, &in.radius);

    /* clustering alone (reported, not asserted: timing is not a behaviour) */
    sv_cluster_options co = {.alpha = 0.003 * in.radius * in.radius,
                             .area_weighted = true,
                             .seed = 1,
                             .centre = in.centre};
    sv_clusters cl;
    double t0 = sv_now();
    assert_int_equal(sv_cluster_build(lv.leaves, lv.count, &co, &cl, &e), SV_OK);
    double t1 = sv_now();
    print_message("%s: %u leaves -> 32/16/8 planes in %.1f ms (%u k-means iterations); "
                  "normalised error %.3g / %.3g / %.3g\n",
                  obj, lv.count, 1e3 * (t1 - t0), cl.iterations,
                  cl.levels[0].error / (cl.weight * in.radius * in.radius),
                  cl.levels[1].error / (cl.weight * in.radius * in.radius),
                  cl.levels[2].error / (cl.weight * in.radius * in.radius));
    assert_int_equal(cl.levels[0].count, 32);
    sv_clusters_free(&cl);

    sv_stand_in s = {0};
    t0 = sv_now();
    assert_int_equal(sv_method_leaf_clusters_ops.run(&in, NULL, &s, &e), SV_OK);
    print_message("%s: leaf_clusters method (clustering + quads) %.1f ms\n", obj,
                  1e3 * (sv_now() - t0));
    const uint32_t levels[] = {32, 16, 8};
    assert_stand_in_sound(&s, &in, levels, 3);
    assert_int_equal(s.lods[0].quad_count, 32);
    assert_int_equal(s.lods[1].quad_count, 16);
    assert_int_equal(s.lods[2].quad_count, 8);
    sv_stand_in_free(&s);
    sv_leaves_free(&lv);
    sv_classification_free(&cls);
    sv_mesh_destroy(m);
    free(b_obj);
    free(b_mtl);
}

/* The trunk cap a ladder step sets (-1: none), for method m at step i under
 * a triangle budget, from the user's settings `user` (JSON); *said: the
 * hook's answer (SV_LADDER_STEP or SV_LADDER_OVER). */
static long ladder_said(const sv_method *m, int i, uint32_t budget, const char *user, int *said)
{
    cJSON *set = cJSON_Parse(user);
    assert_non_null(set);
    *said = m->ladder(i, budget, set);
    assert_int_not_equal(*said, SV_LADDER_END);
    const cJSON *t = cJSON_GetObjectItemCaseSensitive(set, "trunk_max_triangles");
    long v = t ? (long)t->valuedouble : -1;
    cJSON_Delete(set);
    return v;
}

static long ladder_trunk(const sv_method *m, int i, uint32_t budget, const char *user)
{
    int said;
    return ladder_said(m, i, budget, user, &said);
}

/* Under a target's triangle budget the kept trunk yields to the quads
 * (sv_ladder_trunk_share): never above the default 200, never below a
 * quarter of the budget; a cap of the user's own is kept; no budget, no cap. */
static void ladder_shares_a_triangle_budget_with_the_trunk(void **state)
{
    (void)state;
    const sv_method *lc = &sv_method_leaf_clusters, *bc = &sv_method_billboard_cloud;
    /* steps 4..10: K = 16, 24, 32, 48, 64, 96, 128 */
    const long want[] = {200, 200, 200, 168, 136, 72, 66};
    for (int i = 4; i <= 10; i++) {
        assert_int_equal(ladder_trunk(lc, i, 264, "{}"), want[i - 4]);
        assert_int_equal(ladder_trunk(bc, i, 264, "{}"), want[i - 4]);
    }
    assert_int_equal(ladder_trunk(lc, 10, 264, "{\"trunk_max_triangles\": 500}"), 500);
    assert_int_equal(ladder_trunk(lc, 6, 0, "{}"), -1);
    assert_int_equal(ladder_trunk(bc, 6, 0, "{}"), -1);
    assert_int_equal(ladder_trunk(lc, 0, 2, "{}"), 1); /* at least one triangle */
    /* a step whose quads leave the trunk less than its floor is called over
     * the budget (the search does not bake it): 128 quads are 256 of 264
     * triangles, under the floor of 66; 96 quads leave 72 */
    int said;
    ladder_said(lc, 10, 264, "{}", &said);
    assert_int_equal(said, SV_LADDER_OVER);
    ladder_said(bc, 10, 264, "{}", &said);
    assert_int_equal(said, SV_LADDER_OVER);
    ladder_said(bc, 9, 264, "{}", &said);
    assert_int_equal(said, SV_LADDER_STEP);
    ladder_said(bc, 10, 0, "{}", &said); /* no budget: nothing is over */
    assert_int_equal(said, SV_LADDER_STEP);
    ladder_said(lc, 10, 264, "{\"trunk_max_triangles\": 500}", &said); /* the user's cap */
    assert_int_equal(said, SV_LADDER_STEP);
    assert_int_equal(sv_method_find("crossed_quads")->ladder(4, 264, NULL), SV_LADDER_END);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(ladder_shares_a_triangle_budget_with_the_trunk),
        cmocka_unit_test(default_settings_are_accepted),
        cmocka_unit_test(bad_settings_fail_naming_the_key),
        cmocka_unit_test(toy_tree_gives_one_lod_per_level_with_sound_quads),
        cmocka_unit_test(twigs_the_trunk_cap_drops_go_onto_the_quads),
        cmocka_unit_test(quads_are_planes_of_their_leaves),
        cmocka_unit_test(same_seed_gives_identical_stand_in_and_seed_matters),
        cmocka_unit_test(tree_without_leaves_is_unbakeable),
        cmocka_unit_test(bad_settings_make_run_fail_too),
        cmocka_unit_test(real_tree_clusters_into_32_16_8_quads),
    };
    return sv_test_exit(cmocka_run_group_tests(tests, NULL, NULL));
}
