/* test_spec.c — strict bake-spec parsing (core/spec/spec.c) and scene conversions (core/scene.c). */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <string.h>

#include "json_strict.h"
#include "spec.h"

static sv_status parse(const char *json, sv_spec *s, sv_error *e)
{
    memset(e, 0, sizeof *e);
    return sv_spec_parse(json, strlen(json), s, e);
}

static void empty_spec_gives_every_default(void **state)
{
    (void)state;
    sv_spec s;
    sv_error e;
    assert_int_equal(parse("{}", &s, &e), SV_OK);
    assert_string_equal(s.method, SV_DEFAULT_METHOD);
    assert_int_equal(s.max_atlas, 2048);
    assert_true(s.alpha_threshold == 0); /* calibrated */
    assert_int_equal(s.texel_pixels, 256);
    assert_int_equal(s.eval_views, 24);
    assert_false(s.eval_flattening_bound); /* measured only when asked */
    assert_int_equal(s.eval_size_count, 4);
    assert_int_equal(s.eval_sizes[0], 256);
    assert_int_equal(s.eval_small_render, 256); /* 64 and 32 px judged as sveval does */
    assert_true(s.lod_slack == 0.02 && s.lod_cost_ratio == 10 && s.lod_triangles_per_pixel == 2);
    assert_true(s.lod_min_saving == 0.25);
    assert_int_equal(s.scene.viewer, SV_VIEWER_SIDE);
    assert_int_equal(s.scene.lighting, SV_LIGHTING_UNLIT);
    assert_true(s.scene.distance_auto); /* the range follows the tree's size */
    assert_int_equal(s.seed, 1);
    sv_spec_free(&s);
    /* a zero-length spec part means {} */
    assert_int_equal(sv_spec_parse("", 0, &s, &e), SV_OK);
    sv_spec_free(&s);
}

static void full_spec_sets_every_section(void **state)
{
    (void)state;
    sv_spec s;
    sv_error e;
    const char *j =
        "{\"method\":\"crossed_quads\",\"crossed_quads\":{\"planes\":3},"
        "\"scene\":{\"lighting\":\"dynamic\",\"viewer\":\"ground\",\"distance\":[5,50],"
        "\"shadows\":true,\"ambient_occlusion\":true,\"light_dir\":[0,2,0],\"fov_deg\":45,"
        "\"screen_height\":720,\"camera_speed\":3},"
        "\"import\":{\"units\":\"cm\",\"up\":\"Z\"},"
        "\"classify\":{\"foliage\":[\"Leaf*\"],\"trunk\":[\"Bark\",\"Pot\"]},"
        "\"bake\":{\"max_atlas\":1024,\"alpha_threshold\":0.5},"
        "\"evaluate\":{\"views\":8,\"sizes\":[32,128],\"flattening_bound\":true},\"lod\":{"
        "\"tolerance\":0.2,\"tolerance_"
        "pixels\":0},\"seed\":7}";
    assert_int_equal(parse(j, &s, &e), SV_OK);
    assert_string_equal(s.method, "crossed_quads");
    assert_non_null(s.settings);
    assert_int_equal(s.scene.lighting, SV_LIGHTING_DYNAMIC);
    assert_int_equal(s.scene.viewer, SV_VIEWER_GROUND);
    assert_false(s.scene.distance_auto); /* given: used as it is */
    assert_true(s.scene.distance_min == 5 && s.scene.distance_max == 50);
    assert_true(s.scene.shadows && s.scene.ambient_occlusion);
    assert_true(fabs(s.scene.light_dir[1] - 1.0) < 1e-12); /* normalised */
    assert_true(fabs(s.unit_scale - 0.01) < 1e-12);
    assert_int_equal(s.up_axis, 'Z');
    assert_int_equal(s.foliage_count, 1);
    assert_int_equal(s.trunk_count, 2);
    assert_string_equal(s.trunk[1], "Pot");
    assert_int_equal(s.max_atlas, 1024);
    assert_int_equal(s.eval_size_count, 2);
    assert_int_equal(s.eval_sizes[0], 128); /* sorted largest first */
    assert_true(s.eval_flattening_bound);
    assert_int_equal(s.seed, 7);
    assert_true(s.lod_tolerance == 0.2 && s.lod_tolerance_pixels == 0);
    sv_spec_free(&s);
}

