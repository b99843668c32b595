/* test_client_cli.c — the `sylva` command's pure parts (client/cli.h): option
 * parsing, batch grouping, spec building from --method/--set, the summary,
 * progress lines and exit codes. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "companions.h"
#include "summary_table.h"

#define ARGV(...) ((char *[]){"sylva", __VA_ARGS__, NULL})
#define ARGC(...) ((int)(sizeof((char *[]){"sylva", __VA_ARGS__}) / sizeof(char *)))
#define PARSE(cli, env_s, env_t, err, ...) \
    sylva_cli_parse(ARGC(__VA_ARGS__), ARGV(__VA_ARGS__), env_s, env_t, cli, err, sizeof err)

static void parse_reads_bake_options_before_and_after_the_command(void **state)
{
    (void)state;
    sylva_cli cli;
    char err[256];
    assert_int_equal(PARSE(&cli, NULL, NULL, err, "--json", "bake", "t.obj", "t.mtl", "--out", "o",
                           "--method", "slicing", "--set", "slices=4", "--set=scene.viewer=ground",
                           "--timeout=30"),
                     SYLVA_EXIT_OK);
    assert_int_equal(cli.cmd, SYLVA_CMD_BAKE);
    assert_true(cli.json);
    assert_string_equal(cli.out, "o");
    assert_string_equal(cli.method, "slicing");
    assert_int_equal(cli.set_count, 2);
    assert_string_equal(cli.sets[1], "scene.viewer=ground");
    assert_int_equal(cli.arg_count, 2);
    assert_string_equal(cli.args[1], "t.mtl");
    assert_true(cli.timeout_s == 30);
    assert_int_equal(cli.server_count, 1);
    assert_string_equal(cli.servers[0], SYLVA_DEFAULT_SERVER);
    sylva_cli_free(&cli);
}

static void servers_come_from_repeated_and_comma_separated_options(void **state)
{
    (void)state;
    sylva_cli cli;
    char err[256];
    assert_int_equal(PARSE(&cli, "http://env:1", "envtok", err, "health", "--server",
                           "http://a:1, http://b:2", "--server", "http://c:3"),
                     SYLVA_EXIT_OK);
    assert_int_equal(cli.server_count, 3);
    assert_string_equal(cli.servers[0], "http://a:1");
    assert_string_equal(cli.servers[1], "http://b:2");
    assert_string_equal(cli.servers[2], "http://c:3");
    assert_string_equal(cli.token, "envtok");
    sylva_cli_free(&cli);
}

static void environment_gives_server_and_token_when_no_option_does(void **state)
{
    (void)state;
    sylva_cli cli;
    char err[256];
    assert_int_equal(PARSE(&cli, "http://x:9,http://y:9", NULL, err, "status",
                           "0123456789abcdef0123456789abcdef0123456789abcdef0123456789abcdef"),
                     SYLVA_EXIT_OK);
    assert_int_equal(cli.server_count, 2);
    assert_string_equal(cli.servers[1], "http://y:9");
    assert_null(cli.token);
    sylva_cli_free(&cli);
    assert_int_equal(PARSE(&cli, NULL, "envtok", err, "--token", "mine", "health"), SYLVA_EXIT_OK);
    assert_string_equal(cli.token, "mine");
    sylva_cli_free(&cli);
}

static void retries_and_progress_mode_are_parsed(void **state)
{
    (void)state;
    sylva_cli cli;
    char err[256];
    assert_int_equal(PARSE(&cli, NULL, NULL, err, "health"), SYLVA_EXIT_OK);
    assert_int_equal(cli.retries, -1);
    assert_int_equal(cli.progress, SYLVA_PROGRESS_AUTO);
    sylva_cli_free(&cli);
    assert_int_equal(PARSE(&cli, NULL, NULL, err, "bake", "t.glb", "--out", "o", "--retries", "0",
                           "--progress", "plain"),
                     SYLVA_EXIT_OK);
    assert_int_equal(cli.retries, 0);
    assert_int_equal(cli.progress, SYLVA_PROGRESS_PLAIN);
    sylva_cli_free(&cli);
    assert_int_equal(PARSE(&cli, NULL, NULL, err, "health", "--quiet"), SYLVA_EXIT_OK);
    assert_int_equal(cli.progress, SYLVA_PROGRESS_NONE);
    sylva_cli_free(&cli);
    assert_int_equal(PARSE(&cli, NULL, NULL, err, "health", "--retries", "-1"), SYLVA_EXIT_USAGE);
    sylva_cli_free(&cli);
    assert_int_equal(PARSE(&cli, NULL, NULL, err, "health", "--progress=loud"), SYLVA_EXIT_USAGE);
    sylva_cli_free(&cli);
}

static void usage_errors_name_the_problem(void **state)
{
    (void)state;
    sylva_cli cli;
    char err[256];
    assert_int_equal(PARSE(&cli, NULL, NULL, err, "bake", "t.obj"), SYLVA_EXIT_USAGE);
    assert_non_null(strstr(err, "--out"));
    sylva_cli_free(&cli);
    assert_int_equal(PARSE(&cli, NULL, NULL, err, "frobnicate"), SYLVA_EXIT_USAGE);
    assert_non_null(strstr(err, "frobnicate"));
    sylva_cli_free(&cli);
    assert_int_equal(PARSE(&cli, NULL, NULL, err, "bake", "t.obj", "--out", "o", "--bogus"),
                     SYLVA_EXIT_USAGE);
    assert_non_null(strstr(err, "--bogus"));
    sylva_cli_free(&cli);
    assert_int_equal(
        PARSE(&cli, NULL, NULL, err, "bake", "t.obj", "--out", "o", "--set", "noequals"),
        SYLVA_EXIT_USAGE);
    assert_non_null(strstr(err, "key=value"));
    sylva_cli_free(&cli);
    assert_int_equal(PARSE(&cli, NULL, NULL, err, "bake", "t.obj", "--out", "o", "--set", "k=1"),
                     SYLVA_EXIT_USAGE);
    assert_non_null(strstr(err, "--method"));
    sylva_cli_free(&cli);
    assert_int_equal(PARSE(&cli, NULL, NULL, err, "status"), SYLVA_EXIT_USAGE);
    sylva_cli_free(&cli);
    assert_int_equal(PARSE(&cli, NULL, NULL, err, "fetch", "k"), SYLVA_EXIT_USAGE);
    assert_non_null(strstr(err, "--out"));
    sylva_cli_free(&cli);
    assert_int_equal(PARSE(&cli, NULL, NULL, err, "health", "--server"), SYLVA_EXIT_USAGE);
    assert_non_null(strstr(err, "needs a value"));
    sylva_cli_free(&cli);
    assert_int_equal(
        PARSE(&cli, NULL, NULL, err, "bake", "t.obj", "--out", "o", "--timeout", "soon"),
        SYLVA_EXIT_USAGE);
    sylva_cli_free(&cli);
}

static void groups(sylva_cli *cli, sylva_bake_group **g, size_t *n, int want, char *err,
                   size_t errlen)
{
    assert_int_equal(sylva_cli_groups(cli, g, n, err, errlen), want);
}

static void one_mesh_takes_every_other_file_as_companion(void **state)
{
    (void)state;
    sylva_cli cli;
    char err[256];
    assert_int_equal(PARSE(&cli, NULL, NULL, err, "bake", "d/tree.mtl", "d/tree.obj", "x/bark.jpg",
                           "--out", "out"),
                     SYLVA_EXIT_OK);
    sylva_bake_group *g;
    size_t n;
    groups(&cli, &g, &n, SYLVA_EXIT_OK, err, sizeof err);
    assert_int_equal(n, 1);
    assert_string_equal(g[0].mesh, "d/tree.obj");
    assert_int_equal(g[0].file_count, 2);
    assert_string_equal(g[0].files[0], "d/tree.mtl");
    assert_string_equal(g[0].files[1], "x/bark.jpg");
    assert_string_equal(g[0].out_dir, "out");
    sylva_cli_groups_free(g, n);
    sylva_cli_free(&cli);
}

static void several_meshes_take_companions_from_their_own_directory(void **state)
{
    (void)state;
    sylva_cli cli;
    char err[256];
    /* Shell glob order: the .mtl sorts before its .obj. */
    assert_int_equal(PARSE(&cli, NULL, NULL, err, "bake", "a/ash.mtl", "a/ash.obj", "a/bark.png",
                           "b/oak.glb", "--out", "out"),
                     SYLVA_EXIT_OK);
    sylva_bake_group *g;
    size_t n;
    groups(&cli, &g, &n, SYLVA_EXIT_OK, err, sizeof err);
    assert_int_equal(n, 2);
    assert_string_equal(g[0].mesh, "a/ash.obj");
    assert_int_equal(g[0].file_count, 2);
    assert_string_equal(g[1].mesh, "b/oak.glb");
    assert_int_equal(g[1].file_count, 0);
    assert_string_equal(g[0].out_dir, "out/ash");
    assert_string_equal(g[1].out_dir, "out/oak");
    sylva_cli_groups_free(g, n);
    sylva_cli_free(&cli);
}

