/* trunk.h — the kept trunk geometry of a LOD, simplified with meshoptimizer
 * (Debian's libmeshoptimizer-dev; sylva does not write a mesh simplifier). */
#ifndef SV_TRUNK_H
#define SV_TRUNK_H

#include "classify.h"

/* New mesh with the trunk triangles of mesh (tri_part[t] == SV_PART_TRUNK),
 * simplified per material with meshopt_simplify to about ratio × the triangle
 * count (ratio 1 keeps them as they are), error bounded by max_error (world
 * units; 0 = no bound). *out is NULL when the mesh has no trunk. */
sv_status sv_trunk_mesh(const sv_mesh *mesh, const uint8_t *tri_part, double ratio,
                        double max_error, sv_mesh **out, sv_error *err);

/* sv_trunk_mesh held to a triangle budget: simplified with meshopt_simplify
 * to max_triangles within max_error; when the error bound (or the topology)
 * stops it above the budget, meshopt_simplifySloppy takes the result down to
 * at most max_triangles (a budget below what shape-preserving simplification
 * can hold wins over the bound). max_triangles 0 = no cap (sv_trunk_mesh with
 * `ratio`). *out is NULL when the mesh has no trunk or nothing survives. */
sv_status sv_trunk_mesh_budget(const sv_mesh *mesh, const uint8_t *tri_part, double ratio,
                               uint32_t max_triangles, double max_error, sv_mesh **out,
                               sv_error *err);

/* The trunk of a quad level, whose quads draw what it leaves out: the trunk
 * triangles simplified to at most min(max_triangles, ratio × their count).
 * Candidates: (A) material by material, welded by position and UV; (B) the
 * whole trunk at once welded by position (the error decides which material
 * keeps triangles); when both fit, the smaller meshopt error wins. When A
 * does not fit (many separate branches: sapling's maple has 3,121), (C) the
 * connected parts, largest area first, each simplified alone within 1/256 of
 * the trunk's extent (coarser bounds up to 1/16 tried), kept while they fit;
 * B or C, whichever draws more of the trunk's area (per part, the smaller of
 * its drawn and its own area). Parts left out are the quads' to draw (B and
 * vertex clustering dissolved the maple's stem; A gave
 * decorativePlant's pot 31 triangles by its share of the count). *out NULL
 * when there is no trunk. */
sv_status sv_trunk_mesh_parts(const sv_mesh *mesh, const uint8_t *tri_part, double ratio,
                              uint32_t max_triangles, sv_mesh **out, sv_error *err);

/* The trunk of one level as geometry, and what it leaves to the quads: *tm =
 * the trunk triangles (part[t] == SV_PART_TRUNK) simplified to about ratio ×
 * their count and at most `budget` triangles (sv_trunk_mesh_parts; NULL when there is
 * no trunk or part is NULL), and skip[t] = 1 (skip: triangle_count bytes) for
 * each trunk triangle that mesh draws — its centroid within 1 % of `radius` of
 * the kept surface. The other trunk triangles (thin branches the budget could
 * not hold) are for the method's quads, so nothing is drawn twice and no
 * branch is lost. */
sv_status sv_trunk_kept(const sv_mesh *m, const uint8_t *part, double radius, double ratio,
                        uint32_t budget, sv_mesh **tm, uint8_t *skip, sv_error *err);

/* Cell side of sv_twig_groups in the methods, as a fraction of the bounding
 * radius (docs/methods/leaf_clusters.md: on the maple it costs little
 * accuracy against one element a triangle and cuts its clustering most). */
#define SV_TWIG_CELL (1.0 / 64.0)

/* The trunk triangles a kept trunk leaves out (part[t] == SV_PART_TRUNK and
 * !skip[t]: twigs, thin branches), grouped by the cube of side cell_frac ×
 * radius their centroid falls in (a grid from centre − radius; cells
 * clamped to 4096 a side): tris[0..count) cell by cell, in index order within
 * a cell, cells in a fixed order; group g is tris[first[g]] ..
 * tris[first[g + 1] − 1], first[groups] = count. Both arrays are allocated
 * by the call (sv_twigs_free). */
typedef struct sv_twigs {
    uint32_t *tris, *first;
    uint32_t count, groups;
} sv_twigs;

/* Fills *out as stated above (zeroed on failure). Deterministic;
 * SV_ERR_NOMEM only. */
sv_status sv_twig_groups(const sv_mesh *m, const uint8_t *part, const uint8_t *skip,
                         const double centre[3], double radius, double cell_frac, sv_twigs *out,
                         sv_error *err);

/* Frees the arrays of tw and zeroes it. NULL is fine. */
void sv_twigs_free(sv_twigs *tw);

#endif
