/* Unit tests: server/key.c — content key framing, names, SHA-256 helpers.
 * The expected keys were computed independently with Python's hashlib over
 * the framing documented in docs/api.md. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "key.h"

static const char spec[] = "{\"method\":\"x\"}";
static const char mesh[] = "v 0 0 0\n";

static void key_matches_documented_framing(void **state)
{
    (void)state;
    svd_key_part s = {.data = (const uint8_t *)spec, .size = strlen(spec)};
    svd_key_part m = {.name = "tree.obj", .data = (const uint8_t *)mesh, .size = strlen(mesh)};
    svd_key_part f[2] = {{.name = "b.png", .data = (const uint8_t *)"\x89PNG", .size = 4},
                         {.name = "a.mtl", .data = (const uint8_t *)"newmtl m\n", .size = 9}};
    char k[SVD_KEY_HEX];
    assert_int_equal(svd_key_compute(&s, &m, f, 2, k, NULL), SV_OK);
    assert_string_equal(k, "1230599077439815640abf9dfe42b62c109efb4e38938921408ddac29212793c");
}

static void key_orders_companion_files_by_name(void **state)
{
    (void)state;
    svd_key_part s = {.data = (const uint8_t *)spec, .size = strlen(spec)};
    svd_key_part m = {.name = "tree.obj", .data = (const uint8_t *)mesh, .size = strlen(mesh)};
    svd_key_part f1[2] = {{.name = "a.mtl", .data = (const uint8_t *)"newmtl m\n", .size = 9},
                          {.name = "b.png", .data = (const uint8_t *)"\x89PNG", .size = 4}};
    svd_key_part f2[2] = {f1[1], f1[0]};
    char k1[SVD_KEY_HEX], k2[SVD_KEY_HEX];
    assert_int_equal(svd_key_compute(&s, &m, f1, 2, k1, NULL), SV_OK);
    assert_int_equal(svd_key_compute(&s, &m, f2, 2, k2, NULL), SV_OK);
    assert_string_equal(k1, k2);
}

static void key_treats_empty_spec_as_empty_object(void **state)
{
    (void)state;
    svd_key_part empty = {.data = (const uint8_t *)"", .size = 0};
    svd_key_part m = {.name = "m.glb", .data = (const uint8_t *)"", .size = 0};
    char k1[SVD_KEY_HEX], k2[SVD_KEY_HEX];
    assert_int_equal(svd_key_compute(&empty, &m, NULL, 0, k1, NULL), SV_OK);
    assert_int_equal(svd_key_compute(NULL, &m, NULL, 0, k2, NULL), SV_OK);
    assert_string_equal(k1, "fa64bd07ab3a13a73519d26f3eccfec23d3d8c9f49b7364c09a3091084480c87");
    assert_string_equal(k1, k2);
}

static void key_from_files_equals_key_from_memory(void **state)
{
    (void)state;
    char dir[] = "/tmp/svkeyXXXXXX";
    assert_non_null(mkdtemp(dir));
    char mp[64], sp[64];
    snprintf(mp, sizeof mp, "%s/tree.obj", dir);
    snprintf(sp, sizeof sp, "%s/spec.json", dir);
    FILE *f = fopen(mp, "wb");
    fwrite(mesh, 1, strlen(mesh), f);
    fclose(f);
    f = fopen(sp, "wb");
    fwrite(spec, 1, strlen(spec), f);
    fclose(f);
    svd_key_part s1 = {.data = (const uint8_t *)spec, .size = strlen(spec)};
    svd_key_part m1 = {.name = "tree.obj", .data = (const uint8_t *)mesh, .size = strlen(mesh)};
    svd_key_part s2 = {.path = sp};
    svd_key_part m2 = {.name = "tree.obj", .path = mp};
    char k1[SVD_KEY_HEX], k2[SVD_KEY_HEX];
    assert_int_equal(svd_key_compute(&s1, &m1, NULL, 0, k1, NULL), SV_OK);
    assert_int_equal(svd_key_compute(&s2, &m2, NULL, 0, k2, NULL), SV_OK);
    assert_string_equal(k1, k2);
    unlink(mp);
    unlink(sp);
    rmdir(dir);
}

static void key_changes_when_one_byte_changes(void **state)
{
    (void)state;
    svd_key_part s = {.data = (const uint8_t *)spec, .size = strlen(spec)};
    svd_key_part m = {.name = "tree.obj", .data = (const uint8_t *)mesh, .size = strlen(mesh)};
    svd_key_part m2 = {.name = "tree.obj", .data = (const uint8_t *)"v 0 0 1\n", .size = 8};
    svd_key_part m3 = {.name = "tree2.obj", .data = (const uint8_t *)mesh, .size = strlen(mesh)};
    char k1[SVD_KEY_HEX], k2[SVD_KEY_HEX], k3[SVD_KEY_HEX];
    svd_key_compute(&s, &m, NULL, 0, k1, NULL);
    svd_key_compute(&s, &m2, NULL, 0, k2, NULL);
    svd_key_compute(&s, &m3, NULL, 0, k3, NULL);
    assert_string_not_equal(k1, k2);
    assert_string_not_equal(k1, k3);
}

static void key_refuses_duplicate_and_invalid_names(void **state)
{
    (void)state;
    svd_key_part m = {.name = "tree.obj", .data = (const uint8_t *)mesh, .size = strlen(mesh)};
    svd_key_part dup[2] = {{.name = "a.png", .data = (const uint8_t *)"x", .size = 1},
                           {.name = "a.png", .data = (const uint8_t *)"y", .size = 1}};
    svd_key_part same_as_mesh = {.name = "tree.obj", .data = (const uint8_t *)"x", .size = 1};
    svd_key_part bad = {.name = "../etc/passwd", .data = (const uint8_t *)"x", .size = 1};
    char k[SVD_KEY_HEX];
    sv_error e = {0};
    assert_int_equal(svd_key_compute(NULL, &m, dup, 2, k, &e), SV_ERR_SPEC);
    assert_non_null(strstr(e.message, "duplicate"));
    assert_int_equal(svd_key_compute(NULL, &m, &same_as_mesh, 1, k, &e), SV_ERR_SPEC);
    assert_int_equal(svd_key_compute(NULL, &m, &bad, 1, k, &e), SV_ERR_SPEC);
}

static void names_are_plain_base_names(void **state)
{
    (void)state;
    assert_true(svd_name_valid("tree.glb"));
    assert_true(svd_name_valid("a-b_c.1.png"));
    assert_false(svd_name_valid(""));
    assert_false(svd_name_valid("."));
    assert_false(svd_name_valid(".."));
    assert_false(svd_name_valid("a/b"));
    assert_false(svd_name_valid("a\\b"));
    assert_false(svd_name_valid("a b"));
    assert_false(svd_name_valid("a\nb"));
    assert_false(svd_name_valid("a\x7f"));
    char longname[300];
    memset(longname, 'a', 256);
    longname[256] = '\0';
    assert_false(svd_name_valid(longname));
    longname[255] = '\0';
    assert_true(svd_name_valid(longname));
}

static void keys_are_64_lowercase_hex(void **state)
{
    (void)state;
    assert_true(svd_key_valid("1230599077439815640abf9dfe42b62c109efb4e38938921408ddac29212793c"));
    assert_false(svd_key_valid("1230599077439815640ABF9dfe42b62c109efb4e38938921408ddac29212793c"));
    assert_false(svd_key_valid("123"));
    assert_false(svd_key_valid(NULL));
}

static void sha256_of_abc_is_the_standard_vector(void **state)
{
    (void)state;
    char h[SVD_KEY_HEX];
    svd_sha256_hex("abc", 3, h);
    assert_string_equal(h, "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(key_matches_documented_framing),
        cmocka_unit_test(key_orders_companion_files_by_name),
        cmocka_unit_test(key_treats_empty_spec_as_empty_object),
        cmocka_unit_test(key_from_files_equals_key_from_memory),
        cmocka_unit_test(key_changes_when_one_byte_changes),
        cmocka_unit_test(key_refuses_duplicate_and_invalid_names),
        cmocka_unit_test(names_are_plain_base_names),
        cmocka_unit_test(keys_are_64_lowercase_hex),
        cmocka_unit_test(sha256_of_abc_is_the_standard_vector),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