static void ambiguous_companion_is_refused_with_a_hint(void **state)
{
    (void)state;
    sylva_cli cli;
    char err[256];
    assert_int_equal(
        PARSE(&cli, NULL, NULL, err, "bake", "a/t.obj", "a/t.glb", "a/t.mtl", "--out", "out"),
        SYLVA_EXIT_OK);
    sylva_bake_group *g = NULL;
    size_t n = 0;
    groups(&cli, &g, &n, SYLVA_EXIT_USAGE, err, sizeof err);
    assert_null(g);
    assert_non_null(strstr(err, "a/t.mtl"));
    assert_non_null(strstr(err, "--"));
    sylva_cli_free(&cli);
}

static void double_dash_separates_explicit_groups_and_same_stems_keep_extensions(void **state)
{
    (void)state;
    sylva_cli cli;
    char err[256];
    assert_int_equal(
        PARSE(&cli, NULL, NULL, err, "bake", "a/t.obj", "a/t.mtl", "--", "a/t.glb", "--out", "out"),
        SYLVA_EXIT_OK);
    sylva_bake_group *g;
    size_t n;
    groups(&cli, &g, &n, SYLVA_EXIT_OK, err, sizeof err);
    assert_int_equal(n, 2);
    assert_string_equal(g[0].mesh, "a/t.obj");
    assert_int_equal(g[0].file_count, 1);
    assert_string_equal(g[1].mesh, "a/t.glb");
    assert_string_equal(g[0].out_dir, "out/t_obj");
    assert_string_equal(g[1].out_dir, "out/t_glb");
    sylva_cli_groups_free(g, n);
    sylva_cli_free(&cli);
}

