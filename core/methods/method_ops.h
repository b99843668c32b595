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

/* What methods keep across the bakes of one request (a target search bakes
 * once per try): slots by key, each freed with the memo by its own
 * function. Only for work whose outcome a method can tell is the same
 * (billboard_cloud: ε runs known to exceed a plane budget, planes.h
 * sv_bbc_memo), so outputs never depend on what was kept. */
typedef struct sv_memo sv_memo;
/* An empty memo, or NULL (out of memory). */
sv_memo *sv_memo_create(void);
/* Frees every slot (with its function) and the memo; NULL is fine. */
void sv_memo_free(sv_memo *m);
/* The slot `key`, made by make() (freed by free_fn) the first time; NULL
 * when m is NULL or make() or the memo's growth failed. */
void *sv_memo_slot(sv_memo *m, const char *key, void *(*make)(void), void (*free_fn)(void *));

typedef struct sv_method_input {
    const sv_mesh *mesh;
    const sv_classification *cls;
    const sv_leaves *leaves;
    double centre[3]; /* bounding sphere (sv_mesh_sphere) */
    double radius;
    const sv_scene *scene;
    uint64_t seed; /* spec "seed" (default 1): every random choice derives from it */
    sv_memo *memo; /* the request's (NULL: nothing is kept) */
} sv_method_input;

/* ---- the chain's own levels (docs/lod.md) ----
 *
 * The method whose schema says chain_levels builds the levels the LOD chain
 * places by its own schedule between the full mesh and the quad levels
 * (sv_method_ops chain). What it cannot do without the renderer the pipeline
 * lends it as two callbacks. */

/* Covered area (pixels summed over the pipeline's views) when triangles
 * tris[0..count) of the original are drawn alone: a visible ratio's input. */
typedef sv_status (*sv_chain_cover_fn)(void *user, const uint32_t *tris, uint32_t count,
                                       double *covered, sv_error *err);
/* Scores a candidate level (its whole geometry, trunk included) against the
 * original, higher = closer. */
typedef sv_status (*sv_chain_score_fn)(void *user, const sv_mesh *level, double *score,
                                       sv_error *err);

typedef struct sv_chain_in {
    const sv_method_input *in;
    const cJSON *settings; /* the spec's object of the method (NULL: its defaults) */
    bool own;              /* the spec's method is this one: every level asked for is built */
    bool build;            /* false: the settings are only checked against the mesh */
    sv_chain_cover_fn cover;
    void *cover_user;
    uint32_t cover_views, cover_pixels; /* what cover draws: views of pixels², for the report */
    sv_chain_score_fn score;
    void *score_user;
} sv_chain_in;

/* Where one of the chain's levels sits in its schedule. */
typedef struct sv_chain_place {
    char source[32];    /* the method that made it (its level hooks, report.json "source"),
                           or a name of no method (a leafless tree's "trunk") */
    double lambda;      /* its share of the tree's detail: 1 = the full mesh, exact everywhere */
    double distance;    /* the nearest distance it is drawn from (INFINITY: never reached) */
    double trunk_error; /* metres its trunk may be off (report.json trunk_max_error) */
} sv_chain_place;

typedef struct sv_chain_out {
    sv_stand_in levels;    /* finest first; a level with a payload sets its own ops */
    sv_chain_place *place; /* one per level */
    cJSON *skipped;        /* levels not built: [{name, stage, reason}]; NULL: none */
    cJSON *report;         /* report.json lod_chain.<method name>; NULL: nothing built */
} sv_chain_out;

/* Frees every part; leaves *o zeroed. */
void sv_chain_out_free(sv_chain_out *o);

/* Appends a note of a level not built, {name, stage, reason} with the
 * reason printf'd from fmt (cut at 399 bytes), to the array skipped (the
 * chain's and the method's, report.json "skipped"); returns the note. */
cJSON *sv_chain_skip_note(cJSON *skipped, const char *name, const char *stage, const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));

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
    /* Only the method whose schema says chain_levels: parses and checks its
     * settings (in->settings) against the mesh and, when in->build, builds
     * the chain's levels the scene needs into out (zeroed by the caller,
     * freed by it with sv_chain_out_free, also on failure). */
    sv_status (*chain)(const sv_chain_in *in, sv_chain_out *out, sv_error *err);
} sv_method_ops;

/* The build half of the method named `name`, or NULL. */
const sv_method_ops *sv_method_ops_find(const char *name);

/* Every registered build half, in the order of sv_method_list; *count
 * receives their number. */
const sv_method_ops *const *sv_method_ops_list(size_t *count);

#endif
