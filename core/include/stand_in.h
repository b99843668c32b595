/* stand_in.h — what every method hands the bake pipeline: quads to bake, and
 * explicit geometry to keep as a mesh, grouped in levels of detail.
 *
 * A quad is a rectangle on a plane n·x + d = 0; it is textured by rendering,
 * orthographically along -n, every face that lies within `slab` of the plane
 * (billboard-cloud paper §3.3.7: all valid faces, not only the assigned ones),
 * or exactly the faces in `bake_faces` when the method says which.
 */
#ifndef SV_STAND_IN_H
#define SV_STAND_IN_H

#include "mesh.h"

#define SV_PARTS_TRUNK 1u
#define SV_PARTS_FOLIAGE 2u

typedef struct sv_quad {
    double normal[3];      /* unit plane normal; the texture is seen from +normal */
    double d;              /* plane: normal·x + d = 0 */
    double centre[3];      /* rectangle centre, on the plane */
    double axis_u[3];      /* unit, in the plane: texture +u (image +x) */
    double axis_v[3];      /* unit, in the plane: texture +v (image +y, up); normal = u × v */
    double half_u, half_v; /* half extents in world units */
    double slab;     /* half thickness: faces whose vertices all satisfy |n·p + d| <= slab are
                             baked (or, with clip, every face cut by the slab's two planes) */
    bool clip;       /* true: clip geometry at the slab planes (slicings) instead of
                             selecting whole faces (billboard clouds, clusters) */
    uint32_t *faces; /* faces this quad simplifies (assigned), owned */
    uint32_t face_count;
    double face_area;     /* total area of the assigned faces */
    uint8_t parts;        /* when bake_faces is NULL: mask of triangle parts eligible
                             for baking (SV_PARTS_TRUNK | SV_PARTS_FOLIAGE); 0 = all */
    uint32_t *bake_faces; /* faces to render into the texture; NULL = every face of the
                             method's input set within the slab */
    uint32_t bake_face_count;
    int32_t group;  /* slicing index, cluster level, ... (-1 none) */
    int32_t parent; /* index of the coarser-level quad this one merges into (-1 none) */
} sv_quad;

typedef enum sv_trunk_mode {
    SV_TRUNK_NONE = 0,  /* the trunk is in the quads */
    SV_TRUNK_MESH,      /* the trunk triangles are kept as they are */
    SV_TRUNK_SIMPLIFIED /* the trunk triangles simplified (meshoptimizer) to trunk_ratio */
} sv_trunk_mode;

#define SV_MAX_VIEW_SETS 4

/* For stand-ins that a renderer draws view-dependently (slicings: the two
 * slicings nearest the view, blended): given a unit view direction (from the
 * tree's centre towards the viewer, as the evaluator passes it), fills up to SV_MAX_VIEW_SETS sets of quads with
 * weights summing to 1. sets[k] receives quad indices (room for quad_count
 * each), counts[k] their number. Returns the number of sets (0 = draw all). */
struct sv_lod_plan;
typedef uint32_t (*sv_view_select_fn)(const struct sv_lod_plan *lod, const double view_dir[3],
                                      uint32_t *const sets[SV_MAX_VIEW_SETS],
                                      uint32_t counts[SV_MAX_VIEW_SETS],
                                      double weights[SV_MAX_VIEW_SETS]);

typedef struct sv_lod_plan {
    char name[32];  /* "lod0", "clusters32", ... */
    sv_quad *quads; /* owned */
    uint32_t quad_count;
    sv_mesh *geometry; /* optional explicit mesh drawn as is (stochastic levels); owned */
    sv_trunk_mode trunk;
    double trunk_ratio;           /* SV_TRUNK_SIMPLIFIED: target fraction of trunk triangles */
    uint32_t trunk_max_triangles; /* SV_TRUNK_SIMPLIFIED: hard cap on the kept trunk's
                                 triangles (0 = none): simplified within the error
                                 bound first, then meshopt_simplifySloppy to the cap */
    sv_view_select_fn select;     /* optional: view-dependent drawing (see above); the kept
                                 geometry is always drawn */
    void *select_data;            /* for select's use (owned by the method; freed with
                                 free() by sv_stand_in_free) */
    void *payload; /* non-NULL: what the level is instead of quads (an octahedral impostor's
                      sv_octa_grid), the method's own type, reached through ops; owned,
                      one block freed with free() */
    const struct sv_level_ops *ops; /* the hooks for a level with a payload (level.h), filled by
                                       the pipeline from sv_level_ops_find; NULL: quads */
} sv_lod_plan;

typedef struct sv_stand_in {
    sv_lod_plan *lods; /* finest first; owned */
    uint32_t lod_count;
    char method[32];
} sv_stand_in;

/* Frees every LOD, quad arrays and geometry. NULL is fine. */
void sv_stand_in_free(sv_stand_in *s);

/* Appends an empty LOD (zeroed, trunk SV_TRUNK_NONE) and returns it, NULL on ENOMEM. */
sv_lod_plan *sv_stand_in_add_lod(sv_stand_in *s, const char *name);

/* Appends a quad to a LOD (copied; ownership of its arrays moves to the LOD,
 * also on failure: then they are freed). */
sv_status sv_lod_add_quad(sv_lod_plan *lod, const sv_quad *q, sv_error *err);

/* Fills centre/axes/extents of q as the rectangle that encloses the projection
 * of points[0..n) onto q's plane with axis_u chosen by the minimum-area enclosing
 * rectangle (convex hull + rotating calipers). q->normal and q->d must be set.
 * axis_u runs along the longer side, its largest world component positive;
 * degenerate inputs get a minimum extent (conventions in stand_in.c). */
void sv_quad_fit_points(sv_quad *q, const double *points, size_t n);

/* The four corners in order (-u,-v), (+u,-v), (+u,+v), (-u,+v). */
void sv_quad_corners(const sv_quad *q, double corners[4][3]);

/* The flattening bound's geometry (docs/accuracy.md "The flattening bound"):
 * every face a quad of lod textures (its bake_faces, or else its assigned
 * faces) as a triangle of src with its vertices projected orthogonally onto
 * that quad's plane, uvs, normals and material kept; a face of several
 * quads appears once per quad. The vertices are not shared (3 per triangle);
 * materials and images are src's (images as sv_image_copy shares them).
 * *out is a new mesh (no triangles when no quad names a face). */
sv_status sv_lod_flatten(const sv_mesh *src, const sv_lod_plan *lod, sv_mesh **out, sv_error *err);

#endif
