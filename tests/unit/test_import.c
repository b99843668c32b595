/* sylva-test: cost=10 (tests/run.sh starts the longest first) */
/* test_import.c — format sniffing, upload name resolution, the glTF precheck and
 * mesh import (core/io/sniff.c, core/io/gltf_precheck.c, core/io/import.c).
 *
 * Bad inputs are generated here; the real trees come from $SYLVA_DATA (skipped
 * with a message when it is not set). */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <cmocka.h>
#include "gltf.h"
#include "test_data.h"
#include "test_skip.h"

#include <dirent.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "import.h"
#include "validate.h"
#include "image_io.h"

/* ---------- helpers ---------- */

typedef struct upload {
    sv_file files[32];
    char *names[32];
    uint8_t *bufs[32];
    size_t count;
} upload;

static void upload_add(upload *u, const char *name, const void *data, size_t size)
{
    assert_true(u->count < 32);
    u->names[u->count] = strdup(name);
    u->bufs[u->count] = malloc(size ? size : 1);
    assert_non_null(u->bufs[u->count]);
    if (size) memcpy(u->bufs[u->count], data, size);
    u->files[u->count] = (sv_file){u->names[u->count], u->bufs[u->count], size};
    u->count++;
}

static void upload_add_str(upload *u, const char *name, const char *text)
{
    upload_add(u, name, text, strlen(text));
}

static void upload_free(upload *u)
{
    for (size_t i = 0; i < u->count; i++) {
        free(u->names[i]);
        free(u->bufs[i]);
    }
    memset(u, 0, sizeof *u);
}

/* Loads dir/main first, then every other regular file of dir. */
static bool upload_dir(upload *u, const char *dir, const char *main)
{
    char path[1024];
    snprintf(path, sizeof path, "%s/%s", dir, main);
    size_t n;
    uint8_t *b = sv_test_read_all(path, &n);
    if (!b) return false;
    upload_add(u, main, b, n);
    free(b);
    DIR *d = opendir(dir);
    assert_non_null(d);
    struct dirent *e;
    /* sorted order is not needed: lookup is by name */
    while ((e = readdir(d))) {
        if (e->d_name[0] == '.' || strcmp(e->d_name, main) == 0) continue;
        const char *ext = strrchr(e->d_name, '.');
        /* the other mesh file of the folder (obj next to glb) is not a companion */
        if (ext && (strcmp(ext, ".glb") == 0 || strcmp(ext, ".obj") == 0)) continue;
        snprintf(path, sizeof path, "%s/%s", dir, e->d_name);
        b = sv_test_read_all(path, &n);
        if (!b) continue;
        upload_add(u, e->d_name, b, n);
        free(b);
    }
    closedir(d);
    return true;
}

static sv_status import_upload(upload *u, const sv_import_options *opt, sv_mesh **m,
                               sv_import_info *info, sv_error *err)
{
    return sv_import(u->files, u->count, opt, m, info, err);
}

/* Imports a single in-memory file and expects failure with `want`, the message
 * containing `needle`. */
static void expect_import_fails(const char *name, const void *data, size_t size, sv_status want,
                                const char *needle)
{
    upload u = {0};
    upload_add(&u, name, data, size);
    sv_mesh *m = (sv_mesh *)1;
    sv_error err = {0};
    sv_status st = import_upload(&u, NULL, &m, NULL, &err);
    if (st != want || !strstr(err.message, needle))
        print_error("got status %s '%s', wanted %s containing '%s'\n", sv_status_code(st),
                    err.message, sv_status_code(want), needle);
    assert_int_equal(st, want);
    assert_null(m);
    assert_non_null(strstr(err.message, needle));
    upload_free(&u);
}

/* A GLB with one triangle (3 vertices, uint16 indices). `index2` is the third
 * index, so a value >= 3 makes it point beyond the vertices. */
static uint8_t *make_glb(uint16_t index2, size_t *size)
{
    const float pos[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    const uint16_t idx[4] = {0, 1, index2, 0}; /* padded to 8 bytes */
    char json[1024];
    int jn = snprintf(json, sizeof json,
                      "{\"asset\":{\"version\":\"2.0\"},\"scene\":0,\"scenes\":[{\"nodes\":[0]}],"
                      "\"nodes\":[{\"mesh\":0}],\"meshes\":[{\"primitives\":[{\"attributes\":"
                      "{\"POSITION\":0},\"indices\":1}]}],\"accessors\":["
                      "{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\","
                      "\"min\":[0,0,0],\"max\":[1,1,0]},"
                      "{\"bufferView\":1,\"componentType\":5123,\"count\":3,\"type\":\"SCALAR\"}],"
                      "\"bufferViews\":[{\"buffer\":0,\"byteOffset\":0,\"byteLength\":36},"
                      "{\"buffer\":0,\"byteOffset\":36,\"byteLength\":6}],"
                      "\"buffers\":[{\"byteLength\":44}]}");
    while (jn % 4) json[jn++] = ' ';
    size_t bin = 44, total = 12 + 8 + (size_t)jn + 8 + bin;
    uint8_t *b = calloc(1, total);
    uint32_t h[3] = {0x46546C67u, 2, (uint32_t)total};
    memcpy(b, h, 12);
    uint32_t c0[2] = {(uint32_t)jn, 0x4E4F534Au};
    memcpy(b + 12, c0, 8);
    memcpy(b + 20, json, (size_t)jn);
    uint32_t c1[2] = {(uint32_t)bin, 0x004E4942u};
    memcpy(b + 20 + jn, c1, 8);
    memcpy(b + 28 + jn, pos, 36);
    memcpy(b + 28 + jn + 36, idx, 8);
    *size = total;
    return b;
}

/* A .gltf whose only buffer has the given uri (geometry irrelevant: the
 * precheck refuses the reference before anything else). */
static void expect_buffer_uri_refused(const char *uri, const char *needle)
{
    char json[512];
    snprintf(json, sizeof json,
             "{\"asset\":{\"version\":\"2.0\"},\"buffers\":[{\"uri\":\"%s\",\"byteLength\":12}]}",
             uri);
    expect_import_fails("scene.gltf", json, strlen(json), SV_ERR_REFUSED, needle);
}

static const char *tri_obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";

/* ---------- sniffing ---------- */

static void sniff_recognises_each_accepted_format_by_its_bytes(void **state)
{
    (void)state;
    static const struct {
        const char *bytes;
        sv_format want;
    } cases[] = {
        {"glTF\x02\0\0\0", SV_FORMAT_GLB},
        {"  {\"asset\":{\"version\":\"2.0\"}}", SV_FORMAT_GLTF},
        {"# exported\nmtllib a.mtl\nv 0 0 0\n", SV_FORMAT_OBJ},
        {"ply\nformat ascii 1.0\nelement vertex 3\n", SV_FORMAT_PLY},
        {"Kaydara FBX Binary  \0\x1a", SV_FORMAT_FBX},
        {"; FBX 7.4.0 project file\n", SV_FORMAT_FBX},
        {"<?xml version=\"1.0\"?>\n<COLLADA xmlns=\"x\">", SV_FORMAT_COLLADA},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        size_t n = strlen(cases[i].bytes);
        if (cases[i].want == SV_FORMAT_FBX && cases[i].bytes[0] == 'K') n = 22;
        assert_int_equal(sv_sniff_format((const uint8_t *)cases[i].bytes, n), cases[i].want);
    }
    assert_string_equal(sv_format_name(SV_FORMAT_GLB), "glb");
    assert_string_equal(sv_format_name(SV_FORMAT_COLLADA), "dae");
}

static void sniff_rejects_other_formats_and_noise(void **state)
{
    (void)state;
    const char *texts[] = {"",
                           "x",
                           "{\"not\":\"gltf\"}",
                           "<html><body></body></html>",
                           "hello world\nthis is text\n",
                           "\x89PNG\r\n\x1a\n",
                           "solid cube\nfacet normal 0 0 1\n" /* STL: not accepted */};
    for (size_t i = 0; i < sizeof texts / sizeof texts[0]; i++)
        assert_int_equal(sv_sniff_format((const uint8_t *)texts[i], strlen(texts[i])),
                         SV_FORMAT_UNKNOWN);
    uint8_t noise[4096];
    uint64_t s = 12345;
    for (int trial = 0; trial < 50; trial++) {
        for (size_t i = 0; i < sizeof noise; i++) {
            s = s * 6364136223846793005ull + 1442695040888963407ull;
            noise[i] = (uint8_t)(s >> 56);
        }
        sv_format f = sv_sniff_format(noise, sizeof noise);
        assert_int_equal(f, SV_FORMAT_UNKNOWN);
    }
}

/* ---------- upload name resolution ---------- */

static void upload_find_refuses_names_that_leave_the_upload(void **state)
{
    (void)state;
    sv_file files[] = {{"secret.png", (const uint8_t *)"x", 1},
                       {"passwd", (const uint8_t *)"x", 1}};
    const char *bad[] = {"/etc/passwd",
                         "../secret.png",
                         "a/../../secret.png",
                         "..\\secret.png",
                         "tex\\..\\..\\secret.png",
                         "\\\\server\\share\\secret.png",
                         "file:secret.png",
                         "file:///etc/passwd",
                         "http://example.com/secret.png",
                         "C:\\textures\\secret.png",
                         "c:secret.png",
                         "..",
                         "",
                         "%2e%2e/secret.png",
                         "%2Fetc%2Fpasswd",
                         "a/%2E%2E%5C%2E%2E%5Csecret.png"};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        size_t idx = 99;
        sv_error err = {0};
        assert_int_equal(sv_upload_find(files, 2, bad[i], &idx, &err), SV_ERR_REFUSED);
        assert_int_equal(idx, 99);
        if (bad[i][0]) assert_non_null(strstr(err.message, "refused"));
    }
}

