/* openapi.h — the OpenAPI 3.1 description of HTTP API v1: server/openapi.json,
 * compiled into sylvad (the Makefile turns it into a string literal) and
 * served at GET /v1/openapi.json. tests/unit/test_server_routes.c checks that
 * its paths and methods are the route table's (routes.c), both ways;
 * tests/integration/openapi.sh validates the served document with an OpenAPI
 * 3.1 validator (docs/api.md "The API description"). */
#ifndef SVD_OPENAPI_H
#define SVD_OPENAPI_H

#include <stddef.h>

/* The document (NUL-terminated, static); *len (if non-NULL) its length. */
const char *svd_openapi_json(size_t *len);

#endif
