/* routes.c — the v1 routing table (see routes.h and docs/api.md). */
#include "routes.h"

#include <stdio.h>
#include <string.h>

static const char *const labels[SVD_R_COUNT] = {
    [SVD_R_NONE] = "other",     [SVD_R_HEALTH] = "health", [SVD_R_METRICS] = "metrics",
    [SVD_R_INFO] = "info",      [SVD_R_SUBMIT] = "submit", [SVD_R_PUT] = "put",
    [SVD_R_STATUS] = "status",  [SVD_R_DELETE] = "delete", [SVD_R_ARTIFACT] = "artifact",
    [SVD_R_LIST] = "list",
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

void svd_route_find(const char *method, const char *path, svd_route_match *m)
{
    memset(m, 0, sizeof *m);
    int get = strcmp(method, "GET") == 0 || strcmp(method, "HEAD") == 0;
    if (strcmp(path, "/v1/health") == 0 || strcmp(path, "/v1/metrics") == 0 ||
        strcmp(path, "/v1/info") == 0) {
        if (!get) return fail(m, 405, "method not allowed", "GET, HEAD");
        m->route = path[4] == 'h' ? SVD_R_HEALTH : path[4] == 'm' ? SVD_R_METRICS : SVD_R_INFO;
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
    if (kl != 64) return fail(m, 400, "bad key: expected 64 lowercase hex digits", NULL);
    memcpy(m->key, k, 64);
    m->key[64] = '\0';
    if (!svd_key_valid(m->key)) return fail(m, 400, "bad key: expected 64 lowercase hex digits", NULL);
    if (!slash) {
        if (get) m->route = SVD_R_STATUS;
        else if (strcmp(method, "PUT") == 0) m->route = SVD_R_PUT;
        else if (strcmp(method, "DELETE") == 0) m->route = SVD_R_DELETE;
        else return fail(m, 405, "method not allowed", "GET, HEAD, PUT, DELETE");
        return;
    }
    if (strncmp(slash, "/artifacts/", 11) != 0) return fail(m, 404, "no such resource", NULL);
    const char *name = slash + 11;
    if (!svd_name_valid(name)) return fail(m, 404, "no such artifact: invalid artifact name", NULL);
    if (!get) return fail(m, 405, "method not allowed", "GET, HEAD");
    snprintf(m->name, sizeof m->name, "%s", name);
    m->route = SVD_R_ARTIFACT;
}