static void mesh_extensions_are_recognised_in_any_case(void **state)
{
    (void)state;
    assert_true(sylva_cli_is_mesh("a/T.OBJ"));
    assert_true(sylva_cli_is_mesh("x.gltf"));
    assert_true(sylva_cli_is_mesh("x.GLB"));
    assert_true(sylva_cli_is_mesh("x.ply"));
    assert_false(sylva_cli_is_mesh("x.bin"));
    assert_false(sylva_cli_is_mesh("x.obj.png"));
    assert_false(sylva_cli_is_mesh("dir.obj/file"));
}

static void spec_file_is_sent_byte_for_byte_without_set(void **state)
{
    (void)state;
    const char base[] = "{ \"method\" : \"slicing\" }\n";
    char *out = NULL;
    size_t len = 0;
    char err[256];
    assert_int_equal(
        sylva_cli_build_spec(base, sizeof base - 1, NULL, NULL, 0, &out, &len, err, sizeof err),
        SYLVA_EXIT_OK);
    assert_int_equal(len, sizeof base - 1);
    assert_memory_equal(out, base, len);
    free(out);
    assert_int_equal(sylva_cli_build_spec(NULL, 0, NULL, NULL, 0, &out, &len, err, sizeof err),
                     SYLVA_EXIT_OK);
    assert_null(out);
}

