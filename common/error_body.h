/* error_body.h — the one shape of an error in sylva's JSON (docs/api.md):
 * {"error":{"code": CODE, "message": MESSAGE}}, built here only: the
 * daemon's error answers and a failed job's record and status (server/),
 * `sylva-bake check-spec` (core/cli/).
 *
 * Header-only (static): each program includes it from the files that answer.
 */
#ifndef SYLVA_ERROR_BODY_H
#define SYLVA_ERROR_BODY_H

#include <cjson/cJSON.h>
#include <stdlib.h>

/* Adds "error": {"code": code, "message": message} to the object parent;
 * returns the new object (NULL when out of memory). */
static inline cJSON *sylva_error_add(cJSON *parent, const char *code, const char *message)
{
    cJSON *e = cJSON_AddObjectToObject(parent, "error");
    if (e) {
        cJSON_AddStringToObject(e, "code", code);
        cJSON_AddStringToObject(e, "message", message);
    }
    return e;
}

/* The document {"error":{"code","message"}}, unformatted (malloc'ed; NULL
 * when out of memory). */
static inline char *sylva_error_body(const char *code, const char *message)
{
    cJSON *root = cJSON_CreateObject();
    char *s = root && sylva_error_add(root, code, message) ? cJSON_PrintUnformatted(root) : NULL;
    cJSON_Delete(root);
    return s;
}

#endif
