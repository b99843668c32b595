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

/* The trunk of one level as geometry, and what it leaves to the quads: *tm =
 * the trunk triangles (part[t] == SV_PART_TRUNK) simplified to about ratio ×
 * their count and at most `budget` triangles (sv_trunk_mesh_budget, no error
 * bound; NULL when there is
 * no trunk or part is NULL), and skip[t] = 1 (skip: triangle_count bytes) for
 * each trunk triangle that mesh draws — its centroid within 1 % of `radius` of
 * the kept surface. The other trunk triangles (thin branches the budget could
 * not hold) are for the method's quads, so nothing is drawn twice and no
 * branch is lost (issue 18). */
sv_status sv_trunk_kept(const sv_mesh *m, const uint8_t *part, double radius, double ratio,
                        uint32_t budget, sv_mesh **tm, uint8_t *skip, sv_error *err);

#endif