static void upload_find_matches_exact_then_base_name_then_case(void **state)
{
    (void)state;
    sv_file files[] = {
        {"tree.obj", NULL, 0}, {"textures/leaf.png", NULL, 0}, {"Bark.JPG", NULL, 0}};
    size_t idx = 0;
    assert_int_equal(sv_upload_find(files, 3, "textures/leaf.png", &idx, NULL), SV_OK);
    assert_int_equal(idx, 1);
    assert_int_equal(sv_upload_find(files, 3, "maps\\leaf.png", &idx, NULL), SV_OK);
    assert_int_equal(idx, 1);
    assert_int_equal(sv_upload_find(files, 3, "./bark.jpg", &idx, NULL), SV_OK);
    assert_int_equal(idx, 2);
    sv_error err = {0};
    assert_int_equal(sv_upload_find(files, 3, "missing.png", &idx, &err), SV_ERR_IO);
    assert_non_null(strstr(err.message, "missing.png"));
}

/* ---------- glTF precheck ---------- */

static void precheck_accepts_a_minimal_glb(void **state)
{
    (void)state;
    size_t n;
    uint8_t *glb = make_glb(2, &n);
    sv_error err = {0};
    assert_int_equal(sv_gltf_precheck(glb, n, true, NULL, 0, NULL, &err), SV_OK);
    free(glb);
}

static void glb_truncated_at_several_lengths_is_refused(void **state)
{
    (void)state;
    size_t n;
    uint8_t *glb = make_glb(2, &n);
    const size_t cuts[] = {4, 11, 12, 16, 19, 20, 60, n / 2, n - 44, n - 9, n - 1};
    for (size_t i = 0; i < sizeof cuts / sizeof cuts[0]; i++) {
        sv_error err = {0};
        assert_int_equal(sv_gltf_precheck(glb, cuts[i], true, NULL, 0, NULL, &err), SV_ERR_PARSE);
        assert_non_null(strstr(err.message, "truncated"));
        expect_import_fails("tree.glb", glb, cuts[i], SV_ERR_PARSE, "truncated");
    }
    /* shorter than the magic: not recognisable as anything */
    expect_import_fails("tree.glb", glb, 3, SV_ERR_FORMAT, "not a mesh format");
    free(glb);
}

static void glb_whose_header_length_lies_is_refused(void **state)
{
    (void)state;
    size_t n;
    uint8_t *glb = make_glb(2, &n);
    uint32_t len = (uint32_t)n - 8; /* says shorter than it is */
    memcpy(glb + 8, &len, 4);
    expect_import_fails("tree.glb", glb, n, SV_ERR_PARSE, "header length lies");
    len = (uint32_t)n + 1000; /* says longer: looks truncated */
    memcpy(glb + 8, &len, 4);
    expect_import_fails("tree.glb", glb, n, SV_ERR_PARSE, "header says");
    len = (uint32_t)n;
    memcpy(glb + 8, &len, 4);
    uint32_t chunk = 0x7fffffff; /* JSON chunk length lies */
    memcpy(glb + 12, &chunk, 4);
    expect_import_fails("tree.glb", glb, n, SV_ERR_PARSE, "chunk 0 says");
    free(glb);
}

static void glb_index_beyond_vertex_count_is_refused(void **state)
{
    (void)state;
    size_t n;
    uint8_t *glb = make_glb(7, &n);
    expect_import_fails("tree.glb", glb, n, SV_ERR_INVALID, "triangle 0 refers to vertex 7 of 3");
    free(glb);
}

static void gltf_buffer_uri_outside_the_upload_is_refused(void **state)
{
    (void)state;
    expect_buffer_uri_refused("/etc/passwd", "/etc/passwd");
    expect_buffer_uri_refused("../tree.bin", "../tree.bin");
    expect_buffer_uri_refused("sub/../../tree.bin", "..");
    expect_buffer_uri_refused("file:///etc/passwd", "file:///etc/passwd");
    expect_buffer_uri_refused("file:tree.bin", "file:tree.bin");
    expect_buffer_uri_refused("%2e%2e/tree.bin", "../tree.bin");
    expect_buffer_uri_refused("%2Fetc%2Fpasswd", "/etc/passwd");
    expect_buffer_uri_refused("https://example.com/tree.bin", "https:");
    expect_buffer_uri_refused("..\\\\tree.bin", "..");
    expect_buffer_uri_refused("not-uploaded.bin", "not among the uploaded files");
}

static void gltf_with_deep_node_chain_is_refused_before_assimp(void **state)
{
    (void)state;
    const int depth = 20000;
    size_t cap = (size_t)depth * 24 + 256, len = 0;
    char *j = malloc(cap);
    len += (size_t)snprintf(
        j + len, cap - len,
        "{\"asset\":{\"version\":\"2.0\"},\"scenes\":[{\"nodes\":[0]}],\"nodes\":[");
    for (int i = 0; i < depth; i++) {
        if (i + 1 < depth)
            len += (size_t)snprintf(j + len, cap - len, "{\"children\":[%d]},", i + 1);
        else len += (size_t)snprintf(j + len, cap - len, "{}");
    }
    len += (size_t)snprintf(j + len, cap - len, "]}");
    sv_error err = {0};
    assert_int_equal(sv_gltf_precheck((uint8_t *)j, len, false, NULL, 0, NULL, &err), SV_ERR_LIMIT);
    assert_non_null(strstr(err.message, "deeper than 256 levels"));
    /* Through the importer: assimp 5.2.5 would overflow its stack on this. */
    expect_import_fails("deep.gltf", j, len, SV_ERR_LIMIT, "deeper than 256 levels");
    free(j);
}

static void gltf_node_cycles_and_shared_children_are_refused(void **state)
{
    (void)state;
    const char *cycle = "{\"asset\":{\"version\":\"2.0\"},\"nodes\":[{\"children\":[1]},"
                        "{\"children\":[2]},{\"children\":[1]}]}";
    const char *self = "{\"asset\":{\"version\":\"2.0\"},\"nodes\":[{\"children\":[0]}]}";
    const char *two_parents = "{\"asset\":{\"version\":\"2.0\"},\"nodes\":[{\"children\":[2]},"
                              "{\"children\":[2]},{}]}";
    const char *bad_child = "{\"asset\":{\"version\":\"2.0\"},\"nodes\":[{\"children\":[5]}]}";
    sv_error err = {0};
    assert_int_equal(
        sv_gltf_precheck((const uint8_t *)cycle, strlen(cycle), false, NULL, 0, NULL, &err),
        SV_ERR_PARSE);
    assert_non_null(strstr(err.message, "child of both"));
    assert_int_equal(
        sv_gltf_precheck((const uint8_t *)self, strlen(self), false, NULL, 0, NULL, &err),
        SV_ERR_PARSE);
    assert_non_null(strstr(err.message, "cycle through node 0"));
    assert_int_equal(sv_gltf_precheck((const uint8_t *)two_parents, strlen(two_parents), false,
                                      NULL, 0, NULL, &err),
                     SV_ERR_PARSE);
    assert_non_null(strstr(err.message, "node 2 is a child of both"));
    assert_int_equal(
        sv_gltf_precheck((const uint8_t *)bad_child, strlen(bad_child), false, NULL, 0, NULL, &err),
        SV_ERR_PARSE);
    assert_non_null(strstr(err.message, "not a node index"));
}