static void set_values_parse_as_json_else_string_and_dotted_keys_start_at_the_root(void **state)
{
    (void)state;
    const char *sets[] = {"clusters=32",   "two_sided=true",      "name=oak 1",
                          "weights=[1,2]", "scene.viewer=ground", "scene.distance_min=5",
                          "clusters=16"};
    char *out = NULL;
    size_t len = 0;
    char err[256];
    assert_int_equal(
        sylva_cli_build_spec(NULL, 0, "leaf_clusters", sets, 7, &out, &len, err, sizeof err),
        SYLVA_EXIT_OK);
    assert_string_equal(out, "{\"method\":\"leaf_clusters\",\"leaf_clusters\":{\"clusters\":16,"
                             "\"two_sided\":true,\"name\":\"oak 1\",\"weights\":[1,2]},"
                             "\"scene\":{\"viewer\":\"ground\",\"distance_min\":5}}");
    free(out);
}

static void set_overrides_a_spec_file_and_uses_its_method(void **state)
{
    (void)state;
    const char base[] = "{\"method\":\"slicing\",\"slicing\":{\"slices\":8},\"seed\":3}";
    const char *sets[] = {"slices=4", "seed=9", ".lod={\"chain\":false}"};
    char *out = NULL;
    size_t len = 0;
    char err[256];
    /* "seed" is a top-level scalar of the spec: the root's (`--set seed=2`
     * sets it); a leading dot names the root for any key. */
    assert_int_equal(
        sylva_cli_build_spec(base, sizeof base - 1, NULL, sets, 3, &out, &len, err, sizeof err),
        SYLVA_EXIT_OK);
    assert_string_equal(out, "{\"method\":\"slicing\",\"slicing\":{\"slices\":4},"
                             "\"seed\":9,\"lod\":{\"chain\":false}}");
    free(out);
    assert_int_equal(
        sylva_cli_build_spec("[1]", 3, "slicing", sets, 1, &out, &len, err, sizeof err),
        SYLVA_EXIT_USAGE);
    assert_non_null(strstr(err, "not a JSON object"));
    const char *clash[] = {"scene.viewer=1", "scene.viewer.x=2"};
    assert_int_equal(
        sylva_cli_build_spec(NULL, 0, "slicing", clash, 2, &out, &len, err, sizeof err),
        SYLVA_EXIT_USAGE);
    assert_non_null(strstr(err, "scene"));
}

static const char REPORT[] =
    "{\"lods\":[{\"name\":\"lod0\",\"quads\":48,\"triangles\":96,\"accuracy\":["
    "{\"pixels\":64,\"iou_mean\":0.8,\"color_error_mean\":0.1},"
    "{\"pixels\":256,\"iou_mean\":0.9,\"color_error_mean\":0.05}]},"
    "{\"name\":\"lod1\",\"quads\":12,\"triangles\":24}],"
    "\"times\":{\"import\":0.5,\"bake\":2.25,\"total\":3}}";
static const char PLANES[] =
    "{\"lods\":[{\"name\":\"lod0\",\"atlas\":{\"width\":2048,\"height\":1024}},"
    "{\"name\":\"lod1\",\"atlas\":{\"width\":512,\"height\":512}}]}";

static void summary_collects_lods_planes_atlas_accuracy_and_times(void **state)
{
    (void)state;
    cJSON *s = sylva_cli_summary(NULL, REPORT, PLANES);
    assert_non_null(s);
    const cJSON *lods = cJSON_GetObjectItem(s, "lods");
    assert_int_equal(cJSON_GetArraySize(lods), 2);
    assert_true(cJSON_GetObjectItem(s, "planes")->valuedouble == 60);
    assert_true(cJSON_GetObjectItem(s, "atlas_texels")->valuedouble == 2048.0 * 1024 + 512 * 512);
    const cJSON *l0 = cJSON_GetArrayItem(lods, 0);
    const cJSON *acc = cJSON_GetObjectItem(l0, "accuracy");
    /* The closest view (most pixels) is the one reported. */
    assert_true(cJSON_GetObjectItem(acc, "pixels")->valuedouble == 256);
    assert_true(cJSON_GetObjectItem(acc, "iou_mean")->valuedouble == 0.9);
    assert_true(cJSON_GetArrayItem(cJSON_GetObjectItem(l0, "atlas"), 0)->valuedouble == 2048);
    assert_null(cJSON_GetObjectItem(cJSON_GetArrayItem(lods, 1), "accuracy"));
    assert_true(cJSON_GetObjectItem(cJSON_GetObjectItem(s, "times"), "bake")->valuedouble == 2.25);
    char text[1024];
    sylva_cli_summary_format(s, text, sizeof text);
    assert_non_null(strstr(text, "LODs: 2, planes: 60"));
    assert_non_null(strstr(text, "atlas 2048x1024"));
    assert_non_null(strstr(text, "IoU 0.900"));
    assert_non_null(strstr(text, "bake 2.25s"));
    cJSON_Delete(s);
}

