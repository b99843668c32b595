/* fuzz_spec.c — libFuzzer target: the bake spec parser (core/spec/spec.c,
 * sv_spec_parse; docs/spec.md), including every method's settings check.
 * Any bytes must parse or fail with SV_ERR_SPEC/NOMEM and a message. */
#include <stdlib.h>
#include <string.h>

#include "spec.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    /* An exact-size heap copy (no NUL) so ASan sees any read past len. */
    char *json = malloc(size ? size : 1);
    if (!json) return 0;
    memcpy(json, data, size);
    sv_spec spec;
    sv_error e = {0};
    sv_status st = sv_spec_parse(json, size, &spec, &e);
    if (st != SV_OK && st != SV_ERR_SPEC && st != SV_ERR_NOMEM) abort();
    if (st != SV_OK && e.message[0] == 0) abort(); /* a failure names its problem */
    sv_spec_free(&spec);
    free(json);
    return 0;
}