static void gltf_declared_counts_over_limits_are_refused(void **state)
{
    (void)state;
    size_t n;
    uint8_t *glb = make_glb(2, &n);
    sv_limits lim = {.max_triangles = 0, .max_nodes = 0};
    sv_error err = {0};
    assert_int_equal(sv_gltf_precheck(glb, n, true, NULL, 0, &lim, &err), SV_OK);
    /* one node instancing one triangle: a limit of zero triangles is "default";
     * instead ask for fewer nodes than there are */
    const char *nodes = "{\"asset\":{\"version\":\"2.0\"},\"nodes\":[{},{},{}]}";
    lim.max_nodes = 2;
    assert_int_equal(
        sv_gltf_precheck((const uint8_t *)nodes, strlen(nodes), false, NULL, 0, &lim, &err),
        SV_ERR_LIMIT);
    assert_non_null(strstr(err.message, "3 nodes (limit 2)"));
    /* an accessor whose count × stride overruns its bufferView */
    char *j = malloc(n);
    memcpy(j, glb, n);
    char *c = strstr(j + 20, "\"count\":3,\"type\":\"VEC3\"");
    assert_non_null(c);
    memcpy(c, "\"count\":9", 9);
    sv_error e2 = {0};
    assert_int_equal(sv_gltf_precheck((uint8_t *)j, n, true, NULL, 0, NULL, &e2), SV_ERR_PARSE);
    assert_non_null(strstr(e2.message, "accessor 0 needs"));
    free(j);
    free(glb);
}

static void gltf_version_1_and_bad_json_are_refused(void **state)
{
    (void)state;
    const char *v1 = "{\"asset\":{\"version\":\"1.0\"}}";
    expect_import_fails("old.gltf", v1, strlen(v1), SV_ERR_FORMAT, "version '1.0'");
    const char *bad = "{\"asset\":{\"version\":\"2.0\"},\"nodes\":[{]}";
    expect_import_fails("bad.gltf", bad, strlen(bad), SV_ERR_PARSE, "JSON syntax error");
}

/* The JSON and BIN chunk of make_glb, as a .gltf with the buffer given by `uri`
 * ("%s" is replaced by nothing: the caller supplies the whole uri). */
static char *gltf_from_glb(const char *uri, uint8_t bin[44])
{
    size_t n;
    uint8_t *glb = make_glb(2, &n);
    uint32_t jn;
    memcpy(&jn, glb + 12, 4);
    memcpy(bin, glb + 28 + jn, 44);
    char *json = malloc(jn + 1);
    memcpy(json, glb + 20, jn);
    json[jn] = 0;
    const char *from = "\"buffers\":[{\"byteLength\":44}]";
    char *at = strstr(json, from);
    assert_non_null(at);
    size_t cap = jn + strlen(uri) + 64;
    char *out = malloc(cap);
    snprintf(out, cap, "%.*s\"buffers\":[{\"uri\":\"%s\",\"byteLength\":44}]%s", (int)(at - json),
             json, uri, at + strlen(from));
    free(json);
    free(glb);
    return out;
}