static void summary_falls_back_to_the_job_times_and_survives_missing_files(void **state)
{
    (void)state;
    cJSON *s = sylva_cli_summary("{\"key\":\"k\",\"times\":{\"import\":1.5}}", NULL, "not json");
    assert_non_null(s);
    assert_null(cJSON_GetObjectItem(s, "lods"));
    assert_true(cJSON_GetObjectItem(cJSON_GetObjectItem(s, "times"), "import")->valuedouble == 1.5);
    char text[8];
    size_t want = sylva_cli_summary_format(s, text, sizeof text);
    assert_true(want > sizeof text);
    assert_int_equal(strlen(text), sizeof text - 1); /* truncated, terminated */
    cJSON_Delete(s);
}

/* An unmet target is in the summary (report.json's, else the
 * status document's), printed with its reason, and gives exit 3. */
static void summary_carries_an_unmet_target_and_its_reason(void **state)
{
    (void)state;
    const char *report =
        "{\"target\":{\"goal\":{\"iou\":0.99},\"met\":false,\"chosen\":2,"
        "\"reason\":\"goal IoU 0.99: no setting reached it\",\"tries\":[{},{},{}]}}";
    cJSON *s = sylva_cli_summary(NULL, report, NULL);
    const cJSON *t = cJSON_GetObjectItem(s, "target");
    assert_true(cJSON_IsFalse(cJSON_GetObjectItem(t, "met")));
    assert_null(cJSON_GetObjectItem(t, "tries"));
    char text[1024];
    sylva_cli_summary_format(s, text, sizeof text);
    assert_non_null(strstr(text, "  target not met: goal IoU 0.99: no setting reached it\n"));
    assert_int_equal(sylva_cli_done_exit_code(s), SYLVA_EXIT_TARGET);
    cJSON_Delete(s);
    /* without report.json: the status document's "target" */
    s = sylva_cli_summary("{\"key\":\"k\",\"target\":{\"met\":false,\"reason\":\"why\"}}", NULL,
                          NULL);
    assert_int_equal(sylva_cli_done_exit_code(s), SYLVA_EXIT_TARGET);
    sylva_cli_summary_format(s, text, sizeof text);
    assert_non_null(strstr(text, "target not met: why"));
    cJSON_Delete(s);
    /* met, or no target at all: exit 0 */
    s = sylva_cli_summary(NULL, "{\"target\":{\"met\":true,\"chosen\":0}}", NULL);
    assert_int_equal(sylva_cli_done_exit_code(s), SYLVA_EXIT_OK);
    sylva_cli_summary_format(s, text, sizeof text);
    assert_non_null(strstr(text, "  target met\n"));
    cJSON_Delete(s);
    s = sylva_cli_summary(NULL, REPORT, PLANES);
    assert_int_equal(sylva_cli_done_exit_code(s), SYLVA_EXIT_OK);
    sylva_cli_summary_format(s, text, sizeof text);
    assert_null(strstr(text, "target"));
    cJSON_Delete(s);
}

/* `sylva status` of a done bake has no report.json, only the status
 * document, whose manifest carries report.json's summary: the levels come
 * from there, each with its triangles; a mesh level shows no planes and no
 * atlas ("0 planes atlas 0x0" before). */
