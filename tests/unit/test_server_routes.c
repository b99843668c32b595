/* Unit tests: server/routes.c and server/config.c (pure parts of sylvad). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <cjson/cJSON.h>

#include "config.h"
#include "openapi.h"
#include "routes.h"

#define KEY "1230599077439815640abf9dfe42b62c109efb4e38938921408ddac29212793c"

static void routes_map_the_v1_api(void **state)
{
    (void)state;
    svd_route_match m;
    svd_route_find("GET", "/v1/health", &m);
    assert_int_equal(m.route, SVD_R_HEALTH);
    svd_route_find("GET", "/v1/metrics", &m);
    assert_int_equal(m.route, SVD_R_METRICS);
    svd_route_find("HEAD", "/v1/info", &m);
    assert_int_equal(m.route, SVD_R_INFO);
    svd_route_find("POST", "/v1/bakes", &m);
    assert_int_equal(m.route, SVD_R_SUBMIT);
    svd_route_find("PUT", "/v1/bakes/" KEY, &m);
    assert_int_equal(m.route, SVD_R_PUT);
    assert_string_equal(m.key, KEY);
    svd_route_find("GET", "/v1/bakes/" KEY, &m);
    assert_int_equal(m.route, SVD_R_STATUS);
    svd_route_find("DELETE", "/v1/bakes/" KEY, &m);
    assert_int_equal(m.route, SVD_R_DELETE);
    svd_route_find("GET", "/v1/bakes/" KEY "/artifacts/model.glb", &m);
    assert_int_equal(m.route, SVD_R_ARTIFACT);
    assert_string_equal(m.name, "model.glb");
}

static void routes_refuse_wrong_methods_with_allow(void **state)
{
    (void)state;
    svd_route_match m;
    svd_route_find("POST", "/v1/health", &m);
    assert_int_equal(m.status, 405);
    assert_string_equal(m.allow, "GET, HEAD");
    svd_route_find("PUT", "/v1/bakes", &m);
    assert_int_equal(m.status, 405);
    assert_string_equal(m.allow, "GET, HEAD, POST");
    svd_route_find("GET", "/v1/bakes", &m); /* the caller's bakes */
    assert_int_equal(m.status, 0);
    assert_int_equal(m.route, SVD_R_LIST);
    svd_route_find("PATCH", "/v1/bakes/" KEY, &m);
    assert_int_equal(m.status, 405);
}

/* A key prefix of 8 to 63 hex digits names a bake on every route that reads
 * or deletes one (the daemon resolves it); PUT takes only the whole key. */
static void routes_take_a_key_prefix_but_not_on_put(void **state)
{
    (void)state;
    svd_route_match m;
    svd_route_find("GET", "/v1/bakes/12305990", &m);
    assert_int_equal(m.route, SVD_R_STATUS);
    assert_true(m.key_prefix);
    assert_string_equal(m.key, "12305990");
    svd_route_find("GET", "/v1/bakes/123059907743/artifacts/model.glb", &m);
    assert_int_equal(m.route, SVD_R_ARTIFACT);
    assert_string_equal(m.key, "123059907743");
    svd_route_find("GET", "/v1/bakes/12305990/view", &m);
    assert_int_equal(m.route, SVD_R_VIEW);
    svd_route_find("GET", "/v1/bakes/12305990/inputs", &m);
    assert_int_equal(m.route, SVD_R_INPUTS);
    svd_route_find("GET", "/v1/bakes/12305990/inputs/tree.obj", &m);
    assert_int_equal(m.route, SVD_R_INPUT);
    svd_route_find("DELETE", "/v1/bakes/12305990", &m);
    assert_int_equal(m.route, SVD_R_DELETE);
    assert_true(m.key_prefix);
    svd_route_find("PUT", "/v1/bakes/12305990", &m);
    assert_int_equal(m.status, 400);
    assert_non_null(strstr(m.message, "whole key"));
    svd_route_find("GET", "/v1/bakes/" KEY, &m);
    assert_false(m.key_prefix);
}