static void gltf_with_uploaded_bin_or_data_uri_imports(void **state)
{
    (void)state;
    uint8_t bin[44];
    char *json = gltf_from_glb("tri%20data.bin", bin);
    upload u = {0};
    upload_add_str(&u, "scene.gltf", json);
    upload_add(&u, "tri data.bin", bin, sizeof bin);
    sv_mesh *m = NULL;
    sv_import_info info;
    sv_error err = {0};
    sv_status st = import_upload(&u, NULL, &m, &info, &err);
    if (st != SV_OK) print_error("%s\n", err.message);
    assert_int_equal(st, SV_OK);
    assert_int_equal(info.format, SV_FORMAT_GLTF);
    assert_int_equal(m->triangle_count, 1);
    sv_mesh_destroy(m);
    upload_free(&u);
    free(json);
    /* the same bytes inline */
    static const char b64[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    char uri[200] = "data:application/octet-stream;base64,";
    size_t o = strlen(uri);
    for (size_t i = 0; i < 44; i += 3) {
        uint32_t v = (uint32_t)bin[i] << 16 | (i + 1 < 44 ? (uint32_t)bin[i + 1] << 8 : 0) |
                     (i + 2 < 44 ? bin[i + 2] : 0);
        uri[o++] = b64[v >> 18 & 63];
        uri[o++] = b64[v >> 12 & 63];
        uri[o++] = i + 1 < 44 ? b64[v >> 6 & 63] : '=';
        uri[o++] = i + 2 < 44 ? b64[v & 63] : '=';
    }
    uri[o] = 0;
    json = gltf_from_glb(uri, bin);
    upload_add_str(&u, "inline.gltf", json);
    st = import_upload(&u, NULL, &m, &info, &err);
    if (st != SV_OK) print_error("%s\n", err.message);
    assert_int_equal(st, SV_OK);
    assert_int_equal(m->triangle_count, 1);
    sv_mesh_destroy(m);
    upload_free(&u);
    free(json);
}

/* ---------- import: bad inputs ---------- */

static void empty_one_byte_and_random_files_are_refused(void **state)
{
    (void)state;
    expect_import_fails("tree.obj", "", 0, SV_ERR_PARSE, "is empty");
    expect_import_fails("tree.glb", "g", 1, SV_ERR_FORMAT, "not a mesh format");
    uint64_t s = 99;
    for (int trial = 0; trial < 20; trial++) {
        size_t n = 1 + (size_t)(trial * 977) % 5000;
        uint8_t *b = malloc(n);
        for (size_t i = 0; i < n; i++) {
            s = s * 6364136223846793005ull + 1442695040888963407ull;
            b[i] = (uint8_t)(s >> 56);
        }
        expect_import_fails(trial % 2 ? "tree.glb" : "tree.obj", b, n, SV_ERR_FORMAT,
                            "not a mesh format");
        free(b);
    }
}

static void obj_with_nan_or_inf_vertex_is_refused_naming_the_vertex(void **state)
{
    (void)state;
    const char *nan_obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv nan 0 0\nf 1 2 3\nf 2 3 4\n";
    expect_import_fails("nan.obj", nan_obj, strlen(nan_obj), SV_ERR_INVALID,
                        "has a NaN coordinate");
    const char *inf_obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 inf 0\nf 1 2 3\nf 2 3 4\n";
    expect_import_fails("inf.obj", inf_obj, strlen(inf_obj), SV_ERR_INVALID,
                        "has an infinite coordinate");
    /* finite in the file, infinite once scaled to metres */
    upload u = {0};
    upload_add_str(&u, "big.obj", "v 0 0 0\nv 3e38 0 0\nv 0 1 0\nf 1 2 3\n");
    sv_import_options opt = {.unit_scale = 100};
    sv_mesh *m = NULL;
    sv_error err = {0};
    assert_int_equal(import_upload(&u, &opt, &m, NULL, &err), SV_ERR_INVALID);
    assert_non_null(strstr(err.message, "vertex 1 has an infinite coordinate"));
    upload_free(&u);
}

static void obj_face_referencing_a_missing_vertex_is_refused(void **state)
{
    (void)state;
    const char *obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n";
    upload u = {0};
    upload_add_str(&u, "bad.obj", obj);
    sv_mesh *m = NULL;
    sv_error err = {0};
    sv_status st = import_upload(&u, NULL, &m, NULL, &err);
    assert_null(m);
    assert_true(st == SV_ERR_PARSE || st == SV_ERR_INVALID);
    assert_non_null(strstr(err.message, "bad.obj"));
    assert_non_null(strstr(err.message, "index"));
    upload_free(&u);
}

static void ply_renamed_glb_is_imported_as_ply(void **state)
{
    (void)state;
    /* Sniffing decides, not the name: PLY is an accepted format, so the file is
     * imported as PLY (assimp is told "tree.ply"). */
    const char *ply = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
                      "property float y\nproperty float z\nelement face 1\n"
                      "property list uchar int vertex_indices\nend_header\n"
                      "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    upload u = {0};
    upload_add_str(&u, "tree.glb", ply);
    sv_mesh *m = NULL;
    sv_import_info info;
    sv_error err = {0};
    assert_int_equal(import_upload(&u, NULL, &m, &info, &err), SV_OK);
    assert_int_equal(info.format, SV_FORMAT_PLY);
    assert_int_equal(m->triangle_count, 1);
    assert_int_equal(m->vertex_count, 3);
    sv_mesh_destroy(m);
    upload_free(&u);
}

static void limits_are_enforced_before_assimp_allocates(void **state)
{
    (void)state;
    upload u = {0};
    upload_add_str(&u, "quad.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n");
    sv_import_options opt = {.limits = {.max_triangles = 1}};
    sv_mesh *m = NULL;
    sv_error err = {0};
    assert_int_equal(import_upload(&u, &opt, &m, NULL, &err), SV_ERR_LIMIT);
    assert_non_null(strstr(err.message, "2 triangles (limit 1)"));
    opt = (sv_import_options){.limits = {.max_file_bytes = 10}};
    assert_int_equal(import_upload(&u, &opt, &m, NULL, &err), SV_ERR_LIMIT);
    assert_non_null(strstr(err.message, "quad.obj"));
    assert_null(m);
    upload_free(&u);
}

static void bad_units_or_axis_options_are_refused(void **state)
{
    (void)state;
    upload u = {0};
    upload_add_str(&u, "t.obj", tri_obj);
    sv_mesh *m = NULL;
    sv_error err = {0};
    sv_import_options opt = {.up_axis = 'X'};
    assert_int_equal(import_upload(&u, &opt, &m, NULL, &err), SV_ERR_SPEC);
    opt = (sv_import_options){.unit_scale = -1};
    assert_int_equal(import_upload(&u, &opt, &m, NULL, &err), SV_ERR_SPEC);
    upload_free(&u);
}

/* ---------- import: references and textures ---------- */

static uint8_t *png_bytes(uint32_t w, uint32_t h, uint8_t alpha, size_t *size)
{
    sv_image img;
    assert_int_equal(sv_image_alloc(&img, w, h, 4, 8, NULL), SV_OK);
    uint8_t *p = img.data;
    for (size_t i = 0; i < (size_t)w * h; i++) {
        p[4 * i] = 10;
        p[4 * i + 1] = 200;
        p[4 * i + 2] = 30;
        p[4 * i + 3] = i == 0 ? alpha : 255;
    }
    uint8_t *out = NULL;
    assert_int_equal(sv_image_encode_png(&img, &out, size, NULL), SV_OK);
    sv_image_free(&img);
    return out;
}

static const char *uv_obj = "mtllib t.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\n"
                            "usemtl leafy\nf 1/1 2/2 3/3\n";

/* The canary: a texture named ../secret.png or by an absolute path must never be
 * read, even though a file called secret.png is in the upload and one exists on
 * disk at the absolute path. */
static void texture_outside_the_upload_is_never_read(void **state)
{
    (void)state;
    size_t pn;
    uint8_t *png = png_bytes(4, 4, 255, &pn);
    char dir[] = "/tmp/sylva-canary-XXXXXX";
    assert_non_null(mkdtemp(dir));
    char abs_path[256];
    snprintf(abs_path, sizeof abs_path, "%s/secret.png", dir);
    FILE *f = fopen(abs_path, "wb");
    assert_non_null(f);
    fwrite(png, 1, pn, f);
    fclose(f);
    char mtl[512];
    const char *refs[] = {"../secret.png", abs_path, "..\\secret.png", "file:secret.png"};
    for (size_t i = 0; i < sizeof refs / sizeof refs[0]; i++) {
        snprintf(mtl, sizeof mtl, "newmtl leafy\nKd 1 1 1\nmap_Kd %s\n", refs[i]);
        upload u = {0};
        upload_add_str(&u, "t.obj", uv_obj);
        upload_add_str(&u, "t.mtl", mtl);
        upload_add(&u, "secret.png", png, pn);
        sv_mesh *m = NULL;
        sv_import_info info;
        sv_error err = {0};
        assert_int_equal(import_upload(&u, NULL, &m, &info, &err), SV_ERR_REFUSED);
        assert_null(m);
        assert_int_equal(info.textures_decoded, 0);
        assert_non_null(strstr(err.message, "refused"));
        upload_free(&u);
    }
    /* same through a glTF image uri */
    char json[512];
    snprintf(json, sizeof json, "{\"asset\":{\"version\":\"2.0\"},\"images\":[{\"uri\":\"%s\"}]}",
             abs_path);
    expect_import_fails("t.gltf", json, strlen(json), SV_ERR_REFUSED, abs_path);
    const char *rel = "{\"asset\":{\"version\":\"2.0\"},\"images\":[{\"uri\":\"../secret.png\"}]}";
    expect_import_fails("t.gltf", rel, strlen(rel), SV_ERR_REFUSED, "../secret.png");
    unlink(abs_path);
    rmdir(dir);
    free(png);
}

static void mtllib_outside_the_upload_is_refused(void **state)
{
    (void)state;
    const char *obj = "mtllib ../../etc/t.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    upload u = {0};
    upload_add_str(&u, "t.obj", obj);
    upload_add_str(&u, "t.mtl", "newmtl a\nKd 1 0 0\n");
    sv_mesh *m = NULL;
    sv_error err = {0};
    assert_int_equal(import_upload(&u, NULL, &m, NULL, &err), SV_ERR_REFUSED);
    assert_non_null(strstr(err.message, "../../etc/t.mtl"));
    upload_free(&u);
}

/* Honest outcomes: a base-colour texture the .mtl names that was
 * not supplied fails the import by default, naming the file and the way on. */
static void missing_texture_fails_naming_it_by_default(void **state)
{
    (void)state;
    upload u = {0};
    upload_add_str(&u, "t.obj", uv_obj);
    upload_add_str(&u, "t.mtl", "newmtl leafy\nKd 0.5 0.5 0.5\nmap_Kd leaf.png\n");
    sv_mesh *m = (sv_mesh *)1;
    sv_import_info info;
    sv_error err = {0};
    assert_int_equal(import_upload(&u, NULL, &m, &info, &err), SV_ERR_MISSING);
    assert_null(m);
    assert_string_equal(sv_status_code(SV_ERR_MISSING), "missing");
    if (!strstr(err.message, "'t.obj' references a file that was not supplied: leaf.png") ||
        !strstr(err.message, "\"missing_files\": \"warn\""))
        fail_msg("message: %s", err.message);
    assert_int_equal(info.files_missing, 1);
    assert_string_equal(info.missing_files, "leaf.png");
    upload_free(&u);
}

/* With import.missing_files "warn" the same upload imports: the material
 * keeps its colour and the warning names the file. */
static void missing_texture_is_a_warning_with_missing_files_warn(void **state)
{
    (void)state;
    upload u = {0};
    upload_add_str(&u, "t.obj", uv_obj);
    upload_add_str(&u, "t.mtl", "newmtl leafy\nKd 0.5 0.5 0.5\nmap_Kd leaf.png\n");
    sv_mesh *m = NULL;
    sv_import_info info;
    sv_error err = {0};
    sv_import_options opt = {.missing_files_warn = true};
    assert_int_equal(import_upload(&u, &opt, &m, &info, &err), SV_OK);
    assert_int_equal(info.textures_missing, 1);
    assert_int_equal(info.textures_decoded, 0);
    assert_int_equal(info.files_missing, 1);
    assert_non_null(strstr(info.warnings, "'leaf.png' was not supplied"));
    assert_int_equal(m->materials[m->tri_material[0]].base_texture, -1);
    assert_float_equal(m->materials[m->tri_material[0]].base_color[0], 0.5, 1e-6);
    sv_mesh_destroy(m);
    upload_free(&u);
}

/* A missing mtllib: an error by default; with "warn" the mesh imports grey and
 * the warning names the .mtl once (assimp asks for "x.mtl", "./x.mtl" and its
 * "<stem>.mtl" guess: only the name the OBJ gives is reported). */
static void missing_mtl_fails_by_default_and_is_a_warning_with_warn(void **state)
{
    (void)state;
    const char *obj = "mtllib leaves.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl leafy\nf 1 2 3\n";
    upload u = {0};
    upload_add_str(&u, "t.obj", obj);
    sv_mesh *m = (sv_mesh *)1;
    sv_import_info info;
    sv_error err = {0};
    assert_int_equal(import_upload(&u, NULL, &m, &info, &err), SV_ERR_MISSING);
    assert_null(m);
    if (!strstr(err.message, "not supplied: leaves.mtl. Supply it"))
        fail_msg("message: %s", err.message);
    assert_string_equal(info.missing_files, "leaves.mtl");
    sv_import_options opt = {.missing_files_warn = true};
    assert_int_equal(import_upload(&u, &opt, &m, &info, &err), SV_OK);
    assert_int_equal(info.files_missing, 1);
    assert_non_null(
        strstr(info.warnings, "'leaves.mtl' was not supplied: its materials are plain grey"));
    assert_null(strstr(info.warnings, "t.mtl"));
    sv_mesh_destroy(m);
    upload_free(&u);
}

/* An OBJ whose mtllib names another file than the one uploaded beside it:
 * assimp reads "<stem>.mtl" instead, so nothing is lost: a warning, no error. */
static void missing_mtl_is_forgiven_when_the_stem_mtl_is_read(void **state)
{
    (void)state;
    const char *obj = "mtllib old_name.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl red\nf 1 2 3\n";
    upload u = {0};
    upload_add_str(&u, "t.obj", obj);
    upload_add_str(&u, "t.mtl", "newmtl red\nKd 1 0 0\n");
    sv_mesh *m = NULL;
    sv_import_info info;
    sv_error err = {0};
    sv_status st = import_upload(&u, NULL, &m, &info, &err);
    if (st != SV_OK) fail_msg("%s", err.message);
    assert_int_equal(info.files_missing, 0);
    assert_non_null(strstr(
        info.warnings, "'old_name.mtl' was not supplied: the materials were read from 't.mtl'"));
    assert_float_equal(m->materials[m->tri_material[0]].base_color[0], 1.0, 1e-6);
    sv_mesh_destroy(m);
    upload_free(&u);
}

/* Every missing file is named once, however many materials use it. */
static void every_missing_file_is_named_once(void **state)
{
    (void)state;
    const char *obj = "mtllib t.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 0 1\n"
                      "usemtl a\nf 1/1 2/2 3/3\nusemtl b\nf 2/2 4/1 3/3\nusemtl c\nf 1/1 4/2 2/3\n";
    const char *mtl = "newmtl a\nmap_Kd leaf.png\nnewmtl b\nmap_Kd leaf.png\n"
                      "newmtl c\nmap_Kd bark.jpg\n";
    upload u = {0};
    upload_add_str(&u, "t.obj", obj);
    upload_add_str(&u, "t.mtl", mtl);
    sv_mesh *m = NULL;
    sv_import_info info;
    sv_error err = {0};
    assert_int_equal(import_upload(&u, NULL, &m, &info, &err), SV_ERR_MISSING);
    assert_int_equal(info.files_missing, 2);
    assert_string_equal(info.missing_files, "leaf.png, bark.jpg");
    if (!strstr(err.message,
                "references 2 files that were not supplied: leaf.png, bark.jpg. Supply them"))
        fail_msg("message: %s", err.message);
    upload_free(&u);
}

/* Many missing files: the count is exact, the list and the warnings are cut
 * short saying so, and room is left for the checks after import. */
static void many_missing_files_are_counted_and_never_dropped_silently(void **state)
{
    (void)state;
    char obj[8192] = "mtllib t.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\n";
    char mtl[8192] = "";
    for (int i = 0; i < 60; i++) {
        size_t n = strlen(obj), k = strlen(mtl);
        snprintf(obj + n, sizeof obj - n, "usemtl m%02d\nf 1/1 2/2 3/3\n", i);
        snprintf(mtl + k, sizeof mtl - k,
                 "newmtl m%02d\nmap_Kd a_rather_long_texture_name_%02d.png\n", i, i);
    }
    upload u = {0};
    upload_add_str(&u, "t.obj", obj);
    upload_add_str(&u, "t.mtl", mtl);
    sv_mesh *m = NULL;
    sv_import_info info;
    sv_error err = {0};
    assert_int_equal(import_upload(&u, NULL, &m, &info, &err), SV_ERR_MISSING);
    assert_int_equal(info.files_missing, 60);
    if (!strstr(err.message,
                "references 60 files that were not supplied: a_rather_long_texture_name_00.png"))
        fail_msg("message: %s", err.message);
    assert_non_null(strstr(info.missing_files, ", ..."));
    sv_import_options opt = {.missing_files_warn = true};
    assert_int_equal(import_upload(&u, &opt, &m, &info, &err), SV_OK);
    assert_true(info.warnings_left_out > 0);
    assert_non_null(strstr(info.warnings, "more import warnings were left out"));
    assert_true(strlen(info.warnings) < sizeof info.warnings - 512); /* room for plausibility */
    sv_mesh_destroy(m);
    upload_free(&u);
}

/* glTF: an image uri that was not uploaded is the same error (a missing
 * buffer stays a refusal: the geometry cannot be read without it). */
static void gltf_image_not_uploaded_fails_naming_it(void **state)
{
    (void)state;
    uint8_t bin[44];
    char *base = gltf_from_glb("t.bin", bin);
    const char *from = "\"indices\":1}]}]";
    char *at = strstr(base, from);
    assert_non_null(at);
    char json[2048];
    snprintf(json, sizeof json,
             "%.*s\"indices\":1,\"material\":0}]}],\"materials\":[{\"name\":\"leaf\","
             "\"pbrMetallicRoughness\":{\"baseColorTexture\":{\"index\":0}}}],"
             "\"textures\":[{\"source\":0}],\"images\":[{\"uri\":\"leaf.png\"}]%s",
             (int)(at - base), base, at + strlen(from));
    upload u = {0};
    upload_add_str(&u, "t.gltf", json);
    upload_add(&u, "t.bin", bin, sizeof bin);
    sv_mesh *m = NULL;
    sv_import_info info;
    sv_error err = {0};
    assert_int_equal(import_upload(&u, NULL, &m, &info, &err), SV_ERR_MISSING);
    if (!strstr(err.message, "not supplied: leaf.png")) fail_msg("message: %s", err.message);
    sv_import_options opt = {.missing_files_warn = true};
    sv_status st = import_upload(&u, &opt, &m, &info, &err);
    if (st != SV_OK) fail_msg("%s", err.message);
    assert_non_null(strstr(info.warnings, "'leaf.png' was not supplied"));
    sv_mesh_destroy(m);
    upload_free(&u);
    free(base);
}

/* A texture that was supplied but does not decode stays a warning (the file
 * is there; its bytes are the problem): the default does not refuse it. */
static void undecodable_texture_stays_a_warning(void **state)
{
    (void)state;
    upload u = {0};
    upload_add_str(&u, "t.obj", uv_obj);
    upload_add_str(&u, "t.mtl", "newmtl leafy\nKd 0.5 0.5 0.5\nmap_Kd leaf.png\n");
    upload_add_str(&u, "leaf.png", "not a png at all");
    sv_mesh *m = NULL;
    sv_import_info info;
    sv_error err = {0};
    sv_status st = import_upload(&u, NULL, &m, &info, &err);
    if (st != SV_OK) fail_msg("%s", err.message);
    assert_int_equal(info.files_missing, 0);
    assert_int_equal(info.textures_missing, 1);
    assert_non_null(strstr(info.warnings, "leaf.png"));
    sv_mesh_destroy(m);
    upload_free(&u);
}

static const sv_material *material_named(const sv_mesh *m, const char *name)
{
    for (uint32_t i = 0; i < m->material_count; i++)
        if (strcmp(m->materials[i].name, name) == 0) return &m->materials[i];
    return NULL;
}

static void obj_alpha_rules_give_mask_blend_and_double_sided(void **state)
{
    (void)state;
    size_t opaque_n, cut_n;
    uint8_t *opaque = png_bytes(4, 4, 255, &opaque_n);
    uint8_t *cut = png_bytes(4, 4, 0, &cut_n);
    const char *obj = "mtllib t.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nv 2 0 0\nv 2 1 0\n"
                      "v 3 0 0\nv 3 1 0\nvt 0 0\n"
                      "usemtl mapd\nf 1/1 2/1 3/1\nusemtl rgba\nf 2/1 4/1 3/1\n"
                      "usemtl glass\nf 2/1 5/1 4/1\nusemtl bark\nf 5/1 6/1 4/1\n"
                      "usemtl plain\nf 5/1 7/1 6/1\n";
    const char *mtl = "newmtl mapd\nmap_Kd opaque.png\nmap_d opaque.png\n"
                      "newmtl rgba\nmap_Kd cut.png\n"
                      "newmtl glass\nKd 0.2 0.3 0.4\nd 0.5\n"
                      "newmtl bark\nKd 0.1 0.1 0.1\nmap_Kd opaque.png\n"
                      "newmtl plain\nKd 0.2 0.3 0.4\n";
    upload u = {0};
    upload_add_str(&u, "t.obj", obj);
    upload_add_str(&u, "t.mtl", mtl);
    upload_add(&u, "opaque.png", opaque, opaque_n);
    upload_add(&u, "cut.png", cut, cut_n);
    sv_mesh *m = NULL;
    sv_import_info info;
    sv_error err = {0};
    assert_int_equal(import_upload(&u, NULL, &m, &info, &err), SV_OK);
    const sv_material *mapd = material_named(m, "mapd"), *rgba = material_named(m, "rgba");
    const sv_material *glass = material_named(m, "glass"), *bark = material_named(m, "bark");
    const sv_material *plain = material_named(m, "plain");
    assert_non_null(mapd);
    assert_non_null(rgba);
    assert_non_null(glass);
    assert_non_null(bark);
    assert_non_null(plain);
    assert_int_equal(mapd->alpha_mode, SV_ALPHA_MASK);
    assert_float_equal(mapd->alpha_cutoff, 0.5, 1e-6);
    assert_true(mapd->double_sided);
    assert_int_equal(rgba->alpha_mode, SV_ALPHA_MASK);
    assert_true(rgba->double_sided);
    assert_int_equal(glass->alpha_mode, SV_ALPHA_BLEND);
    assert_float_equal(glass->base_color[3], 0.5, 1e-6);
    assert_int_equal(bark->alpha_mode, SV_ALPHA_OPAQUE);
    assert_false(bark->double_sided);
    /* MTL: Kd multiplies map_Kd (the textured bark keeps its dark Kd) */
    assert_float_equal(bark->base_color[0], 0.1, 1e-6);
    assert_true(bark->base_texture >= 0);
    assert_int_equal(plain->alpha_mode, SV_ALPHA_OPAQUE);
    assert_float_equal(plain->base_color[2], 0.4, 1e-6);
    /* mapd and bark share opaque.png: decoded once */
    assert_int_equal(info.textures_decoded, 2);
    assert_int_equal(m->image_count, 2);
    assert_int_equal(mapd->base_texture, bark->base_texture);
    assert_string_equal(bark->texture_uri, "opaque.png");
    const sv_image *img = &m->images[rgba->base_texture];
    assert_int_equal(img->width, 4);
    assert_int_equal(((uint8_t *)img->data)[3], 0);
    assert_int_equal(((uint8_t *)img->data)[1], 200);
    sv_mesh_destroy(m);
    upload_free(&u);
    free(opaque);
    free(cut);
}

static void texture_over_the_size_limit_is_refused(void **state)
{
    (void)state;
    size_t n;
    uint8_t *png = png_bytes(64, 8, 255, &n);
    upload u = {0};
    upload_add_str(&u, "t.obj", uv_obj);
    upload_add_str(&u, "t.mtl", "newmtl leafy\nmap_Kd big.png\n");
    upload_add(&u, "big.png", png, n);
    sv_import_options opt = {.limits = {.max_texture_size = 32}};
    sv_mesh *m = NULL;
    sv_error err = {0};
    assert_int_equal(import_upload(&u, &opt, &m, NULL, &err), SV_ERR_LIMIT);
    assert_non_null(strstr(err.message, "64x8"));
    upload_free(&u);
    free(png);
}

/* Decoded-pixel budgets: a texture whose decode would take more memory than
 * max_texture_bytes is refused before its pixels are decoded, and an upload
 * whose textures together decode to more than max_textures_bytes is refused
 * naming the texture that crossed it. */
static void texture_over_the_memory_budgets_is_refused(void **state)
{
    (void)state;
    size_t n;
    uint8_t *png = png_bytes(256, 256, 255, &n); /* 8 bytes a pixel to decode: 512 KiB */
    upload u = {0};
    upload_add_str(&u, "t.obj", uv_obj);
    upload_add_str(&u, "t.mtl", "newmtl leafy\nmap_Kd big.png\n");
    upload_add(&u, "big.png", png, n);
    sv_import_options opt = {.limits = {.max_texture_bytes = 256 * 1024}};
    sv_mesh *m = NULL;
    sv_error err = {0};
    assert_int_equal(import_upload(&u, &opt, &m, NULL, &err), SV_ERR_LIMIT);
    assert_non_null(strstr(err.message, "budget of a texture"));
    upload_free(&u);
    /* two materials of 256 KiB decoded each, an upload budget of 384 KiB */
    upload u2 = {0};
    upload_add_str(&u2, "t.obj",
                   "mtllib t.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 0 1\n"
                   "usemtl a\nf 1/1 2/2 3/3\nusemtl b\nf 2/2 4/1 3/3\n");
    upload_add_str(&u2, "t.mtl", "newmtl a\nmap_Kd a.png\nnewmtl b\nmap_Kd b.png\n");
    upload_add(&u2, "a.png", png, n);
    upload_add(&u2, "b.png", png, n);
    sv_import_options opt2 = {.limits = {.max_textures_bytes = 384 * 1024}};
    m = NULL;
    assert_int_equal(import_upload(&u2, &opt2, &m, NULL, &err), SV_ERR_LIMIT);
    assert_non_null(strstr(err.message, "budget of an upload"));
    upload_free(&u2);
    free(png);
}

static void units_and_z_up_are_converted_to_metres_y_up(void **state)
{
    (void)state;
    upload u = {0};
    upload_add_str(&u, "t.obj", "v 0 0 0\nv 100 0 0\nv 0 0 300\nf 1 2 3\n");
    sv_import_options opt = {.unit_scale = 0.01, .up_axis = 'Z'};
    sv_mesh *m = NULL;
    sv_import_info info;
    sv_error err = {0};
    assert_int_equal(import_upload(&u, &opt, &m, &info, &err), SV_OK);
    assert_float_equal(info.unit_scale, 0.01, 1e-12);
    assert_int_equal(info.up_axis, 'Z'); /* what was converted from */
    double mn[3], mx[3];
    assert_true(sv_mesh_bounds(m, mn, mx));
    assert_float_equal(mx[0], 1.0, 1e-6);
    assert_float_equal(mx[1], 3.0, 1e-6); /* source +Z is now +Y */
    assert_float_equal(mx[2] - mn[2], 0.0, 1e-6);
    /* normals were generated (none in the file) and rotated consistently */
    float ny = m->normals[1], nz = m->normals[2];
    assert_float_equal(ny, 0.0, 1e-6);
    assert_float_equal(fabs(nz), 1.0, 1e-6);
    sv_mesh_destroy(m);
    upload_free(&u);
}

/* An OBJ far from the origin: read in double, written in a local frame whose
 * origin (the grid point nearest the box's centre at its lowest Y) is in
 * info.origin; the local vertices are the same tree's at the origin, bit for
 * bit (float would hold 10^7 only to the unit). Near the origin: origin 0. */
static void far_obj_is_read_in_double_into_a_local_frame(void **state)
{
    (void)state;
    const char *near = "v 0.37 0 0.001\nv 0 0.5 -0.25\nv 0.125 3 0\nf 1 2 3\n";
    const char *far = "v 10000000.37 10000000 10000000.001\nv 10000000 10000000.5 9999999.75\n"
                      "v 10000000.125 10000003 10000000\nf 1 2 3\n";
    sv_mesh *m[2] = {NULL, NULL};
    sv_import_info info[2];
    for (int i = 0; i < 2; i++) {
        upload u = {0};
        upload_add_str(&u, "t.obj", i ? far : near);
        sv_import_options opt = {.unit_scale = 0.2};
        sv_error err = {0};
        assert_int_equal(import_upload(&u, &opt, &m[i], &info[i], &err), SV_OK);
        upload_free(&u);
    }
    for (int k = 0; k < 3; k++) {
        assert_true(info[0].origin[k] == 0);
        assert_float_equal(info[1].origin[k], 2e6, 1e-6);
    }
    assert_int_equal(m[0]->vertex_count, m[1]->vertex_count);
    for (uint32_t i = 0; i < 3 * m[0]->vertex_count; i++)
        assert_true(m[0]->positions[i] == m[1]->positions[i]);
    assert_float_equal(m[1]->positions[0], 0.074, 1e-7); /* 0.37 x 0.2, not 0 or 0.2 */
    sv_mesh_destroy(m[0]);
    sv_mesh_destroy(m[1]);
}

/* make_glb's triangle with its root node given `node` (JSON members after
 * "mesh":0, e.g. ",\"translation\":[1,2,3]"): a new GLB, *size bytes. */
static uint8_t *glb_with_root(const char *node, size_t *size)
{
    size_t n;
    uint8_t *base = make_glb(2, &n);
    uint32_t jn;
    memcpy(&jn, base + 12, 4);
    char json[2048], out[2048];
    memcpy(json, base + 20, jn);
    json[jn] = 0;
    const char *from = "\"nodes\":[{\"mesh\":0";
    char *a = strstr(json, from);
    assert_non_null(a);
    snprintf(out, sizeof out, "%.*s%s%s%s", (int)(a - json), json, from, node, a + strlen(from));
    size_t jl = strlen(out);
    while (jl % 4) out[jl++] = ' ';
    size_t total = 12 + 8 + jl + 8 + 44;
    uint8_t *glb = calloc(1, total);
    assert_non_null(glb);
    uint32_t h[5] = {0x46546C67u, 2, (uint32_t)total, (uint32_t)jl, 0x4E4F534Au};
    memcpy(glb, h, 20);
    memcpy(glb + 20, out, jl);
    memcpy(glb + 20 + jl, base + 20 + jn, 8 + 44);
    free(base);
    *size = total;
    return glb;
}

/* A GLB placed far away by its root node (a translation, or a matrix): the
 * translation is taken off before assimp flattens the scene in float, so the
 * local vertices are the unplaced triangle's, bit for bit. */
static void far_glb_root_translation_is_kept_in_double(void **state)
{
    (void)state;
    const char *roots[3] = {
        "", ",\"translation\":[10000000,20000000.5,-30000000]",
        ",\"matrix\":[1,0,0,0,0,1,0,0,0,0,1,0,10000000,20000000.5,-30000000,1]"};
    sv_mesh *m[3];
    sv_import_info info[3];
    for (int i = 0; i < 3; i++) {
        size_t n;
        uint8_t *glb = glb_with_root(roots[i], &n);
        upload u = {0};
        upload_add(&u, "t.glb", glb, n);
        sv_error err = {0};
        sv_status st = import_upload(&u, NULL, &m[i], &info[i], &err);
        if (st != SV_OK) print_error("%s\n", err.message);
        assert_int_equal(st, SV_OK);
        upload_free(&u);
        free(glb);
    }
    const double want[3] = {1e7, 2e7, -3e7};
    for (int i = 1; i < 3; i++) {
        for (int k = 0; k < 3; k++) assert_true(info[i].origin[k] == want[k]);
        for (uint32_t v = 0; v < 3 * m[0]->vertex_count; v++) /* + 0.5 in y, exact */
            assert_true(m[i]->positions[v] == m[0]->positions[v] + (v % 3 == 1 ? 0.5f : 0.0f));
    }
    for (int i = 0; i < 3; i++) sv_mesh_destroy(m[i]);
}

/* A glTF primitive without normals is drawn flat (glTF 2.0, "Meshes"): its
 * triangles get corners of their own and each corner its face's normal,
 * where shared corners would have smoothed across the fold. A file with no
 * normals at all says so (info.no_normals, the writer's cue), an OBJ too;
 * one with normals does not. */
static void gltf_without_normals_imports_flat_and_says_so(void **state)
{
    (void)state;
    /* two triangles folded along a shared edge: faces +Z and +Y */
    sv_mesh *f = sv_mesh_create(4, 2, 1, 0);
    assert_non_null(f);
    static const float p[4][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, -1}};
    static const uint32_t ix[6] = {0, 1, 2, 1, 0, 3};
    memcpy(f->positions, p, sizeof p);
    memcpy(f->indices, ix, sizeof ix);
    sv_gltf_lod lod = {.name = "folded", .mesh = f, .no_normals = true};
    uint8_t *glb;
    size_t n;
    sv_error err = {0};
    assert_int_equal(sv_gltf_encode_glb(&lod, 1, &glb, &n, &err), SV_OK);
    upload u = {0};
    upload_add(&u, "folded.glb", glb, n);
    sv_mesh *m;
    sv_import_info info;
    assert_int_equal(import_upload(&u, NULL, &m, &info, &err), SV_OK);
    assert_true(info.no_normals);
    assert_int_equal(m->triangle_count, 2);
    assert_int_equal(m->vertex_count, 6);
    for (uint32_t t = 0; t < 2; t++) {
        const uint32_t *c = &m->indices[3 * t];
        const float *a = &m->positions[3 * c[0]], *b = &m->positions[3 * c[1]],
                    *d = &m->positions[3 * c[2]];
        double e1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]},
               e2[3] = {d[0] - a[0], d[1] - a[1], d[2] - a[2]};
        double fn[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                        e1[0] * e2[1] - e1[1] * e2[0]};
        double l = sqrt(fn[0] * fn[0] + fn[1] * fn[1] + fn[2] * fn[2]);
        for (int k = 0; k < 3; k++)
            for (int j = 0; j < 3; j++)
                assert_float_equal(m->normals[3 * c[k] + j], fn[j] / l, 1e-6);
    }
    sv_mesh_destroy(m);
    upload_free(&u);
    free(glb);
    sv_mesh_destroy(f);
    /* an OBJ without "vn" lines has no normals either; one with them has */
    const char *objs[2] = {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
                           "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1\n"};
    for (int i = 0; i < 2; i++) {
        upload o = {0};
        upload_add_str(&o, "t.obj", objs[i]);
        assert_int_equal(import_upload(&o, NULL, &m, &info, &err), SV_OK);
        assert_int_equal(info.no_normals, i == 0);
        sv_mesh_destroy(m);
        upload_free(&o);
    }
}

