/* fbx.h — the LOD group as FBX, through assimp's exporter (core/io/fbx_write.c).
 *
 * What is written (docs/outputs.md, lods.fbx and lod<i>_<name>.fbx): binary
 * FBX 7.5 (assimp's "fbx" exporter), one root node named root_name whose
 * children are the levels, in order, each a node named lods[i].name (the
 * `<asset>_LOD<i>` convention Unity's importer groups into a LOD group) with
 * the level's translation and one FBX mesh per material its triangles use
 * (named `<mesh name>_<material index>`). Units: centimetres, the FBX default
 * (assimp writes UnitScaleFactor 1): positions and translations are the
 * levels' metres × 100, so Unity, Unreal and Blender import the tree at its
 * size. +Y up. UVs flipped to FBX's v-up convention. Materials: the diffuse
 * colour (the glTF base-colour factor), opacity (its alpha), two-sidedness,
 * and the base-colour texture as a file beside the FBX, named
 * `tex_<16 hex digits of a hash of its pixels>.<png|jpg>`: the input's own
 * bytes when the pixels are still the file's (sv_image_source), else PNG.
 * Equal materials of several levels are one FBX material; materials that
 * differ but share a name get the level's index appended.
 *
 * Deterministic: assimp stamps the file with the local time of the export
 * (FBXHeaderExtension/CreationTimeStamp); the writer sets every field of it
 * to a fixed date (1970-01-01 00:00:00.000), so the same levels give the same
 * bytes. Nothing else of the file depends on the time, the process or the
 * machine (assimp's object ids count from a fixed start in each export).
 */
#ifndef SV_FBX_H
#define SV_FBX_H

#include "gltf.h"

/* A file already in the folder that holds an image's pixels (an atlas):
 * the FBX refers to it instead of writing a tex_ file. */
typedef struct sv_fbx_file {
    const sv_image *img; /* matched by its pixels' buffer and size */
    const char *file;    /* its name in the folder */
} sv_fbx_file;

/* Writes dir/file (binary FBX, above) holding lods[0..lod_count) under one
 * root node named root_name, and each texture they sample beside it in dir.
 * Images that are one of known[0..known_count) (may be NULL) are referred
 * to by that file's name and not written again. Only name, mesh and translation of each sv_gltf_lod are read (no extras or
 * attributes: FBX has no place assimp writes them to). SV_ERR_INVALID for bad
 * input (no levels, an index or material out of range, a missing name),
 * SV_ERR_NOMEM, SV_ERR_IO when a file cannot be written, SV_ERR_INTERNAL
 * with assimp's message when the export fails. A failure may leave some
 * textures written, never a partial FBX. */
sv_status sv_fbx_write(const char *dir, const char *file, const char *root_name,
                       const sv_gltf_lod *lods, uint32_t lod_count, const sv_fbx_file *known,
                       uint32_t known_count, sv_error *err);

#endif
