/* method_ops.h — a method's build half: what turns the classified mesh into
 * an sv_stand_in (quads and kept geometry per LOD), and the hooks the
 * pipeline reaches its levels through. Only the bake links it (sylvad links
 * the schema half, method.h).
 *
 * Methods are pure geometry: no GL, no files; the pipeline bakes, packs,
 * evaluates and writes what they make. A level that is not quads carries a
 * payload the pipeline reaches through its per-level hooks (level.h).
 */
#ifndef SV_METHOD_OPS_H
#define SV_METHOD_OPS_H

#include <cjson/cJSON.h>

#include "classify.h"
#include "method.h"
#include "scene.h"
#include "stand_in.h"

struct sv_baked_lod; /* bake.h */
struct sv_level_ops; /* level.h */

typedef struct sv_method_input {
    const sv_mesh *mesh;
    const sv_classification *cls;
    const sv_leaves *leaves;
    double centre[3]; /* bounding sphere (sv_mesh_sphere) */
    double radius;
    const sv_scene *scene;
    uint64_t seed; /* spec "seed" (default 1): every random choice derives from it */
} sv_method_input;

typedef struct sv_method_ops {
    const sv_method *method; /* its schema half */
    /* Builds the stand-in. out is zero-initialised by the caller. */
    sv_status (*run)(const sv_method_input *in, const cJSON *settings, sv_stand_in *out,
                     sv_error *err);
    /* planes.json (docs/outputs.md): adds what a runtime needs beyond the
     * plain quad list to `entry`, the object of one LOD this method made —
     * keys after "quads", and quads appended to `quads` (that entry's
     * array). baked is the LOD's bake (its mesh and uv_rects), source_triangles
     * the original mesh's triangle count. NULL: nothing to add. */
    void (*planes_json)(const sv_lod_plan *lod, const struct sv_baked_lod *baked,
                        uint32_t source_triangles, cJSON *entry, cJSON *quads);
    /* The hooks of the levels it makes when they are not quads (level.h);
     * NULL: its levels are quads. */
    const struct sv_level_ops *levels;
} sv_method_ops;

/* The build half of the method named `name`, or NULL. */
const sv_method_ops *sv_method_ops_find(const char *name);

/* Every registered build half, in the order of sv_method_list; *count
 * receives their number. */
const sv_method_ops *const *sv_method_ops_list(size_t *count);

#endif
