/* method.h — a method's schema: what it is called, what its settings are
 * and how the target search steps them. All that sylvad links (it checks
 * specs); pure C and cJSON, no geometry.
 *
 * Each method's settings are the JSON object under the spec key named after
 * it (NULL = all defaults); unknown keys, wrong types and out-of-range values
 * fail with SV_ERR_SPEC naming the key. What a method builds, and how, is its
 * other half, sv_method_ops (method_ops.h), which only the bake links. Both
 * halves of every method are listed once, in core/methods/registry.h.
 */
#ifndef SV_METHOD_H
#define SV_METHOD_H

#include <cjson/cJSON.h>
#include <stdbool.h>
#include <stdint.h>

#include "sv.h"

/* What a ladder hook (sv_method.ladder) says of a step. */
enum { SV_LADDER_END = 0, SV_LADDER_STEP = 1, SV_LADDER_OVER = 2 };

typedef struct sv_method {
    const char *name;    /* spec "method" value and settings key */
    const char *summary; /* one line for `GET /v1/info` and --help */
    /* Validates settings without running (the daemon calls this). */
    sv_status (*check)(const cJSON *settings, sv_error *err);
    /* The target search's ladder (docs/spec.md "target", the table of
     * ladders), cheapest first: rewrites `settings` — a copy of the user's
     * settings object of this method, owned by the caller — to step `step`
     * (0 = cheapest), replacing the knob's keys and keeping the user's
     * others. Returns SV_LADDER_END, settings untouched, past the last
     * step, else SV_LADDER_STEP, or SV_LADDER_OVER for a step that cannot
     * keep within max_triangles (its quads leave the trunk less than its
     * floor: sv_ladder_trunk_share), which the search does not bake. NULL:
     * the method has nothing to search (a target then fails). Pure JSON.
     * max_triangles: the target's triangle budget (0 = none), for methods
     * whose kept trunk shares it with the quads (sv_ladder_trunk_share). */
    int (*ladder)(int step, uint32_t max_triangles, cJSON *settings);
    /* True: this method's levels are the LOD chain's stochastic levels
     * (docs/lod.md), built by the chain itself (they need the renderer to
     * measure r and score candidates); its settings are the chain's
     * stochastic settings, and it cannot be the chain's coarsest method. */
    bool chain_levels;
} sv_method;

/* The method named `name`, or NULL. */
const sv_method *sv_method_find(const char *name);

/* All registered methods; *count receives their number. */
const sv_method *const *sv_method_list(size_t *count);

/* The method whose levels are the chain's stochastic levels (chain_levels),
 * or NULL. */
const sv_method *sv_method_chain_levels(void);

/* Helpers for strict settings parsing shared by the methods: each returns
 * SV_ERR_SPEC naming `method.key` when the value has the wrong type or lies
 * outside [lo, hi]; a missing key leaves *out unchanged (the default). */
sv_status sv_setting_number(const cJSON *obj, const char *method, const char *key, double lo,
                            double hi, double *out, sv_error *err);
sv_status sv_setting_int(const cJSON *obj, const char *method, const char *key, long lo, long hi,
                         long *out, sv_error *err);
sv_status sv_setting_bool(const cJSON *obj, const char *method, const char *key, bool *out,
                          sv_error *err);
/* A per-level integer: a number (every level) or an array of 1..n numbers
 * (level i; the last repeats). out has n entries; missing key: unchanged. */
sv_status sv_setting_int_per_level(const cJSON *obj, const char *method, const char *key, long lo,
                                   long hi, long *out, int n, sv_error *err);
/* The target search's split of a triangle budget (docs/spec.md "target"):
 * with max_triangles > 0 and no "trunk_max_triangles" of the user's in
 * settings, sets it to what the budget leaves after `quads` quads (2
 * triangles each), never above `trunk_default` and never below a quarter of
 * the budget (at least 1); a step whose quads leave less than that is over
 * the budget. Nothing otherwise. Returns SV_LADDER_OVER for such a step,
 * else SV_LADDER_STEP (the ladder hook's answer for it). */
int sv_ladder_trunk_share(cJSON *settings, uint32_t max_triangles, int quads, long trunk_default);
/* Fails naming the first key of obj not in the NULL-terminated list `known`
 * (also fails when obj is not an object). NULL obj is fine. */
sv_status sv_setting_only(const cJSON *obj, const char *method, const char *const *known,
                          sv_error *err);

#endif