static void summary_of_a_status_document_lists_each_level_with_its_triangles(void **state)
{
    (void)state;
    const char *job =
        "{\"key\":\"k\",\"state\":\"done\",\"manifest\":{\"artifacts\":[],\"summary\":{"
        "\"lods\":[{\"name\":\"full\",\"quads\":0,\"triangles\":3616,\"texels\":0,"
        "\"accuracy\":[{\"pixels\":64,\"iou_mean\":1}]},"
        "{\"name\":\"crossed\",\"quads\":2,\"triangles\":4,\"texels\":16384}]}}}";
    cJSON *s = sylva_cli_summary(job, NULL, NULL);
    const cJSON *lods = cJSON_GetObjectItem(s, "lods");
    assert_int_equal(cJSON_GetArraySize(lods), 2);
    assert_true(cJSON_GetObjectItem(cJSON_GetArrayItem(lods, 0), "triangles")->valuedouble == 3616);
    char text[1024];
    sylva_cli_summary_format(s, text, sizeof text);
    assert_non_null(strstr(text, "full"));
    assert_non_null(strstr(text, "3616 triangles"));
    assert_non_null(strstr(text, "4 triangles"));
    assert_non_null(strstr(text, "2 planes"));
    assert_null(strstr(text, "0 planes"));
    assert_null(strstr(text, "0x0"));
    cJSON_Delete(s);
}

static void progress_lines_show_stage_and_percent(void **state)
{
    (void)state;
    char buf[128];
    sylva_cli_progress_format("oak.glb", "bake", 0.42, 0, 0, -1, false, buf, sizeof buf);
    assert_string_equal(buf, "oak.glb: bake 42%");
    sylva_cli_progress_format("oak.glb", "pack", 0.5, 0, 0, -1, true, buf, sizeof buf);
    assert_non_null(strstr(buf, "[##########..........]"));
    assert_non_null(strstr(buf, " 50%"));
    assert_null(strchr(buf, '\r'));
    sylva_cli_progress_format("x", "write", 7.0, 0, 0, -1, false, buf, sizeof buf);
    assert_string_equal(buf, "x: write 100%");
    /* a target search's try and the elapsed time */
    sylva_cli_progress_format("t.obj", "bake", 0.3, 2, 4, 3.14, false, buf, sizeof buf);
    assert_string_equal(buf, "t.obj: bake 30% (try 2 of at most 4), 3.1 s");
    sylva_cli_progress_format("t.obj", "bake", 0.3, 2, 4, 12.0, true, buf, sizeof buf);
    assert_non_null(strstr(buf, "bake      try 2/4   12.0 s"));
}

static void exit_codes_separate_input_service_integrity_and_cancel(void **state)
{
    (void)state;
    assert_int_equal(sylva_cli_exit_code(SYLVA_OK), 0);
    assert_int_equal(sylva_cli_exit_code(SYLVA_ERR_BAKE_FAILED), SYLVA_EXIT_FAILED);
    assert_int_equal(sylva_cli_exit_code(SYLVA_ERR_REJECTED), SYLVA_EXIT_FAILED);
    assert_int_equal(sylva_cli_exit_code(SYLVA_ERR_ARG), SYLVA_EXIT_USAGE);
    assert_int_equal(sylva_cli_exit_code(SYLVA_ERR_CONNECT), SYLVA_EXIT_SERVICE);
    assert_int_equal(sylva_cli_exit_code(SYLVA_ERR_BUSY), SYLVA_EXIT_SERVICE);
    assert_int_equal(sylva_cli_exit_code(SYLVA_ERR_INTEGRITY), SYLVA_EXIT_INTEGRITY);
    assert_int_equal(sylva_cli_exit_code(SYLVA_ERR_CANCELLED), SYLVA_EXIT_CANCELLED);
}

/* A batch: any failure outranks an unmet target, which outranks success. */
static void batch_exit_puts_failures_before_an_unmet_target(void **state)
{
    (void)state;
    assert_int_equal(SYLVA_EXIT_TARGET, 3);
    assert_int_equal(sylva_cli_worse_exit(SYLVA_EXIT_TARGET, SYLVA_EXIT_SERVICE),
                     SYLVA_EXIT_SERVICE);
    assert_int_equal(sylva_cli_worse_exit(SYLVA_EXIT_OK, SYLVA_EXIT_TARGET), SYLVA_EXIT_TARGET);
    assert_int_equal(sylva_cli_worse_exit(SYLVA_EXIT_TARGET, SYLVA_EXIT_OK), SYLVA_EXIT_TARGET);
    assert_int_equal(sylva_cli_worse_exit(SYLVA_EXIT_TARGET, SYLVA_EXIT_FAILED), SYLVA_EXIT_FAILED);
    assert_int_equal(sylva_cli_worse_exit(SYLVA_EXIT_SERVICE, SYLVA_EXIT_TARGET),
                     SYLVA_EXIT_SERVICE);
    assert_int_equal(sylva_cli_worse_exit(SYLVA_EXIT_FAILED, SYLVA_EXIT_CANCELLED),
                     SYLVA_EXIT_CANCELLED);
    assert_int_equal(sylva_cli_worse_exit(SYLVA_EXIT_OK, SYLVA_EXIT_OK), SYLVA_EXIT_OK);
}