static void glb_materials_and_transforms_come_through(void **state)
{
    (void)state;
    /* A node with a translation and a MASK, double-sided material. */
    size_t n;
    uint8_t *base = make_glb(2, &n);
    const char *from = "\"nodes\":[{\"mesh\":0}]";
    const char *to = "\"nodes\":[{\"mesh\":0,\"translation\":[0,5,0]}]";
    const char *mat_from = "\"indices\":1}]}]";
    const char *mat_to = "\"indices\":1,\"material\":0}]}],\"materials\":[{\"name\":\"leaf\","
                         "\"alphaMode\":\"MASK\",\"alphaCutoff\":0.3,\"doubleSided\":true,"
                         "\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.2,0.4,0.6,1]}}]";
    uint32_t jn;
    memcpy(&jn, base + 12, 4);
    char json[2048];
    memcpy(json, base + 20, jn);
    json[jn] = 0;
    char *a = strstr(json, from), *b;
    assert_non_null(a);
    char out[2048];
    snprintf(out, sizeof out, "%.*s%s%s", (int)(a - json), json, to, a + strlen(from));
    b = strstr(out, mat_from);
    assert_non_null(b);
    snprintf(json, sizeof json, "%.*s%s%s", (int)(b - out), out, mat_to, b + strlen(mat_from));
    size_t jl = strlen(json);
    while (jl % 4) json[jl++] = ' ';
    size_t total = 12 + 8 + jl + 8 + 44;
    uint8_t *glb = calloc(1, total);
    uint32_t h[5] = {0x46546C67u, 2, (uint32_t)total, (uint32_t)jl, 0x4E4F534Au};
    memcpy(glb, h, 20);
    memcpy(glb + 20, json, jl);
    memcpy(glb + 20 + jl, base + 20 + jn, 8 + 44);
    upload u = {0};
    upload_add(&u, "t.glb", glb, total);
    sv_mesh *m = NULL;
    sv_import_info info;
    sv_error err = {0};
    sv_status st = import_upload(&u, NULL, &m, &info, &err); /* glTF default: metres, Y up */
    if (st != SV_OK) print_error("%s\n", err.message);
    assert_int_equal(st, SV_OK);
    assert_float_equal(info.unit_scale, 1.0, 0);
    double mn[3], mx[3];
    sv_mesh_bounds(m, mn, mx);
    /* the translation is applied; the positions are local, their frame's
     * origin (a grid point near the box's base, 10 m apart for this 1 m
     * box: y 5 rounds up to 10) in info.origin */
    assert_float_equal(info.origin[1], 10.0, 0);
    assert_float_equal(mn[1] + info.origin[1], 5.0, 1e-6);
    assert_float_equal(mx[1] + info.origin[1], 6.0, 1e-6);
    const sv_material *leaf = material_named(m, "leaf");
    assert_non_null(leaf);
    assert_int_equal(leaf->alpha_mode, SV_ALPHA_MASK);
    assert_float_equal(leaf->alpha_cutoff, 0.3, 1e-6);
    assert_true(leaf->double_sided);
    assert_float_equal(leaf->base_color[1], 0.4, 1e-6);
    sv_mesh_destroy(m);
    upload_free(&u);
    free(glb);
    free(base);
}

