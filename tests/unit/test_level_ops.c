/* sylva-test: cost=1 (tests/run.sh starts the longest first) */
/* test_level_ops.c — the per-level hooks (level.h): the
 * octahedral method's level carries its grid and the registry gives it
 * hooks, the hooks describe and size the grid as the pipeline did by name,
 * its draw hook is the reference runtime, quad methods have no hooks (their
 * levels are quads, as before), and the chain's stochastic levels are named
 * by a flag on the method, not by its name. */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <cmocka.h>
#include "test_skip.h"

#include <stdlib.h>
#include <string.h>

#include "evaluate.h"
#include "level.h"
#include "method_ops.h"
#include "octahedral.h"
#include "spec.h"

/* Two crossed coloured squares, 1 m wide, standing on the origin. */
static sv_mesh *cross(void)
{
    sv_mesh *m = sv_mesh_create(8, 4, 1, 0);
    assert_non_null(m);
    static const float p[8][3] = {{-0.5f, 0, 0}, {0.5f, 0, 0}, {0.5f, 1, 0}, {-0.5f, 1, 0},
                                  {0, 0, -0.5f}, {0, 0, 0.5f}, {0, 1, 0.5f}, {0, 1, -0.5f}};
    memcpy(m->positions, p, sizeof p);
    static const uint32_t t[12] = {0, 1, 2, 0, 2, 3, 4, 5, 6, 4, 6, 7};
    memcpy(m->indices, t, sizeof t);
    memset(m->tri_material, 0, 4 * sizeof *m->tri_material);
    static const float col[3] = {0.2f, 0.6f, 0.1f};
    memcpy(m->materials[0].base_color, col, sizeof col);
    m->materials[0].double_sided = true;
    sv_mesh_compute_normals(m);
    return m;
}

/* The octahedral method's one level for mesh m with settings json. */
static void octa_level(const sv_mesh *m, const char *json, sv_stand_in *out)
{
    cJSON *set = cJSON_Parse(json);
    assert_non_null(set);
    sv_method_input in = {m, NULL, NULL, {0, 0.5, 0}, 0.75, NULL, 1, NULL};
    memset(out, 0, sizeof *out);
    sv_error err = {0};
    assert_int_equal(sv_method_octahedral_ops.run(&in, set, out, &err), SV_OK);
    cJSON_Delete(set);
    assert_int_equal(out->lod_count, 1);
}

static void octahedral_level_carries_its_grid_and_hooks(void **state)
{
    (void)state;
    sv_mesh *m = cross();
    sv_stand_in si;
    octa_level(m, "{\"grid\": 6, \"hemi\": true}", &si);
    sv_lod_plan *lp = &si.lods[0];
    const sv_octa_grid *g = lp->payload;
    assert_non_null(g);
    assert_int_equal(g->n, 6);
    assert_true(g->hemi);
    assert_int_equal(lp->quad_count, 0);
    /* the method leaves the hooks to the registry (they render: sylvad,
     * which links the method, must not link them) */
    assert_null(lp->ops);
    const sv_level_ops *ops = sv_level_ops_find(sv_method_octahedral.name);
    assert_ptr_equal(ops, &sv_octa_level_ops);
    assert_string_equal(ops->method, sv_method_octahedral.name);
    assert_non_null(ops->bake);
    assert_non_null(ops->draw);
    assert_non_null(ops->shrink);
    assert_non_null(ops->images);
    assert_non_null(ops->doc_entry);
    assert_non_null(ops->view);
    assert_string_equal(ops->doc_file, "impostor.json");
    assert_string_equal(ops->doc_schema, "sylva.impostor/1");
    size_t n = 0;
    const sv_method_ops *const *all = sv_method_ops_list(&n);
    int found = 0;
    for (size_t i = 0; i < n; i++) found += all[i]->levels == ops;
    assert_int_equal(found, 1);
    sv_stand_in_free(&si);
    sv_mesh_destroy(m);
}

