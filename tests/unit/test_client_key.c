/* test_client_key.c — libsylva's content key framing (docs/api.md) against
 * vectors computed independently with printf | sha256sum in the shell:
 *
 *   printf 'sylva-key-v1\nspec 20\n{"method":"slicing"}\nmesh tree.obj 8\nv 0 0 0\n\n'\
 *          'file Z.bin 4\n\x00\x01\x02\xff\nfile a.mtl 9\nnewmtl x\n\nfile b.png 3\nPNG\n'
 *     | sha256sum  -> 9207de66...5757e
 *   printf 'sylva-key-v1\nspec 2\n{}\nmesh m.glb 0\n\n' | sha256sum -> fa64bd07...80c87
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "out_names.h"
#include "sylva.h"

static const char KEY_FULL[] = "9207de668be070a3c0789675f160f56da87fcee0ef08aeb3de533abc2a55757e";
static const char KEY_EMPTY[] = "fa64bd07ab3a13a73519d26f3eccfec23d3d8c9f49b7364c09a3091084480c87";

static const char SPEC[] = "{\"method\":\"slicing\"}";
static const char MESH[] = "v 0 0 0\n";
static const char MTL[] = "newmtl x\n";
static const unsigned char BIN[] = {0x00, 0x01, 0x02, 0xff};

static void key_matches_shell_vector_with_companions_in_any_order(void **state)
{
    (void)state;
    /* Given out of order: the framing sorts them bytewise (Z < a < b). */
    sylva_file files[3] = {
        {.name = "b.png", .data = "PNG", .size = 3},
        {.name = "a.mtl", .data = MTL, .size = sizeof MTL - 1},
        {.name = "Z.bin", .data = BIN, .size = sizeof BIN},
    };
    sylva_input in = {.spec = SPEC,
                      .spec_len = sizeof SPEC - 1,
                      .mesh = {.name = "tree.obj", .data = MESH, .size = sizeof MESH - 1},
                      .files = files,
                      .file_count = 3};
    char key[SYLVA_KEY_HEX + 1];
    char err[256];
    assert_int_equal(sylva_key_compute(&in, key, err, sizeof err), SYLVA_OK);
    assert_string_equal(key, KEY_FULL);
    sylva_file rev[3] = {files[2], files[0], files[1]};
    in.files = rev;
    assert_int_equal(sylva_key_compute(&in, key, err, sizeof err), SYLVA_OK);
    assert_string_equal(key, KEY_FULL);
}

static void key_of_files_on_disk_equals_key_of_same_bytes_in_memory(void **state)
{
    (void)state;
    char dir[] = "/tmp/sylva_keytest_XXXXXX";
    assert_non_null(mkdtemp(dir));
    char p_mesh[256], p_mtl[256], p_bin[256], p_png[256];
    snprintf(p_mesh, sizeof p_mesh, "%s/tree.obj", dir);
    snprintf(p_mtl, sizeof p_mtl, "%s/a.mtl", dir);
    snprintf(p_bin, sizeof p_bin, "%s/Z.bin", dir);
    snprintf(p_png, sizeof p_png, "%s/b.png", dir);
    const struct {
        const char *path;
        const void *data;
        size_t size;
    } w[4] = {{p_mesh, MESH, sizeof MESH - 1},
              {p_mtl, MTL, sizeof MTL - 1},
              {p_bin, BIN, sizeof BIN},
              {p_png, "PNG", 3}};
    for (int i = 0; i < 4; i++) {
        FILE *f = fopen(w[i].path, "wb");
        assert_non_null(f);
        assert_int_equal(fwrite(w[i].data, 1, w[i].size, f), w[i].size);
        fclose(f);
    }
    /* Upload names default to the base names of the paths. */
    sylva_file files[3] = {{.path = p_png}, {.path = p_bin}, {.path = p_mtl}};
    sylva_input in = {.spec = SPEC,
                      .spec_len = sizeof SPEC - 1,
                      .mesh = {.path = p_mesh},
                      .files = files,
                      .file_count = 3};
    char key[SYLVA_KEY_HEX + 1];
    char err[256];
    assert_int_equal(sylva_key_compute(&in, key, err, sizeof err), SYLVA_OK);
    assert_string_equal(key, KEY_FULL);
    char hex[SYLVA_KEY_HEX + 1];
    assert_int_equal(sylva_sha256_file(p_png, hex), SYLVA_OK);
    /* printf 'PNG' | sha256sum */
    char want[SYLVA_KEY_HEX + 1];
    assert_int_equal(sylva_sha256_hex("PNG", 3, want), SYLVA_OK);
    assert_string_equal(hex, want);
    for (int i = 0; i < 4; i++) unlink(w[i].path);
    rmdir(dir);
}

static void empty_or_missing_spec_counts_as_braces(void **state)
{
    (void)state;
    sylva_input in = {.mesh = {.name = "m.glb", .data = "", .size = 0}};
    char key[SYLVA_KEY_HEX + 1];
    assert_int_equal(sylva_key_compute(&in, key, NULL, 0), SYLVA_OK);
    assert_string_equal(key, KEY_EMPTY);
    in.spec = "";
    in.spec_len = 0;
    assert_int_equal(sylva_key_compute(&in, key, NULL, 0), SYLVA_OK);
    assert_string_equal(key, KEY_EMPTY);
    in.spec = "{}";
    in.spec_len = 2;
    assert_int_equal(sylva_key_compute(&in, key, NULL, 0), SYLVA_OK);
    assert_string_equal(key, KEY_EMPTY);
    /* One changed spec byte changes the key. */
    in.spec = "{ }";
    in.spec_len = 3;
    assert_int_equal(sylva_key_compute(&in, key, NULL, 0), SYLVA_OK);
    assert_string_not_equal(key, KEY_EMPTY);
}

