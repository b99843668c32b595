/* mesh.h — the triangle mesh every core stage shares.
 *
 * Geometry is indexed triangles with per-vertex position, normal and UV, and one
 * material per triangle. Materials follow glTF's metallic-roughness subset that
 * matters for vegetation: base colour factor × base-colour texture, alpha mode
 * (opaque, mask with cutoff, blend) and double-sidedness. Images are owned by the
 * mesh and referenced by index, so materials can share them.
 * Units and axes: see sv.h (metres, +Y up). No GL state lives here.
 */
#ifndef SV_MESH_H
#define SV_MESH_H

#include "sv.h"
#include "image.h"

typedef enum sv_alpha_mode { SV_ALPHA_OPAQUE = 0, SV_ALPHA_MASK, SV_ALPHA_BLEND } sv_alpha_mode;

typedef struct sv_material {
    char name[128];
    float base_color[4];       /* RGBA factor, multiplies the texture */
    int32_t base_texture;      /* index into mesh->images, -1 when none */
    int32_t normal_texture;    /* tangent-space normal map, -1 when none */
    int32_t occlusion_texture; /* R channel = ambient occlusion, -1 when none */
    sv_alpha_mode alpha_mode;
    float alpha_cutoff; /* MASK: texels with alpha < cutoff are discarded (default 0.5) */
    bool double_sided;
    bool unlit;            /* colour already holds its lighting (baked static light):
                                  drawn as is even when lighting is on (glTF KHR_materials_unlit) */
    char texture_uri[256]; /* the source's name for base_texture (for reports) */
} sv_material;

typedef struct sv_mesh {
    uint32_t vertex_count;
    uint32_t triangle_count;
    uint32_t material_count;
    uint32_t image_count;
    float *positions;       /* 3 * vertex_count */
    float *normals;         /* 3 * vertex_count, unit length (computed if absent) */
    float *uvs;             /* 2 * vertex_count, (0,0) when the source had none; v down like glTF */
    uint32_t *indices;      /* 3 * triangle_count, CCW */
    uint32_t *tri_material; /* triangle_count, index into materials */
    sv_material *materials; /* material_count */
    sv_image *images;       /* image_count, owned */
} sv_mesh;

/* An extra per-vertex float attribute of a mesh, for a writer to carry
 * (glTF: application-specific semantics must begin with '_', e.g.
 * "_LEAF_CENTRE", "_ORDER"). */
typedef struct sv_vertex_attribute {
    const char *name;    /* must start with '_' and be at most 63 bytes */
    const float *data;   /* components * mesh->vertex_count floats, finite */
    uint32_t components; /* 1 (SCALAR) .. 4 (VEC4) */
} sv_vertex_attribute;

/* Allocates a mesh with room for the given counts (arrays zeroed, materials
 * initialised with sv_material_init). Returns NULL on overflow/allocation failure. */
sv_mesh *sv_mesh_create(uint32_t vertex_count, uint32_t triangle_count, uint32_t material_count,
                        uint32_t image_count);

/* Frees the mesh, its arrays and images. NULL is fine. */
void sv_mesh_destroy(sv_mesh *mesh);

/* Whether a and b draw the same: equal counts, vertex arrays, indices and
 * per-triangle materials, materials equal in every field a renderer reads
 * (colour, texture slots, alpha mode and cutoff, sides, unlit; not the
 * names), images equal in size and pixels (the same shared pixels, or equal
 * bytes). A level whose mesh draws as an earlier level's is measured once.
 * NULL equals only NULL. */
bool sv_mesh_draws_same(const sv_mesh *a, const sv_mesh *b);

/* Sets a material to glTF defaults: white, no textures, opaque, cutoff 0.5,
 * single-sided, empty name. */
void sv_material_init(sv_material *m);

/* Axis-aligned bounds of the vertices referenced by triangles (all vertices if
 * the mesh has no triangles). Returns false when there is nothing to bound. */
bool sv_mesh_bounds(const sv_mesh *mesh, double min[3], double max[3]);

/* Centre and radius of the bounding sphere used for every relative tolerance in
 * sylva: centre of the AABB, radius half its diagonal. */
void sv_mesh_sphere(const sv_mesh *mesh, double centre[3], double *radius);

/* Recomputes per-vertex normals as the area-weighted sum of adjacent face normals. */
void sv_mesh_compute_normals(sv_mesh *mesh);

/* Area of triangle t. */
double sv_tri_area(const sv_mesh *mesh, uint32_t t);

/* Unit normal of triangle t (zero vector for a degenerate triangle). */
void sv_tri_normal(const sv_mesh *mesh, uint32_t t, double n[3]);

/* The cross product of triangle t's edges (b - a) × (c - a), in double: its
 * unit normal times twice its area (area-weighted vertex normals sum it). */
void sv_tri_cross(const sv_mesh *mesh, uint32_t t, double n[3]);

/* New mesh holding triangles tris[0..count) of src (in that order), with only
 * the vertices they use, and copies of src's materials and images (so material
 * and image indices are unchanged). Returns SV_ERR_NOMEM on failure. */
/* The framing sphere of the evaluator (and of ../shared/tools/sveval):
 * centre = centre of the bounding box, radius = distance to the farthest
 * vertex used by a triangle (<= sv_mesh_sphere's half diagonal). Zeroes for
 * an empty mesh. */
void sv_mesh_frame_sphere(const sv_mesh *m, double c[3], double *r);

sv_status sv_mesh_subset(const sv_mesh *src, const uint32_t *tris, uint32_t count, sv_mesh **out,
                         sv_error *err);

/* Copies src's materials and images (sharing the pixels, sv_image_copy)
 * into dst, made with the same material and image counts. On failure dst
 * keeps what was copied; the caller destroys it. */
sv_status sv_mesh_copy_looks(const sv_mesh *src, sv_mesh *dst, sv_error *err);

/* New mesh with the triangles of a followed by those of b (either may be NULL);
 * b's material and image indices are offset past a's. */
sv_status sv_mesh_merge(const sv_mesh *a, const sv_mesh *b, sv_mesh **out, sv_error *err);

#endif