static void routes_refuse_bad_keys_and_traversal(void **state)
{
    (void)state;
    svd_route_match m;
    svd_route_find("GET", "/v1/bakes/abc", &m);
    assert_int_equal(m.status, 400);
    svd_route_find("GET",
                   "/v1/bakes/"
                   "1230599077439815640ABF9dfe42b62c109efb4e38938921408ddac29212793c",
                   &m);
    assert_int_equal(m.status, 400);
    /* a prefix of fewer than 8 hex digits, or one with a non-hex digit */
    svd_route_find("GET", "/v1/bakes/1230599", &m);
    assert_int_equal(m.status, 400);
    assert_non_null(strstr(m.message, "at least 8"));
    svd_route_find("GET", "/v1/bakes/1230599g", &m);
    assert_int_equal(m.status, 400);
    svd_route_find("GET", "/v1/bakes/" KEY "0", &m); /* 65 digits */
    assert_int_equal(m.status, 400);
    svd_route_find("GET", "/v1/bakes/" KEY "/artifacts/../inputs.json", &m);
    assert_int_equal(m.status, 404);
    svd_route_find("GET", "/v1/bakes/" KEY "/artifacts/..", &m);
    assert_int_equal(m.status, 404);
    svd_route_find("GET", "/v1/bakes/" KEY "/in/tree.obj", &m);
    assert_int_equal(m.status, 404);
    svd_route_find("GET", "/etc/passwd", &m);
    assert_int_equal(m.status, 404);
}

/* A documented path with its parameters filled in: {key} a whole key,
 * {name} an artifact name, {path} a viewer file. */
static void concrete_path(const char *tmpl, char *out, size_t cap)
{
    size_t o = 0;
    for (const char *p = tmpl; *p && o + 1 < cap;) {
        const char *sub = NULL;
        if (strncmp(p, "{key}", 5) == 0) sub = KEY, p += 5;
        else if (strncmp(p, "{name}", 6) == 0) sub = "model.glb", p += 6;
        else if (strncmp(p, "{path}", 6) == 0) sub = "three/addons/loaders/GLTFLoader.js", p += 6;
        if (sub) o += (size_t)snprintf(out + o, cap - o, "%s", sub);
        else out[o++] = *p++;
    }
    out[o < cap ? o : cap - 1] = '\0';
}

/* server/openapi.json (as sylvad serves it) and the route table agree both
 * ways: every documented path and method is a route, each path takes
 * exactly the methods documented (HEAD with GET), and every route of the
 * table is documented. A route added to routes.c without its description,
 * or a description of a route that is not there, fails here. */
static void openapi_document_lists_exactly_the_routes_of_the_table(void **state)
{
    (void)state;
    size_t len = 0;
    const char *text = svd_openapi_json(&len);
    assert_true(len > 1000);
    cJSON *doc = cJSON_ParseWithLength(text, len);
    assert_non_null(doc);
    assert_string_equal(cJSON_GetStringValue(cJSON_GetObjectItem(doc, "openapi")), "3.1.0");
    static const char *const methods[] = {"get",   "put",     "post", "delete",
                                          "patch", "options", "trace"};
    bool seen[SVD_R_COUNT] = {false};

    const cJSON *item;
    cJSON_ArrayForEach(item, cJSON_GetObjectItem(doc, "paths"))
    {
        char path[512], up[16];
        concrete_path(item->string, path, sizeof path);

        for (size_t i = 0; i < sizeof methods / sizeof methods[0]; i++) {
            bool documented = cJSON_GetObjectItem(item, methods[i]) != NULL;
            size_t k = 0;
            for (; methods[i][k]; k++) up[k] = (char)(methods[i][k] - 'a' + 'A');
            up[k] = '\0';
            svd_route_match m;
            svd_route_find(up, path, &m);
            if (documented != (m.status == 0 && m.route != SVD_R_NONE))
                fail_msg("%s %s: documented %d, the router says %d (%s)", up, path, documented,
                         m.status, m.message ? m.message : "a route");
            if (documented) seen[m.route] = true;
            if (documented && strcmp(up, "GET") == 0) { /* HEAD is GET's */
                svd_route_find("HEAD", path, &m);
                assert_int_equal(m.status, 0);
            }
        }
    }
    for (int r = 1; r < SVD_R_COUNT; r++)
        if (!seen[r]) fail_msg("route %s is not in server/openapi.json", svd_route_label(r));
    /* the error body every route answers */
    const cJSON *err = cJSON_GetObjectItem(
        cJSON_GetObjectItem(cJSON_GetObjectItem(doc, "components"), "schemas"), "Error");
    assert_non_null(err);
    cJSON_Delete(doc);
}

static void config_defaults_listen_on_loopback_8080(void **state)
{
    (void)state;
    svd_config c;
    svd_config_defaults(&c);
    assert_string_equal(c.listen_host, "127.0.0.1");
    assert_int_equal(c.port, 8080);
    assert_true(svd_config_is_loopback(&c));
    assert_int_equal(c.attempts, 3);
}