/* docs/client.md's exit table: the numbers sylva-bake uses too. */
static void exit_table_is_the_one_both_tools_share(void **state)
{
    (void)state;
    assert_int_equal(SYLVA_EXIT_OK, 0);
    assert_int_equal(SYLVA_EXIT_FAILED, 1);
    assert_int_equal(SYLVA_EXIT_USAGE, 2);
    assert_int_equal(SYLVA_EXIT_TARGET, 3);
    assert_int_equal(SYLVA_EXIT_INTEGRITY, 4);
    assert_int_equal(SYLVA_EXIT_CANCELLED, 5);
    assert_int_equal(SYLVA_EXIT_SERVICE, 6);
    assert_int_equal(sylva_cli_exit_code(SYLVA_ERR_IO), SYLVA_EXIT_FAILED);
    assert_int_equal(sylva_cli_exit_code(SYLVA_ERR_TIMEOUT), SYLVA_EXIT_SERVICE);
}

/* --units, --up, -o, -q and -v: the flags sylva-bake bake takes too. */
static void shared_flags_become_sets_and_short_options(void **state)
{
    (void)state;
    char *argv[] = {"sylva", "bake",   "t.obj", "-o", "out",   "--units",
                    "cm",    "--up=Z", "-q",    "-v", "--set", "billboard_cloud.lods=[20]",
                    NULL};
    sylva_cli cli;
    char err[256];
    assert_int_equal(sylva_cli_parse(12, argv, NULL, NULL, &cli, err, sizeof err), SYLVA_EXIT_OK);
    assert_string_equal(cli.out, "out");
    assert_true(cli.quiet && cli.verbose);
    assert_int_equal(cli.progress, SYLVA_PROGRESS_NONE);
    char *spec = NULL;
    size_t len = 0;
    assert_int_equal(
        sylva_cli_build_spec(NULL, 0, NULL, cli.sets, cli.set_count, &spec, &len, err, sizeof err),
        SYLVA_EXIT_OK);
    assert_string_equal(spec, "{\"import\":{\"units\":\"cm\",\"up\":\"Z\"},"
                              "\"billboard_cloud\":{\"lods\":[20]}}");
    free(spec);
    sylva_cli_free(&cli);
    char *bad[] = {"sylva", "bake", "t.obj", "-o", "out", "--up", "X", NULL};
    assert_int_equal(sylva_cli_parse(7, bad, NULL, NULL, &cli, err, sizeof err), SYLVA_EXIT_USAGE);
    assert_non_null(strstr(err, "--up expects Y, Z or auto"));
    sylva_cli_free(&cli);
}

typedef struct refs {
    char list[512];
} refs;

static void collect(void *user, const char *ref)
{
    refs *r = user;
    strcat(r->list, ref);
    strcat(r->list, "|");
}

