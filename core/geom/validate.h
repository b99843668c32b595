/* validate.h — mesh validation and repair.
 *
 * Rejects what cannot be repaired with a message naming the element
 * ("vertex 1234 has a NaN coordinate", "triangle 17 refers to vertex 90001 of
 * 90000"); repairs what can be (zero-area and exactly duplicated triangles are
 * removed, missing normals computed) and counts the repairs in the report.
 */
#ifndef SV_VALIDATE_H
#define SV_VALIDATE_H

#include "mesh.h"

typedef struct sv_validate_report {
    uint32_t removed_degenerate; /* zero-area triangles removed */
    uint32_t removed_duplicate; /* exact duplicates (same 3 vertex positions, any rotation) removed */
    uint32_t fixed_normals;     /* vertex normals that were non-finite or zero and recomputed */
    uint32_t unused_vertices;   /* vertices referenced by no triangle (kept, reported) */
} sv_validate_report;

/* Validates mesh in place. Fails with SV_ERR_INVALID on NaN/Inf positions,
 * out-of-range indices or material indices, or a mesh with no triangles left;
 * SV_ERR_LIMIT when counts exceed limits. On success the mesh is repaired and
 * report (may be NULL) says what changed. */
sv_status sv_validate(sv_mesh *mesh, const sv_limits *limits, sv_validate_report *report,
                      sv_error *err);

#endif
