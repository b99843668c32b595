/* classify.h — foliage vs trunk, and leaf elements.
 *
 * Classification, per material, in order of precedence:
 *   1. the caller's explicit lists (names or globs) win;
 *   2. alpha-masked/blended materials, and names that say foliage (leaf, leaves,
 *      foliage, needle, twig, frond, branch-card, ...);
 *   3. otherwise connected-component analysis: small, flat, disconnected pieces
 *      are leaves.
 * Leaf elements (Garcia et al. §2) are connected pieces of foliage, welded by
 * position within a tolerance relative to the tree's size.
 */
#ifndef SV_CLASSIFY_H
#define SV_CLASSIFY_H

#include "mesh.h"

typedef enum sv_part { SV_PART_TRUNK = 0, SV_PART_FOLIAGE = 1 } sv_part;

typedef struct sv_classify_options {
    const char *const *foliage; /* material names or globs forced to foliage */
    size_t foliage_count;
    const char *const *trunk; /* material names or globs forced to trunk */
    size_t trunk_count;
} sv_classify_options;

typedef struct sv_material_class {
    sv_part part;
    char reason[160]; /* e.g. "name matches 'leaf'", "alpha mask", "listed by caller" */
    uint32_t triangles;
} sv_material_class;

typedef struct sv_classification {
    uint8_t *tri_part;            /* triangle_count entries of sv_part */
    sv_material_class *materials; /* material_count entries */
    uint32_t material_count;
    uint32_t foliage_triangles, trunk_triangles;
} sv_classification;

/* Classifies every triangle. On success *out must be released with
 * sv_classification_free. */
sv_status sv_classify(const sv_mesh *mesh, const sv_classify_options *opt, sv_classification *out,
                      sv_error *err);
void sv_classification_free(sv_classification *c);

typedef struct sv_leaf {
    double centre[3]; /* area-weighted centroid */
    double normal[3]; /* unit; area-weighted average after flipping into one half-space */
    double area;
    double radius;  /* max distance of a vertex from centre */
    uint32_t first; /* first index into sv_leaves.tris */
    uint32_t count; /* number of triangles */
} sv_leaf;

typedef struct sv_leaves {
    sv_leaf *leaves;
    uint32_t count;
    uint32_t *tris; /* triangle indices grouped by leaf */
    uint32_t tri_count;
    double median_area; /* statistics for reports */
    double max_area;
    uint32_t split; /* pieces split because they were far larger than a typical leaf */
} sv_leaves;

/* Builds leaf elements from the foliage triangles. Deterministic order (by the
 * lowest triangle index of each element). */
sv_status sv_leaves_build(const sv_mesh *mesh, const sv_classification *c, sv_leaves *out,
                          sv_error *err);
void sv_leaves_free(sv_leaves *l);

#endif