/* import.up: "Y" (default), "Z", or "auto" (detect and rotate, plausibility.h) */
static void import_up_accepts_auto(void **state)
{
    (void)state;
    static const struct {
        const char *json;
        char up;
    } cases[] = {{"{}", 'Y'},
                 {"{\"import\":{\"up\":\"Y\"}}", 'Y'},
                 {"{\"import\":{\"up\":\"Z\"}}", 'Z'},
                 {"{\"import\":{\"up\":\"auto\"}}", 'A'}};
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        sv_spec s;
        sv_error e = {0};
        assert_int_equal(sv_spec_parse(cases[i].json, strlen(cases[i].json), &s, &e), SV_OK);
        assert_int_equal(s.up_axis, cases[i].up);
        sv_spec_free(&s);
    }
}

/* import.missing_files: "error" (default: a referenced file that was not
 * supplied fails the import) or "warn" (proceed, say so in the report) */
static void import_missing_files_defaults_to_error_and_accepts_warn(void **state)
{
    (void)state;
    static const struct {
        const char *json;
        bool warn;
    } cases[] = {{"{}", false},
                 {"{\"import\":{\"missing_files\":\"error\"}}", false},
                 {"{\"import\":{\"missing_files\":\"warn\"}}", true},
                 {"{\"import\":{\"units\":\"cm\",\"missing_files\":\"warn\"}}", true}};
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        sv_spec s;
        sv_error e = {0};
        assert_int_equal(sv_spec_parse(cases[i].json, strlen(cases[i].json), &s, &e), SV_OK);
        if (s.missing_files_warn != cases[i].warn) fail_msg("case %zu: %s", i, cases[i].json);
        sv_spec_free(&s);
    }
}

static void output_fbx_defaults_to_on_and_can_be_turned_off(void **state)
{
    (void)state;
    static const struct {
        const char *json;
        bool fbx;
    } cases[] = {{"{}", true},
                 {"{\"output\":{}}", true},
                 {"{\"output\":{\"fbx\":true}}", true},
                 {"{\"output\":{\"fbx\":false}}", false}};
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        sv_spec s;
        sv_error e = {0};
        assert_int_equal(sv_spec_parse(cases[i].json, strlen(cases[i].json), &s, &e), SV_OK);
        if (s.output_fbx != cases[i].fbx) fail_msg("case %zu: %s", i, cases[i].json);
        sv_spec_free(&s);
    }
}

static void output_compress_defaults_to_none(void **state)
{
    (void)state;
    static const struct {
        const char *json;
        sv_compress c;
    } cases[] = {{"{}", SV_COMPRESS_NONE},
                 {"{\"output\":{\"compress\":\"none\"}}", SV_COMPRESS_NONE},
                 {"{\"output\":{\"compress\":\"quantize\"}}", SV_COMPRESS_QUANTIZE},
                 {"{\"output\":{\"compress\":\"meshopt\",\"fbx\":false}}", SV_COMPRESS_MESHOPT}};
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        sv_spec s;
        sv_error e = {0};
        assert_int_equal(sv_spec_parse(cases[i].json, strlen(cases[i].json), &s, &e), SV_OK);
        if (s.output_compress != cases[i].c) fail_msg("case %zu: %s", i, cases[i].json);
        sv_spec_free(&s);
    }
}

/* The disk estimate counts every file a bake writes: the meshes in three
 * glTF files (model.glb, the level files, lods.glb) and, unless output.fbx is
 * false, the FBX files; the atlases in four copies. */
static void output_estimate_counts_the_lod_group_and_fbx_files(void **state)
{
    (void)state;
    const char *specs[3] = {"{}", "{\"output\":{\"fbx\":false}}", "{\"bake\":{\"max_atlas\":256}}"};
    sv_spec s[3];
    sv_error e = {0};
    for (int i = 0; i < 3; i++)
        assert_int_equal(sv_spec_parse(specs[i], strlen(specs[i]), &s[i], &e), SV_OK);
    uint64_t in = 10000000, atlas2048 = 4 * 8 * 4 * 2048ull * 2048 / 3;
    assert_int_equal(sv_spec_output_estimate(&s[0], in), 36 * in + atlas2048);
    assert_int_equal(sv_spec_output_estimate(&s[1], in), 18 * in + atlas2048);
    assert_int_equal(sv_spec_output_estimate(&s[2], 0), 4 * 8 * 4 * 256ull * 256 / 3);
    /* above what the shared trees' bakes wrote (docs/benchmarks.md): the
     * decorative plant's 59.0 MB folder from 1.71 MB, the ficus's 121 MB from 4.70 MB */
    assert_true(sv_spec_output_estimate(&s[0], 1707521) > 58989031);
    assert_true(sv_spec_output_estimate(&s[0], 4703357) > 121120000);
    for (int i = 0; i < 3; i++) sv_spec_free(&s[i]);
}

static void expect_error(const char *json, const char *needle)
{
    sv_spec s;
    sv_error e;
    assert_int_equal(parse(json, &s, &e), SV_ERR_SPEC);
    if (!strstr(e.message, needle)) fail_msg("message '%s' lacks '%s'", e.message, needle);
    sv_spec_free(&s); /* safe after failure */
}