static void config_flags_override_file(void **state)
{
    (void)state;
    char path[] = "/tmp/svcfgXXXXXX";
    int fd = mkstemp(path);
    const char *text = "# sylvad\nlisten = 0.0.0.0:9000\nworkers = 3   # "
                       "comment\n\nmax_upload_bytes = 2M\nlog_level = debug\n";
    assert_int_equal(write(fd, text, strlen(text)), (ssize_t)strlen(text));
    close(fd);
    char *argv[] = {"sylvad", "--config", path, "--workers", "5", "--max-wait=7", NULL};
    svd_config c;
    sv_error e = {0};
    assert_int_equal(svd_config_from_args(&c, 6, argv, &e), SV_OK);
    assert_string_equal(c.listen_host, "0.0.0.0");
    assert_int_equal(c.port, 9000);
    assert_false(svd_config_is_loopback(&c));
    assert_int_equal(c.workers, 5);
    assert_int_equal(c.max_wait, 7);
    assert_int_equal(c.max_upload_bytes, 2u << 20);
    assert_int_equal(c.log_level, SVD_LOG_DEBUG);
    unlink(path);
}

static void config_names_the_bad_line(void **state)
{
    (void)state;
    char path[] = "/tmp/svcfgXXXXXX";
    int fd = mkstemp(path);
    const char *text = "workers = 2\nno_such_thing = 1\n";
    assert_int_equal(write(fd, text, strlen(text)), (ssize_t)strlen(text));
    close(fd);
    svd_config c;
    svd_config_defaults(&c);
    sv_error e = {0};
    assert_int_equal(svd_config_load_file(&c, path, &e), SV_ERR_SPEC);
    assert_non_null(strstr(e.message, ":2:"));
    assert_non_null(strstr(e.message, "no_such_thing"));
    unlink(path);
}

static void config_refuses_bad_values(void **state)
{
    (void)state;
    svd_config c;
    svd_config_defaults(&c);
    sv_error e = {0};
    assert_int_equal(svd_config_set(&c, "listen", "localhost", &e), SV_ERR_SPEC);
    assert_int_equal(svd_config_set(&c, "listen", "127.0.0.1:70000", &e), SV_ERR_SPEC);
    assert_int_equal(svd_config_set(&c, "workers", "-1", &e), SV_ERR_SPEC);
    assert_int_equal(svd_config_set(&c, "max_upload_bytes", "99999999999G", &e), SV_ERR_SPEC);
    assert_int_equal(svd_config_set(&c, "log_level", "loud", &e), SV_ERR_SPEC);
    assert_int_equal(c.worker_nice, 10);
    assert_int_equal(svd_config_set(&c, "worker_nice", "20", &e), SV_ERR_SPEC);
    assert_non_null(strstr(e.message, "0..19"));
    assert_int_equal(svd_config_set(&c, "worker-nice", "19", &e), SV_OK);
    assert_int_equal(c.worker_nice, 19);
    assert_true(c.worker_pool); /* on by default (workers.h) */
    assert_int_equal(svd_config_set(&c, "worker_pool", "maybe", &e), SV_ERR_SPEC);
    assert_int_equal(svd_config_set(&c, "worker-pool", "off", &e), SV_OK);
    assert_false(c.worker_pool);
    assert_int_equal(svd_config_set(&c, "listen", "[::1]:0", &e), SV_OK);
    assert_string_equal(c.listen_host, "::1");
    assert_int_equal(c.port, 0);
    assert_true(svd_config_is_loopback(&c));
}

static void sizes_accept_binary_suffixes(void **state)
{
    (void)state;
    uint64_t v;
    assert_true(svd_parse_size("512", &v));
    assert_int_equal(v, 512);
    assert_true(svd_parse_size("4K", &v));
    assert_int_equal(v, 4096);
    assert_true(svd_parse_size("3G", &v));
    assert_int_equal(v, 3ull << 30);
    assert_false(svd_parse_size("3X", &v));
    assert_false(svd_parse_size("", &v));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(routes_map_the_v1_api),
        cmocka_unit_test(routes_refuse_wrong_methods_with_allow),
        cmocka_unit_test(routes_refuse_bad_keys_and_traversal),
        cmocka_unit_test(routes_take_a_key_prefix_but_not_on_put),
        cmocka_unit_test(openapi_document_lists_exactly_the_routes_of_the_table),
        cmocka_unit_test(config_defaults_listen_on_loopback_8080),
        cmocka_unit_test(config_flags_override_file),
        cmocka_unit_test(config_names_the_bad_line),
        cmocka_unit_test(config_refuses_bad_values),
        cmocka_unit_test(sizes_accept_binary_suffixes),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