static void sha256_of_abc_is_the_fips_vector(void **state)
{
    (void)state;
    char hex[SYLVA_KEY_HEX + 1];
    assert_int_equal(sylva_sha256_hex("abc", 3, hex), SYLVA_OK);
    assert_string_equal(hex, "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
}

static void key_refuses_duplicate_companion_names(void **state)
{
    (void)state;
    sylva_file files[2] = {{.name = "a.png", .data = "1", .size = 1},
                           {.name = "a.png", .data = "2", .size = 1}};
    sylva_input in = {
        .mesh = {.name = "t.obj", .data = "x", .size = 1}, .files = files, .file_count = 2};
    char key[SYLVA_KEY_HEX + 1];
    char err[256] = "";
    assert_int_equal(sylva_key_compute(&in, key, err, sizeof err), SYLVA_ERR_ARG);
    assert_non_null(strstr(err, "duplicate"));
    /* A companion named like the mesh is a duplicate too. */
    files[1].name = "t.obj";
    assert_int_equal(sylva_key_compute(&in, key, err, sizeof err), SYLVA_ERR_ARG);
}

static void key_refuses_names_that_are_not_base_names(void **state)
{
    (void)state;
    const char *bad[] = {"../x.png", "a/b.png",    "a\\b.png",  ".",
                         "..",       "sp ace.png", "tab\t.png", ""};
    char key[SYLVA_KEY_HEX + 1];
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        sylva_file f = {.name = bad[i], .data = "1", .size = 1};
        sylva_input in = {
            .mesh = {.name = "t.obj", .data = "x", .size = 1}, .files = &f, .file_count = 1};
        char err[256] = "";
        assert_int_equal(sylva_key_compute(&in, key, err, sizeof err), SYLVA_ERR_ARG);
        assert_true(err[0] != '\0');
        assert_false(sylva_name_valid(bad[i]));
    }
    char longname[300];
    memset(longname, 'a', 256);
    longname[256] = '\0';
    assert_false(sylva_name_valid(longname));
    longname[255] = '\0';
    assert_true(sylva_name_valid(longname));
    assert_true(sylva_name_valid("leaves_oak_color.png"));
}

static void key_reports_a_missing_file_by_name(void **state)
{
    (void)state;
    sylva_input in = {.mesh = {.path = "/nonexistent/dir/tree.obj"}};
    char key[SYLVA_KEY_HEX + 1];
    char err[256] = "";
    assert_int_equal(sylva_key_compute(&in, key, err, sizeof err), SYLVA_ERR_IO);
    assert_non_null(strstr(err, "/nonexistent/dir/tree.obj"));
}

static void status_table_has_a_name_and_message_for_every_code(void **state)
{
    (void)state;
    for (int s = 0; s < SYLVA_STATUS_COUNT; s++) {
        assert_non_null(sylva_status_name((sylva_status)s));
        assert_true(strlen(sylva_status_message((sylva_status)s)) > 3);
        for (int t = 0; t < s; t++)
            assert_string_not_equal(sylva_status_name((sylva_status)s),
                                    sylva_status_name((sylva_status)t));
    }
    assert_string_equal(sylva_status_name(SYLVA_STATUS_COUNT), "unknown");
}

/* The names a reused --out folder is cleaned of (out_names.h): sylva's own
 * outputs, never a user's file that merely looks alike. */
static void output_names_are_sylvas_own_only(void **state)
{
    (void)state;
    const char *ours[] = {"model.glb",
                          "planes.json",
                          "report.json",
                          "preview.png",
                          "error.json",
                          "impostor.json",
                          "lod0_full.glb",
                          "lod12_clusters32.glb",
                          "atlas_clusters32_albedo.png",
                          "atlas_x_normal.png",
                          "lods.glb",
                          "lods.fbx",
                          "lod2_clusters32.fbx",
                          "tex_0123456789abcdef.png",
                          "tex_fedcba9876543210.jpg"};
    const char *theirs[] = {"tree.glb",
                            "model.gltf",
                            "lod_x.glb",
                            "lodA_x.glb",
                            "lod3.glb",
                            "atlas_.png",
                            "atlas.png",
                            "notes.txt",
                            "report.json.bak",
                            "spec.json",
                            "a/model.glb",
                            "lods.obj",
                            "tree.fbx",
                            "tex_bark.jpg",
                            "tex_0123456789abcdeg.png",
                            "tex_0123456789abcdef.tga"};
    for (size_t i = 0; i < sizeof ours / sizeof ours[0]; i++)
        assert_true(sylva_is_output_name(ours[i]));
    for (size_t i = 0; i < sizeof theirs / sizeof theirs[0]; i++) {
        if (sylva_is_output_name(theirs[i])) print_error("%s\n", theirs[i]);
        assert_false(sylva_is_output_name(theirs[i]));
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(key_matches_shell_vector_with_companions_in_any_order),
        cmocka_unit_test(key_of_files_on_disk_equals_key_of_same_bytes_in_memory),
        cmocka_unit_test(empty_or_missing_spec_counts_as_braces),
        cmocka_unit_test(sha256_of_abc_is_the_fips_vector),
        cmocka_unit_test(key_refuses_duplicate_companion_names),
        cmocka_unit_test(key_refuses_names_that_are_not_base_names),
        cmocka_unit_test(key_reports_a_missing_file_by_name),
        cmocka_unit_test(status_table_has_a_name_and_message_for_every_code),
        cmocka_unit_test(output_names_are_sylvas_own_only),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
