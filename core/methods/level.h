/* level.h — the per-level hooks: how a level that is not quads plugs into
 * the pipeline (docs/design.md, "Adding a method").
 *
 * A method's run may make a LOD that is something else than quads and kept
 * geometry (an octahedral impostor: a grid of frames) by leaving what it is
 * in sv_lod_plan.payload. The pipeline fills sv_lod_plan.ops from the
 * build registry (sv_level_ops_find, by the name of the method that made the
 * level) and from then on reaches the level only through these hooks: it
 * bakes, sizes, draws, writes and describes it without knowing what it is.
 * Every hook may be NULL: the pipeline then does for that step what it does
 * for a quad level. A level without ops (every quad method's) is baked,
 * drawn and written as quads, as before. The payload is one block that
 * sv_stand_in_free frees with free() (stand_in.c, at the top of core, knows
 * no hooks).
 *
 * The hooks render, so they belong to a method's build half (sv_method_ops
 * levels, method_ops.h), never to its schema (method.h), which sylvad links.
 */
#ifndef SV_LEVEL_H
#define SV_LEVEL_H

#include <cjson/cJSON.h>
#include <stdlib.h>

#include "bake.h"
#include "render.h"
#include "stand_in.h"

/* What the bake hook is given besides the plan. */
typedef struct sv_level_bake_in {
    sv_renderer *ren;
    const sv_gpu_mesh *gsrc; /* the original on ren */
    const sv_mesh *src;      /* the original */
    const sv_bake_options *opt;
    uint32_t largest_pixels; /* the largest evaluated screen size (256 when nothing is
                                evaluated): the level is never drawn taller */
    double texels_per_pixel; /* texels per screen pixel an atlas keeps */
    uint32_t max_atlas;      /* bake.max_atlas (0 = the default) */
} sv_level_bake_in;

/* A level's names in the outputs (docs/outputs.md), for the hooks that
 * describe it. */
typedef struct sv_level_names {
    const char *lod;        /* the plan's name ("octa12") */
    const char *node;       /* its glTF node in model.glb */
    const char (*maps)[64]; /* its atlas files: albedo, normal, ao, depth ("" = not baked) */
} sv_level_names;

/* Images a level adds to the outputs beyond its atlases (an impostor's
 * mips): each a file name of the bake's folder and its pixels, which the
 * pipeline writes as PNG. Owned: sv_level_images_free (a zeroed one is fine). */
typedef struct sv_level_image {
    char name[96]; /* "atlas_<lod>_albedo_mip1.png" */
    sv_image image;
} sv_level_image;

typedef struct sv_level_images {
    sv_level_image *items;
    uint32_t count;
} sv_level_images;

/* Frees every image and the list; leaves *l zeroed. */
static inline void sv_level_images_free(sv_level_images *l)
{
    for (uint32_t i = 0; i < l->count; i++) sv_image_free(&l->items[i].image);
    free(l->items);
    l->items = NULL;
    l->count = 0;
}

/* The files of a finished bake's folder, as the pipeline reads them for the
 * view hook: a level reaches them only through these. */
typedef struct sv_level_files {
    void *user;
    /* The JSON document `name` (caller deletes it); NULL with *missing set
     * when the folder has no such file, NULL with err set when it cannot
     * be read or parsed. */
    cJSON *(*json)(void *user, const char *name, bool *missing, sv_error *err);
    /* The PNG `name` decoded into img: 16-bit grey when gray16, else RGBA8. */
    sv_status (*image)(void *user, const char *name, bool gray16, sv_image *img, sv_error *err);
} sv_level_files;

/* What a level adds to its glTF node (outputs.c): vertex attributes by name,
 * one value set per vertex of the baked mesh, and extras merged into the
 * node's. Owned by the struct: sv_level_gltf_free (a zeroed one is fine). */
#define SV_LEVEL_MAX_ATTRIBUTES 4
typedef struct sv_level_gltf {
    sv_vertex_attribute attr[SV_LEVEL_MAX_ATTRIBUTES];
    uint32_t attr_count;
    float *data;   /* every attribute's values, one block (attr[i].data point into it) */
    cJSON *extras; /* NULL: none */
} sv_level_gltf;