static void doc_entry_describes_the_grid(void **state)
{
    (void)state;
    sv_mesh *m = cross();
    sv_stand_in si;
    octa_level(m, "{\"grid\": 4, \"frame_pixels\": 64}", &si);
    sv_lod_plan *lp = &si.lods[0];
    sv_octa_grid *g = lp->payload;
    g->mip_count = 2;
    const char maps[4][64] = {"atlas_octa4_albedo.png", "", "", "atlas_octa4_depth.png"};
    sv_level_names names = {lp->name, "tree_LOD0", maps};
    cJSON *e = sv_octa_level_ops.doc_entry(lp, &names);
    assert_non_null(e);
    assert_string_equal(cJSON_GetObjectItem(e, "lod")->valuestring, "octa4");
    assert_string_equal(cJSON_GetObjectItem(e, "node")->valuestring, "tree_LOD0");
    assert_int_equal(cJSON_GetObjectItem(e, "grid")->valueint, 4);
    assert_int_equal(cJSON_GetObjectItem(e, "frame_pixels")->valueint, 64);
    assert_false(cJSON_IsTrue(cJSON_GetObjectItem(e, "hemi")));
    const cJSON *mp = cJSON_GetObjectItem(e, "maps");
    assert_string_equal(cJSON_GetObjectItem(mp, "albedo")->valuestring, maps[0]);
    assert_null(cJSON_GetObjectItem(mp, "normal"));
    assert_string_equal(cJSON_GetObjectItem(mp, "depth")->valuestring, maps[3]);
    const cJSON *mips = cJSON_GetObjectItem(e, "mips");
    assert_int_equal(cJSON_GetArraySize(mips), 3); /* level 0 and the two written */
    assert_string_equal(cJSON_GetArrayItem(mips, 2)->valuestring, "atlas_octa4_albedo_mip2.png");
    cJSON_Delete(e);
    sv_stand_in_free(&si);
    sv_mesh_destroy(m);
}

static void shrink_keeps_frames_whole(void **state)
{
    (void)state;
    sv_octa_grid *g = calloc(1, sizeof *g);
    assert_non_null(g);
    g->n = 8;
    g->frame_pixels = 64;
    sv_lod_plan lp = {.payload = g, .ops = &sv_octa_level_ops};
    /* halving 5 times would leave 2 texels: frames stop at the minimum */
    assert_int_equal(sv_octa_level_ops.shrink(&lp, 5), 2);
    assert_int_equal(g->frame_pixels, SV_OCTA_MIN_FRAME_PIXELS);
    assert_int_equal(sv_octa_level_ops.shrink(&lp, 1), 0);
    assert_int_equal(g->frame_pixels, SV_OCTA_MIN_FRAME_PIXELS);
    g->frame_pixels = 128;
    assert_int_equal(sv_octa_level_ops.shrink(&lp, 1), 1); /* fewer asked: fewer done */
    assert_int_equal(g->frame_pixels, 64);
    free(g);
}

/* The bake hook sizes the frames as the pipeline did (sv_octa_frame_pixels
 * of the largest evaluated size) and the draw hook is the reference runtime. */
static void bake_and_draw_hooks_are_the_impostors(void **state)
{
    (void)state;
    sv_renderer *r = NULL;
    sv_error err = {0};
    /* no OSMesa context is a failure (libosmesa6 is a dependency), not a skip */
    assert_int_equal(sv_renderer_create(512, &r, &err), SV_OK);
    sv_mesh *m = cross();
    sv_gpu_mesh *gm = NULL;
    assert_int_equal(sv_gpu_mesh_upload(r, m, &gm, &err), SV_OK);
    sv_stand_in si;
    octa_level(m, "{\"grid\": 4}", &si);
    sv_lod_plan *lp = &si.lods[0];
    lp->ops = sv_level_ops_find(sv_method_octahedral.name); /* as chain.c does */
    sv_octa_grid *g = lp->payload;
    assert_int_equal(g->frame_pixels, 0); /* left to the bake */
    sv_bake_options bo;
    sv_bake_options_init(&bo);
    bo.depth_map = true;
    sv_level_bake_in in = {r, gm, m, &bo, 32, 4.0, 512};
    sv_baked_lod b;
    assert_int_equal(lp->ops->bake(lp, &in, &b, &err), SV_OK);
    assert_int_equal(g->frame_pixels, sv_octa_frame_pixels(4, 32, 4.0, 512));
    assert_int_equal(b.albedo.width, 4 * g->frame_pixels);
    double c[3] = {0, 0.5, 0}, d[3] = {0.3, 0.2, 0.93};
    sv_camera cam;
    sv_eval_camera(c, 0.75, d, &cam);
    sv_image a = {0}, o = {0};
    assert_int_equal(lp->ops->draw(lp, &b, &cam, 64, 64, &a, NULL, &err), SV_OK);
    assert_int_equal(sv_octa_render(g, &b.albedo, &b.depth, &cam, 64, 64, &o, NULL, &err), SV_OK);
    assert_memory_equal(a.data, o.data, 64 * 64 * 4);
    size_t drawn = 0;
    for (size_t i = 0; i < 64 * 64; i++) drawn += ((uint8_t *)a.data)[4 * i + 3] != 0;
    assert_true(drawn > 100); /* the cross is there */
    sv_image_free(&a);
    sv_image_free(&o);
    sv_baked_lod_free(&b);
    sv_stand_in_free(&si);
    sv_gpu_mesh_free(gm);
    sv_mesh_destroy(m);
    sv_renderer_destroy(r);
}