/* What two JSON parsers could read differently is refused, in a spec, in any
 * object of it, and by the shared reader glTF and the daemon use. */
static void ambiguous_json_is_refused(void **state)
{
    (void)state;
    expect_error("{} x", "content after the JSON value at byte 3");
    expect_error("{}{}", "content after the JSON value");
    expect_error("{\"method\":\"octahedral\",\"method\":7}", "\"method\" appears twice");
    expect_error("{\"scene\":{\"sky\":1,\"sky\":2}}", "\"sky\" appears twice");
    expect_error("{\"seed\\u0000\":1}", "key at byte 1 holds a NUL");
    expect_error("{\"seed\":\"a\\u0000\"}", "string at byte 8 holds a NUL");
    sv_error e = {0};
    const char raw[] = "{\"a\x01\":1}";
    assert_null(sv_json_parse_strict(raw, sizeof raw - 1, "t", SV_ERR_PARSE, &e));
    assert_non_null(strstr(e.message, "raw control character"));
    const char ok[] = " {\"a\":[{\"b\":1},{\"b\":2}],\"c\":\"\\u0001\"}\n";
    cJSON *j = sv_json_parse_strict(ok, sizeof ok - 1, "t", SV_ERR_PARSE, &e);
    assert_non_null(j); /* the same key in two objects is fine */
    cJSON_Delete(j);
}

static void bad_specs_are_refused_naming_the_key(void **state)
{
    (void)state;
    expect_error("{", "invalid JSON");
    expect_error("[]", "expected a JSON object");
    expect_error("{\"colour\":1}", "unknown key 'colour'");
    /* curl -F spec=spec.json sends the name: the error says so */
    expect_error("spec.json", "a file name? (curl -F spec=@FILE sends the file");
    expect_error("  /tmp/x/my spec.json\n", "holds '/tmp/x/my spec.json'");
    expect_error("nope", "invalid JSON near byte 0");
    expect_error("{\"method\":\"nope\"}", "unknown method 'nope'");
    expect_error("{\"method\":3}", "method");
    expect_error("{\"scene\":{\"viewer\":\"underwater\"}}", "scene.viewer");
    expect_error("{\"output\":{\"fbx\":1}}", "output.fbx");
    expect_error("{\"output\":{\"compress\":true}}",
                 "output.compress: expected one of none, quantize, meshopt");
    expect_error("{\"output\":{\"compress\":\"draco\"}}", "output.compress");
    expect_error("{\"output\":true}", "output: expected an object");
    expect_error("{\"scene\":{\"lighting\":1}}", "scene.lighting");
    expect_error("{\"scene\":{\"distance\":[10,5]}}", "scene.distance");
    expect_error("{\"scene\":{\"light_dir\":[0,0,0]}}", "scene.light_dir");
    expect_error("{\"scene\":{\"ambient_occlusion\":true}}", "scene.ambient_occlusion");
    expect_error("{\"scene\":{\"fov_deg\":1e308}}", "scene.fov_deg");
    expect_error("{\"scene\":{\"sky\":1}}", "sky");
    expect_error("{\"scene\":3}", "scene: expected an object");
    expect_error("{\"import\":{\"units\":\"furlong\"}}", "import.units");
    expect_error("{\"import\":{\"up\":\"X\"}}", "import.up: expected one of Y, Z, auto");
    expect_error("{\"import\":{\"missing_files\":\"ignore\"}}",
                 "import.missing_files: expected one of error, warn");
    expect_error("{\"import\":{\"missing_files\":false}}",
                 "import.missing_files: expected one of error, warn");
    expect_error("{\"bake\":{\"max_atlas\":1000}}", "power of two");
    expect_error("{\"bake\":{\"max_atlas\":1e30}}", "bake.max_atlas");
    expect_error("{\"bake\":{\"alpha_threshold\":\"high\"}}", "bake.alpha_threshold");
    expect_error("{\"evaluate\":{\"sizes\":[]}}", "evaluate.sizes");
    expect_error("{\"evaluate\":{\"sizes\":[12.5]}}", "evaluate.sizes[0]");
    expect_error("{\"evaluate\":{\"flattening_bound\":1}}", "evaluate.flattening_bound");
    expect_error("{\"classify\":{\"foliage\":\"leaf\"}}", "classify.foliage");
    expect_error("{\"classify\":{\"foliage\":[\"\"]}}", "classify.foliage[0]");
    expect_error("{\"lod\":{\"tolerance_pixels\":-1}}", "lod.tolerance_pixels");
    expect_error("{\"lod\":{\"slack\":2}}", "lod.slack");
    expect_error("{\"lod\":{\"cost_ratio\":-1}}", "lod.cost_ratio");
    expect_error("{\"lod\":{\"min_saving\":1}}", "lod.min_saving");
    expect_error("{\"lod\":{\"triangles_per_pixel\":\"many\"}}", "lod.triangles_per_pixel");
    expect_error("{\"evaluate\":{\"small_render\":-4}}", "evaluate.small_render");
    expect_error("{\"seed\":-1}", "seed");
    expect_error("{\"seed\":1.5}", "seed");
    expect_error("{\"method\":\"crossed_quads\",\"crossed_quads\":{\"planes\":9}}",
                 "crossed_quads.planes");
    expect_error("{\"method\":\"crossed_quads\",\"crossed_quads\":{\"zzz\":1}}", "zzz");
}

