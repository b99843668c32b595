/* routes.c — the v1 routing table (see routes.h and docs/api.md). */
#include "routes.h"

#include <stdio.h>
#include <string.h>

static const char *const labels[SVD_R_COUNT] = {
    [SVD_R_NONE] = "other",    [SVD_R_HEALTH] = "health", [SVD_R_METRICS] = "metrics",
    [SVD_R_INFO] = "info",     [SVD_R_SUBMIT] = "submit", [SVD_R_PUT] = "put",
    [SVD_R_STATUS] = "status", [SVD_R_DELETE] = "delete", [SVD_R_ARTIFACT] = "artifact",
    [SVD_R_LIST] = "list",     [SVD_R_VIEW] = "view",     [SVD_R_INPUT] = "input",
    [SVD_R_INPUTS] = "inputs", [SVD_R_VIEWER] = "viewer", [SVD_R_OPENAPI] = "openapi",
};

const char *svd_route_label(svd_route r)
{
    return (unsigned)r < SVD_R_COUNT ? labels[r] : "other";
}

static void fail(svd_route_match *m, int status, const char *msg, const char *allow)
{
    m->route = SVD_R_NONE;
    m->status = status;
    m->message = msg;
    m->allow = allow;
}

bool svd_viewer_path_valid(const char *path)
{
    size_t n = path ? strlen(path) : 0, seg = 0, segs = 1;
    if (n == 0 || n > SVD_NAME_MAX) return false;
    for (size_t i = 0; i <= n; i++) {
        char c = path[i];
        if (c == '/' || c == '\0') {
            if (seg == 0 || seg > 128 || ++segs > 9) return false;
            seg = 0;
            continue;
        }
        bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                  c == '-' || c == '_' || (c == '.' && seg > 0);
        if (!ok) return false;
        seg++;
    }
    return true;
}

void svd_route_find(const char *method, const char *path, svd_route_match *m)
{
    memset(m, 0, sizeof *m);
    int get = strcmp(method, "GET") == 0 || strcmp(method, "HEAD") == 0;
    if (strcmp(path, "/v1/health") == 0 || strcmp(path, "/v1/metrics") == 0 ||
        strcmp(path, "/v1/info") == 0 || strcmp(path, "/v1/openapi.json") == 0) {
        if (!get) return fail(m, 405, "method not allowed", "GET, HEAD");
        m->route = path[4] == 'h'   ? SVD_R_HEALTH
                   : path[4] == 'm' ? SVD_R_METRICS
                   : path[4] == 'i' ? SVD_R_INFO
                                    : SVD_R_OPENAPI;
        return;
    }
    if (strncmp(path, "/v1/viewer/", 11) == 0) {
        if (!svd_viewer_path_valid(path + 11)) return fail(m, 404, "no such viewer file", NULL);
        if (!get) return fail(m, 405, "method not allowed", "GET, HEAD");
        snprintf(m->name, sizeof m->name, "%s", path + 11);
        m->route = SVD_R_VIEWER;
        return;
    }
    if (strcmp(path, "/v1/bakes") == 0 || strcmp(path, "/v1/bakes/") == 0) {
        if (get) m->route = SVD_R_LIST;
        else if (strcmp(method, "POST") == 0) m->route = SVD_R_SUBMIT;
        else return fail(m, 405, "method not allowed", "GET, HEAD, POST");
        return;
    }
    if (strncmp(path, "/v1/bakes/", 10) != 0) return fail(m, 404, "no such resource", NULL);
    const char *k = path + 10;
    const char *slash = strchr(k, '/');
    size_t kl = slash ? (size_t)(slash - k) : strlen(k);
    static const char bad_key[] = "bad key: expected 64 lowercase hex digits, or a unique "
                                  "prefix of at least 8 of them";
    if (kl < SYLVA_KEY_PREFIX_MIN || kl > SYLVA_KEY_HEX_LEN) return fail(m, 400, bad_key, NULL);
    memcpy(m->key, k, kl);
    m->key[kl] = '\0';
    if (!sylva_key_prefix_ok(m->key)) return fail(m, 400, bad_key, NULL);
    m->key_prefix = kl < SYLVA_KEY_HEX_LEN;
    if (!slash) {
        if (get) m->route = SVD_R_STATUS;
        else if (strcmp(method, "PUT") == 0 && m->key_prefix)
            return fail(m, 400,
                        "bad key: PUT names the bytes it uploads by their whole key (64 "
                        "lowercase hex digits); a prefix is for reading and DELETE",
                        NULL);
        else if (strcmp(method, "PUT") == 0) m->route = SVD_R_PUT;
        else if (strcmp(method, "DELETE") == 0) m->route = SVD_R_DELETE;
        else return fail(m, 405, "method not allowed", "GET, HEAD, PUT, DELETE");
        return;
    }
    if (strcmp(slash, "/view") == 0 || strcmp(slash, "/inputs") == 0 ||
        strcmp(slash, "/inputs/") == 0) {
        if (!get) return fail(m, 405, "method not allowed", "GET, HEAD");
        m->route = slash[1] == 'v' ? SVD_R_VIEW : SVD_R_INPUTS;
        return;
    }
    svd_route route;
    const char *name;
    if (strncmp(slash, "/artifacts/", 11) == 0) route = SVD_R_ARTIFACT, name = slash + 11;
    else if (strncmp(slash, "/inputs/", 8) == 0) route = SVD_R_INPUT, name = slash + 8;
    else return fail(m, 404, "no such resource", NULL);
    if (!svd_name_valid(name))
        return fail(m, 404,
                    route == SVD_R_ARTIFACT ? "no such artifact: invalid artifact name"
                                            : "no such input: invalid file name",
                    NULL);
    if (!get) return fail(m, 405, "method not allowed", "GET, HEAD");
    snprintf(m->name, sizeof m->name, "%s", name);
    m->route = route;
}
