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

#endif
