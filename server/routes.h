/* routes.h — maps (method, path) to a route of the v1 API. Pure; tested
 * without a socket. Paths arrive already percent-decoded (libmicrohttpd). */
#ifndef SVD_ROUTES_H
#define SVD_ROUTES_H

#include "key.h"

/* Every route is in server/openapi.json with its methods: a route added
 * here without it fails tests/unit/test_server_routes.c. */

typedef enum svd_route {
    SVD_R_NONE = 0, /* no route: see status */
    SVD_R_HEALTH,   /* GET /v1/health */
    SVD_R_METRICS,  /* GET /v1/metrics */
    SVD_R_INFO,     /* GET /v1/info */
    SVD_R_SUBMIT,   /* POST /v1/bakes */
    SVD_R_PUT,      /* PUT /v1/bakes/{key} */
    SVD_R_STATUS,   /* GET /v1/bakes/{key} */
    SVD_R_DELETE,   /* DELETE /v1/bakes/{key} */
    SVD_R_ARTIFACT, /* GET /v1/bakes/{key}/artifacts/{name} */
    SVD_R_LIST,     /* GET /v1/bakes: the caller's bakes */
    SVD_R_VIEW,     /* GET /v1/bakes/{key}/view: the viewer page */
    SVD_R_INPUT,    /* GET /v1/bakes/{key}/inputs/{name}: an uploaded file */
    SVD_R_INPUTS,   /* GET /v1/bakes/{key}/inputs: the list of them */
    SVD_R_VIEWER,   /* GET /v1/viewer/{path}: the viewer page's own files */
    SVD_R_OPENAPI,  /* GET /v1/openapi.json: the API's description (openapi.h) */
    SVD_R_COUNT
} svd_route;

typedef struct svd_route_match {
    svd_route route;
    int status;                  /* 0 on a match, else 400, 404 or 405 */
    const char *allow;           /* for 405: the Allow header value */
    const char *message;         /* for errors: why */
    char key[SVD_KEY_HEX];       /* for bake routes: the key, or a prefix of it */
    bool key_prefix;             /* key holds SYLVA_KEY_PREFIX_MIN..63 hex digits: the
                                    caller resolves it (svd_jobs_resolve); never on PUT */
    char name[SVD_NAME_MAX + 1]; /* SVD_R_ARTIFACT, SVD_R_INPUT: a valid name;
                                        SVD_R_VIEWER: a path (svd_viewer_path_valid) */
} svd_route_match;

/* Matches a request. HEAD is treated as GET. A bake route takes the key or
 * a prefix of at least SYLVA_KEY_PREFIX_MIN lowercase hex digits (key_prefix
 * set), but PUT, which names the bytes it uploads, takes the whole key;
 * anything else there is 400. Never fails to fill *m. */
void svd_route_find(const char *method, const char *path, svd_route_match *m);

/* True if path (relative, below the viewer directory) is 1..SVD_NAME_MAX
 * bytes of at most 8 '/'-separated segments, each 1..128 bytes of
 * [A-Za-z0-9._-] not starting with '.': no empty, "." or ".." segment, no
 * absolute path, nothing a shell or a URL would read otherwise. */
bool svd_viewer_path_valid(const char *path);

/* Stable label of a route for metrics and logs ("health", "artifact", ...). */
const char *svd_route_label(svd_route r);

#endif
