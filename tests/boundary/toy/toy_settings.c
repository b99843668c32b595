/* toy_settings.c — the schema half of the toy method (method.h): a method
 * with no settings and nothing for the target search to step.
 * tests/integration/boundary.sh copies this folder into a copy of the tree
 * as core/methods/toy/, adds SV_METHOD(toy) to core/methods/registry.h and
 * bakes with it: adding a method is its folder and one registry line. */
#include "method.h"

static sv_status toy_check(const cJSON *settings, sv_error *err)
{
    static const char *const keys[] = {NULL};
    return sv_setting_only(settings, "toy", keys, err);
}

const sv_method sv_method_toy = {
    .name = "toy",
    .summary = "a single vertical quad facing +Z (a test of the method boundary)",
    .check = toy_check,
};
