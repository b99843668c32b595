/* gltf.h — glTF 2.0 binary (.glb) writer for a chain of levels of detail.
 *
 * Layout of what is written (glTF 2.0 spec, §4.4 "GLB file format"):
 *   - one node per LOD, one mesh per non-empty LOD, each node with the LOD's
 *     translation when it is not zero; ONLY the finest LOD's node
 *     is in the scene. The coarser ones are MSFT_lod alternates of it
 *     (node.extensions.MSFT_lod.ids, finest→coarsest) and
 *     node.extras.MSFT_screencoverage holds one value per LOD: LOD i is drawn
 *     while the object covers more than value i of the screen (MSFT_lod README);
 *     "extensionsUsed": ["MSFT_lod"] when there is more than one LOD.
 *   - one primitive per material used by the LOD's triangles; all primitives of
 *     a LOD share its vertex accessors (POSITION with min/max, NORMAL
 *     renormalised, TEXCOORD_0 when one of the mesh's materials has a
 *     texture, then the caller's extra attributes) and each has
 *     its own index accessor (uint16 when every index < 65535, else uint32).
 *     Vertices equal in every attribute written (bit for bit) are written
 *     once, in the order the triangles first use them; vertices no triangle
 *     uses are left out (the triangles and what they draw are unchanged).
 *   - materials: pbrMetallicRoughness with baseColorFactor, baseColorTexture,
 *     metallicFactor 0, roughnessFactor 1; alphaMode OPAQUE / MASK (with
 *     alphaCutoff) / BLEND; doubleSided; normalTexture, occlusionTexture.
 *   - images are in the binary chunk: an image whose pixels are still those
 *     of the input's file is that file's own bytes with its mimeType
 *     (sv_image_source: a JPEG stays image/jpeg), every other image PNG
 *     (sv_image_encode_png); images with the
 *     same pixels are stored once, whichever LOD or material uses them.
 *   - asset.generator is "sylva <SV_VERSION>".
 * Bytes are deterministic: the same input gives the same file. Chunks and
 * buffer views are 4-byte aligned.
 */
#ifndef SV_GLTF_H
#define SV_GLTF_H

#include <cjson/cJSON.h>

#include "image_io.h"
#include "mesh.h"

/* An extra per-vertex float attribute (mesh.h). */
typedef sv_vertex_attribute sv_gltf_attribute;

/* How a level's geometry is stored (docs/outputs.md "Sizes"). */
typedef enum sv_gltf_compress {
    SV_GLTF_FLOAT = 0, /* float positions, normals and UVs */
    /* KHR_mesh_quantization: positions as 16-bit integers with the node's
     * translation and uniform scale undoing the quantization (float when the
     * level has extra attributes, which are in the positions' space), normals
     * as normalized bytes, UVs in [0, 1] as normalized 16-bit integers (float
     * otherwise); the extension is required */
    SV_GLTF_QUANTIZE,
    /* SV_GLTF_QUANTIZE, then every vertex and index buffer view encoded with
     * EXT_meshopt_compression (meshoptimizer's codecs: attributes, triangles)
     * in the binary chunk, the views' declared buffer a placeholder without
     * data (buffer 1, "fallback": true); both extensions are required */
    SV_GLTF_MESHOPT
} sv_gltf_compress;

typedef struct sv_gltf_lod {
    const char *name;       /* node and mesh name; NULL = "lod<i>" */
    const sv_mesh *mesh;    /* may have zero triangles: the node has no mesh */
    double screen_coverage; /* MSFT_screencoverage: lower bound of this LOD, in [0,1] */
    const sv_gltf_attribute *attributes; /* optional extra vertex attributes */
    uint32_t attribute_count;
    const cJSON *extras;       /* optional object merged into the node's extras
                                       (e.g. the fade window); copied, not owned */
    const char *mesh_name;     /* mesh name; NULL = the node's name */
    double translation[3];     /* the node's translation (the mesh's local origin in the
                              scene, metres): written when not zero, with every
                              digit of the double (JSON numbers), so a tree far
                              from the origin keeps local float vertices */
    sv_gltf_compress compress; /* how the geometry is stored (default: floats) */
    bool no_normals;           /* leave NORMAL out (the source had none: glTF readers compute
                                  them, flat by the spec, as they would for the source), so
                                  vertices merge on position and UV alone */
} sv_gltf_lod;

/* Encodes lods[0..lod_count) (finest first, lod_count >= 1) as GLB into a
 * malloc'ed buffer (*out, *out_size; caller frees). On failure *out is NULL and
 * the error names the problem: SV_ERR_INVALID for bad input (index out of range,
 * NaN position, material index out of range, bad attribute), SV_ERR_NOMEM,
 * SV_ERR_LIMIT when the file would exceed 4 GiB, or an image-encoding error. */
sv_status sv_gltf_encode_glb(const sv_gltf_lod *lods, uint32_t lod_count, uint8_t **out,
                             size_t *out_size, sv_error *err);

/* sv_gltf_encode_glb, then writes the bytes to path (SV_ERR_IO on failure; no
 * partial file is left behind). */
sv_status sv_gltf_write_glb(const char *path, const sv_gltf_lod *lods, uint32_t lod_count,
                            sv_error *err);

/* The levels as one LOD group (docs/outputs.md, lods.glb): node 0 is the
 * root, named root_name, with `extras` (copied; NULL: none), and the only
 * node of the scene; nodes 1..lod_count are the levels, in order, its
 * children, each with its name (which must be non-empty: `<asset>_LOD<i>`),
 * translation, mesh and extras as sv_gltf_encode_glb writes them. No
 * MSFT_lod, no MSFT_screencoverage: every level is an ordinary node, which
 * every importer shows and an engine's import script groups by name. */
typedef struct sv_gltf_group {
    const char *root_name;
    const cJSON *extras; /* an object, or NULL */
} sv_gltf_group;

/* Encodes lods[0..lod_count) as a LOD group (above) into a malloc'ed buffer,
 * with sv_gltf_encode_glb's encoding and errors (SV_ERR_INVALID also for a
 * missing root or level name); deterministic. */
sv_status sv_gltf_encode_group_glb(const sv_gltf_group *group, const sv_gltf_lod *lods,
                                   uint32_t lod_count, uint8_t **out, size_t *out_size,
                                   sv_error *err);

/* sv_gltf_encode_group_glb, then writes the bytes to path as
 * sv_gltf_write_glb does. */
sv_status sv_gltf_write_group_glb(const char *path, const sv_gltf_group *group,
                                  const sv_gltf_lod *lods, uint32_t lod_count, sv_error *err);

/* One level as a standalone GLB (docs/outputs.md, lod<i>_<name>.glb): one
 * scene whose only node is this level (named lod->name, which must be
 * non-empty), no MSFT_lod and no screen coverage, every image the level
 * samples embedded in the binary chunk. Same encoding and errors as
 * sv_gltf_encode_glb (SV_ERR_INVALID also for a missing name); deterministic. */
sv_status sv_gltf_encode_level_glb(const sv_gltf_lod *lod, uint8_t **out, size_t *out_size,
                                   sv_error *err);

/* sv_gltf_encode_level_glb, then writes the bytes to path as
 * sv_gltf_write_glb does. */
sv_status sv_gltf_write_level_glb(const char *path, const sv_gltf_lod *lod, sv_error *err);

#endif
