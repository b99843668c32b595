/* crossed_quads.h — the crossed quads' own declarations, shared by its
 * schema half (crossed_quads_settings.c) and its build half
 * (crossed_quads.c); nothing outside core/methods/crossed_quads/ includes
 * it but tests. */
#ifndef SV_CROSSED_QUADS_H
#define SV_CROSSED_QUADS_H

#include "method.h"
#include "method_ops.h"

#define CQ_NAME "crossed_quads"

typedef struct cq_settings {
    long planes;
    bool horizontal;
} cq_settings;

/* The settings object s (NULL: defaults) into o; SV_ERR_SPEC naming the key. */
sv_status cq_parse(const cJSON *s, cq_settings *o, sv_error *err);

extern const sv_method sv_method_crossed_quads;
extern const sv_method_ops sv_method_crossed_quads_ops;

#endif