/* ---------- the real trees ---------- */

/* the shared trees and what their import must give: tests/data/trees.tsv
 * (test_data.h), the one table of them */
static sv_alpha_mode alpha_named(const char *s)
{
    return !strcmp(s, "mask")    ? SV_ALPHA_MASK
           : !strcmp(s, "blend") ? SV_ALPHA_BLEND
                                 : SV_ALPHA_OPAQUE;
}

static void imports_every_tree_in_the_data_set_with_readme_counts(void **state)
{
    (void)state;
    const char *data = sv_test_data("real-tree import");
    sv_test_tree trees[32];
    size_t count = sv_test_trees(trees, 32);
    assert_true(count >= sv_test_trees_min());
    for (size_t i = 0; i < count; i++) {
        const sv_test_tree *tc = &trees[i];
        char dir[1024];
        int len = snprintf(dir, sizeof dir, "%s/%s", data, tc->dir);
        assert_true(len > 0 && (size_t)len < sizeof dir);
        upload u = {0};
        if (!upload_dir(&u, dir, tc->file)) {
            print_error("missing %s/%s\n", dir, tc->file);
            fail();
        }
        sv_import_options opt = {.unit_scale = tc->unit_scale};
        sv_mesh *m = NULL;
        sv_import_info info;
        sv_error err = {0};
        double t0 = sv_now();
        clock_t c0 = clock();
        sv_status st = import_upload(&u, &opt, &m, &info, &err);
        double cpu = (double)(clock() - c0) / CLOCKS_PER_SEC;
        double t1 = sv_now();
        if (st != SV_OK) print_error("%s: %s\n", tc->file, err.message);
        assert_int_equal(st, SV_OK);
        uint32_t imported = m->triangle_count;
        sv_validate_report rep;
        st = sv_validate(m, NULL, &rep, &err);
        if (st != SV_OK) print_error("%s: %s\n", tc->file, err.message);
        assert_int_equal(st, SV_OK);
        uint32_t mat1 = 0;
        for (uint32_t t = 0; t < m->triangle_count; t++)
            if (strcmp(m->materials[m->tri_material[t]].name, tc->material) == 0) mat1++;
        double mn[3], mx[3];
        sv_mesh_bounds(m, mn, mx);
        printf("%-30s %s: imported %u triangles (README %u), after validate %u "
               "(-%u zero-area, -%u duplicate), %u vertices, %u materials, %s %u triangles, "
               "%u textures (%u missing), height %.2f m, import %.3f s wall, %.3f s CPU\n",
               tc->file, sv_format_name(info.format), imported, tc->triangles, m->triangle_count,
               rep.removed_degenerate, rep.removed_duplicate, m->vertex_count, m->material_count,
               tc->material, mat1, info.textures_decoded, info.textures_missing, mx[1] - mn[1],
               t1 - t0, cpu);
        assert_int_equal(imported, tc->triangles);
        assert_int_equal(m->triangle_count + rep.removed_degenerate + rep.removed_duplicate,
                         tc->triangles);
        /* repairs are a small fraction of a real tree */
        assert_true(rep.removed_degenerate + rep.removed_duplicate <= tc->triangles / 100);
        assert_true(mat1 <= tc->material_triangles &&
                    mat1 + tc->material_triangles / 100 >= tc->material_triangles);
        assert_int_equal(info.textures_decoded, tc->textures);
        /* alpha: map_d (bush, ez-tree OBJ), an RGBA texture without map_d
         * (bonsai), glTF's own alphaMode (oak GLB: BLEND) */
        for (uint32_t k = 0; k < m->material_count; k++)
            if (strcmp(m->materials[k].name, tc->material) == 0) {
                assert_int_equal(m->materials[k].alpha_mode, alpha_named(tc->alpha));
                if (alpha_named(tc->alpha) != SV_ALPHA_OPAQUE)
                    assert_true(m->materials[k].double_sided);
            }
        assert_int_equal(info.textures_missing, 0);
        /* plausible tree heights in metres: the cm trees were scaled */
        assert_true(mx[1] - mn[1] > 0.2 && mx[1] - mn[1] < 150.0);
        sv_mesh_destroy(m);
        upload_free(&u);
    }
}