/* Frees the values and the extras; leaves *g zeroed. */
static inline void sv_level_gltf_free(sv_level_gltf *g)
{
    free(g->data);
    cJSON_Delete(g->extras);
    *g = (sv_level_gltf){0};
}

typedef struct sv_level_ops {
    const char *method; /* the method whose levels these hooks serve */
    /* Bake stage (pipeline.c): bakes the level into out instead of
     * sv_bake_lod; may settle what the plan left to the bake (a frame size). */
    sv_status (*bake)(sv_lod_plan *lod, const sv_level_bake_in *in, sv_baked_lod *out,
                      sv_error *err);
    /* Evaluation and preview (pipeline.c, outputs.c; sv_eval_draw_fn's
     * contract): draws the baked level with cam into a w × h RGBA8 color
     * (allocated) and depth[w·h] (may be NULL). Non-NULL: the level is not
     * drawn as a triangle mesh, and never taken for the original or for an
     * earlier level. */
    sv_status (*draw)(const sv_lod_plan *lod, const sv_baked_lod *baked, const sv_camera *cam,
                      uint32_t w, uint32_t h, sv_image *color, float *depth, sv_error *err);
    /* Atlas shrinking (calibrate.c): the pipeline would halve the level's
     * atlas `halvings` times; returns how many it allows (at most that) and
     * records the new size in the payload. */
    int (*shrink)(sv_lod_plan *lod, int halvings);
    /* Writing (outputs.c), after the atlases: the level's own extra images
     * (mips) into out (zeroed by the caller, freed by it with
     * sv_level_images_free), which the pipeline writes; may note what it
     * made in the payload for doc_entry. */
    sv_status (*images)(sv_lod_plan *lod, const sv_baked_lod *baked, sv_level_images *out,
                        sv_error *err);
    /* A JSON document beside planes.json (report.c): doc_file
     * {"schema": doc_schema, "lods": [one doc_entry per such level, in
     * chain order]}. NULL doc_entry: no document. */
    const char *doc_file;
    const char *doc_schema;
    cJSON *(*doc_entry)(const sv_lod_plan *lod, const sv_level_names *names);
    /* `sylva-bake view` (view.c): when level `lod` of the finished bake
     * whose files are `files` is one of these, draws it with cam into a
     * size × size RGBA8 out and sets *found; leaves *found false (and
     * returns SV_OK) otherwise. */
    sv_status (*view)(const sv_level_files *files, const char *lod, const sv_camera *cam,
                      uint32_t size, sv_image *out, bool *found, sv_error *err);
    /* glTF writing (outputs.c): what the level adds to its node in
     * model.glb, its own file and lods.glb, from its bake (out zeroed by the
     * caller, freed by it with sv_level_gltf_free, also on failure). */
    sv_status (*gltf)(const sv_lod_plan *lod, const sv_baked_lod *baked, sv_level_gltf *out,
                      sv_error *err);
    /* report.json (report.c): adds the level's own fields to its "lods"
     * entry o, after "source". */
    void (*report)(const sv_lod_plan *lod, cJSON *o);
} sv_level_ops;

/* The hooks for the levels of method `method` (its sv_method_ops levels,
 * method_ops.h), or NULL (its levels are quads). */
const sv_level_ops *sv_level_ops_find(const char *method);

/* A document's 3-vector: true and v filled when a is an array of exactly
 * three numbers (an impostor.json "centre"), else false, v untouched. */
static inline bool sv_level_json_vec3(const cJSON *a, double v[3])
{
    if (!cJSON_IsArray(a) || cJSON_GetArraySize(a) != 3) return false;
    double t[3];
    for (int k = 0; k < 3; k++) {
        const cJSON *e = cJSON_GetArrayItem(a, k);
        if (!cJSON_IsNumber(e)) return false;
        t[k] = e->valuedouble;
    }
    for (int k = 0; k < 3; k++) v[k] = t[k];
    return true;
}

#endif