static void deeply_nested_json_is_refused_without_crashing(void **state)
{
    (void)state;
    static char deep[200002];
    for (int i = 0; i < 100000; i++) {
        deep[i] = '[';
        deep[100000 + i] = ']';
    }
    sv_spec s;
    sv_error e = {0};
    assert_int_equal(sv_spec_parse(deep, 200000, &s, &e), SV_ERR_SPEC);
    sv_spec_free(&s);
}

static void scene_pixels_and_distance_are_inverse(void **state)
{
    (void)state;
    sv_scene sc;
    sv_scene_defaults(&sc);
    double d = sv_scene_distance_for_pixels(&sc, 10.0, 64);
    assert_true(fabs(sv_scene_pixels(&sc, 10.0, d) - 64) < 1e-9);
    /* 60° fov, 1080 px: a 10 m tree at 10 m spans 10/(2·10·tan30°)·1080 px */
    assert_true(fabs(sv_scene_pixels(&sc, 10, 10) - 1080 / (2 * tan(M_PI / 6))) < 1e-6);
}

/* scene.distance "auto" (the default): from where the tree fills the screen
 * to SV_SCENE_AUTO_RANGE times farther, so the same tree in cm or in m gets
 * the same range in pixels; a given range is never touched. */
static void auto_distance_follows_the_tree_size(void **state)
{
    (void)state;
    sv_spec s;
    sv_error e;
    assert_int_equal(parse("{\"scene\":{\"distance\":\"auto\"}}", &s, &e), SV_OK);
    assert_true(s.scene.distance_auto);
    sv_scene a = s.scene, b = s.scene;
    sv_spec_free(&s);
    sv_scene_resolve_distance(&a, 12.0);
    sv_scene_resolve_distance(&b, 1200.0); /* the same tree in centimetres */
    assert_true(fabs(sv_scene_pixels(&a, 12.0, a.distance_min) - 1080) < 1e-6);
    assert_true(fabs(sv_scene_pixels(&a, 12.0, a.distance_max) - 10.8) < 1e-6);
    assert_true(fabs(b.distance_min / a.distance_min - 100) < 1e-9);
    assert_true(fabs(a.distance_min - 12.0 / (2 * tan(M_PI / 6))) < 1e-9);
    /* nonsense sizes leave the range alone */
    sv_scene c = a;
    sv_scene_resolve_distance(&c, 0);
    sv_scene_resolve_distance(&c, NAN);
    assert_true(c.distance_min == a.distance_min && c.distance_max == a.distance_max);
    /* a given range is kept */
    assert_int_equal(parse("{\"scene\":{\"distance\":[5,50]}}", &s, &e), SV_OK);
    sv_scene g = s.scene;
    sv_spec_free(&s);
    sv_scene_resolve_distance(&g, 12.0);
    assert_true(g.distance_min == 5 && g.distance_max == 50);
    expect_error("{\"scene\":{\"distance\":\"near\"}}", "scene.distance");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(empty_spec_gives_every_default),
        cmocka_unit_test(ambiguous_json_is_refused),
        cmocka_unit_test(full_spec_sets_every_section),
        cmocka_unit_test(import_up_accepts_auto),
        cmocka_unit_test(import_missing_files_defaults_to_error_and_accepts_warn),
        cmocka_unit_test(output_fbx_defaults_to_on_and_can_be_turned_off),
        cmocka_unit_test(output_compress_defaults_to_none),
        cmocka_unit_test(output_estimate_counts_the_lod_group_and_fbx_files),
        cmocka_unit_test(bad_specs_are_refused_naming_the_key),
        cmocka_unit_test(deeply_nested_json_is_refused_without_crashing),
        cmocka_unit_test(scene_pixels_and_distance_are_inverse),
        cmocka_unit_test(auto_distance_follows_the_tree_size),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