/* The references companions.h finds, and the ones it will not follow. */
static void references_are_found_and_unsafe_ones_named(void **state)
{
    (void)state;
    refs r = {""};
    const char obj[] = "# x\nmtllib tree.mtl\r\nv 0 0 0\n  mtllib sub/more.mtl  \n";
    sylva_refs_scan("t.obj", (const unsigned char *)obj, sizeof obj - 1, collect, &r);
    assert_string_equal(r.list, "tree.mtl|sub/more.mtl|");
    r.list[0] = 0;
    const char mtl[] = "newmtl a\nmap_Kd -s 1 1 1 leaf.png\nmap_d  alpha.png\nKd 1 1 1\n";
    sylva_refs_scan("t.mtl", (const unsigned char *)mtl, sizeof mtl - 1, collect, &r);
    assert_string_equal(r.list, "leaf.png|alpha.png|");
    r.list[0] = 0;
    const char gltf[] = "{\"buffers\":[{\"uri\":\"t.bin\"},{\"uri\":\"data:application/"
                        "octet-stream;base64,AA==\"}],\"images\":[{\"uri\":\"my%20leaf.png\"}]}";
    sylva_refs_scan("t.gltf", (const unsigned char *)gltf, sizeof gltf - 1, collect, &r);
    assert_string_equal(r.list, "t.bin|my leaf.png|");
    assert_null(sylva_ref_unsafe("leaf.png"));
    assert_null(sylva_ref_unsafe("textures/leaf.png"));
    assert_non_null(sylva_ref_unsafe("/etc/passwd"));
    assert_non_null(sylva_ref_unsafe("../x.png"));
    assert_non_null(sylva_ref_unsafe("a\\..\\x.png"));
    assert_non_null(sylva_ref_unsafe("file:x.png"));
    assert_non_null(sylva_ref_unsafe("C:x.png"));
    assert_non_null(sylva_ref_unsafe(""));
}

/* The summary table: triangles of a mesh level, IoU at 64 px truncated. */
static void summary_table_shows_triangles_and_iou_at_64_truncated(void **state)
{
    (void)state;
    cJSON *rep = cJSON_Parse("{\"lods\":[{\"name\":\"full\",\"file\":\"lod0_full.glb\","
                             "\"triangles\":3616,\"texels\":0,\"switch_pixels\":1080.4,"
                             "\"accuracy\":[{\"pixels\":64,\"iou_mean\":0.98769}]}]}");
    char buf[1024] = "";
    FILE *f = fmemopen(buf, sizeof buf, "w");
    assert_int_equal(sylva_summary_table(rep, NULL, f), 1);
    fclose(f);
    assert_non_null(strstr(buf, "level"));
    assert_non_null(strstr(buf, "full                   3616          0       1080   0.987  "
                                "lod0_full.glb"));
    cJSON_Delete(rep);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(parse_reads_bake_options_before_and_after_the_command),
        cmocka_unit_test(servers_come_from_repeated_and_comma_separated_options),
        cmocka_unit_test(environment_gives_server_and_token_when_no_option_does),
        cmocka_unit_test(retries_and_progress_mode_are_parsed),
        cmocka_unit_test(usage_errors_name_the_problem),
        cmocka_unit_test(one_mesh_takes_every_other_file_as_companion),
        cmocka_unit_test(several_meshes_take_companions_from_their_own_directory),
        cmocka_unit_test(ambiguous_companion_is_refused_with_a_hint),
        cmocka_unit_test(double_dash_separates_explicit_groups_and_same_stems_keep_extensions),
        cmocka_unit_test(mesh_extensions_are_recognised_in_any_case),
        cmocka_unit_test(spec_file_is_sent_byte_for_byte_without_set),
        cmocka_unit_test(set_values_parse_as_json_else_string_and_dotted_keys_start_at_the_root),
        cmocka_unit_test(set_overrides_a_spec_file_and_uses_its_method),
        cmocka_unit_test(summary_collects_lods_planes_atlas_accuracy_and_times),
        cmocka_unit_test(summary_falls_back_to_the_job_times_and_survives_missing_files),
        cmocka_unit_test(progress_lines_show_stage_and_percent),
        cmocka_unit_test(exit_codes_separate_input_service_integrity_and_cancel),
        cmocka_unit_test(summary_carries_an_unmet_target_and_its_reason),
        cmocka_unit_test(summary_of_a_status_document_lists_each_level_with_its_triangles),
        cmocka_unit_test(batch_exit_puts_failures_before_an_unmet_target),
        cmocka_unit_test(exit_table_is_the_one_both_tools_share),
        cmocka_unit_test(shared_flags_become_sets_and_short_options),
        cmocka_unit_test(references_are_found_and_unsafe_ones_named),
        cmocka_unit_test(summary_table_shows_triangles_and_iou_at_64_truncated),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
