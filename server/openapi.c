/* openapi.c — server/openapi.json as a string (see openapi.h). */
#include "openapi.h"

static const char doc[] =
#include "openapi_json.inc" /* $(BUILD)/gen: server/openapi.json, one literal per line */
    ;

const char *svd_openapi_json(size_t *len)
{
    if (len) *len = sizeof doc - 1;
    return doc;
}
