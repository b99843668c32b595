/* import.h — mesh import from in-memory files (assimp behind this interface).
 *
 * The caller hands in every file of the upload: files[0] is the main mesh file
 * (.glb, .gltf, .obj, .ply, .fbx, .dae); the rest are what it references (.bin,
 * .mtl, textures). The importer serves assimp only these files: an absolute path,
 * a `..` component, a `file:` or other URI scheme, or a name not handed in is
 * refused with SV_ERR_REFUSED naming the reference. The format is sniffed from
 * the bytes (not the name); only glTF/GLB, OBJ, PLY, FBX and COLLADA reach assimp,
 * under a name with the sniffed format's extension, and the import fails when
 * assimp says it used another reader. Every format is pre-checked before assimp
 * sees it: glTF/GLB by sv_gltf_precheck (structure, node depth, cycles, declared
 * counts), the others by sv_mesh_precheck (complete headers, declared counts
 * bounded by the file size). Textures are decoded to RGBA8 through image.h.
 */
#ifndef SV_IMPORT_H
#define SV_IMPORT_H

#include "mesh.h"

typedef struct sv_file {
    const char *name; /* base name as uploaded, e.g. "tree.obj" */
    const uint8_t *data;
    size_t size;
} sv_file;

typedef enum sv_format {
    SV_FORMAT_UNKNOWN = 0,
    SV_FORMAT_GLB,
    SV_FORMAT_GLTF,
    SV_FORMAT_OBJ,
    SV_FORMAT_PLY,
    SV_FORMAT_FBX,
    SV_FORMAT_COLLADA
} sv_format;

/* Name of a format ("glb", "obj", ...). */
const char *sv_format_name(sv_format f);

/* Sniffs the format from the first bytes. Returns SV_FORMAT_UNKNOWN when the
 * bytes match none of the accepted formats. Pure; never reads past size. */
sv_format sv_sniff_format(const uint8_t *data, size_t size);

/* Resolves `ref`, a file name written inside an upload (an OBJ's mtllib or
 * map_Kd, a glTF uri after percent-decoding, a name assimp asks for), to one of
 * files[0..count-1]: by exact name, then by base name, then by base name ignoring
 * case; a percent-encoded ref ("my%20leaf.png") is also tried decoded, and both
 * forms must be safe. Backslashes count as separators. Returns SV_OK and *index; SV_ERR_REFUSED
 * (message names ref) for an empty, absolute (/x, \x, C:x), `..`-containing or
 * scheme-prefixed (file:, http:, ...) reference, which is never looked up; SV_ERR_IO
 * when ref is safe but no uploaded file has that name. Pure. */
sv_status sv_upload_find(const sv_file *files, size_t count, const char *ref, size_t *index,
                         sv_error *err);

typedef struct sv_import_options {
    double unit_scale;       /* metres per source unit; 0 = format default (1) */
    char up_axis;            /* 'Y' (default, 0 means Y) or 'Z': Z-up sources are rotated to Y-up */
    sv_limits limits;        /* zero fields = defaults */
    bool missing_files_warn; /* false (default): a referenced .mtl or base-colour texture
                                that was not uploaded fails with SV_ERR_MISSING; true: a
                                warning, the material keeps its plain colour */
} sv_import_options;

typedef struct sv_import_info {
    sv_format format;
    double unit_scale; /* what was applied */
    char up_axis;
    uint32_t source_meshes; /* assimp meshes merged */
    uint32_t textures_decoded;
    uint32_t textures_missing;  /* not uploaded or not decodable: material keeps its colour */
    uint32_t files_missing;     /* referenced files (.mtl, textures) that were not uploaded */
    char missing_files[256];    /* their names, ", "-separated (", ..." when cut short) */
    char warnings[4096];        /* '\n'-separated notes (missing textures, ...); the importer
                               fills at most 3 KiB and says how many it left out, so
                               later checks (plausibility.h) always have room */
    uint32_t warnings_left_out; /* import notes that did not fit */
    double origin[3];           /* where the mesh's local origin is in the file (metres, sylva's
                         frame): positions are file positions minus origin, taken in
                         double; zero for a tree modelled near the origin */
    bool no_normals;            /* the file gave no normals: every one was computed from the
                                   faces (docs/outputs.md "Sizes": the mesh levels' files leave
                                   them out too, and readers compute their own, as for the file) */
} sv_import_info;

/* Imports files[0] (with files[1..count-1] as its companions) into a new mesh
 * in sylva's convention (metres, +Y up), node transforms applied, all meshes
 * merged, triangulated, in a local frame: positions are the file's minus
 * info->origin (the grid point nearest the bounding box's centre at its
 * lowest Y, the grid's spacing the power of ten (file units, at least 1)
 * at least twice the longest side, so 0 for a tree near the origin),
 * computed in double; an OBJ's
 * positions, and a glTF's root-node translations, are read in double before
 * assimp sees them. On success *out owns the mesh (sv_mesh_destroy).
 * On failure *out is NULL and err names the problem. info may be NULL.
 * A referenced .mtl or base-colour texture that is not among the files fails
 * with SV_ERR_MISSING naming every such file (info->missing_files), unless
 * opt->missing_files_warn (then it is in info->warnings). */
sv_status sv_import(const sv_file *files, size_t count, const sv_import_options *opt, sv_mesh **out,
                    sv_import_info *info, sv_error *err);

/* Pre-check of a glTF JSON document or GLB container without assimp: header and
 * chunk lengths, JSON syntax, node graph depth <= limits.max_node_depth and no
 * cycles, node/mesh/accessor counts and accessor sizes within limits, every
 * buffer/image URI either data: or the name of a file in `files`.
 * Exposed for tests and fuzzing. */
sv_status sv_gltf_precheck(const uint8_t *data, size_t size, bool is_glb, const sv_file *files,
                           size_t count, const sv_limits *limits, sv_error *err);

/* Structural pre-check of an OBJ, PLY, FBX or COLLADA file (core/io/mesh_precheck.c)
 * without assimp, iterative and bounded by size: a PLY header must be complete
 * (end_header within 64 KiB) and its body must hold every instance it declares;
 * OBJ and COLLADA must be text (no NUL), COLLADA closed by </COLLADA>; a binary
 * FBX's record tree must lie inside the file, an ascii FBX's braces and strings
 * must close. Declared OBJ/PLY vertex and triangle counts are held against the
 * limits (NULL = defaults). SV_OK for glTF/GLB (see sv_gltf_precheck).
 * Failures are SV_ERR_PARSE (SV_ERR_LIMIT for counts) with a message that
 * names `shown` (the file's name) and the problem. Exposed for tests and fuzzing. */
sv_status sv_mesh_precheck(sv_format fmt, const uint8_t *data, size_t size, const char *shown,
                           const sv_limits *limits, sv_error *err);

#endif