/* Quad methods have no hooks: their levels are baked, drawn and written as
 * quads; the impostor's and the chain's stochastic levels have theirs; a
 * level's payload without hooks is still freed. */
static void quad_methods_have_no_hooks(void **state)
{
    (void)state;
    size_t n = 0;
    const sv_method *const *ms = sv_method_list(&n);
    int with = 0;
    for (size_t i = 0; i < n; i++)
        if (sv_level_ops_find(ms[i]->name)) {
            with++;
            assert_true(ms[i] == &sv_method_octahedral || ms[i] == sv_method_chain_levels());
        }
    assert_int_equal(with, 2);
    assert_null(sv_level_ops_find("no such method"));
    assert_null(sv_level_ops_find(NULL));
    sv_stand_in si = {0};
    sv_lod_plan *lp = sv_stand_in_add_lod(&si, "q");
    assert_non_null(lp);
    assert_null(lp->payload);
    assert_null(lp->ops);
    lp->payload = malloc(16); /* freed with free() (ASan's leak check) */
    sv_stand_in_free(&si);
}

/* The chain's stochastic levels are the method that says so, and only its
 * build half has the chain hook the pipeline builds them through. */
static void chain_levels_is_a_flag(void **state)
{
    (void)state;
    const sv_method *c = sv_method_chain_levels();
    assert_ptr_equal(c, sv_method_find("stochastic"));
    size_t n = 0;
    const sv_method *const *ms = sv_method_list(&n);
    int flagged = 0;
    for (size_t i = 0; i < n; i++) flagged += ms[i]->chain_levels;
    assert_int_equal(flagged, 1);
    const sv_method_ops *const *ops = sv_method_ops_list(&n);
    for (size_t i = 0; i < n; i++) assert_true((ops[i]->chain != NULL) == (ops[i]->method == c));
    /* it cannot be the coarsest level of the chain; a quad method can */
    sv_spec s;
    sv_error err = {0};
    char json[128];
    snprintf(json, sizeof json, "{\"lod\": {\"coarsest\": \"%s\"}}", c->name);
    assert_int_equal(sv_spec_parse(json, strlen(json), &s, &err), SV_ERR_SPEC);
    sv_spec_free(&s);
    const char *ok = "{\"lod\": {\"coarsest\": \"crossed_quads\"}}";
    assert_int_equal(sv_spec_parse(ok, strlen(ok), &s, &err), SV_OK);
    assert_string_equal(s.lod_coarsest, "crossed_quads");
    sv_spec_free(&s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(octahedral_level_carries_its_grid_and_hooks),
        cmocka_unit_test(doc_entry_describes_the_grid),
        cmocka_unit_test(shrink_keeps_frames_whole),
        cmocka_unit_test(bake_and_draw_hooks_are_the_impostors),
        cmocka_unit_test(quad_methods_have_no_hooks),
        cmocka_unit_test(chain_levels_is_a_flag),
    };
    return sv_test_exit(cmocka_run_group_tests(tests, NULL, NULL));
}