static void scopia_trees_are_in_centimetres_unless_scaled(void **state)
{
    (void)state;
    const char *data = sv_test_data("the Scopia units");
    char dir[1024];
    snprintf(dir, sizeof dir, "%s/scopia_bonsai-tree", data);
    upload u = {0};
    assert_true(upload_dir(&u, dir, "bonsai-tree.obj"));
    double h[2];
    for (int k = 0; k < 2; k++) {
        sv_import_options opt = {.unit_scale = k ? 0.01 : 0};
        sv_mesh *m = NULL;
        assert_int_equal(import_upload(&u, &opt, &m, NULL, NULL), SV_OK);
        double mn[3], mx[3];
        sv_mesh_bounds(m, mn, mx);
        h[k] = mx[1] - mn[1];
        sv_mesh_destroy(m);
    }
    assert_float_equal(h[0] * 0.01, h[1], 1e-4 * h[0]);
    upload_free(&u);
}

static void import_is_deterministic(void **state)
{
    (void)state;
    const char *data = sv_test_data("import determinism");
    char dir[1024];
    snprintf(dir, sizeof dir, "%s/eztree_aspen_small", data);
    upload u = {0};
    assert_true(upload_dir(&u, dir, "aspen_small.obj"));
    sv_mesh *a = NULL, *b = NULL;
    assert_int_equal(import_upload(&u, NULL, &a, NULL, NULL), SV_OK);
    assert_int_equal(import_upload(&u, NULL, &b, NULL, NULL), SV_OK);
    assert_int_equal(a->vertex_count, b->vertex_count);
    assert_int_equal(a->triangle_count, b->triangle_count);
    assert_memory_equal(a->positions, b->positions, 3 * sizeof(float) * a->vertex_count);
    assert_memory_equal(a->indices, b->indices, 3 * sizeof(uint32_t) * a->triangle_count);
    assert_memory_equal(a->uvs, b->uvs, 2 * sizeof(float) * a->vertex_count);
    for (uint32_t i = 0; i < a->image_count; i++)
        assert_memory_equal(a->images[i].data, b->images[i].data,
                            sv_image_stride(&a->images[i]) * a->images[i].height);
    sv_mesh_destroy(a);
    sv_mesh_destroy(b);
    upload_free(&u);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(sniff_recognises_each_accepted_format_by_its_bytes),
        cmocka_unit_test(sniff_rejects_other_formats_and_noise),
        cmocka_unit_test(upload_find_refuses_names_that_leave_the_upload),
        cmocka_unit_test(upload_find_matches_exact_then_base_name_then_case),
        cmocka_unit_test(precheck_accepts_a_minimal_glb),
        cmocka_unit_test(glb_truncated_at_several_lengths_is_refused),
        cmocka_unit_test(glb_whose_header_length_lies_is_refused),
        cmocka_unit_test(glb_index_beyond_vertex_count_is_refused),
        cmocka_unit_test(gltf_buffer_uri_outside_the_upload_is_refused),
        cmocka_unit_test(gltf_with_deep_node_chain_is_refused_before_assimp),
        cmocka_unit_test(gltf_node_cycles_and_shared_children_are_refused),
        cmocka_unit_test(gltf_declared_counts_over_limits_are_refused),
        cmocka_unit_test(gltf_version_1_and_bad_json_are_refused),
        cmocka_unit_test(gltf_with_uploaded_bin_or_data_uri_imports),
        cmocka_unit_test(empty_one_byte_and_random_files_are_refused),
        cmocka_unit_test(obj_with_nan_or_inf_vertex_is_refused_naming_the_vertex),
        cmocka_unit_test(obj_face_referencing_a_missing_vertex_is_refused),
        cmocka_unit_test(ply_renamed_glb_is_imported_as_ply),
        cmocka_unit_test(limits_are_enforced_before_assimp_allocates),
        cmocka_unit_test(texture_over_the_memory_budgets_is_refused),
        cmocka_unit_test(bad_units_or_axis_options_are_refused),
        cmocka_unit_test(texture_outside_the_upload_is_never_read),
        cmocka_unit_test(mtllib_outside_the_upload_is_refused),
        cmocka_unit_test(missing_texture_fails_naming_it_by_default),
        cmocka_unit_test(missing_texture_is_a_warning_with_missing_files_warn),
        cmocka_unit_test(missing_mtl_fails_by_default_and_is_a_warning_with_warn),
        cmocka_unit_test(missing_mtl_is_forgiven_when_the_stem_mtl_is_read),
        cmocka_unit_test(every_missing_file_is_named_once),
        cmocka_unit_test(many_missing_files_are_counted_and_never_dropped_silently),
        cmocka_unit_test(gltf_image_not_uploaded_fails_naming_it),
        cmocka_unit_test(undecodable_texture_stays_a_warning),
        cmocka_unit_test(obj_alpha_rules_give_mask_blend_and_double_sided),
        cmocka_unit_test(texture_over_the_size_limit_is_refused),
        cmocka_unit_test(units_and_z_up_are_converted_to_metres_y_up),
        cmocka_unit_test(far_obj_is_read_in_double_into_a_local_frame),
        cmocka_unit_test(far_glb_root_translation_is_kept_in_double),
        cmocka_unit_test(gltf_without_normals_imports_flat_and_says_so),
        cmocka_unit_test(glb_materials_and_transforms_come_through),
        cmocka_unit_test(imports_every_tree_in_the_data_set_with_readme_counts),
        cmocka_unit_test(scopia_trees_are_in_centimetres_unless_scaled),
        cmocka_unit_test(import_is_deterministic),
    };
    return sv_test_exit(cmocka_run_group_tests(tests, NULL, NULL));
}
