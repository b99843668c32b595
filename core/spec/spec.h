/* spec.h — the bake spec: the JSON document a user sends with a mesh.
 *
 *   {"method": "billboard_cloud", "billboard_cloud": {...}, "scene": {...},
 *    "import": {...}, "classify": {...}, "bake": {...}, "evaluate": {...},
 *    "lod": {...}, "target": {...}, "seed": 1}
 *
 * Every field has a default, so `{}` is valid. Parsing is strict: unknown keys,
 * wrong types and out-of-range values fail with SV_ERR_SPEC naming the key
 * (e.g. "scene.viewer: expected one of ground, aerial, orbit"). The daemon
 * parses specs with this too (pure C + cJSON, no GL, no assimp). Field
 * reference: docs/spec.md.
 */
#ifndef SV_SPEC_H
#define SV_SPEC_H

#include <cjson/cJSON.h>

#include "scene.h"

#define SV_MAX_EVAL_SIZES 8

/* output.compress (docs/spec.md "output"): how the glTF files' geometry is
 * stored. */
typedef enum sv_compress {
    SV_COMPRESS_NONE = 0, /* float attributes */
    SV_COMPRESS_QUANTIZE, /* KHR_mesh_quantization */
    SV_COMPRESS_MESHOPT   /* quantized, then EXT_meshopt_compression */
} sv_compress;

typedef struct sv_spec {
    char method[32];
    cJSON *root;           /* the parsed document, owned */
    const cJSON *settings; /* root[method] or NULL (defaults) */
    sv_scene scene;
    uint64_t seed; /* default 1 */
    /* import */
    double unit_scale;       /* metres per unit; 0 = format default */
    char up_axis;            /* 'Y', 'Z' or 'A' ("auto": detected, plausibility.h) */
    bool missing_files_warn; /* import.missing_files "warn": a referenced .mtl or texture
                                     that was not supplied is a warning; false ("error", the
                                     default): the import fails (SV_ERR_MISSING) */
    /* classify */
    const char **foliage; /* pointers into root */
    size_t foliage_count;
    const char **trunk;
    size_t trunk_count;
    /* bake */
    uint32_t max_atlas;       /* default 2048 */
    uint32_t max_supersample; /* default 8 */
    double texel_size;        /* 0 = auto */
    double alpha_threshold;   /* 0 = "calibrated" (the default): coverage alpha, cutoff
                                     calibrated per level; else a binary threshold */
    uint32_t texel_pixels;    /* default 256: texels are at least 2·radius / texel_pixels
                                     (0 = no floor: the finest that fits max_atlas) */
    uint32_t padding;         /* default 4 */
    uint32_t dilate;          /* default 8 */
    /* evaluate */
    bool evaluate;              /* default true */
    uint32_t eval_views;        /* default 24 */
    uint32_t eval_supersample;  /* default 2 (sizes above the small render's) */
    uint32_t eval_small_render; /* sizes <= this / 4 are judged from their own render this tall
                                   (sveval's 256: 4x4 samples a pixel at 64 px); 0 = one render */
    uint32_t eval_sizes[SV_MAX_EVAL_SIZES]; /* default 256,128,64,32 */
    uint32_t eval_size_count;
    bool eval_flattening_bound; /* default false: also measure each quad level's leaves
                                   flattened onto its planes as geometry (docs/accuracy.md) */
    /* lod */
    double lod_tolerance; /* max (1 - coverage IoU) for a LOD at lod_tolerance_pixels, default 0.1 */
    double
        lod_tolerance_pixels; /* size where lod_tolerance holds; it scales as 1/size (default 64; 0 = one tolerance at every size) */
    double lod_slack;         /* a level lod_cost_ratio times cheaper within this much error of the
                               tolerance (or of the dearer level) is drawn instead (default 0.02) */
    double lod_cost_ratio;    /* default 10; 0 = off (lod_plan.h rule 3) */
    double lod_min_saving;    /* a switch saves at least this fraction of triangles (default 0.25; 0 = off) */
    double lod_triangles_per_pixel; /* at most k·S² triangles drawn at S px (default 2; 0 = no cap) */
    bool lod_chain; /* full mesh → stochastic levels → method → coarsest (default true) */
    char lod_coarsest[32]; /* method appended as the coarsest LOD, "" = none
                                     (default "crossed_quads"); docs/lod.md */
    /* output (docs/spec.md "output") */
    bool output_fbx; /* lods.fbx and lod<i>_<name>.fbx beside the glTF files (default true) */
    sv_compress output_compress; /* the glTF files' geometry (default SV_COMPRESS_NONE) */
    /* target (docs/spec.md "target"): search the method's knobs, cheapest first */
    bool has_target;               /* a "target" object was given */
    double target_iou;             /* coverage IoU to reach, 0 = none */
    uint32_t target_pixels;        /* screen size the IoU is judged at (an evaluate size) */
    bool target_worst;             /* judge the worst view instead of the mean */
    uint32_t target_max_planes;    /* 0 = no budget */
    uint32_t target_max_triangles; /* 0 = no budget */
} sv_spec;

/* Parses and validates a spec (including the method's own settings through its
 * check function). On failure the spec is left empty (safe to sv_spec_free). */
sv_status sv_spec_parse(const char *json, size_t len, sv_spec *out, sv_error *err);

/* Frees what sv_spec_parse allocated. NULL or an empty spec is fine. */
void sv_spec_free(sv_spec *spec);

/* An upper estimate of the bytes a bake of input_bytes of uploads with this
 * spec writes (docs/operations.md, disk_reserve_bytes): the chain's meshes,
 * with the input's textures, in model.glb, the level files and lods.glb (6
 * times the input each) and, with output.fbx, the FBX files (18 times the
 * input); every quad level's maps at most max_atlas² texels of 8 bytes (RGBA
 * albedo, normal, ao, depth), levels after the first a quarter the size of
 * the one before (4/3 in all), in four copies (the image file, model.glb,
 * the level's file, lods.glb). Used to hold disk room for a bake's outputs
 * when it is accepted. */
uint64_t sv_spec_output_estimate(const sv_spec *spec, uint64_t input_bytes);

/* Default method name when the spec does not give one. */
#define SV_DEFAULT_METHOD "billboard_cloud"

#endif
